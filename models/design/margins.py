"""Stability margins of the sampled loop: how much gain, phase and delay the loop of
``models.design.closed_loop`` (the nominal linear part held over ``T_s`` with the
scenario's linear effects, and a controller's linear feedback) can lose.

The loop is broken at the plant input (``L_i = -K P``) and at the measured output
(``L_o = -P K``, ``models.design.loop_transfer``), on a log-spaced frequency grid up to
the Nyquist frequency ``pi / T_s`` (the end point included: a sampled loop's response is
real there). At each break:

* **loop at a time**, per joint ``j``: the loop opened at channel ``j`` with the others
  closed, ``l_j = F_jj - F_jo (I + F_oo)^-1 F_oj``; its gain margin (the factor on the
  phase crossovers closest to 1 on a log scale, below 1 a lower margin: python-control's
  ``stability_margins`` convention), phase margin (smallest in size over the gain
  crossovers), crossover and delay margin ``PM / omega_c`` (the smallest over the
  crossovers, a negative ``PM`` taken as ``PM + 360 deg``: MATLAB's ``allmargin``);
  crossings are found on the grid and refined with Brent's method;
* **disk margin** at skew 0 (Seiler, Packard and Gahinet, "An introduction to disk
  margins", IEEE Control Systems 2020): ``alpha = 1 / max_omega mu(S - I/2)``, ``mu`` the
  structured singular value for one complex scalar per channel (the perturbations of
  all channels at once), bounded above by ``inf_D sigma_max(D M D^-1)`` over positive
  diagonal ``D`` (exact for up to three channels); the disk-based gain margin
  ``(1 + alpha/2) / (1 - alpha/2)`` (``inf`` for ``alpha >= 2``) and phase margin ``2
  atan(alpha / 2)``; python-control's ``disk_margins`` computes the same (a test compares);
* the peaks ``max sigma_max(S)`` and ``max sigma_max(T)``.

**Delay margin of the loop** (``delay_margin``): the smallest extra delay, the same on
every joint, at which the sampled loop's spectral radius reaches 1, computed on the
sampled loop itself rather than from a phase: the total delay ``d T_s + tau`` is
modelled as ``d`` whole periods (``sensor.delay_samples``) and the fraction ``tau``
(``actuator.compute_delay``, the delayed hold), the radius scanned in steps of
``T_s / DELAY_STEPS_PER_SAMPLE`` and the first crossing bisected to ``DELAY_RESOLUTION
T_s``; ``inf`` beyond ``MAX_DELAY_SAMPLES`` periods.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np
import scipy.optimize

from posfb.models.design.closed_loop import LoopEffects, held_plant, spectral_radius
from posfb.models.design.loop_transfer import (
    DiscreteSystem,
    closed_loop_matrix,
    feedback_system,
    plant_system,
)
from posfb.models.design.realisation import DiscreteFilter

#: Frequencies of the grid (log-spaced, the Nyquist frequency the last).
GRID_POINTS = 1500

#: The coarser grid of the per-plant figures of a study (``SampledFeedback.robustness``;
#: the peak is refined between grid points either way).
STUDY_GRID_POINTS = 300

#: The grid's lowest frequency, as a fraction of the Nyquist frequency.
LOWEST_FREQUENCY = 1e-4

#: Steps per period of the delay scan, and the bisection's resolution (periods).
DELAY_STEPS_PER_SAMPLE = 8
DELAY_RESOLUTION = 1e-3

#: The largest extra delay the scan tries (periods); beyond it the margin is ``inf``.
MAX_DELAY_SAMPLES = 20

#: The two breaks, in the order they are reported.
BREAKS = ("input", "output")


@dataclass(frozen=True)
class ChannelMargins:
    """Loop-at-a-time margins of one channel (module docstring): ``gain_margin`` (factor;
    ``inf``: no phase crossover) at ``phase_crossover_rad_per_s``, ``phase_margin_deg``
    (``inf``: no gain crossover) at ``crossover_rad_per_s`` and ``delay_margin_s``."""

    gain_margin: float
    phase_crossover_rad_per_s: float
    phase_margin_deg: float
    crossover_rad_per_s: float
    delay_margin_s: float


@dataclass(frozen=True)
class BreakMargins:
    """The margins with the loop broken ``where`` (``input``: at the plant input,
    ``output``: at the measured output): the disk margin ``alpha`` and its gain and phase
    margins at ``disk_frequency_rad_per_s``, the sensitivity peaks and ``channels`` (one
    ``ChannelMargins`` per joint)."""

    where: str
    disk_margin: float
    disk_gain_margin: float
    disk_phase_margin_deg: float
    disk_frequency_rad_per_s: float
    peak_sensitivity: float
    peak_complementary_sensitivity: float
    channels: tuple[ChannelMargins, ...]


@dataclass(frozen=True)
class LoopMargins:
    """Every margin of one sampled loop: its spectral ``radius``, the loop's
    ``delay_margin_s`` (``delay_margin``) and the margins at the two breaks. The loop-wide
    figures are the worse of the two breaks'."""

    sample_time: float
    radius: float
    delay_margin_s: float
    at_input: BreakMargins
    at_output: BreakMargins

    @property
    def stable(self) -> bool:
        return self.radius < 1.0

    @property
    def delay_margin_samples(self) -> float:
        return self.delay_margin_s / self.sample_time

    @property
    def breaks(self) -> tuple[BreakMargins, BreakMargins]:
        return self.at_input, self.at_output

    @property
    def disk_margin(self) -> float:
        return min(b.disk_margin for b in self.breaks)

    @property
    def disk_gain_margin(self) -> float:
        return disk_gain_margin(self.disk_margin)

    @property
    def disk_phase_margin_deg(self) -> float:
        return disk_phase_margin_deg(self.disk_margin)

    @property
    def peak_sensitivity(self) -> float:
        return max(b.peak_sensitivity for b in self.breaks)

    @property
    def peak_complementary_sensitivity(self) -> float:
        return max(b.peak_complementary_sensitivity for b in self.breaks)


