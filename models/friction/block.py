"""The C++ block of any registered friction law: a ``SymbolicVectorSystem`` from the
joint velocities to the plant's applied generalized force, with every parameter a
per-Context numeric parameter (one diagram serves every Monte-Carlo sample).

Its parameter vector is ``[f_c1..f_cn, v_s, law parameters...]``
(``FrictionLawSpec``): ``set_coulomb`` writes the first ``n + 1`` entries (the Coulomb
levels live in ``ArmParameters``), ``set_law`` the rest (from the law's settings). All
default to NaN, so a Context that never got them fails loudly ("Detected NaN in applied
generalized force input port"). State 0 integrates the work the joints do against
friction, ``-sum_j f_j v_j`` (J); a law with internal states (LuGre's bristles) keeps
them after it.
"""

from __future__ import annotations

import numpy as np
from pydrake.systems.framework import Context, DiagramBuilder, InputPort, OutputPort

from posfb.models.friction.registry import law_spec, law_values, tag
from posfb.models.validation import shown


class SymbolicFriction:
    """One law's ``SymbolicVectorSystem`` in a diagram, and its per-Context setters."""

    def __init__(
        self,
        builder: DiagramBuilder,
        settings: object,
        velocities: OutputPort,
        applied_force: InputPort,
    ) -> None:
        self.spec = law_spec(settings)
        self.joints = velocities.size()
        self.system = builder.AddSystem(self.spec.system(self.joints))
        builder.Connect(velocities, self.system.get_input_port(0))
        builder.Connect(self.system.get_output_port(0), applied_force)

    def _parameters(self, root_context: Context) -> np.ndarray:
        return self.system.GetMyContextFromRoot(root_context).get_numeric_parameter(0).value()

    def _write(self, root_context: Context, vector: np.ndarray) -> None:
        context = self.system.GetMyMutableContextFromRoot(root_context)
        context.get_mutable_numeric_parameter(0).SetFromVector(vector)

    def set_coulomb(self, root_context: Context, levels: tuple[float, ...], v_s: float) -> None:
        """Set the Coulomb levels ``f_c`` (N m, one per joint) and ``v_s`` (rad/s)."""
        n = self.joints
        if self.spec.positive_coulomb:
            for j, level in enumerate(levels):
                if not level > 0.0:
                    raise ValueError(
                        f"coulomb[{j}] = {shown(level)} with friction = {tag(self.spec.settings())}"
                        "; > 0 is required (the law divides by g(v) >= f_c)"
                    )
        vector = np.array([*levels, v_s], dtype=float)
        if self.spec.parameters:
            vector = np.concatenate([vector, self._parameters(root_context)[n + 1 :]])
        self._write(root_context, vector)

    def set_law(self, root_context: Context, settings: object) -> None:
        """Set the law's own parameters from its scenario ``settings`` (same kind)."""
        if law_spec(settings) is not self.spec:
            raise ValueError(
                f"friction = {tag(settings)}, but the diagram was built for "
                f"{tag(self.spec.settings())}; a new diagram is required for another law"
            )
        values = law_values(settings, self.joints)
        if not values:
            return
        head = self._parameters(root_context)[: self.joints + 1]
        self._write(root_context, np.concatenate([head, np.asarray(values, dtype=float)]))

    def coulomb_levels(self, root_context: Context) -> tuple[float, ...]:
        return tuple(float(f) for f in self._parameters(root_context)[: self.joints])

    def law_parameters(self, root_context: Context) -> tuple[float, ...]:
        """The law's own parameters in ``root_context`` (after ``[f_c, v_s]``)."""
        return tuple(float(p) for p in self._parameters(root_context)[self.joints + 1 :])

    def loss(self, root_context: Context) -> float:
        """The work the joints did against friction so far (J)."""
        state = self.system.GetMyContextFromRoot(root_context).get_continuous_state_vector()
        return float(state[0])

    def law_states(self, root_context: Context) -> tuple[float, ...]:
        """The law's internal states (LuGre: the bristle deflections ``z``, rad)."""
        state = self.system.GetMyContextFromRoot(root_context).get_continuous_state_vector()
        return tuple(float(state[i]) for i in range(1, state.size()))
