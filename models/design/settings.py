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
from posfb.models.nominal import NominalModel, joint_count
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
        (entry.name, typing.get_type_hints(UncertaintyBounds)[entry.name],
         field(default=entry.default))
        for entry in fields(UncertaintyBounds)
    ],  # fmt: skip
    namespace={"__doc__": "Assumption 1's bounds and k_C1 (UncertaintyBounds' fields)."},
)


def _paper_h_gamma() -> list[float]:
    """``gamma_i`` of the paper's ``H(s) = diag(gamma_i / (s + gamma_i))`` (the default
    ``NonlinearTorqueConfig.B_zeta``'s diagonal)."""
    return [float(v) for v in np.diag(default_of(NonlinearTorqueConfig, "B_zeta")())]


@dataclass
class DiagonalH:
    """``H(s) = diag(gamma_i / (s + gamma_i))``, the paper's choice (Sec. 3.4, remark 1):
    ``gamma_i > 0`` above the bandwidth of ``q_id``; SPR with relative degree 1."""

    gamma: list[float] = field(default_factory=_paper_h_gamma)


@dataclass
class StateSpaceH:
    """``H(s) = C_zeta (sI - A_zeta)^-1 B_zeta`` (n x n each), checked for SPR."""

    A_zeta: list[list[float]] = field(default_factory=default_of(NonlinearTorqueConfig, "A_zeta"))
    B_zeta: list[list[float]] = field(default_factory=default_of(NonlinearTorqueConfig, "B_zeta"))
    C_zeta: list[list[float]] = field(default_factory=default_of(NonlinearTorqueConfig, "C_zeta"))


FilterH = DiagonalH | StateSpaceH


def h_matrices(settings: FilterH, joints: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A_zeta, B_zeta, C_zeta)`` of either form of ``H(s)`` (one ``gamma`` broadcasts
    to the ``joints`` joints)."""
    if isinstance(settings, StateSpaceH):
        return tuple(np.asarray(m, dtype=float) for m in (settings.A_zeta, settings.B_zeta,
                                                          settings.C_zeta))  # fmt: skip
    gamma = np.asarray(per_joint("H.gamma", settings.gamma, joints), dtype=float)
    if not np.all(np.isfinite(gamma)) or np.any(gamma <= 0.0):
        raise ValueError(f"H.gamma = {settings.gamma!r}; finite values > 0 are required")
    return -np.diag(gamma), np.diag(gamma), np.eye(gamma.size)


def _vector(settings: object, name: str, joints: int) -> tuple[float, ...]:
    return tuple(per_joint(name, getattr(settings, name), joints))


@dataclass
class Pid:
    """Computed torque + PID (Eq. 26, ``controller: !Pid {...}``): the diagonal gains
    ``Kp``, ``Kv``, ``KI`` (per joint). No Sec. 3 design."""

    #: A flat section's ``kind`` is refused with this hint.
    REMOVED: typing.ClassVar[dict[str, str]] = {"kind": FLAT_FORM_HINT}

    Kp: list[float] = field(default_factory=default_of(PidGains, "Kp"))
    Kv: list[float] = field(default_factory=default_of(PidGains, "Kv"))
    KI: list[float] = field(default_factory=default_of(PidGains, "KI"))

    def config(self, nominal: NominalModel, sample_time: float) -> ControllerConfig:
        n = joint_count(nominal)
        gains = PidGains(*(_vector(self, name, n) for name in ("Kp", "Kv", "KI")))
        return replace(ControllerConfig.without_design(nominal, sample_time), pid=gains)


@dataclass
class LinearTorqueInputs:
    """The inputs of the linear torque that Lin + LC and the paper's controller share: the
    LQR weights ``Q1``, ``Q2``, ``R`` and ``lambdas`` of ``Lambda(s)`` (Sec. 3.2) and how the
    filter is sampled (``discretisation``: foh, zoh, tustin). Not an entry itself: Drake's
    YAML would fill an entry of a subclass where this class is asked for."""

    #: A flat section's ``kind`` is refused with this hint.
    REMOVED: typing.ClassVar[dict[str, str]] = {"kind": FLAT_FORM_HINT}

    discretisation: str = field(default_factory=default_of(ControllerConfig, "discretisation"))
    Q1: list[list[float]] = field(default_factory=default_of(LqrWeights, "Q1"))
    Q2: list[list[float]] = field(default_factory=default_of(LqrWeights, "Q2"))
    R: list[list[float]] = field(default_factory=default_of(LqrWeights, "R"))
    lambdas: list[float] = field(default_factory=default_of(LqrWeights, "lambdas"))

    def lqr(self, joints: int) -> LqrWeights:
        lambdas = _vector(self, "lambdas", joints)
        return LqrWeights(Q1=self.Q1, Q2=self.Q2, R=self.R, lambdas=lambdas)

    def config(self, nominal: NominalModel, sample_time: float) -> ControllerConfig:
        return replace(
            ControllerConfig.without_design(nominal, sample_time),
            lqr=self.lqr(joint_count(nominal)),
            discretisation=self.discretisation,
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

    def config(self, nominal: NominalModel, sample_time: float) -> ControllerConfig:
        joints = joint_count(nominal)
        A_zeta, B_zeta, C_zeta = h_matrices(self.H, joints)
        nonlinear = NonlinearTorqueConfig(
            alpha_star=self.alpha_star, K_alpha=self.K_alpha, alpha0=self.alpha0,
            A_zeta=A_zeta, B_zeta=B_zeta, C_zeta=C_zeta, filter_a=self.filter_a,
        )  # fmt: skip
        return replace(
            super().config(nominal, sample_time),
            nonlinear=nonlinear,
            bounds=UncertaintyBounds(**dataclasses.asdict(self.bounds)),
        )