def disk_gain_margin(alpha: float) -> float:
    """The disk-based gain margin (factor) of disk margin ``alpha`` at skew 0."""
    return math.inf if alpha >= 2.0 else (1.0 + alpha / 2.0) / (1.0 - alpha / 2.0)


def disk_phase_margin_deg(alpha: float) -> float:
    """The disk-based phase margin (degrees) of disk margin ``alpha`` at skew 0."""
    return math.degrees(2.0 * math.atan(alpha / 2.0))


def frequency_grid(sample_time: float, points: int = GRID_POINTS) -> np.ndarray:
    """``points`` log-spaced frequencies (rad/s) up to the Nyquist frequency, inclusive."""
    nyquist = math.pi / sample_time
    return np.logspace(math.log10(LOWEST_FREQUENCY * nyquist), math.log10(nyquist), points)


def _osborne(magnitudes: np.ndarray, sweeps: int = 30) -> np.ndarray:
    """Log scalings ``x`` (``x_0 = 0``) that balance the rows and columns of
    ``magnitudes`` (Osborne's iteration, every channel per sweep at once): the start of
    ``structured_norm``'s search."""
    off = magnitudes * (1.0 - np.eye(len(magnitudes)))
    x = np.zeros(len(magnitudes))
    for _ in range(sweeps):
        scale = np.exp(x)
        rows = (off @ (1.0 / scale)) * scale
        columns = (scale @ off) / scale
        usable = (rows > 0.0) & (columns > 0.0)
        x[usable] += 0.25 * np.log(columns[usable] / rows[usable])
    return x - x[0]


