"""Starting settings for a new arm (``posfb scenario init``): rules that carry the paper's
Sec. 4.2 choices, made for Table 1's arm at ``T_s = 0.01 s``, to any serial arm and any
sample time. Every rule is a pure function of the arm's nominal ``M0*`` (V s^2/rad),
the sample time ``T_s`` and the trajectory; each reads its reference from the one place
the paper's setting is defined (``models.design.config``, ``models.lumped.TABLE1``,
``models.trajectory.PAPER_TRAJECTORY``, ``models.controllers.tuning``), so nothing here
repeats a number of the paper.

**LQR weights** (Sec. 3.2, Eq. 11, 14-16). Per joint ``j`` the augmented system
``m_j q'' + b_j q' = eta``, ``eta' = -lambda_j eta + v`` (Eq. 5-6 with ``m_j = M0*_jj``,
``b_j = B*_jj``) with the cost ``Qp q^2 + Qv q'^2 + Qe eta^2 + R v^2`` has closed-loop
poles ``s_1..s_3`` whose product satisfies, by the return-difference identity of the
scalar LQR at ``s = 0`` (the open loop has a pole there and the zero-frequency terms
of ``Qv``, ``Qe`` vanish)::

    |s_1 s_2 s_3| = sqrt(Qp / R) / m_j,   whatever b_j, lambda_j, Qv, Qe.

So the geometric mean of the joint's pole radii, its *bandwidth*
``omega_j = (Qp / (R m_j^2))^(1/6)`` (``joint_bandwidth``), is set exactly by ``Qp / R``
and ``m_j``; ``B*`` does not enter it (the LQR itself accounts for ``B*`` and the
coupling of ``M0*``). The rule (``lqr_weights``): every joint gets the loop of the
paper's joint 1, the slower of its two (``omega_1 T_s = 0.287`` rad per sample, against
0.49 for joint 2), scaled to ``T_s`` and to the joint's inertia. With
``rho_j = m_j omega_j^2 / (m_ref omega_ref^2)`` (the joint's torque scale over the
reference's):

* ``omega_j = omega_ref T_ref / T_s`` (the paper's bandwidth per sample);
* ``Qp_j = Qp_ref rho_j^2``, ``Qv_j = Qv_ref (rho_j omega_ref / omega_j)^2``,
  ``Qe_j = Qe_ref``, ``R_j = Qp_j / (m_j^2 omega_j^6)`` (so ``omega_j`` holds; it is
  ``R_ref (omega_ref / omega_j)^2``) and ``lambda_j = lambda_ref omega_j / omega_ref``.

These are the reference's weights in the joint's own units (time ``1 / omega_j``, torque
``m_j omega_j^2``) with the cost itself scaled by ``rho_j^2 omega_ref / omega_j``, which
is what makes ``P`` (Eq. 15), hence ``E x~`` of Eq. 20 (the input of ``H(s)`` and of
``tau_NC``), scale like the joint's torque: for a joint with ``b_j = 0`` the linear loop
has the reference's poles times ``omega_j / omega_ref`` and ``E x~`` is the reference's
times ``rho_j``. (The absolute scale of ``Q`` and ``R`` leaves ``K`` unchanged but not
``E``: an unscaled cost makes ``tau_NC`` too strong for light joints.)

On Table 1's arm at 0.01 s, joint 1 gets the paper's ``Q1_11``, ``Q1_33``, ``Q2_11``,
``R_11`` and ``lambda_1``.

**Bandwidth over the path** (``largest_bandwidth_scale``): ``M0*`` is one inertia, the arm
visits many (``models.design.configurations``): where ``M*(q)`` is lighter than ``M0*``
the same gains make a faster loop, and past some ratio an unstable sampled loop. The
bandwidth above is multiplied by the largest scale of ``BANDWIDTH_SCALES`` (1 down to
1/16) at which Lin+LC's sampled loop is stable at ``M0*``, at every configuration of the
path with ``M*(q)`` frozen, and at the path's lightest configuration with its ``M*(q)``
divided by ``CONFIGURATION_GAIN_MARGIN`` (a gain margin of 2 where the loop is most
sensitive). The shipped arms keep scale 1; an arm whose ``M*(q)`` varies many-fold gets a
slower loop, or, below 1/16, the reason why none passes.

**G(s) pole** (Sec. 3.4, ``filter_pole``): ``a = a_ref max(1, T_ref / T_s)``: the
paper's ``a = 100`` at ``T_s = 0.01 s`` has ``a T_s / ln 2 = 1.44``; faster sampling keeps
that margin over the condition ``a > ln 2 / T_s``, slower sampling keeps the paper's
``a`` (its margin only grows). At 5 ms it is 200, the worked example's value.

**H(s)** (Sec. 3.4, remark 1, ``h_gamma``): ``gamma_i`` "above the bandwidth of
``q_id``": the paper's ``gamma = 10`` is 2.5 times its fastest trajectory frequency
(4 rad/s); the rule keeps that ratio to the new trajectory's fastest frequency.

**alpha*** (Eq. 21, ``largest_alpha_star``): the largest ``alpha* <= alpha*_ref = 4``
whose sampled-data spectral radius at ``M0*`` and over the path's configurations
(``models.design.configurations``; ``Design.sampled_data_spectral_radius``)
is at most 0.95, found by bisection (``scipy.optimize.brentq``): the paper's ``alpha*``
where its loop is stable with a margin, otherwise as much of the nonlinear torque as
the sampled loop takes. Where a lowered bandwidth leaves Lin+LC's own worst radius above
0.95, the target is half-way from it to 1 (``alpha_target``).

**PID** (Eq. 26, ``pid_gains``): Eq. 26 acts on the acceleration-level error ``q~'' +
Kv q~' + Kp q~ + KI int q~ = 0``; the rule places its characteristic polynomial at
``(s + omega)^2 (s + omega / 10)``: a critically damped pair and the integrator's pole a
decade below it, so ``Kp = 1.2 omega^2`` (1/s^2), ``Kv = 2.1 omega`` (1/s), ``KI = 0.1
omega^3`` (1/s^3). ``omega`` is the baseline bandwidth ``2 pi / (20 T_s)`` of the sampling rule
(``SAMPLES_PER_BANDWIDTH``: 20 samples per period), lowered for joint ``j`` where one
encoder count ``2 pi / N`` would move its voltage ``M0*_jj (Kv count / T_s + Kp count)``
(the backward-difference velocity jumps by ``count / T_s``) by more than 5 % of the limit
(``quantisation_bandwidth``): at fast sampling the sampling rule alone makes PID chatter
on the encoder's counts (a 4-link arm at 2 ms saturated 36 % of its samples). At the
paper's settings (Table 1, 10 ms, 20000 counts, 24 V) one count moves it 3.4 % and the
sampling rule stands.

**Trajectory** (Sec. 4.2 wave form, ``initial_waves``): each joint moves from its offset
by ``amplitude = h / 2`` and oscillates by ``wave_amplitude = 2 h / 9`` with ``h`` a
quarter turn: the paper's joint 1 (pi/4 and pi/9 of pi/2). ``h`` is cut to 90 % of the
room between the offset and the joint limit on the side it moves to. Frequencies
continue the paper's 4, 3 rad/s geometrically (``4 (3/4)^(j-1)``, ``wave_frequencies``).
``largest_scale`` then shrinks every amplitude by one factor until the nominal model's
peak voltage is at most 60 % of the limit (``VOLTAGE_HEADROOM``), leaving the rest to
the feedback.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, fields
from functools import lru_cache

import numpy as np
import scipy.optimize

from posfb.models.design.config import (
    LqrWeights,
    NonlinearTorqueConfig,
    diagonal,
)
from posfb.models.design.loop_context import LoopContext
from posfb.models.lumped import TABLE1, LumpedModel
from posfb.models.trajectory import PAPER_TRAJECTORY, JointWave

#: Fraction of the voltage limit the nominal model may need on the desired trajectory.
VOLTAGE_HEADROOM = 0.6

#: Largest nominal sampled-data spectral radius ``largest_alpha_star`` accepts.
TARGET_RADIUS = 0.95

#: The bandwidth scales the LQR rule tries, largest first: 1 (the paper's bandwidth per
#: sample) down to 1/16 in quarter-octave steps (``largest_bandwidth_scale``).
BANDWIDTH_SCALES = tuple(2.0 ** (-k / 4.0) for k in range(17))

#: The gain margin the bandwidth rule asks of Lin+LC's loop where ``M*(q)`` is lightest on
#: the path: stable with that configuration's ``M*(q)`` divided by it (6 dB, the usual
#: textbook gain margin), besides stable at every configuration of the path.
CONFIGURATION_GAIN_MARGIN = 2.0

#: Fraction of the room to a joint limit a trajectory may use.
LIMIT_FRACTION = 0.9

#: Largest excursion scale ``h`` of a trajectory joint (rad): a quarter turn.
QUARTER_TURN = math.pi / 2

#: The PID rule's integrator pole as a fraction of its bandwidth.
INTEGRATOR_POLE_RATIO = 0.1

#: Fraction of the voltage limit one encoder count may move the PID's voltage by.
QUANTISATION_FRACTION = 0.05

#: Significant digits of the numbers written into a scenario.
DIGITS = 6


#: The sampling rule every default bandwidth starts from (the plug-in baselines' too,
#: ``models.controllers.tuning``): 20 samples per period of the closed-loop bandwidth,
#: the fast end of the 20-40 of Franklin, Powell and Workman ("Digital Control of
#: Dynamic Systems", 3rd ed., Sec. 11.2).
SAMPLES_PER_BANDWIDTH = 20.0


#: Points of the grid ``largest_alpha_star`` searches when no ``alpha*`` reaches its target.
ALPHA_GRID_POINTS = 40


def numbers(values: Sequence[float]) -> str:
    """``values`` as the rules' texts write them: 4 significant digits, comma-separated."""
    return ", ".join(f"{v:.4g}" for v in values)


