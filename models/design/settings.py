"""The scenario entries of the paper's three controllers, and the design inputs each one
gives (``ControllerConfig``).

A scenario names its controller with one tagged entry that holds only that controller's
settings (``diagrams.scenario``): ``controller: !Proposed {alpha_star: 4, ...}``,
``!LinLc {Q1, Q2, R, lambdas, discretisation}`` or ``!Pid {Kp, Kv, KI}`` (the plug-in
baselines' entries are in their own modules). Every default is the paper's Sec. 4.2
setting, read from the one place the design defines it (``models.design.config``);
per-joint lists take one value for every joint or one per joint. ``config`` turns an
entry into the frozen ``ControllerConfig`` the design and the controllers are built
from; the parts a controller does not use are ``ControllerConfig.without_design``'s
placeholders.
"""

# No "from __future__ import annotations": Drake's YAML reads the field types at runtime.

import dataclasses
import typing
from dataclasses import dataclass, field, fields, replace

import numpy as np

from posfb.models.design.config import (
    ControllerConfig,
    LqrWeights,
    NonlinearTorqueConfig,
    PidGains,
    UncertaintyBounds,
)
from posfb.models.design.loop_context import LoopContext
from posfb.models.validation import per_joint

#: What a flat ``controller:`` section's ``kind`` key says now (``yaml_schema.check_shape``).
FLAT_FORM_HINT = (
    "the controller section is now one tagged entry of the chosen controller, e.g. "
    "controller: !LinLc {Q1: ...} (or !Proposed, !Pid, !PdGravity, !Adrc, !Python); "
    "posfb scenario dump --controller KIND writes one, and --controller KIND switches"
)


def default_of(cls: type, name: str) -> typing.Callable[[], object]:
    """A default factory that copies the default of ``cls.name`` (tuples become lists),
    so that a scenario's default is written once, where the design defines it."""
    value = next(f for f in fields(cls) if f.name == name).default

    def factory() -> object:
        if isinstance(value, tuple):
            return [list(v) if isinstance(v, tuple) else v for v in value]
        return value

    return factory


#: Assumption 1 and ``k_C1`` as a scenario writes them: the fields of
#: ``models.design.config.UncertaintyBounds`` (made from it, so each is written once); a
#: bound left empty is ``relative`` times the matching norm of the nominal model.
Bounds = dataclasses.make_dataclass(
    "Bounds",
    [
        (
            entry.name,
            typing.get_type_hints(UncertaintyBounds)[entry.name],
            field(default=entry.default),
        )
        for entry in fields(UncertaintyBounds)
    ],  # fmt: skip
    namespace={
        "__module__": __name__,  # pickled by name (a tuning's processes)
        "__doc__": "Assumption 1's bounds and k_C1 (UncertaintyBounds' fields).",
    },
)


def _h_gamma(context: LoopContext) -> float:
    """``gamma`` of ``H(s)`` by ``scenario init``'s rule (``models.design.initial.
    h_gamma``: the paper's ratio to the fastest wave frequency); the paper's ``gamma``
    when no wave of the context has a frequency."""
    from posfb.models.design.initial import h_gamma, paper_h_gamma

    moving = [f for f in context.frequencies if f > 0.0]
    return h_gamma(moving) if moving else paper_h_gamma()


def _paper(cls: type, name: str) -> object:
    """The paper's value of ``cls.name`` as a scenario writes it (lists of floats)."""
    return default_of(cls, name)()


def _filled(entry: object, values: dict[str, typing.Callable[[], object]]) -> object:
    """A copy of ``entry`` with each field left out (``None``) among ``values`` set to its
    value (each computed only when needed)."""
    changes = {name: make() for name, make in values.items() if getattr(entry, name) is None}
    return replace(entry, **changes) if changes else entry


@dataclass
class DiagonalH:
    """``H(s) = diag(gamma_i / (s + gamma_i))``, the paper's choice (Sec. 3.4, remark 1):
    ``gamma_i > 0`` above the bandwidth of ``q_id``; SPR with relative degree 1. Left out:
    from the arm (module docstring)."""

    gamma: list[float] | None = None

    def with_arm_defaults(self, context: LoopContext) -> "DiagonalH":
        """This ``H`` with a left-out ``gamma`` from ``context`` (module docstring)."""
        if context.paper_arm:
            paper = [float(v) for v in np.diag(_paper(NonlinearTorqueConfig, "B_zeta"))]
            return _filled(self, {"gamma": lambda: paper})
        return _filled(self, {"gamma": lambda: [_h_gamma(context)] * context.joints})