def structured_norm(M: np.ndarray) -> float:
    """``inf_D sigma_max(D M D^-1)`` over positive diagonal ``D``: the upper bound of
    ``mu`` for one complex scalar per channel (exact for ``n <= 3``). In closed form for
    two channels (``_structured_norm_2``); beyond, ``log sigma_max`` is convex in ``x =
    log D``, with gradient ``|u_i|^2 - |v_i|^2`` (``u``, ``v`` the top singular vectors
    of ``D M D^-1``), so BFGS from Osborne's balancing finds it. Any ``D`` gives an upper
    bound, so the answer is one even where the top singular value repeats (and the
    gradient does not exist)."""
    return _scaled_norm(M)[0]


def _scaled_norm(M: np.ndarray, start: np.ndarray | None = None) -> tuple[float, np.ndarray | None]:
    """``structured_norm`` and the log scaling ``x`` it ends at (``None`` for ``n <= 2``),
    the search started from ``start`` where given (a neighbouring frequency's ``x``: the
    disk margin's refinement), else from Osborne's balancing."""
    n = len(M)
    if n == 1:
        return float(abs(M[0, 0])), None
    if n == 2:
        return _structured_norm_2(M), None

    def log_top(x: np.ndarray) -> tuple[float, np.ndarray]:
        scale = np.exp(np.concatenate([[0.0], x]))
        U, sigma, Vh = np.linalg.svd(M * scale[:, None] / scale[None, :])
        gradient = np.abs(U[:, 0]) ** 2 - np.abs(Vh[0]) ** 2
        return float(np.log(sigma[0])), gradient[1:]

    if start is None:
        start = _osborne(np.abs(M))[1:]
    found = scipy.optimize.minimize(log_top, start, jac=True, method="BFGS",
                                    options={"gtol": 1e-8})  # fmt: skip
    value = min(math.exp(found.fun), math.exp(log_top(start)[0]), float(np.linalg.norm(M, 2)))
    return value, np.asarray(found.x)


def _structured_norm_2(M: np.ndarray) -> float:
    """``structured_norm`` of a 2 x 2 matrix in closed form: with ``D = diag(1, d)``,
    ``sigma_max^2 = (F + sqrt(F^2 - 4 |det M|^2)) / 2`` grows with the Frobenius norm ``F
    = |m11|^2 + |m22|^2 + d^2 |m12|^2 + |m21|^2 / d^2`` of ``D M D^-1`` (its determinant
    does not depend on ``d``), smallest at ``d^2 = |m21| / |m12|``."""
    a = np.abs(M)
    frobenius = a[0, 0] ** 2 + a[1, 1] ** 2 + 2.0 * a[0, 1] * a[1, 0]
    determinant = abs(M[0, 0] * M[1, 1] - M[0, 1] * M[1, 0]) ** 2
    return float(math.sqrt(0.5 * (frobenius + math.sqrt(max(frobenius**2 - 4 * determinant,
                                                                0.0)))))  # fmt: skip


def loop_at_a_time(F: np.ndarray, channel: int) -> np.ndarray:
    """``l_j`` of the loop ``F`` (frequencies x n x n) opened at ``channel`` alone."""
    n = F.shape[1]
    if n == 1:
        return F[:, 0, 0].copy()
    others = [i for i in range(n) if i != channel]
    closed = np.eye(n - 1) + F[:, others][:, :, others]
    through = np.linalg.solve(closed, F[:, others, channel][:, :, None])[:, :, 0]
    return F[:, channel, channel] - np.einsum("fi,fi->f", F[:, channel, others], through)


def _crossings(values: np.ndarray, omega: np.ndarray, function: Callable[[float], float]) -> list:
    """The frequencies where ``function`` (whose grid values are ``values``) changes sign,
    refined with Brent's method."""
    found = []
    for i in np.flatnonzero(np.sign(values[:-1]) * np.sign(values[1:]) < 0.0):
        found.append(scipy.optimize.brentq(function, omega[i], omega[i + 1], xtol=1e-12))
    found += [float(w) for w, v in zip(omega, values, strict=True) if v == 0.0]
    return found