def rounded(value: float) -> float:
    """``value`` to ``DIGITS`` significant digits (what a scenario file holds)."""
    return float(f"{float(value):.{DIGITS}g}")


def _default(cls: type, name: str) -> object:
    return next(f for f in fields(cls) if f.name == name).default


def joint_bandwidth(Qp: float, R: float, m: float) -> float:
    """``(Qp / (R m^2))^(1/6)`` (rad/s): the geometric mean of the pole radii of one joint's
    augmented LQR loop (Eq. 11, 14), exact for any damping ``b`` and ``lambda`` (module
    docstring)."""
    return float((Qp / (R * m * m)) ** (1.0 / 6.0))


@dataclass(frozen=True)
class ReferenceLoop:
    """The paper's joint-1 loop (Sec. 4.2 weights on Table 1's ``M0*_11``) at ``T_ref``:
    its inertia ``m`` (V s^2/rad), weights, ``lambda`` and ``bandwidth`` (rad/s)."""

    sample_time: float
    m: float
    Qp: float
    Qv: float
    Qe: float
    R: float
    lam: float
    bandwidth: float

    @property
    def per_sample(self) -> float:
        """``omega_ref T_ref``: the bandwidth in rad per sample."""
        return self.bandwidth * self.sample_time


@lru_cache(maxsize=1)
def paper_reference(joint: int = 0) -> ReferenceLoop:
    """The reference loop of ``lqr_weights``: joint ``joint`` (0: the paper's joint 1)
    of the default ``LqrWeights`` on Table 1's ``M0*`` at the default ``T_s``."""
    n = 2
    weights = LqrWeights()
    Q1, Q2, R = (np.asarray(m, dtype=float) for m in (weights.Q1, weights.Q2, weights.R))
    m = float(LumpedModel(TABLE1).M0()[joint, joint])
    Qp, Rj = float(Q1[joint, joint]), float(R[joint, joint])
    return ReferenceLoop(
        sample_time=float(_default(LoopContext, "sample_time")),
        m=m, Qp=Qp, Qv=float(Q1[n + joint, n + joint]), Qe=float(Q2[joint, joint]), R=Rj,
        lam=float(weights.lambdas[joint]), bandwidth=joint_bandwidth(Qp, Rj, m),
    )  # fmt: skip