@dataclass
class StateSpaceH:
    """``H(s) = C_zeta (sI - A_zeta)^-1 B_zeta`` (n x n each), checked for SPR. Left out:
    from the arm (module docstring; the diagonal ``H`` of the arm's ``gamma``)."""

    A_zeta: list[list[float]] | None = None
    B_zeta: list[list[float]] | None = None
    C_zeta: list[list[float]] | None = None

    def with_arm_defaults(self, context: LoopContext) -> "StateSpaceH":
        """This ``H`` with its left-out matrices from ``context`` (module docstring)."""
        names = ("A_zeta", "B_zeta", "C_zeta")
        if context.paper_arm:
            return _filled(self, {name: default_of(NonlinearTorqueConfig, name) for name in names})
        gamma, identity = _h_gamma(context), np.eye(context.joints)
        matrices = dict(zip(names, (-gamma * identity, gamma * identity, identity), strict=True))
        return _filled(self, {name: matrices[name].tolist for name in names})


FilterH = DiagonalH | StateSpaceH


def h_matrices(settings: FilterH, joints: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A_zeta, B_zeta, C_zeta)`` of either form of ``H(s)`` (one ``gamma`` broadcasts
    to the ``joints`` joints; every part is given: ``with_arm_defaults`` fills them)."""
    if isinstance(settings, StateSpaceH):
        return tuple(np.asarray(m, dtype=float) for m in (settings.A_zeta, settings.B_zeta,
                                                          settings.C_zeta))  # fmt: skip
    gamma = np.asarray(per_joint("H.gamma", settings.gamma, joints), dtype=float)
    if not np.all(np.isfinite(gamma)) or np.any(gamma <= 0.0):
        raise ValueError(f"H.gamma = {settings.gamma!r}; finite values > 0 are required")
    return -np.diag(gamma), np.diag(gamma), np.eye(gamma.size)


def _vector(settings: object, name: str, joints: int) -> tuple[float, ...]:
    return tuple(per_joint(name, getattr(settings, name), joints))


def _rows(matrix: tuple[tuple[float, ...], ...]) -> list[list[float]]:
    return [list(row) for row in matrix]


def _pid_rule(context: LoopContext) -> dict[str, list[float]]:
    """``Kp``, ``Kv``, ``KI`` by ``scenario init``'s rule (``models.design.initial.
    pid_gains``), joint by joint with its own encoder counts and voltage limit. An ideal
    encoder (0 counts) has no count to chatter on: its joint gets the sampling rule
    alone (an unbounded allowance, so the quantisation bound never binds)."""
    import math

    from posfb.models.design.initial import pid_gains

    n, M0 = context.joints, context.M0()
    counts = per_joint("sensor.encoder_counts", list(context.encoder_counts) or [0], n)
    limits = per_joint("actuator.voltage_limit", list(context.voltage_limit) or [math.inf], n)
    gains: dict[str, list[float]] = {"Kp": [], "Kv": [], "KI": []}
    for j in range(n):
        ideal = counts[j] == 0
        joint = pid_gains(context.sample_time, M0[j : j + 1, j : j + 1], 1 if ideal else counts[j],
                          math.inf if ideal else limits[j])  # fmt: skip
        for name in gains:
            gains[name].append(getattr(joint, name)[0])
    return gains


@dataclass
class Pid:
    """Computed torque + PID (Eq. 26, ``controller: !Pid {...}``): the diagonal gains
    ``Kp``, ``Kv``, ``KI`` (per joint; left out: from the arm, module docstring). No
    Sec. 3 design."""

    #: A flat section's ``kind`` is refused with this hint.
    REMOVED: typing.ClassVar[dict[str, str]] = {"kind": FLAT_FORM_HINT}

    Kp: list[float] | None = None
    Kv: list[float] | None = None
    KI: list[float] | None = None

    def with_arm_defaults(self, context: LoopContext) -> "Pid":
        """This entry with its left-out gains from ``context`` (module docstring)."""
        names = ("Kp", "Kv", "KI")
        if context.paper_arm:
            return _filled(self, {name: default_of(PidGains, name) for name in names})
        if all(getattr(self, name) is not None for name in names):
            return self
        rule = _pid_rule(context)
        return _filled(self, {name: (lambda name=name: rule[name]) for name in names})

    def config(self, context: LoopContext) -> ControllerConfig:
        """The design inputs of this entry in ``context`` (left-out gains from it)."""
        entry = self.with_arm_defaults(context)
        n = context.joints
        gains = PidGains(*(_vector(entry, name, n) for name in ("Kp", "Kv", "KI")))
        return replace(ControllerConfig.without_design(context), pid=gains)


@dataclass
class LinearTorqueInputs:
    """The inputs of the linear torque that Lin + LC and the paper's controller share: the
    LQR weights ``Q1``, ``Q2``, ``R`` and ``lambdas`` of ``Lambda(s)`` (Sec. 3.2) and how the
    filter is sampled (``discretisation``: foh, zoh, tustin). Not an entry itself: Drake's
    YAML would fill an entry of a subclass where this class is asked for."""

    #: A flat section's ``kind`` is refused with this hint.
    REMOVED: typing.ClassVar[dict[str, str]] = {"kind": FLAT_FORM_HINT}

    discretisation: str = field(default_factory=default_of(ControllerConfig, "discretisation"))
    Q1: list[list[float]] | None = None
    Q2: list[list[float]] | None = None
    R: list[list[float]] | None = None
    lambdas: list[float] | None = None

    def with_arm_defaults(self, context: LoopContext) -> "LinearTorqueInputs":
        """This entry with its left-out weights (and ``H``) from ``context`` (module
        docstring)."""
        names = ("Q1", "Q2", "R", "lambdas")
        if context.paper_arm:
            return _filled(self, {name: default_of(LqrWeights, name) for name in names})
        if all(getattr(self, name) is not None for name in names):
            return self
        from posfb.models.design.initial import lqr_weights

        rule = lqr_weights(context.M0(), context.sample_time).lqr()
        matrices = {name: _rows(getattr(rule, name)) for name in ("Q1", "Q2", "R")}
        matrices["lambdas"] = list(rule.lambdas)
        return _filled(self, {name: (lambda name=name: matrices[name]) for name in names})

    def lqr(self, joints: int) -> LqrWeights:
        """The LQR weights for ``joints`` joints (every weight given)."""
        lambdas = _vector(self, "lambdas", joints)
        return LqrWeights(Q1=self.Q1, Q2=self.Q2, R=self.R, lambdas=lambdas)

    def config(self, context: LoopContext) -> ControllerConfig:
        """The design inputs of this entry in ``context`` (left-out settings from it)."""
        entry = self.with_arm_defaults(context)
        return replace(
            ControllerConfig.without_design(context),
            lqr=entry.lqr(context.joints),
            discretisation=entry.discretisation,
        )


@dataclass
class LinLc(LinearTorqueInputs):
    """Lin + LC (Eq. 4 + 13, ``controller: !LinLc {...}``): the linear torque's inputs."""