def channel_margins(
    response: Callable[[np.ndarray], np.ndarray], omega: np.ndarray
) -> ChannelMargins:
    """The margins of a SISO loop whose response at frequencies ``omega`` is
    ``response(omega)`` (module docstring); the grid ``omega`` ends at the Nyquist
    frequency, where the response is real."""
    values = response(omega)
    values[-1] = values[-1].real  # real at the Nyquist frequency (rounding aside)

    def gain(w: float) -> float:
        return float(np.log(np.abs(response(np.array([w]))[0])))

    def imaginary(w: float) -> float:
        return float(response(np.array([w]))[0].imag)

    with np.errstate(divide="ignore"):
        crossovers = _crossings(np.log(np.abs(values)), omega, gain)
    phase_crossings = [
        w for w in _crossings(values.imag, omega, imaginary) if response(np.array([w]))[0].real < 0
    ]  # the Nyquist frequency among them when the response is negative there
    gain_margin, phase_crossover = math.inf, math.nan
    if phase_crossings:
        factors = 1.0 / np.abs(response(np.array(phase_crossings)))
        pick = int(np.argmin(np.abs(np.log(factors))))
        gain_margin, phase_crossover = float(factors[pick]), float(phase_crossings[pick])
    phase_margin, crossover, delay = math.inf, math.nan, math.inf
    if crossovers:
        at = np.array(crossovers)
        margins = np.remainder(np.angle(response(at), deg=True), 360.0) - 180.0
        pick = int(np.argmin(np.abs(margins)))
        phase_margin, crossover = float(margins[pick]), float(at[pick])
        delay = float(np.min(np.radians(np.where(margins < 0.0, margins + 360.0, margins)) / at))
    return ChannelMargins(gain_margin, phase_crossover, phase_margin, crossover, delay)


def _peak(
    values: np.ndarray, omega: np.ndarray, function: Callable[[float], float]
) -> tuple[float, float]:
    """The largest of ``function`` over the grid's range: the grid's largest ``values``
    refined between its neighbours; ``(peak, frequency)``."""
    i = int(np.argmax(values))
    low, high = omega[max(i - 1, 0)], omega[min(i + 1, len(omega) - 1)]
    found = scipy.optimize.minimize_scalar(
        lambda w: -function(w),
        bounds=(low, high),
        method="bounded",
        options={"xatol": 1e-9 * high},
    )
    if -found.fun > values[i]:
        return float(-found.fun), float(found.x)
    return float(values[i]), float(omega[i])


def _disk_margin(
    S: np.ndarray, omega: np.ndarray, sensitivity: Callable[[np.ndarray], np.ndarray]
) -> tuple[float, float]:
    """The disk margin at skew 0 (module docstring) of the sensitivity ``S`` on the grid
    ``omega`` (``sensitivity(w)`` evaluates it anywhere), refined between grid points;
    ``(alpha, frequency)``."""
    eye = np.eye(S.shape[1])
    balanced = S - eye / 2.0
    upper = np.linalg.norm(balanced, 2, axis=(1, 2))
    best, at = 0.0, 0
    for i in np.argsort(-upper):  # mu <= sigma_max: stop when no frequency can beat it
        if upper[i] <= best:
            break
        value = structured_norm(balanced[i])
        if value > best:
            best, at = value, i
    last: list[np.ndarray | None] = [None]  # each refinement step starts at the last one's D

    def refined(w: float) -> float:
        value, last[0] = _scaled_norm(sensitivity(np.array([w]))[0] - eye / 2.0, last[0])
        return value

    peak, frequency = _peak(np.where(np.arange(len(omega)) == at, best, 0.0), omega, refined)
    return 1.0 / peak, frequency