@dataclass(frozen=True)
class InitialWeights:
    """The LQR inputs of ``lqr_weights``: diagonal ``Q1 = diag(Qp, Qv)``, ``Q2 = diag(Qe)``,
    ``R``, the ``lambdas``, the joints' target ``bandwidth`` (rad/s) and torque-scale
    ratios ``rho``."""

    Qp: tuple[float, ...]
    Qv: tuple[float, ...]
    Qe: tuple[float, ...]
    R: tuple[float, ...]
    lambdas: tuple[float, ...]
    bandwidth: float
    rho: tuple[float, ...]
    scale: float = 1.0

    def rule(self) -> list[str]:
        """``lqr_weights``'s rule in words, with this arm's numbers (``scenario init``
        writes it above ``controller.Q1``)."""
        ref = paper_reference()
        scaled = "" if self.scale == 1.0 else f"{self.scale:.4g} x "
        return [
            "LQR weights (Eq. 16), diagonal: every joint gets the paper's joint-1 loop (Q1 = "
            f"{ref.Qp:g}, {ref.Qv:g}; Q2 = {ref.Qe:g};",
            f"R = {ref.R:g}; lambda = {ref.lam:g}; on Table 1's M0*_11 = {ref.m:.4g} at T_s = "
            f"{ref.sample_time:g} s) at the same bandwidth per sample times a scale:",
            f"omega = (Qp_j / (R_j M0*_jj^2))^(1/6) = {scaled}{ref.per_sample:.4f} / T_s = "
            f"{self.bandwidth:.4g} rad/s (the geometric mean of a joint's",
            "LQR pole radii, whatever its damping). With rho_j = M0*_jj omega^2 / "
            f"({ref.m:.4g} x {ref.bandwidth:.4g}^2) = {numbers(self.rho)}:",
            f"Qp_j = {ref.Qp:g} rho_j^2, Qv_j = {ref.Qv:g} (rho_j {ref.bandwidth:.4g} / "
            f"omega)^2, Q2_j = {ref.Qe:g}, R_j = Qp_j / (M0*_jj^2 omega^6),",
            f"lambdas = {ref.lam:g} omega / {ref.bandwidth:.4g}: the paper's weights in the "
            "joint's own time and torque units.",
            f"scale {self.scale:.4g}: the largest of 1, 2^-1/4, ..., 1/16 at which Lin+LC's "
            "sampled loop is stable at M0*, at every configuration of the path",
            f"(M*(q) frozen) and at the path's lightest with M*(q) / "
            f"{CONFIGURATION_GAIN_MARGIN:g} (a gain margin where the loop is most sensitive).",
        ]

    def lqr(self) -> LqrWeights:
        """As the design's ``LqrWeights``."""
        return LqrWeights(
            Q1=diagonal((*self.Qp, *self.Qv)),
            Q2=diagonal(self.Qe),
            R=diagonal(self.R),
            lambdas=self.lambdas,
        )