@dataclass
class Proposed(LinearTorqueInputs):
    """The paper's controller (Eq. 3, ``controller: !Proposed {...}``): Lin + LC's inputs,
    then ``alpha_star``, ``K_alpha``, ``alpha0`` of Eq. 21, the SPR filter ``H``
    (``!DiagonalH {gamma}`` or ``!StateSpaceH {A_zeta, B_zeta, C_zeta}``), the pole
    ``filter_a`` of ``G(s)`` (Sec. 3.4) and the Assumption-1 ``bounds``."""

    alpha_star: float = field(default_factory=default_of(NonlinearTorqueConfig, "alpha_star"))
    K_alpha: float = field(default_factory=default_of(NonlinearTorqueConfig, "K_alpha"))
    alpha0: float = field(default_factory=default_of(NonlinearTorqueConfig, "alpha0"))
    H: FilterH = field(default_factory=DiagonalH)
    filter_a: float = field(default_factory=default_of(NonlinearTorqueConfig, "filter_a"))
    bounds: Bounds = field(default_factory=Bounds)

    def with_arm_defaults(self, context: LoopContext) -> "Proposed":
        """This entry with its left-out weights and ``H`` from ``context`` (module docstring)."""
        entry = super().with_arm_defaults(context)
        H = entry.H.with_arm_defaults(context)
        return entry if H is entry.H else replace(entry, H=H)

    def config(self, context: LoopContext) -> ControllerConfig:
        """The design inputs of this entry in ``context`` (left-out settings from it)."""
        entry = self.with_arm_defaults(context)
        joints = context.joints
        A_zeta, B_zeta, C_zeta = h_matrices(entry.H, joints)
        nonlinear = NonlinearTorqueConfig(
            alpha_star=entry.alpha_star, K_alpha=entry.K_alpha, alpha0=entry.alpha0,
            A_zeta=A_zeta, B_zeta=B_zeta, C_zeta=C_zeta, filter_a=entry.filter_a,
        )  # fmt: skip
        try:
            bounds = UncertaintyBounds(**dataclasses.asdict(entry.bounds))
        except ValueError as error:  # named in its place: controller.bounds.<field>
            raise ValueError(f"bounds.{error}") from None
        return replace(LinearTorqueInputs.config(entry, context), nonlinear=nonlinear,
                       bounds=bounds)  # fmt: skip