def disk_margin(loop: Callable[[np.ndarray], np.ndarray], omega: np.ndarray) -> float:
    """The disk margin at skew 0 of the MIMO loop transfer ``loop(omega)`` alone (what
    ``break_margins`` reports as ``disk_margin``, without the rest)."""
    eye = np.eye(loop(omega[:1]).shape[1])

    def sensitivity(frequencies: np.ndarray) -> np.ndarray:
        return np.linalg.inv(eye + loop(frequencies))

    return _disk_margin(sensitivity(omega), omega, sensitivity)[0]


def break_margins(
    where: str, loop: Callable[[np.ndarray], np.ndarray], omega: np.ndarray,
    channels: bool = True,
) -> BreakMargins:  # fmt: skip
    """The margins of the MIMO loop transfer ``loop(omega)`` (frequencies x n x n) broken
    ``where`` (``BreakMargins``); without ``channels``, the loop-wide ones only (no
    loop-at-a-time margins: ``channels`` is empty)."""
    F = loop(omega)
    n = F.shape[1]
    eye = np.eye(n)

    def sensitivity(frequencies: np.ndarray) -> np.ndarray:
        return np.linalg.inv(eye + loop(frequencies))

    S = np.linalg.inv(eye + F)  # sensitivity(omega), from the grid's response F
    alpha, frequency = _disk_margin(S, omega, sensitivity)
    peak_S, _ = _peak(
        np.linalg.norm(S, 2, axis=(1, 2)), omega,
        lambda w: float(np.linalg.norm(sensitivity(np.array([w]))[0], 2)),
    )  # fmt: skip
    peak_T, _ = _peak(
        np.linalg.norm(eye - S, 2, axis=(1, 2)), omega,
        lambda w: float(np.linalg.norm(eye - sensitivity(np.array([w]))[0], 2)),
    )  # fmt: skip
    def on_grid_once(w: np.ndarray) -> np.ndarray:  # the grid's response is F, not recomputed
        return F if w is omega else loop(w)

    per_channel = tuple(
        channel_margins(lambda w, j=j: loop_at_a_time(on_grid_once(w), j), omega)
        for j in range(n)
    ) if channels else ()  # fmt: skip
    return BreakMargins(
        where=where,
        disk_margin=alpha,
        disk_gain_margin=disk_gain_margin(alpha),
        disk_phase_margin_deg=disk_phase_margin_deg(alpha),
        disk_frequency_rad_per_s=frequency,
        peak_sensitivity=peak_S,
        peak_complementary_sensitivity=peak_T,
        channels=per_channel,
    )


def delay_margin(radius_of: Callable[[float], float], sample_time: float) -> float:
    """The smallest extra delay (s) at which ``radius_of(delay)`` reaches 1 (module
    docstring): 0 when the loop is unstable without one, ``inf`` beyond
    ``MAX_DELAY_SAMPLES`` periods; the loop is stable ``DELAY_RESOLUTION`` periods
    below the value returned."""
    if radius_of(0.0) >= 1.0:
        return 0.0
    step = sample_time / DELAY_STEPS_PER_SAMPLE
    low = 0.0
    for k in range(1, DELAY_STEPS_PER_SAMPLE * MAX_DELAY_SAMPLES + 1):
        high = k * step
        if radius_of(high) >= 1.0:
            break
        low = high
    else:
        return math.inf
    while high - low > DELAY_RESOLUTION * sample_time:
        middle = 0.5 * (low + high)
        low, high = (low, middle) if radius_of(middle) >= 1.0 else (middle, high)
    return high


def delayed(effects: LoopEffects, extra: float, sample_time: float) -> LoopEffects:
    """``effects`` with ``extra`` seconds more loop delay: the total as whole periods on
    the measurement (``delay_samples``) and the fraction as a compute delay."""
    total = effects.delay_samples * sample_time + effects.compute_delay + extra
    whole = math.floor(total / sample_time + 1e-9)
    fraction = max(total - whole * sample_time, 0.0)
    if fraction < 1e-9 * sample_time:
        fraction = 0.0
    return replace(effects, delay_samples=whole, compute_delay=fraction)