def lqr_weights(M0: np.ndarray, sample_time: float, scale: float = 1.0) -> InitialWeights:
    """The rule of the module docstring: per joint the paper's joint-1 loop, at the same
    bandwidth per sample times ``scale`` (``BANDWIDTH_SCALES``), on the joint's ``M0*_jj``.
    Values rounded to ``DIGITS``."""
    if not (math.isfinite(scale) and 0.0 < scale <= 1.0):
        raise ValueError(f"scale = {scale!r}; a bandwidth scale in (0, 1] is required")
    ref = paper_reference()
    omega = scale * ref.per_sample / sample_time
    masses = np.diag(np.asarray(M0, dtype=float))
    if np.any(masses <= 0.0):
        raise ValueError(f"M0* has diagonal {masses.tolist()}; positive entries are required")
    time_ratio = ref.bandwidth / omega
    torque_ratio = (masses * omega**2) / (ref.m * ref.bandwidth**2)
    Qp = [ref.Qp * r**2 for r in torque_ratio]
    return InitialWeights(
        Qp=tuple(rounded(q) for q in Qp),
        Qv=tuple(rounded(ref.Qv * (r * time_ratio) ** 2) for r in torque_ratio),
        Qe=(rounded(ref.Qe),) * masses.size,
        R=tuple(rounded(q / (m * m * omega**6)) for q, m in zip(Qp, masses, strict=True)),
        lambdas=(rounded(ref.lam / time_ratio),) * masses.size,
        bandwidth=omega,
        rho=tuple(float(r) for r in torque_ratio),
        scale=scale,
    )


