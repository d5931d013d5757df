"""Design inputs of the controllers, validated where they enter.

Defaults are the paper's Sec. 4.2 settings. Matrices are tuples of rows
(immutable, so the dataclasses stay frozen and hashable). Each part is sized by
its own entries (``n`` joints: ``lambdas``, ``A_zeta``, ``Kp``); ``ControllerConfig``
requires every part to have the nominal model's ``n`` (the paper's defaults are
for its two joints).
"""

from __future__ import annotations

import functools
from dataclasses import MISSING, dataclass, field, fields, replace
from typing import ClassVar

import numpy as np

from posfb.models.design.discretise import DISCRETISATIONS
from posfb.models.design.loop_context import InLoopContext, LoopContext
from posfb.models.nominal import NominalModel
from posfb.models.validation import (
    require_matrix,
    require_nonnegative,
    require_positive,
    require_vector,
)

Matrix = tuple[tuple[float, ...], ...]


def diagonal(values: tuple[float, ...]) -> Matrix:
    """A diagonal matrix as a tuple of rows."""
    size = len(values)
    return tuple(
        tuple(float(v) if i == j else 0.0 for j in range(size)) for i, v in enumerate(values)
    )


def freeze(instance: object, *names: str) -> None:
    """Store the (validated) fields ``names`` of a frozen dataclass as tuples of floats,
    so configs built from numpy arrays stay hashable and compare by value."""
    for name in names:
        values = np.asarray(getattr(instance, name), dtype=float).tolist()
        frozen = tuple(tuple(row) for row in values) if isinstance(values[0], list) else values
        object.__setattr__(instance, name, tuple(frozen))


def joint_vector(name: str, value: tuple[float, ...] | np.ndarray) -> np.ndarray:
    """``value`` as a finite, non-empty vector (one entry per joint)."""
    array = np.asarray(value, dtype=float)
    if array.ndim != 1 or array.size == 0:
        raise ValueError(
            f"{name} = {np.asarray(value).tolist()!r}; a list of one number per joint is required"
        )
    return require_vector(name, array, array.size)


def require_symmetric(name: str, value: Matrix | np.ndarray, size: int, definite: bool) -> None:
    """Refuse ``value`` unless it is a finite symmetric ``size x size`` matrix that is
    positive definite (``definite``) or positive semidefinite."""
    matrix = require_matrix(name, value, (size, size))
    scale = max(1.0, float(np.max(np.abs(matrix))))
    if not np.allclose(matrix, matrix.T, rtol=0.0, atol=1e-12 * scale):
        raise ValueError(
            f"{name} = {matrix.tolist()} is not symmetric; a symmetric matrix is required"
        )
    smallest = float(np.linalg.eigvalsh(matrix).min())
    if definite and smallest <= 1e-12 * scale:
        raise ValueError(
            f"{name} = {matrix.tolist()} has smallest eigenvalue {smallest:.3g}; "
            "a positive definite matrix is required"
        )
    if smallest < -1e-12 * scale:
        raise ValueError(
            f"{name} = {matrix.tolist()} has smallest eigenvalue {smallest:.3g}; "
            "a positive semidefinite matrix is required"
        )


@dataclass(frozen=True)
class LqrWeights:
    """Weights of the linear control torque (Sec. 3.2): ``Q = diag(Q1, Q2)`` and ``R`` of
    the cost (16), and ``lambda_i`` of ``Lambda(s) = diag(1/(s + lambda_i))`` (Eq. 5).

    As in Sec. 3.2, ``Q1`` (on ``[q~, q~']``) is positive semidefinite, ``Q2`` (on
    ``eta~``) and ``R`` (on ``v~``) are positive definite, ``lambda_i > 0``.
    """

    Q1: Matrix = diagonal((32000.0, 12000.0, 10.0, 10.0))
    Q2: Matrix = diagonal((0.001, 0.001))
    R: Matrix = diagonal((0.0005, 0.0015))
    lambdas: tuple[float, ...] = (10.0, 10.0)

    def __post_init__(self) -> None:
        lambdas = joint_vector("lambdas", self.lambdas)
        for i, value in enumerate(lambdas):
            require_positive(f"lambdas[{i}]", value)
        n = lambdas.size
        try:
            require_symmetric("Q1", self.Q1, 2 * n, definite=False)
            require_symmetric("Q2", self.Q2, n, definite=True)
            require_symmetric("R", self.R, n, definite=True)
        except ValueError as error:
            raise ValueError(f"{error} (n = {n} joints, from lambdas)") from None
        freeze(self, "Q1", "Q2", "R", "lambdas")

    #: The entry whose length is ``n`` (``ControllerConfig`` names it when sizes differ).
    SIZED_BY: ClassVar[str] = "lambdas"

    @property
    def joints(self) -> int:
        """``n``: the number of ``lambdas``."""
        return len(self.lambdas)

    @property
    def Q(self) -> np.ndarray:
        """``Q = diag(Q1, Q2)`` (3n x 3n)."""
        n = self.joints
        q = np.zeros((3 * n, 3 * n))
        q[: 2 * n, : 2 * n] = self.Q1
        q[2 * n :, 2 * n :] = self.Q2
        return q


