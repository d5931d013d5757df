"""The whole design of Sec. 3 from a ``ControllerConfig``, with its checks.

``compute_design`` runs Eq. 5-25 in order: augmented system and LQR (Eq. 11,
14-15), ``E`` (Eq. 20), the KYP check of ``H(s)``, ``G(s)``'s constants
(Sec. 3.4), the bounds (Eq. 17-18), the position-only filters discretised at
``T_s`` and the linear closed loops that say whether the design is stable with
and without sampling. A failed check is recorded (``Design.checks``,
``Design.warnings``), not raised: the report shows it. Only a Riccati equation
that scipy cannot solve raises, since nothing after it can be computed. The
controllers refuse what they cannot use: Lin+LC a failed LQR design
(``Design.require_linear_torque``), the proposed controller also a non-SPR
``H(s)`` or ``a <= ln 2 / T_s`` (``Design.require_nonlinear_torque``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, replace

import numpy as np

from posfb.models.design.augmented import (
    GainBlocks,
    augmented_system,
    column_block,
    is_hurwitz,
    nonlinear_input_matrix,
    solve_lqr,
)
from posfb.models.design.bounds import (
    BoundFilterConstants,
    ResolvedBounds,
    bound_filter_constants,
    resolve_bounds,
)
from posfb.models.design.closed_loop import (
    NO_EFFECTS,
    HeldPlant,
    LoopEffects,
    SampledLoop,
    continuous_closed_loop,
    held_loop,
    held_plant,
    held_transition,
    spectral_radius,
)
from posfb.models.design.common_lyapunov import LyapunovCertificate, common_lyapunov
from posfb.models.design.config import ControllerConfig
from posfb.models.design.configurations import ConfigurationSet, FrozenFigures
from posfb.models.design.realisation import (
    DiscreteFilter,
    linear_control_filter,
    nonlinear_control_filter,
    stack,
    velocity_bound_filter,
)
from posfb.models.design.spr import SprCertificate, spr_certificate
from posfb.models.lumped import LumpedModel, LumpedParameters
from posfb.models.nominal import nominal_model
from posfb.models.serial_model import SerialArmModel

#: Checks whose failure makes ``tau_LC`` (Eq. 13) unusable.
LINEAR_TORQUE_CHECKS = ("riccati",)
#: Checks whose failure makes ``tau_LC + tau_NC`` (Eq. 13, 19-21) unusable.
NONLINEAR_TORQUE_CHECKS = ("riccati", "spr", "bound_filter")


@dataclass(frozen=True)
class Check:
    """One design check; ``detail`` says in plain words what was found."""

    name: str
    passed: bool
    detail: str

    def __post_init__(self) -> None:
        object.__setattr__(self, "passed", bool(self.passed))  # numpy bools are not JSON


@dataclass(frozen=True, eq=False)
class Design(GainBlocks):
    """The computed design. ``M0``, ``B`` are the nominal ``M0*``, ``B*``; ``A_eta``,
    ``A_a``, ``B_a1``, ``B_a2`` Eq. 6 and 11; ``P``, ``K`` Eq. 14-15; ``E`` Eq. 20;
    ``Gamma``, ``kyp_gamma`` the KYP certificate of ``H(s)`` (``kyp_gamma = 0`` and
    ``Gamma`` ``None`` or failing when not SPR); ``coupling_norm = ||P2 (M0*)^-1||`` (Eq. 21).

    Poles (sorted by real part): ``continuous_poles`` of ``A_a - B_a1 K``;
    ``continuous_poles_with_nc`` of the nominal linear plant with the filters of
    Eq. 13 and 20 at ``alpha = alpha*``; ``lc_filter_poles`` of ``A_eta - K3``.
    ``sampled_data_spectral_radius[_lin_lc]``: ``models.design.closed_loop`` at
    ``T_s`` with (without) ``tau_NC`` at ``alpha*``; after ``with_configurations`` the
    worst over its ``configurations`` (and ``M0*``), each loop's figures per configuration
    in ``frozen_radii``.

    ``lin_lc_filter`` realises Eq. 13 (output ``eta~``); ``proposed_filter`` realises
    Eq. 13, 20 and 25 together (outputs ``[eta~, phi, p, pbar]``), both discretised
    at ``T_s`` (``models.design.realisation``).
    """

    config: ControllerConfig
    M0: np.ndarray
    B: np.ndarray
    A_eta: np.ndarray
    A_a: np.ndarray
    B_a1: np.ndarray
    B_a2: np.ndarray
    P: np.ndarray
    K: np.ndarray
    E: np.ndarray
    Gamma: np.ndarray | None
    kyp_gamma: float
    coupling_norm: float
    continuous_poles: np.ndarray
    continuous_poles_with_nc: np.ndarray
    lc_filter_poles: np.ndarray
    bound_filter: BoundFilterConstants
    lin_lc_filter: DiscreteFilter
    proposed_filter: DiscreteFilter
    sampled_data_spectral_radius: float
    sampled_data_spectral_radius_lin_lc: float
    checks: tuple[Check, ...]
    configurations: ConfigurationSet | None = None
    frozen_radii: dict[str, FrozenFigures] | None = None
    certificates: dict[str, LyapunovCertificate] | None = None

    @functools.cached_property
    def bounds(self) -> ResolvedBounds:
        """Assumption 1's constants and ``k_C1`` (``models.design.bounds.resolve_bounds``),
        resolved on first use: only the proposed controller's bound of Eq. 18 and a
        study's coverage read them, so Lin+LC, PID and plug-ins never pay a URDF arm's
        workspace search."""
        return resolve_bounds(self.config.bounds, self.config.nominal)

    @property
    def E1(self) -> np.ndarray:
        return column_block(self.E, 0)

    @property
    def E2(self) -> np.ndarray:
        return column_block(self.E, 1)

    @property
    def E3(self) -> np.ndarray:
        return column_block(self.E, 2)

    @property
    def warnings(self) -> list[str]:
        """The details of the failed checks."""
        return [check.detail for check in self.checks if not check.passed]

    def require(self, names: tuple[str, ...]) -> None:
        """Raise ``ValueError`` with the first failed check among ``names`` (its detail
        names the parameter)."""
        for check in self.checks:
            if check.name in names and not check.passed:
                raise ValueError(check.detail)

    def require_linear_torque(self) -> None:
        """Refuse a failed LQR design (Lin+LC and the proposed controller)."""
        self.require(LINEAR_TORQUE_CHECKS)

    def require_nonlinear_torque(self) -> None:
        """Refuse a failed LQR design, a non-SPR ``H(s)`` or ``a <= ln 2 / T_s``."""
        self.require(NONLINEAR_TORQUE_CHECKS)


def _sorted_poles(matrix: np.ndarray) -> np.ndarray:
    poles = np.linalg.eigvals(matrix)
    return poles[np.lexsort((poles.imag, poles.real))]


def _riccati_check(P: np.ndarray, poles: np.ndarray) -> Check:
    """``P`` positive definite and ``A_a - B_a1 K`` Hurwitz. Definiteness is judged on
    the equilibrated ``D P D`` (``D = diag(P_ii^-1/2)``, unit diagonal): a congruence,
    so it has the signs of ``P``'s eigenvalues, and its smallest eigenvalue does not
    depend on the units of the states (a fast loop's ``P`` spans many decades)."""
    eigenvalues = np.linalg.eigvalsh(P)
    smallest = float(eigenvalues.min())
    diagonal = np.diag(P)
    if np.all(diagonal > 0.0):
        scale = 1.0 / np.sqrt(diagonal)
        definite = float(np.linalg.eigvalsh(P * np.outer(scale, scale)).min()) > 1e-12
    else:
        definite = False
    passed = definite and is_hurwitz(poles)
    if passed:
        detail = (
            "Riccati equation (Eq. 15): P is positive definite and A_a - B_a1 K is Hurwitz "
            f"(slowest pole real part {poles.real.max():.4g})"
        )
    else:
        detail = (
            f"Q1, Q2, R: the Riccati solution P has smallest eigenvalue {smallest:.3g} and "
            f"A_a - B_a1 K has largest pole real part {poles.real.max():.4g}: the LQR design "
            "(Eq. 14-15) failed"
        )
    return Check("riccati", passed, detail)


def _spr_check(spr: SprCertificate) -> Check:
    if spr.is_spr:
        detail = (
            "H(s) is strictly positive real with relative degree 1 (KYP: Gamma = "
            f"{np.round(spr.Gamma, 6).tolist()}, gamma = {spr.gamma:.4g})"
        )
    else:
        detail = (
            f"A_zeta, B_zeta, C_zeta: H(s) is not strictly positive real ({spr.reason}); "
            "tau_NC (Eq. 19-21) needs an SPR H(s) of relative degree 1"
        )
    return Check("spr", spr.is_spr, detail)


def _bound_filter_check(constants: BoundFilterConstants) -> Check:
    if constants.valid:
        detail = (
            f"G(s) = a/(s + a) with filter_a = {constants.a:g} > ln 2 / T_s = "
            f"{constants.min_a:.4g}: abar = {constants.abar:.4f} < 1/2, c = {constants.c:.4f}"
        )
    else:
        suggestion = math.ceil(1.1 * constants.min_a)  # 10 % above the limit
        detail = (
            f"controller.filter_a = {constants.a:g} is not above ln 2 / T_s = "
            f"{constants.min_a:.4g} at T_s = {constants.sample_time:g} s (abar = exp(-a T_s) = "
            f"{constants.abar:.4f} >= 1/2): the bounds U1, U2 of Eq. 24-25 do not hold and the "
            f"proposed controller refuses this setting; a filter_a above {constants.min_a:.4g} "
            f"is required (e.g. --set controller.filter_a={suggestion})"
        )
    return Check("bound_filter", constants.valid, detail)


def _stability_check(
    name: str, what: str, radius: float, frozen: FrozenFigures | None = None,
    configurations: ConfigurationSet | None = None,
) -> Check:  # fmt: skip
    """``radius < 1``; with ``frozen`` figures over ``configurations``, the worst of them
    and the one at ``M0*`` (``radius``) both."""
    if frozen is None or configurations is None:
        verdict = "< 1: stable" if radius < 1.0 else ">= 1: UNSTABLE"
        return Check(name, radius < 1.0, f"{what}: spectral radius {radius:.4f} {verdict}")
    worst = frozen.worst
    passed = worst < 1.0 and radius < 1.0
    where = configurations.configurations[frozen.worst_index].describe()
    verdict = "< 1: stable" if passed else ">= 1: UNSTABLE"
    return Check(
        name, passed,
        f"{what}: spectral radius {max(worst, radius):.4f} {verdict} (worst of "
        f"{len(configurations)} configurations of the path with M*(q) frozen: {worst:.4f} at "
        f"{where}; at M0*: {radius:.4f})",
    )  # fmt: skip


@dataclass(frozen=True)
class DesignedLoop:
    """One sampled-data loop a design closes around the held nominal linear part: a Sec. 3
    filter at ``alpha = alpha*``. ``name`` is the design check that judges it, and its key
    in ``Design.frozen_radii``, ``Design.certificates`` and ``plant_spectral_radii``;
    ``label`` how the report names it; ``filter`` and ``radius`` the ``Design`` members
    that hold its filter and its spectral radius; ``nonlinear``: the filter outputs
    ``[eta~, phi, p, pbar]`` and ``u = eta~ - alpha* phi`` (Eq. 13, 19 with ``alpha =
    alpha*``; the bound filter runs open loop, so its poles ``abar`` are in the spectrum
    too), else it outputs ``eta~`` and ``u = eta~`` (Eq. 13)."""

    name: str
    label: str
    filter: str
    radius: str
    nonlinear: bool

    def output_gain(self, n: int, outputs: int, alpha_star: float) -> np.ndarray:
        """``G`` of ``u = G y`` for this loop's filter with ``outputs`` outputs."""
        if not self.nonlinear:
            return np.eye(n)
        return np.hstack([np.eye(n), -alpha_star * np.eye(n), np.zeros((n, outputs - 2 * n))])


#: The loops a design computes, by name: ``tau_LC + tau_NC`` with the bound filter (the
#: proposed controller's) and ``tau_LC`` alone (Lin+LC's). A controller names its loop in
#: its spec (``ControllerSpec.design_loop``); PID is no filter of Sec. 3.
DESIGNED_LOOPS = {
    loop.name: loop
    for loop in (
        DesignedLoop("sampled_data", "proposed, alpha = alpha*", "proposed_filter",
                     "sampled_data_spectral_radius", nonlinear=True),
        DesignedLoop("sampled_data_lin_lc", "Lin+LC", "lin_lc_filter",
                     "sampled_data_spectral_radius_lin_lc", nonlinear=False),
    )
}  # fmt: skip


def _designed_loop(name: str) -> DesignedLoop:
    """The loop ``name`` of ``DESIGNED_LOOPS``; another name is refused in one line."""
    if name not in DESIGNED_LOOPS:
        raise ValueError(f"design loop {name!r}: one of {', '.join(DESIGNED_LOOPS)} is required")
    return DESIGNED_LOOPS[name]


def _filters(design: Design) -> dict[str, DiscreteFilter]:
    """Each designed loop's filter, by loop name."""
    return {name: getattr(design, loop.filter) for name, loop in DESIGNED_LOOPS.items()}


def _loop_transitions(
    M0: np.ndarray,
    B: np.ndarray,
    filters: dict[str, DiscreteFilter],
    alpha_star: float,
    sample_time: float,
    effects: LoopEffects = NO_EFFECTS,
) -> dict[str, np.ndarray]:
    """The transition matrix of each ``DESIGNED_LOOPS`` sampled-data loop (its filter in
    ``filters``) on the linear part ``M0 q~'' + B q~' = u`` with ``effects``
    (``models.design.closed_loop``)."""
    plant = held_plant(M0, B, sample_time, effects)
    return {
        name: held_transition(
            plant,
            filters[name],
            loop.output_gain(len(M0), filters[name].C.shape[0], alpha_star),
        )  # fmt: skip
        for name, loop in DESIGNED_LOOPS.items()
    }


def _radii(transitions: dict[str, np.ndarray]) -> dict[str, float]:
    """The spectral radius of each loop of ``_loop_transitions``."""
    return {name: spectral_radius(A) for name, A in transitions.items()}


def _sampled_checks(
    config: ControllerConfig, radii: dict[str, float], effects: LoopEffects,
    frozen: dict[str, FrozenFigures] | None = None,
    configurations: ConfigurationSet | None = None,
) -> tuple[Check, Check]:  # fmt: skip
    """The ``sampled_data`` and ``sampled_data_lin_lc`` checks of ``radii`` (at ``M0*``)
    and, with them, of the ``frozen`` radii over ``configurations``; their details name
    the ``effects`` the loop includes."""
    frozen = frozen or {}
    T, method = config.sample_time, config.discretisation.upper()
    included = "; with " + ", ".join(effects.describe()) if effects.describe() else ""
    return (
        _stability_check(
            "sampled_data",
            f"sampled-data closed loop of the proposed controller (nominal linear plant held "
            f"over T_s = {T:g} s, alpha = alpha* = {config.nonlinear.alpha_star:g}, "
            f"{method} filters{included})",
            radii["sampled_data"], frozen.get("sampled_data"), configurations,
        ),
        _stability_check(
            "sampled_data_lin_lc",
            f"sampled-data closed loop of Lin+LC (T_s = {T:g} s, {method} filters{included})",
            radii["sampled_data_lin_lc"], frozen.get("sampled_data_lin_lc"), configurations,
        ),
    )  # fmt: skip


def with_effects(design: Design, effects: LoopEffects) -> Design:
    """``design`` with its sampled-data radii and checks computed on the nominal linear
    part with ``effects`` (a scenario's compute delay, sensor delay, lag, compliant gear:
    ``models.design.closed_loop``); ``design`` itself without any."""
    if effects.ideal:
        return design
    radii = _radii(_loop_transitions(
        design.M0, design.B, _filters(design),
        design.config.nonlinear.alpha_star, design.config.sample_time, effects,
    ))  # fmt: skip
    sampled = {check.name: check for check in _sampled_checks(design.config, radii, effects)}
    return replace(
        design,
        **{loop.radius: radii[name] for name, loop in DESIGNED_LOOPS.items()},
        checks=tuple(sampled.get(check.name, check) for check in design.checks),
    )


def with_configurations(
    design: Design, effects: LoopEffects, configurations: ConfigurationSet,
    certify: tuple[str, ...] = (),
) -> Design:  # fmt: skip
    """``design`` with its sampled-data checks on the nominal linear part with ``effects``
    (``with_effects``) at ``M0*`` and with ``M*(q)`` frozen at every configuration of
    ``configurations`` (``models.design.configurations``): the radii it reports are the
    worst over the set and ``M0*``, ``frozen_radii`` holds each loop's figures; for each
    loop of ``certify`` (``DESIGNED_LOOPS`` names), ``certificates`` holds the search for
    a quadratic Lyapunov function common to its frozen loops and its loop at ``M0*``
    (``models.design.common_lyapunov``)."""
    at_M0 = with_effects(design, effects)
    filters = _filters(design)
    alpha_star, T = design.config.nonlinear.alpha_star, design.config.sample_time
    transitions = [
        _loop_transitions(M, design.B, filters, alpha_star, T, effects)
        for M in (configurations.M0, *configurations.masses)
    ]
    per_configuration = [
        {name: spectral_radius(A) for name, A in loops.items()} for loops in transitions[1:]
    ]
    certificates = {
        name: common_lyapunov([loops[name] for loops in transitions]) for name in certify
    }
    nominal = {name: getattr(at_M0, loop.radius) for name, loop in DESIGNED_LOOPS.items()}
    frozen = {
        name: FrozenFigures(tuple(r[name] for r in per_configuration), nominal[name])
        for name in DESIGNED_LOOPS
    }
    checks = _sampled_checks(design.config, nominal, effects, frozen, configurations)
    sampled = {check.name: check for check in checks}
    return replace(
        at_M0,
        **{
            loop.radius: max(frozen[name].worst, nominal[name])
            for name, loop in DESIGNED_LOOPS.items()
        },  # fmt: skip
        checks=tuple(sampled.get(check.name, check) for check in at_M0.checks),
        configurations=configurations,
        frozen_radii=frozen,
        certificates=certificates,
    )


def design_loop(
    design: Design,
    loop: str,
    M0: np.ndarray,
    B: np.ndarray,
    effects: LoopEffects = NO_EFFECTS,
) -> SampledLoop:
    """The sampled-data loop ``loop`` (a ``DESIGNED_LOOPS`` name) with its filter *as
    designed* closed around the linear part ``M0, B`` with ``effects`` (``SampledLoop``:
    its inputs and outputs too)."""
    plant = held_plant(M0, B, design.config.sample_time, effects)
    return held_design_loop(design, loop, plant)


def _designed(design: Design, loop: str, joints: int) -> tuple[DiscreteFilter, np.ndarray]:
    """The filter of ``loop`` as designed and its output gain."""
    designed_loop = _designed_loop(loop)
    designed = getattr(design, designed_loop.filter)
    gain = designed_loop.output_gain(joints, designed.C.shape[0],
                                     design.config.nonlinear.alpha_star)  # fmt: skip
    return designed, gain


def designed_feedback(design: Design, loop: str) -> DiscreteFilter:
    """The filter of ``loop`` (a ``DESIGNED_LOOPS`` name) as designed, from ``q~`` to the
    feedback voltage: its output gain folded into ``C`` and ``D`` (the proposed
    controller's at ``alpha = alpha*``), as the sampled-data checks close it."""
    designed, gain = _designed(design, loop, design.config.joints)
    return DiscreteFilter(designed.A, designed.B, gain @ designed.C, gain @ designed.D,
                          designed.initial)  # fmt: skip


def held_design_loop(design: Design, loop: str, plant: HeldPlant) -> SampledLoop:
    """``design_loop`` around a plant already held over the design's sample time."""
    return held_loop(plant, *_designed(design, loop, plant.Gamma.shape[1]))


def held_design_radius(design: Design, loop: str, plant: HeldPlant) -> float:
    """The spectral radius of ``held_design_loop`` (only its transition matrix is built)."""
    return spectral_radius(held_transition(plant, *_designed(design, loop, plant.Gamma.shape[1])))


def plant_spectral_radii(
    design: Design,
    plant: LumpedParameters | SerialArmModel,
    effects: LoopEffects = NO_EFFECTS,
    configurations: tuple[tuple[float, ...], ...] = (),
    masses: tuple[np.ndarray, ...] = (),
) -> dict[str, float]:
    """The sampled-data spectral radius of each ``DESIGNED_LOOPS`` loop with the filters
    *as designed* (on the nominal model) closed around the linear part ``M0, B`` of
    ``plant`` (another arm's theta, or a serial arm's model) with ``effects``: the design
    report's check, asked of a sampled plant; with ``configurations`` (joint angles, rad),
    the worst of that and the loops with the plant's own ``M*(q)`` frozen at each
    (``models.design.configurations``), and with ``masses``, of the loops around those
    mass matrices too. On the design's own nominal model without configurations it is
    the design's radii (``with_effects``')."""
    model = LumpedModel(plant) if isinstance(plant, LumpedParameters) else plant
    filters = _filters(design)
    alpha_star, T = design.config.nonlinear.alpha_star, design.config.sample_time
    B = model.B()
    masses = [model.M0(), *(model.M(np.asarray(q, dtype=float)) for q in configurations),
              *masses]  # fmt: skip
    radii = [_radii(_loop_transitions(M, B, filters, alpha_star, T, effects)) for M in masses]
    return {name: max(r[name] for r in radii) for name in DESIGNED_LOOPS}


def compute_design(config: ControllerConfig | None = None) -> Design:
    """The design of Sec. 3 for ``config`` (default: the paper's Sec. 4.2 settings)."""
    config = ControllerConfig() if config is None else config
    model = nominal_model(config.nominal)
    M0, B = model.M0(), model.B()
    nonlinear = config.nonlinear
    T = config.sample_time
    method = config.discretisation

    augmented = augmented_system(M0, B, np.asarray(config.lqr.lambdas))
    lqr = solve_lqr(augmented, config.lqr.Q, np.asarray(config.lqr.R))
    E = nonlinear_input_matrix(lqr.P, M0)
    A_zeta, B_zeta, C_zeta = (
        np.asarray(m, dtype=float) for m in (nonlinear.A_zeta, nonlinear.B_zeta, nonlinear.C_zeta)
    )
    spr = spr_certificate(A_zeta, B_zeta, C_zeta)
    bound_filter = bound_filter_constants(nonlinear.filter_a, T)

    lc = linear_control_filter(lqr.K1, lqr.K2, lqr.K3, augmented.A_eta)
    nc = nonlinear_control_filter(
        lqr.K1, lqr.K2, lqr.K3, augmented.A_eta, E, A_zeta, B_zeta, C_zeta
    )
    n = len(M0)
    nc_gain = np.hstack([np.eye(n), -nonlinear.alpha_star * np.eye(n)])
    lin_lc_filter = lc.discretise(T, method)
    proposed_filter = stack(nc, velocity_bound_filter(nonlinear.filter_a, n)).discretise(T, method)
    radii = _radii(
        _loop_transitions(
            M0,
            B,
            {"sampled_data": proposed_filter, "sampled_data_lin_lc": lin_lc_filter},
            nonlinear.alpha_star,
            T,
        )
    )
    continuous_poles = _sorted_poles(augmented.A_a - augmented.B_a1 @ lqr.K)
    poles_with_nc = _sorted_poles(continuous_closed_loop(M0, B, nc, nc_gain))
    lc_filter_poles = _sorted_poles(lc.A)

    checks = (
        _riccati_check(lqr.P, continuous_poles),
        Check(
            "lc_filter",
            lc_filter_poles.real.max() < 0.0,
            f"the tau_LC filter of Eq. 13 (poles of A_eta - K3: "
            f"{np.round(lc_filter_poles, 3).tolist()}) is "
            + ("stable" if lc_filter_poles.real.max() < 0.0 else "UNSTABLE"),
        ),
        _spr_check(spr),
        _bound_filter_check(bound_filter),
        Check(
            "continuous_with_nc",
            poles_with_nc.real.max() < 0.0,
            f"continuous closed loop with tau_NC at alpha = alpha* = {nonlinear.alpha_star:g}: "
            f"slowest pole real part {poles_with_nc.real.max():.4g}, fastest pole "
            f"|s| = {np.abs(poles_with_nc).max():.4g} rad/s ("
            + ("stable" if poles_with_nc.real.max() < 0.0 else "UNSTABLE")
            + ")",
        ),
        *_sampled_checks(config, radii, NO_EFFECTS),
    )
    return Design(
        config=config,
        M0=M0,
        B=B,
        A_eta=augmented.A_eta,
        A_a=augmented.A_a,
        B_a1=augmented.B_a1,
        B_a2=augmented.B_a2,
        P=lqr.P,
        K=lqr.K,
        E=E,
        Gamma=spr.Gamma,
        kyp_gamma=spr.gamma,
        coupling_norm=float(np.linalg.norm(column_block(lqr.P, 1) @ np.linalg.inv(M0), 2)),
        continuous_poles=continuous_poles,
        continuous_poles_with_nc=poles_with_nc,
        lc_filter_poles=lc_filter_poles,
        bound_filter=bound_filter,
        lin_lc_filter=lin_lc_filter,
        proposed_filter=proposed_filter,
        sampled_data_spectral_radius=radii["sampled_data"],
        sampled_data_spectral_radius_lin_lc=radii["sampled_data_lin_lc"],
        checks=checks,
    )