def largest_bandwidth_scale(acceptable: Callable[[float], bool]) -> float | None:
    """The first (largest) of ``BANDWIDTH_SCALES`` that is ``acceptable``; ``None`` when none
    is (the bandwidth rule of the module docstring)."""
    return next((scale for scale in BANDWIDTH_SCALES if acceptable(scale)), None)


def alpha_target(radius_lin_lc: float) -> float:
    """The radius ``largest_alpha_star`` aims at: ``TARGET_RADIUS``, or, where a lowered
    bandwidth leaves Lin+LC's worst radius above it (a slower loop's poles lie nearer the
    unit circle), half-way from that radius to 1: the nonlinear torque may use half of the
    stability margin Lin+LC leaves. An unstable Lin+LC keeps ``TARGET_RADIUS``."""
    if radius_lin_lc >= 1.0:
        return TARGET_RADIUS
    return max(TARGET_RADIUS, 0.5 * (1.0 + radius_lin_lc))


def filter_pole(sample_time: float) -> float:
    """``a`` of ``G(s) = a / (s + a)``: ``a_ref max(1, T_ref / T_s)`` (module docstring)."""
    a_ref = float(_default(NonlinearTorqueConfig, "filter_a"))
    t_ref = float(_default(LoopContext, "sample_time"))
    return rounded(a_ref * max(1.0, t_ref / sample_time))


def filter_pole_rule(sample_time: float) -> list[str]:
    """``filter_pole``'s rule in words at ``sample_time`` (``scenario init`` writes it
    above ``controller.filter_a``)."""
    a_ref = float(_default(NonlinearTorqueConfig, "filter_a"))
    t_ref = float(_default(LoopContext, "sample_time"))
    a = filter_pole(sample_time)
    return [
        "G(s) = a/(s + a) needs a > ln 2 / T_s = "
        f"{math.log(2) / sample_time:.4g} (Sec. 3.4); rule a = {a_ref:g} max(1, {t_ref:g} / T_s)",
        f"= {a:g}: the paper's a at {t_ref * 1000:g} ms, its margin a T_s / ln 2 = "
        f"{a_ref * t_ref / math.log(2):.3g} kept at faster sampling.",
    ]


def paper_h_gamma() -> float:
    """The paper's ``gamma`` of ``H(s) = gamma / (s + gamma)`` (default ``B_zeta``)."""
    return float(np.asarray(_default(NonlinearTorqueConfig, "B_zeta"))[0, 0])


def h_gamma(frequencies: Sequence[float]) -> float:
    """``gamma`` of ``H(s)``: the paper's ratio of ``gamma`` to its fastest trajectory
    frequency, times the fastest of ``frequencies`` (rad/s)."""
    paper_fastest = max(w.frequency for w in PAPER_TRAJECTORY)
    return rounded(paper_h_gamma() * max(frequencies) / paper_fastest)