@dataclass(frozen=True, eq=False)
class SampledFeedback:
    """A controller's linear ``feedback`` (``q~`` to the voltage) around the nominal
    linear part ``M0 q~'' + B q~' = u`` held over ``sample_time`` with ``effects``: the
    loop the margins break (``plant`` and ``controller`` as discrete systems)."""

    M0: np.ndarray
    B: np.ndarray
    sample_time: float
    effects: LoopEffects
    feedback: DiscreteFilter

    @cached_property
    def plant(self) -> DiscreteSystem:
        held = held_plant(self.M0, self.B, self.sample_time, self.effects)
        return plant_system(held, self.sample_time)

    @cached_property
    def controller(self) -> DiscreteSystem:
        return feedback_system(self.feedback, self.sample_time)

    def closed_loop(self) -> np.ndarray:
        """The closed loop's transition matrix, state ``[plant, controller]``."""
        return closed_loop_matrix(self.plant, self.controller)

    def radius(self, extra_delay: float = 0.0) -> float:
        """The spectral radius of the loop, with ``extra_delay`` seconds on every joint."""
        if extra_delay == 0.0:
            return spectral_radius(self.closed_loop())
        effects = delayed(self.effects, extra_delay, self.sample_time)
        held = held_plant(self.M0, self.B, self.sample_time, effects)
        return spectral_radius(
            closed_loop_matrix(plant_system(held, self.sample_time), self.controller)
        )

    def with_plant(self, M0: np.ndarray, B: np.ndarray, effects: LoopEffects) -> SampledFeedback:
        """The same feedback, as designed, around another plant's linear part."""
        return replace(self, M0=M0, B=B, effects=effects)

    def robustness(
        self, points: int = STUDY_GRID_POINTS, delay: bool = True
    ) -> tuple[float, float, float]:
        """``(radius, disk margin, delay margin in s)``: the figures a study reports per
        plant, the disk margin the worse of the two breaks' on ``points`` frequencies;
        both margins 0 for an unstable loop, the delay margin ``nan`` without ``delay``."""
        radius = self.radius()
        if radius >= 1.0:
            return radius, 0.0, 0.0
        at_input, at_output, omega = self._breaks(points)
        alpha = min(disk_margin(at_input, omega), disk_margin(at_output, omega))
        return radius, alpha, delay_margin(self.radius, self.sample_time) if delay else math.nan

    def _breaks(self, points: int) -> tuple[Callable, Callable, np.ndarray]:
        """The loop transfer broken at the plant's input and at its output, as functions
        of the frequencies, and the grid of ``points`` frequencies; the plant's and the
        controller's responses on the grid are computed once, for both."""
        plant, controller = self.plant, self.controller
        omega = frequency_grid(self.sample_time, points)
        on_grid = (plant.response(omega), controller.response(omega))

        def responses(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            return on_grid if w is omega else (plant.response(w), controller.response(w))

        def at_input(w: np.ndarray) -> np.ndarray:
            P, C = responses(w)
            return -C @ P

        def at_output(w: np.ndarray) -> np.ndarray:
            P, C = responses(w)
            return -P @ C

        return at_input, at_output, omega

    def margins(self, points: int = GRID_POINTS, channels: bool = True) -> LoopMargins:
        """Every margin of the loop (``LoopMargins``) on a grid of ``points`` frequencies;
        without ``channels``, the loop-wide ones only (``break_margins``)."""
        at_input, at_output, omega = self._breaks(points)
        return LoopMargins(
            sample_time=self.sample_time,
            radius=self.radius(),
            delay_margin_s=delay_margin(self.radius, self.sample_time),
            at_input=break_margins("input", at_input, omega, channels),
            at_output=break_margins("output", at_output, omega, channels),
        )