@dataclass(frozen=True)
class NonlinearTorqueConfig:
    """The nonlinear control torque (Sec. 3.3-3.4): ``alpha*``, ``K_alpha`` and the
    initial gain ``alpha(0)`` of Eq. 21; ``H(s) = C_zeta (sI - A_zeta)^-1 B_zeta``
    (Eq. 20, an ``n``-state realisation as in the paper's KYP statement); the pole
    ``a`` of ``G(s) = a/(s + a)`` (Sec. 3.4).

    ``alpha0 = 0`` is this project's choice (reading note 8): the nonlinear torque
    starts switched off and Eq. 21 raises its gain monotonically to ``alpha*``.
    Whether ``H`` is SPR and whether ``a > ln 2 / T_s`` are design checks
    (``models.design.synthesis``): the proposed controller refuses either failure.
    """

    alpha_star: float = 4.0
    K_alpha: float = 20.0
    alpha0: float = 0.0
    A_zeta: Matrix = diagonal((-10.0, -10.0))
    B_zeta: Matrix = diagonal((10.0, 10.0))
    C_zeta: Matrix = diagonal((1.0, 1.0))
    filter_a: float = 100.0

    def __post_init__(self) -> None:
        alpha_star = require_positive("alpha_star", self.alpha_star)
        require_positive("K_alpha", self.K_alpha)
        alpha0 = require_nonnegative("alpha0", self.alpha0)
        if alpha0 > alpha_star:
            raise ValueError(
                f"alpha0 = {self.alpha0!r} exceeds alpha_star = {alpha_star!r}; "
                "0 <= alpha0 <= alpha_star is required"
            )
        n = np.asarray(self.A_zeta, dtype=float).shape[0] if np.ndim(self.A_zeta) == 2 else 0
        if n == 0:
            raise ValueError(f"A_zeta = {self.A_zeta!r}; a square n x n matrix is required")
        for name in ("A_zeta", "B_zeta", "C_zeta"):
            try:
                require_matrix(name, getattr(self, name), (n, n))
            except ValueError as error:
                raise ValueError(f"{error} (n = {n} joints, from A_zeta)") from None
        require_positive("filter_a", self.filter_a)
        freeze(self, "A_zeta", "B_zeta", "C_zeta")

    SIZED_BY: ClassVar[str] = "A_zeta"

    @property
    def joints(self) -> int:
        """``n``: the size of ``A_zeta``."""
        return len(self.A_zeta)


#: The norms Eq. 18's ``||M1*(q)||`` may be evaluated by (``UncertaintyBounds.M1_norm``;
#: their expressions: ``models.laws.spectral_norm.NORMS``).
M1_NORMS = ("spectral", "frobenius")


@dataclass(frozen=True)
class UncertaintyBounds:
    """The bounds of Assumption 1 and ``k_C1`` of the Remark of Sec. 2 (Eq. 17-18).

    A bound left ``None`` is ``relative`` times the matching norm of the nominal
    model (``models.design.bounds.resolve_bounds``): ``||M0*||``,
    ``max_q ||M1*(q)||``, ``k_C1``, ``max_q ||G*(q)||``, ``||B*||``, ``||F*||``.
    ``relative = 0.5`` is this project's choice (reading note 7): it covers the
    few-percent identification mismatch of reading note 9 and the 33 % payload of
    Sec. 4.3 on ``M0*``, ``B*`` and ``F*`` (raise it for larger payload studies).
    The bounds only enter ``delta_bar`` (Eq. 18), i.e. how fast Eq. 21 drives
    ``alpha`` to ``alpha*``. ``k_C1 = None`` computes the smallest constant of
    ``||C*(q, x) y|| <= k_C1 ||x|| ||y||`` from theta_3 and theta_8.

    ``M1_norm`` is how the controller evaluates Eq. 18's ``||M1*(q)||`` each sample
    (``M1_NORMS``): ``spectral``, the paper's norm, or ``frobenius``, an upper bound of it
    (at most ``sqrt(n)`` times larger), which keeps ``delta_bar`` a bound and costs a
    fraction of the spectral norm in generated C (``posfb codegen``), but raises
    ``delta_bar`` and so changes the paper's controller (its runs are labelled as own
    settings).
    """

    relative: float = 0.5
    delta_M0: float | None = None
    delta_M1: float | None = None
    delta_C: float | None = None
    delta_G: float | None = None
    delta_B: float | None = None
    delta_F: float | None = None
    k_C1: float | None = None
    M1_norm: str = "spectral"

    def __post_init__(self) -> None:
        for entry in fields(self):
            value = getattr(self, entry.name)
            if value is not None and entry.name != "M1_norm":
                require_nonnegative(entry.name, value)
        if self.M1_norm not in M1_NORMS:
            raise ValueError(
                f"M1_norm = {self.M1_norm!r}; one of {', '.join(M1_NORMS)} is required"
            )