def h_gamma_rule(gamma: float) -> list[str]:
    """``h_gamma``'s rule in words, for its result ``gamma`` (``scenario init`` writes it
    above ``controller.H``)."""
    paper_fastest = max(w.frequency for w in PAPER_TRAJECTORY)
    return [
        f"H(s) = gamma/(s + gamma), SPR (Sec. 3.4): gamma = {paper_h_gamma():g} x (fastest "
        f"trajectory frequency / the paper's {paper_fastest:g} rad/s)",
        f"= {gamma:g}, above the trajectory's bandwidth as in the paper.",
    ]


@dataclass(frozen=True)
class InitialPid:
    """Eq. 26's per-joint gains of ``pid_gains`` (1/s^2, 1/s, 1/s^3), the sampling
    rule's bandwidth ``omega_s`` and each joint's ``bandwidth`` (rad/s)."""

    Kp: tuple[float, ...]
    Kv: tuple[float, ...]
    KI: tuple[float, ...]
    omega_s: float
    bandwidth: tuple[float, ...]

    def rule(self) -> list[str]:
        """``pid_gains``'s rule in words, with this arm's numbers (``scenario init``
        writes it above ``controllers.pid``)."""
        r = INTEGRATOR_POLE_RATIO
        kp, kv, _ = _pid_coefficients(1.0)
        return [
            "Computed torque + PID (Eq. 26, acceleration-level gains, 1/s^2, 1/s, 1/s^3):",
            f"(s + omega_j)^2 (s + {r:g} omega_j): Kp = {kp:g} omega_j^2, "
            f"Kv = {kv:g} omega_j, KI = {r:g} omega_j^3, omega_j the smaller of",
            f"2 pi / ({SAMPLES_PER_BANDWIDTH:g} T_s) = {self.omega_s:.4g} rad/s "
            "(models/controllers/tuning.py) and the bandwidth at which one encoder count moves",
            f"joint j's voltage by {QUANTISATION_FRACTION:.0%} of the limit: omega_j = "
            f"{numbers(self.bandwidth)} rad/s.",
        ]


def _pid_coefficients(omega: float) -> tuple[float, float, float]:
    """``(Kp, Kv, KI)`` of ``(s + omega)^2 (s + r omega)``."""
    r = INTEGRATOR_POLE_RATIO
    return (1.0 + 2.0 * r) * omega**2, (2.0 + r) * omega, r * omega**3


def quantisation_bandwidth(m: float, count: float, sample_time: float, allowed: float) -> float:
    """The largest ``omega`` at which one encoder ``count`` (rad) moves the PID voltage
    ``m (Kv e'_est + Kp e)`` by at most ``allowed`` (V), the velocity being the backward
    difference ``count / T_s`` (Eq. 26 as posfb runs it): the positive root of
    ``m count (1.2 omega^2 + 2.1 omega / T_s) = allowed``."""
    kp, kv, _ = _pid_coefficients(1.0)  # Kp = kp omega^2, Kv = kv omega
    a, b, c = kp, kv / sample_time, -allowed / (m * count)
    return float((-b + math.sqrt(b * b - 4.0 * a * c)) / (2.0 * a))


def pid_gains(
    sample_time: float, M0: np.ndarray, encoder_counts: int, voltage_limit: float
) -> InitialPid:
    """``(s + omega_j)^2 (s + r omega_j) = s^3 + Kv s^2 + Kp s + KI`` per joint, with
    ``omega_j = min(2 pi / (20 T_s), quantisation_bandwidth(M0*_jj, 2 pi / N, T_s,
    QUANTISATION_FRACTION V))`` and ``r = INTEGRATOR_POLE_RATIO`` (module docstring)."""
    omega_s = 2.0 * math.pi / (SAMPLES_PER_BANDWIDTH * sample_time)
    count = 2.0 * math.pi / encoder_counts
    allowed = QUANTISATION_FRACTION * voltage_limit
    omegas = [
        min(omega_s, quantisation_bandwidth(float(m), count, sample_time, allowed))
        for m in np.diag(np.asarray(M0, dtype=float))
    ]
    gains = [_pid_coefficients(w) for w in omegas]
    return InitialPid(
        Kp=tuple(rounded(g[0]) for g in gains),
        Kv=tuple(rounded(g[1]) for g in gains),
        KI=tuple(rounded(g[2]) for g in gains),
        omega_s=omega_s,
        bandwidth=tuple(omegas),
    )


