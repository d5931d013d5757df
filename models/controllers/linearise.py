"""A controller's linear feedback, derived from its law: the filter from ``q~`` to the
feedback voltage that the margins (``models.design.margins``), the stability map,
tuning and a study's spectral radius close around the plant's linear part.

The law is built on the nominal linear part (``models.nominal.LinearPart``: Eq. 2 with
``h = 0``, so ``tau_Lin`` and the model's gravity vanish) with a constant reference at 0,
so that ``q = q~`` and the feed-forward terms cancel; the memory entries the law holds
(``Law.held``: the paper's controller's ``y = |alpha~1|`` at 0, i.e. ``alpha = alpha*``,
and the running maxima of Eq. 24-25) are fixed at their values and the rest are the
filter's state ``s``. CasADi's Jacobians at ``s = 0``, ``q~ = 0`` give::

    s_{k+1} = A s_k + B q~_k,   u_k = C s_k + D q~_k,   s_0 = initial q~_0

with ``A = d memory_next / d s``, ``B = d memory_next / d q``, ``C = d voltage / d s``,
``D = d voltage / d q`` and ``initial = d start / d q`` (the law's start from the first
measurement). A law that is linear on the linear part gives its exact feedback; one
that is not is linearised at rest.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from posfb.models.design.realisation import DiscreteFilter
from posfb.models.laws.law import Law


def law_feedback(law: Law) -> DiscreteFilter:
    """The linear feedback of ``law`` (module docstring); ``ValueError`` (one line) when a
    Jacobian is not finite at rest (an adapting entry the law does not hold)."""
    n, size = law.joints, law.memory
    held = dict(law.held)
    free = [i for i in range(size) if i not in held]
    state, q = ca.SX.sym("s", len(free)), ca.SX.sym("q", n)
    entries = [state[free.index(i)] if i not in held else ca.SX(held[i]) for i in range(size)]
    memory = ca.vertcat(*entries) if entries else ca.SX(0, 1)
    rest = ca.DM.zeros(3 * n)
    voltage, _, following = law.step(memory, q, rest)
    following = following[free] if free else ca.SX(0, 1)
    started = law.start(q, rest)[free] if free else ca.SX(0, 1)
    jacobians = ca.Function(
        f"{law.name}_linear",
        [state, q],
        [ca.jacobian(following, state), ca.jacobian(following, q), ca.jacobian(voltage, state),
         ca.jacobian(voltage, q), ca.jacobian(started, q)],
    )  # fmt: skip
    A, B, C, D, initial = (
        np.array(ca.densify(value), dtype=float).reshape(rows, columns)
        for value, (rows, columns) in zip(
            jacobians(np.zeros(len(free)), np.zeros(n)),
            ((len(free), len(free)), (len(free), n), (n, len(free)), (n, n), (len(free), n)),
            strict=True,
        )
    )
    for name, matrix in (("A", A), ("B", B), ("C", C), ("D", D), ("initial", initial)):
        if not np.all(np.isfinite(matrix)):
            raise ValueError(
                f"law {law.name!r}: its linear feedback's {name} is not finite at rest; hold "
                "the memory entries that adapt a gain (Law.held)"
            )
    return DiscreteFilter(A=A, B=B, C=C, D=D, initial=initial)