@dataclass(frozen=True)
class PidGains:
    """Diagonal gains of the computed torque + PID baseline (Eq. 26, Sec. 4.2)."""

    Kp: tuple[float, ...] = (800.0, 500.0)
    Kv: tuple[float, ...] = (30.0, 15.0)
    KI: tuple[float, ...] = (1.411, 0.3)

    def __post_init__(self) -> None:
        n = joint_vector("Kp", self.Kp).size
        for name in ("Kp", "Kv", "KI"):
            for i, value in enumerate(require_vector(name, getattr(self, name), n)):
                check = require_nonnegative if name == "KI" else require_positive
                check(f"{name}[{i}]", value)
        freeze(self, "Kp", "Kv", "KI")

    SIZED_BY: ClassVar[str] = "Kp"

    @property
    def joints(self) -> int:
        """``n``: the number of ``Kp``."""
        return len(self.Kp)


@dataclass(frozen=True)
class ControllerConfig(InLoopContext):
    """Everything the three controllers are built from; defaults are the paper's.

    ``context`` is the loop they run in (``models.design.loop_context``): its ``nominal``
    model, the one the controllers use (``models.nominal``: Table 1 by default, whose
    ``M0*`` is its q-independent part, reading note 5, or a nominal URDF), whose joint
    count ``n`` sizes every other part, and its sample time ``T_s``, the period of every
    controller (``nominal`` and ``sample_time`` read it). ``discretisation`` is how the
    filters of Eq. 13, 20 and 25 are sampled (``models.design.discretise.DISCRETISATIONS``;
    zero-order hold by default: the exact discretisation of a filter driven by the held
    encoder reading).
    """

    context: LoopContext = field(default_factory=LoopContext)
    lqr: LqrWeights = field(default_factory=LqrWeights)
    nonlinear: NonlinearTorqueConfig = field(default_factory=NonlinearTorqueConfig)
    bounds: UncertaintyBounds = field(default_factory=UncertaintyBounds)
    pid: PidGains = field(default_factory=PidGains)
    discretisation: str = "zoh"

    def __post_init__(self) -> None:
        if not isinstance(self.context, LoopContext):
            raise ValueError(f"context = {self.context!r} is not a LoopContext")
        if self.discretisation not in DISCRETISATIONS:
            raise ValueError(
                f"discretisation = {self.discretisation!r}; one of "
                f"{', '.join(DISCRETISATIONS)} is required"
            )
        for name, kind in _part_types().items():
            if not isinstance(getattr(self, name), kind):
                raise ValueError(f"{name} = {getattr(self, name)!r} is not a {kind.__name__}")
        n = self.joints
        for name, kind in _part_types().items():
            part = getattr(self, name)
            if hasattr(kind, "SIZED_BY") and part.joints != n:
                raise ValueError(
                    f"{name}.{kind.SIZED_BY} is sized for {part.joints} joints; the nominal "
                    f"model has {n}: one entry per joint is required"
                )

    @property
    def nominal(self) -> NominalModel:
        """The loop's nominal model (``context.nominal``)."""
        return self.context.nominal


    @classmethod
    def without_design(cls, context: LoopContext) -> ControllerConfig:
        """The config of a controller with no Sec. 3 design (a plug-in such as PD +
        gravity or ADRC): the ``context`` (nominal model, ``T_s``) is what it reads. The
        design parts are unit placeholders sized to the nominal model (identity weights,
        ``lambda = 1``, ``H = diag(1 / (s + 1))``, unit PID gains), never used."""
        n = context.joints
        ones, identity = (1.0,) * n, diagonal((1.0,) * n)
        return cls(
            context=context,
            lqr=LqrWeights(Q1=diagonal((1.0,) * 2 * n), Q2=identity, R=identity, lambdas=ones),
            nonlinear=NonlinearTorqueConfig(
                A_zeta=diagonal((-1.0,) * n), B_zeta=identity, C_zeta=identity
            ),
            pid=PidGains(Kp=ones, Kv=ones, KI=ones),
        )

    def with_alpha_star(self, alpha_star: float) -> ControllerConfig:
        """This config with the nonlinear torque's steady-state gain ``alpha*`` changed
        (validated by ``NonlinearTorqueConfig``)."""
        return replace(self, nonlinear=replace(self.nonlinear, alpha_star=alpha_star))


@functools.cache
def _part_types() -> dict[str, type]:
    """The class of each ``ControllerConfig`` part made by a default factory (the LQR
    weights, the nonlinear torque, the bounds, the PID gains), by member name."""
    return {
        part.name: type(part.default_factory())
        for part in fields(ControllerConfig)
        if part.default_factory is not MISSING
    }