@dataclass(frozen=True)
class AlphaChoice:
    """``alpha*`` of ``largest_alpha_star``, its nominal sampled-data ``radius``, and
    whether the ``target`` radius was reachable at all (``met``)."""

    alpha_star: float
    radius: float
    met: bool
    target: float = TARGET_RADIUS

    def rule(self, radius_at_cap: float, radius_lin_lc: float) -> list[str]:
        """``largest_alpha_star``'s rule in words: this choice, the radius
        ``radius_at_cap`` at the paper's ``alpha*`` and Lin+LC's ``radius_lin_lc``
        (``scenario init`` writes it above ``controller.alpha_star``)."""
        cap = float(_default(NonlinearTorqueConfig, "alpha_star"))
        found = f"radius {radius_at_cap:.4f} at alpha* = {cap:g}"
        if self.alpha_star != cap:
            found += f", {self.radius:.4f} at alpha* = {self.alpha_star:g}"
        lines = [
            f"rule: the largest alpha* <= the paper's {cap:g} (Sec. 4.2) whose sampled-data "
            "(at M0* and the path's configurations)",
            f"spectral radius (check sampled_data) is <= {self.target:.4g} (bisection): {found}",
            f"(Lin+LC: {radius_lin_lc:.4f}).",
        ]
        if not self.met:
            lines.append(
                f"no alpha* reaches {self.target:.4g}: this is the alpha* of the smallest "
                f"radius on a {ALPHA_GRID_POINTS}-point grid; prefer Lin+LC or a faster T_s."
            )
        return lines


def largest_alpha_star(
    radius: Callable[[float], float], cap: float | None = None, target: float = TARGET_RADIUS
) -> AlphaChoice:
    """The largest ``alpha* <= cap`` (default the paper's 4) with ``radius(alpha*) <=
    target``, by bisection; when even a small ``alpha*`` exceeds ``target``, the
    ``alpha*`` of an ``ALPHA_GRID_POINTS`` grid with the smallest radius (``met`` is
    false)."""
    cap = float(_default(NonlinearTorqueConfig, "alpha_star")) if cap is None else cap
    at_cap = radius(cap)
    if at_cap <= target:
        return AlphaChoice(cap, at_cap, True, target)
    low = cap * 1e-3
    if radius(low) > target:
        grid = np.linspace(low, cap, ALPHA_GRID_POINTS)
        values = [radius(float(a)) for a in grid]
        best = int(np.argmin(values))
        return AlphaChoice(rounded(grid[best]), values[best], False, target)
    root = scipy.optimize.brentq(lambda a: radius(a) - target, low, cap, xtol=1e-4)
    # Round down so that the written value keeps radius <= target.
    choice = math.floor(root * 1000.0) / 1000.0
    return AlphaChoice(choice, radius(choice), True, target)


def wave_frequencies(joints: int) -> tuple[float, ...]:
    """The paper's 4 and 3 rad/s continued geometrically: ``f_1 (f_2 / f_1)^(j-1)``."""
    first, second = (w.frequency for w in PAPER_TRAJECTORY[:2])
    return tuple(rounded(first * (second / first) ** j) for j in range(joints))


def paper_fractions() -> tuple[float, float]:
    """The paper's joint-1 ``amplitude`` and ``wave_amplitude`` as fractions of a quarter
    turn (1/2 and 2/9)."""
    wave = PAPER_TRAJECTORY[0]
    return wave.amplitude / QUARTER_TURN, wave.wave_amplitude / QUARTER_TURN


def initial_waves(
    offsets: Sequence[float],
    lower: Sequence[float],
    upper: Sequence[float],
    scale: float = 1.0,
) -> tuple[JointWave, ...]:
    """One ``JointWave`` per joint (module docstring): from ``offsets`` toward the side
    with more room before the limits ``lower``, ``upper`` (rad, may be infinite), by
    ``scale`` times the paper's joint-1 fractions of ``h = min(pi/2, 0.9 room)``."""
    amplitude_fraction, wave_fraction = paper_fractions()
    frequencies = wave_frequencies(len(offsets))
    waves = []
    for offset, low, high, frequency in zip(offsets, lower, upper, frequencies, strict=True):
        up, down = high - offset, offset - low
        sign = 1.0 if up >= down else -1.0
        h = min(QUARTER_TURN, LIMIT_FRACTION * max(up, down))
        waves.append(
            JointWave(
                offset=round(float(offset), DIGITS) + 0.0,
                amplitude=rounded(sign * scale * amplitude_fraction * h),
                wave_amplitude=rounded(scale * wave_fraction * h),
                frequency=frequency,
            )
        )
    return tuple(waves)


def trajectory_rule(
    lower: Sequence[float],
    upper: Sequence[float],
    hanging: Sequence[bool],
    scale: float,
    peak: Sequence[float],
    voltage_limit: float,
) -> list[str]:
    """The trajectory's rules in words (``initial_waves``, ``wave_frequencies``,
    ``largest_scale``), for joints with limits ``lower``, ``upper`` (rad), those
    ``hanging`` at their least potential energy, the amplitude ``scale`` found and the
    ``peak`` voltages it needs (``scenario init`` writes it above ``trajectory``)."""
    amplitude_fraction, wave_fraction = paper_fractions()
    first, second = (w.frequency for w in PAPER_TRAJECTORY[:2])
    hung = [j + 1 for j, free in enumerate(hanging) if free]
    centred = [j + 1 for j, free in enumerate(hanging) if not free]
    bounds = enumerate(zip(lower, upper, strict=True))
    limits = "; ".join(f"q{j + 1} [{lo:.4g}, {hi:.4g}]" for j, (lo, hi) in bounds)
    return [
        "Sec. 4.2 wave form, per joint offset + s(t) (amplitude + wave_amplitude "
        "sin(frequency t)).",
        f"offset: joints {_joint_list(centred)} at the centre of their limits, joints "
        f"{_joint_list(hung)}",
        "(range of a full turn or more) at the posture of least potential energy (hanging).",
        f"joint limits (rad): {limits}.",
        f"amplitude = {amplitude_fraction:.4g} h, wave_amplitude = {wave_fraction:.4g} h "
        "(the paper's joint 1: pi/4 and pi/9 of a quarter turn),",
        f"h = min(pi/2, {LIMIT_FRACTION:g} x the room to the limit on the side moved to), "
        f"all times a scale {scale:.4g}:",
        f"the largest scale <= 1 whose nominal inverse dynamics (gravity and friction in) "
        f"need at most {VOLTAGE_HEADROOM:.0%}",
        f"of the voltage limit at every sample instant: peak |u| = {numbers(peak)} V "
        f"(limit {voltage_limit:g} V).",
        f"frequency: the paper's {first:g}, {second:g} rad/s continued geometrically, "
        f"{first:g} ({second:g}/{first:g})^(j-1).",
    ]


def _joint_list(joints: list[int]) -> str:
    return ", ".join(str(j) for j in joints) if joints else "(none)"


def largest_scale(
    peak: Callable[[float], float], limit: float, fewest: float = 1e-3, steps: int = 30
) -> float | None:
    """The largest amplitude scale in ``[fewest, 1]`` (bisection to ``2^-steps``) whose
    ``peak(scale)`` is at most ``limit``; ``None`` when even ``fewest`` exceeds it."""
    if peak(1.0) <= limit:
        return 1.0
    if peak(fewest) > limit:
        return None
    low, high = fewest, 1.0
    for _ in range(steps):
        middle = 0.5 * (low + high)
        if peak(middle) <= limit:
            low = middle
        else:
            high = middle
    return low
