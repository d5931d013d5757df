"""Weighted least squares (or instrumental variables) of a model linear in its
parameters, from sampled positions and the voltages that moved them (issues 29, 42).

The model is ``y_j(t) = Y_j(q, q', q'') p`` per joint ``j`` (``theta_regressor``: ``y = u``
in volts; a URDF arm's torque regressor: ``y = kappa u``). A log holds only the measured
positions ``q_m`` (quantised by the encoder) and the voltages ``u`` the drive applied,
held over each sample period, and where the log has it the controller's reference.
``fit_log`` estimates ``p`` in five steps, with the filters' cutoff of ``cutoff_rule``
unless one is given:

1. **Derivatives** (offline, zero phase): ``q_m`` through a Butterworth low-pass of
   order ``FILTER_ORDER`` run forwards and backwards (``scipy.signal.sosfiltfilt``),
   then ``q'`` by central differences and ``q''`` by the compact second difference
   ``(q[k+1] - 2 q[k] + q[k-1]) / T_s^2``. Each voltage sample is aligned with the
   motion as the mean of the held voltage over the half periods either side of its
   instant, ``(u[k-1] + u[k]) / 2`` (the applied voltage is held from ``t_k`` to
   ``t_k+1``: for ``q'' = u`` the second difference equals it exactly), and goes
   through the same low-pass, so that the two sides of the model carry one filter.
2. **The parallel filter** (Gautier 1997): the regressor columns and the voltages
   through the low-pass once more, so that the nonlinear columns (``cos q2 q''``,
   ``sgn q'``) are filtered as the voltage they explain is; the linear columns then
   carry exactly the voltage's filter (without the voltage's first pass a motion with
   content near the cutoff biased the inertias by 5 %, measured). The filters'
   start-up and end are cut (``EDGE_PERIODS``); what is left is decimated to one
   sample per half period of the cutoff: samples closer than that carry the same
   filtered noise, and the least-squares error variance assumes independent residuals.
3. **Coulomb terms**: a joint's rows whose velocity is below ``stiction_velocity``, or
   within ``guard_periods`` cutoff periods of such a sample, are left out of the fit
   (the friction of a reversal is not the sign model's, and the filters spread it).
4. **Weighted least squares** (Gautier & Poignet 2001): ordinary least squares per
   joint's rows gives each joint's error variance ``sigma_j^2 = |r_j|^2 / (N_j -
   p_j)`` (``p_j`` the parameters joint ``j``'s rows involve); every row is divided by
   its ``sigma_j`` and the weighted problem solved again. The covariance of the
   estimate is ``s^2 (W^T W)^-1`` with ``W`` the weighted regressor and ``s^2`` the
   weighted residual variance (about 1); the standard errors are its diagonal's
   square roots. Each solve is on the column-scaled QR factors (``solve_scaled``): the
   covariance is symmetric by construction.
5. **Instrumental variables** (Soderstrom & Stoica 1983; the reference as instrument, as
   in closed-loop identification) where the controller's ``reference`` is given: ``Y``
   holds the encoder's error through ``q_m``, so least squares is biased (errors in
   variables, towards a smaller scale on a homogeneous equation); the instruments ``Z``
   are the regressor of the reference motion and the voltage columns of the nominal
   voltage along it (``Reference.voltage``), filtered alike, and step 4's solves are
   ``(Z^T A)^-1 Z^T b`` with the covariance ``s^2 (Z^T A)^-1 Z^T Z (A^T Z)^-1``, each of
   ``A``, ``b`` and ``Z`` with its rows divided by their joint's ``sigma_j``.

The condition number reported is that of the decimated regressor with every column
scaled to unit norm (so units do not enter it). The stated intervals were checked on
posfb's simulated logs (``tests/models/identification/test_identification.py``) and on an
independent generator's (``tests/models/identification/test_identification_honest.py``).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
import scipy.linalg
import scipy.signal
import scipy.special

#: Order of the Butterworth low-pass used for the derivatives and the parallel filter.
FILTER_ORDER = 4

#: The default cutoff as a share of the Nyquist frequency of the log.
DEFAULT_CUTOFF_SHARE = 0.1

#: Default velocity below which a joint's rows stay out of the fit (rad/s). Chosen on
#: posfb's simulated logs of the paper's arm (tanh Coulomb friction, Lin+LC, 20 000
#: counts, 10 seeds): 0.05 rad/s left the stated 3-sigma intervals covering 83 % of
#: the identifiable theta on a planned excitation, 0.3 rad/s 100 % (99 % on a
#: multisine), as the friction near a reversal, which the sign model misses, reaches
#: the rows through the filters.
DEFAULT_STICTION_VELOCITY = 0.3

#: Default guard around a slow sample, in periods of the cutoff frequency: the rows
#: that far from one stay out too (the filters spread its error over that time).
DEFAULT_GUARD_PERIODS = 0.5

#: The filtered log's start and end cut, in periods of the cutoff frequency.
EDGE_PERIODS = 3.0

#: The cutoff rule (``cutoff_rule``): the share of the motion's power that
#: defines its band, the cutoff's multiple of that band (most, least) and the share of
#: the motion's acceleration the encoder's noise may add to the filtered ``q''``.
BAND_POWER = 0.99
BAND_FACTOR = 20.0
MIN_BAND_FACTOR = 3.0
NOISE_SHARE = 0.05

#: ``c_N`` of ``cutoff_rule``: the integral of ``x^4 |H(x)|^4`` of the forwards-backwards
#: Butterworth filter of order ``FILTER_ORDER`` at unit cutoff.
NOISE_INTEGRAL = float(
    scipy.special.beta(5 / (2 * FILTER_ORDER), 2 - 5 / (2 * FILTER_ORDER)) / (2 * FILTER_ORDER)
)

#: Fewest rows per parameter the fit accepts.
MIN_ROWS_PER_PARAMETER = 5

Regressor = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


@dataclass(frozen=True)
class FilterSettings:
    """How the log is filtered: ``cutoff_hz`` (``None``: ``DEFAULT_CUTOFF_SHARE`` of the
    Nyquist frequency, or ``cutoff_rule``'s choice once ``with_rule`` resolved it) and the
    rows left out of the Coulomb terms; ``rule`` says where the cutoff came from."""

    cutoff_hz: float | None = None
    stiction_velocity: float = DEFAULT_STICTION_VELOCITY
    guard_periods: float = DEFAULT_GUARD_PERIODS
    rule: str = ""

    def with_rule(
        self,
        time: np.ndarray,
        q_measured: np.ndarray,
        reference: Reference | None,
        step: np.ndarray | None,
    ) -> FilterSettings:
        """These settings with the cutoff ``cutoff_rule`` chooses for the log where none
        is given (and the rule in words either way)."""
        if self.cutoff_hz is not None:
            return replace(self, rule="given")
        hz, rule = cutoff_rule(time, q_measured, reference, step)
        return replace(self, cutoff_hz=hz, rule=rule)

    def cutoff(self, sample_time: float) -> float:
        """The cutoff in Hz for a log sampled every ``sample_time`` s (checked)."""
        nyquist = 0.5 / sample_time
        cutoff = DEFAULT_CUTOFF_SHARE * nyquist if self.cutoff_hz is None else self.cutoff_hz
        if not (np.isfinite(cutoff) and 0.0 < cutoff < nyquist):
            raise ValueError(
                f"cutoff_hz = {self.cutoff_hz!r}; 0 < cutoff_hz < {nyquist:g} Hz (the log's "
                "Nyquist frequency) is required"
            )
        return float(cutoff)

    def __post_init__(self) -> None:
        if not (np.isfinite(self.stiction_velocity) and self.stiction_velocity >= 0.0):
            raise ValueError(
                f"stiction_velocity = {self.stiction_velocity!r} rad/s; a finite value >= 0 "
                "is required"
            )


def motion_band(time: np.ndarray, positions: np.ndarray) -> tuple[float, float]:
    """``(f_99, a_rms)``: the frequency (Hz) below which ``BAND_POWER`` of the motion's
    power lies (all joints together) and the RMS of its
    acceleration within that band (rad/s^2), from the spectrum of ``positions`` ``(N, n)``
    sampled at ``time``. Positions, not velocities: an encoder's error is white in the
    positions, so a quantised record leaves the band where its motion puts it."""
    sample_time = float(time[1] - time[0])
    # The line through the end samples out and a Hann window on: a record that is not a
    # whole number of periods would otherwise leak power to every frequency.
    ramp = np.linspace(0.0, 1.0, positions.shape[0])[:, None]
    moving = positions - positions[0] - ramp * (positions[-1] - positions[0])
    window = np.hanning(positions.shape[0])
    moving = moving * window[:, None] / np.sqrt(np.mean(window**2))  # power kept
    spectrum = np.abs(np.fft.rfft(moving, axis=0)) ** 2
    frequency = np.fft.rfftfreq(moving.shape[0], sample_time)
    power = spectrum.sum(axis=1)
    cumulative = np.cumsum(power) / max(power.sum(), np.finfo(float).tiny)
    top = min(int(np.searchsorted(cumulative, BAND_POWER)), frequency.size - 1)
    acceleration = (2.0 * np.pi * frequency[: top + 1, None]) ** 4 * spectrum[: top + 1]
    rms = float(np.sqrt(2.0 * acceleration.sum() / moving.shape[0] ** 2 / moving.shape[1]))
    return max(float(frequency[top]), float(frequency[1])), rms


def cutoff_rule(
    time: np.ndarray,
    q_measured: np.ndarray,
    reference: Reference | None,
    step: np.ndarray | None,
) -> tuple[float, str]:
    """The filters' cutoff (Hz) for a log, and the rule in words: ``BAND_FACTOR`` times
    the motion's band ``f_99`` (``motion_band`` of the reference where the log has one,
    else of the measured positions), at most ``DEFAULT_CUTOFF_SHARE`` of the Nyquist
    frequency, and at most the frequency at which the encoder's quantisation (a uniform
    error of one ``step``, white: variance ``step^2/12``) puts an RMS of ``NOISE_SHARE``
    of the motion's own acceleration into the filtered ``q''``: through the filters'
    ``|H|^4 = (1 + (f / f_c)^(2N))^-2`` (``N = FILTER_ORDER``, forwards and backwards)
    the noise's ``q''`` has the variance ``(step^2 T / 6) (2 pi)^4 f_c^5 c_N``, with
    ``c_N = integral of x^4 |H(x)|^4 dx = B(5 / 2N, 2 - 5 / 2N) / 2N`` (0.159 for
    ``N = 4``); never below ``MIN_BAND_FACTOR`` ``f_99`` (the filters must pass the
    motion)."""
    sample_time = float(time[1] - time[0])
    nyquist = 0.5 / sample_time
    band, acceleration = motion_band(time, q_measured if reference is None else reference.q)
    source = "measured positions'" if reference is None else "reference's"
    candidates = {
        f"{BAND_FACTOR:g} x the {source} band {band:.3g} Hz": BAND_FACTOR * band,
        f"{DEFAULT_CUTOFF_SHARE:g} x the Nyquist frequency": DEFAULT_CUTOFF_SHARE * nyquist,
    }
    if step is not None and np.all(np.asarray(step) > 0.0):
        coarsest = float(np.max(step))
        density = coarsest**2 * sample_time / 6.0 * (2.0 * np.pi) ** 4 * NOISE_INTEGRAL
        noise = (NOISE_SHARE * acceleration) ** 2 / density
        candidates[
            f"where the encoder's {coarsest:.3g} rad step adds {100 * NOISE_SHARE:g} % noise to "
            "q''"
        ] = noise**0.2
    reason, hz = min(candidates.items(), key=lambda item: item[1])
    floor = MIN_BAND_FACTOR * band
    if hz < floor:
        reason, hz = f"{MIN_BAND_FACTOR:g} x the {source} band {band:.3g} Hz (the least)", floor
    hz = min(hz, 0.999 * nyquist)
    return float(hz), f"{hz:.3g} Hz: {reason}"


@dataclass(frozen=True)
class Motion:
    """The filtered motion of a log at its own samples: positions, velocities and
    accelerations ``(N, n)`` and the voltage aligned with them (``fit_log`` step 1-2)."""

    time: np.ndarray
    q: np.ndarray
    qdot: np.ndarray
    qddot: np.ndarray
    voltage: np.ndarray
    cutoff_hz: float


@dataclass(frozen=True)
class Estimate:
    """A weighted least-squares estimate: ``values`` (one per ``names``), their
    ``covariance`` and standard errors ``std``, each joint's error standard deviation
    ``joint_sigma`` (in ``y``'s unit), the rows used per joint, the scaled regressor's
    ``condition_number`` and the filter's cutoff."""

    names: tuple[str, ...]
    values: np.ndarray
    covariance: np.ndarray
    joint_sigma: np.ndarray
    rows: tuple[int, ...]
    condition_number: float
    cutoff_hz: float
    cutoff_rule: str = ""

    @property
    def std(self) -> np.ndarray:
        return np.sqrt(np.diag(self.covariance))

    @property
    def cutoff_words(self) -> str:
        """The filters' cutoff with the rule that chose it (``cutoff_rule``), or in Hz."""
        return self.cutoff_rule or f"{self.cutoff_hz:g} Hz"

    @property
    def relative_std(self) -> np.ndarray:
        """``std / |value|`` (``inf`` where the value is 0)."""
        with np.errstate(divide="ignore"):
            return np.where(self.values != 0.0, self.std / np.abs(self.values), np.inf)

    def as_dict(self) -> dict[str, float]:
        return {name: float(v) for name, v in zip(self.names, self.values, strict=True)}

    def std_dict(self) -> dict[str, float]:
        return {name: float(s) for name, s in zip(self.names, self.std, strict=True)}


@dataclass(frozen=True)
class Reference:
    """The motion the controller was asked for at the log's samples: positions,
    velocities and accelerations ``(N, n)`` (exact: no encoder in them), and where a fit
    has voltage columns, the nominal model's ``voltage`` along it: the applied voltage
    holds the feedback's answer to the encoder's error, so it cannot instrument itself."""

    q: np.ndarray
    qdot: np.ndarray
    qddot: np.ndarray
    voltage: np.ndarray | None = None


def solve_scaled(
    A: np.ndarray, b: np.ndarray, Z: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """``x`` of ``A x ~ b`` and ``(P^T P)^-1`` with ``P = Q_Z^T A``, both through the
    QR factorisation of the column-scaled matrices: least squares where ``Z`` is
    ``None`` (``Q_Z = Q_A``: the covariance factor is ``(A^T A)^-1``), else the
    instrumental-variable estimate ``(Z^T A)^-1 Z^T b`` (``Z`` as tall as ``A`` and as
    wide), whose covariance factor ``(Z^T A)^-1 Z^T Z (A^T Z)^-1`` equals ``P^-1 P^-T``.
    The factor is ``X X^T`` of one triangular or square solve ``X``, made exactly
    symmetric: a covariance is symmetric by construction, not by a check."""
    norms = np.linalg.norm(A, axis=0)
    scaled = A / norms
    if Z is None:
        Q, P = np.linalg.qr(scaled)
        x = scipy.linalg.solve_triangular(P, Q.T @ b)
        X = scipy.linalg.solve_triangular(P, np.eye(P.shape[0]))
    else:
        Q, _ = np.linalg.qr(Z / np.where(np.any(Z != 0.0, axis=0), np.linalg.norm(Z, axis=0), 1))
        P = Q.T @ scaled
        x = np.linalg.solve(P, Q.T @ b)
        X = np.linalg.inv(P)
    factor = X @ X.T
    factor = 0.5 * (factor + factor.T) / np.outer(norms, norms)
    return x / norms, factor


def _instrument_rows(
    reference: Reference,
    regressor: Regressor,
    voltage_columns: Callable[[np.ndarray], np.ndarray] | None,
    motion: Motion,
    sos: np.ndarray,
    kept: np.ndarray,
    row_mask: np.ndarray,
) -> np.ndarray:
    """The instruments' rows, as ``A``'s: the regressor of the reference motion and the
    voltage columns of the nominal voltage along it (no encoder error in either, yet
    moving as the arm did), through the parallel filter, at the kept rows of each
    joint."""
    Z = regressor(reference.q, reference.qdot, reference.qddot)
    if voltage_columns is not None:
        if reference.voltage is None:
            raise ValueError(
                "reference.voltage is None; the nominal voltage along the reference is "
                "required to instrument voltage columns"
            )
        Z = np.concatenate([Z, voltage_columns(reference.voltage)], axis=2)
    return stacked_rows(scipy.signal.sosfiltfilt(sos, Z, axis=0)[kept], row_mask)


def fitted_rows(
    motion: Motion, Y: np.ndarray, coulomb: Mapping[int, int], settings: FilterSettings
) -> np.ndarray:
    """Which of the kept samples' rows (``Y``: the regressor at ``kept_samples(motion)``,
    ``(N, n, p)``) each joint's equation keeps ``(N, n)``: all but those near rest of a
    joint whose Coulomb term the equation involves (step 3)."""
    sample_time = float(motion.time[1] - motion.time[0])
    slow = np.abs(motion.qdot) < settings.stiction_velocity
    reach = int(round(settings.guard_periods / (motion.cutoff_hz * sample_time)))
    if reach > 0:
        window = np.ones(2 * reach + 1)
        slow = np.stack(
            [np.convolve(slow[:, j], window, mode="same") > 0 for j in range(slow.shape[1])],
            axis=1,
        )
    slow = slow[kept_samples(motion)]
    row_mask = np.ones(Y.shape[:2], dtype=bool)
    for index, joint in coulomb.items():
        involved = np.any(Y[:, :, index] != 0.0, axis=0)
        for j in np.flatnonzero(involved):
            row_mask[:, j] &= ~slow[:, joint]
    return row_mask


def stacked_rows(Y: np.ndarray, row_mask: np.ndarray) -> np.ndarray:
    """Each joint's kept rows of ``Y`` ``(N, n, p)``, joint after joint ``(rows, p)``."""
    return np.concatenate([Y[row_mask[:, j], j, :] for j in range(Y.shape[1])])


def scaled_condition(A: np.ndarray) -> float:
    """The condition number of ``A`` with every column scaled to unit norm (``inf``
    where singular)."""
    norms = np.linalg.norm(A, axis=0)
    singular = np.linalg.svd(A / np.where(norms > 0.0, norms, 1.0), compute_uv=False)
    return float(singular[0] / singular[-1]) if singular[-1] > 0.0 else float("inf")


def planned_condition(
    motion: Motion,
    regressor: Regressor,
    coulomb: Mapping[int, int],
    settings: FilterSettings | None = None,
) -> float:
    """The scaled condition number ``fit_log`` reports on a log of the exact ``motion``
    (a plan's, with the nominal voltage): its regressor through the parallel filter, at
    the rows steps 2-3 keep."""
    settings = settings or FilterSettings()
    sos = lowpass(motion.cutoff_hz, float(motion.time[1] - motion.time[0]))
    Y = scipy.signal.sosfiltfilt(sos, regressor(motion.q, motion.qdot, motion.qddot), axis=0)
    Y = Y[kept_samples(motion)]
    return scaled_condition(stacked_rows(Y, fitted_rows(motion, Y, coulomb, settings)))


def lowpass(cutoff_hz: float, sample_time: float) -> np.ndarray:
    return scipy.signal.butter(
        FILTER_ORDER, cutoff_hz, btype="low", fs=1.0 / sample_time, output="sos"
    )


def filtered_motion(
    time: np.ndarray, q_measured: np.ndarray, voltage: np.ndarray, settings: FilterSettings
) -> Motion:
    """Steps 1-2 of ``fit_log`` up to the regressor: ``q, q', q''`` from the measured
    positions and the voltage aligned with them, both low-passed alike (no edge cut)."""
    sample_time = float(time[1] - time[0])
    cutoff = settings.cutoff(sample_time)
    sos = lowpass(cutoff, sample_time)
    q = scipy.signal.sosfiltfilt(sos, q_measured, axis=0)
    qdot = np.gradient(q, sample_time, axis=0)
    qddot = np.empty_like(q)
    qddot[1:-1] = (q[2:] - 2.0 * q[1:-1] + q[:-2]) / sample_time**2
    qddot[0], qddot[-1] = qddot[1], qddot[-2]
    held = np.vstack([voltage[:1], 0.5 * (voltage[:-1] + voltage[1:])])
    # The voltage through the positions' filter too, so that both sides of the model
    # carry it (the linear terms exactly).
    return Motion(time, q, qdot, qddot, scipy.signal.sosfiltfilt(sos, held, axis=0), cutoff)


def kept_samples(motion: Motion) -> np.ndarray:
    """Indices left after the edge cut and the decimation."""
    sample_time = float(motion.time[1] - motion.time[0])
    edge = int(np.ceil(EDGE_PERIODS / (motion.cutoff_hz * sample_time)))
    step = max(1, int(np.floor(0.5 / (motion.cutoff_hz * sample_time))))
    kept = np.arange(edge, motion.time.size - edge, step)
    return kept


def fit_log(
    time: np.ndarray,
    q_measured: np.ndarray,
    voltage: np.ndarray,
    regressor: Regressor,
    names: Sequence[str],
    *,
    coulomb: Mapping[int, int],
    target: Callable[[np.ndarray], np.ndarray] | None = None,
    voltage_columns: Callable[[np.ndarray], np.ndarray] | None = None,
    settings: FilterSettings | None = None,
    reference: Reference | None = None,
) -> Estimate:
    """The estimate of the parameters ``names`` of ``y = regressor(q, q', q'') p`` from a
    log (module docstring). ``coulomb`` maps a Coulomb parameter's index to its joint;
    ``target`` maps the aligned voltages ``(N, n)`` to ``y`` (default: ``y = u``);
    ``voltage_columns`` (``(N, n) -> (N, n, k)``) appends regressor columns made of the
    aligned voltages (a motor constant's unknown ratio), filtered alike. With the
    controller's ``reference`` motion at the log's samples, the fit is by instrumental
    variables (step 4)."""
    settings = settings or FilterSettings()
    motion = filtered_motion(time, q_measured, voltage, settings)
    sample_time = float(time[1] - time[0])
    sos = lowpass(motion.cutoff_hz, sample_time)
    Y = regressor(motion.q, motion.qdot, motion.qddot)
    if voltage_columns is not None:
        Y = np.concatenate([Y, voltage_columns(motion.voltage)], axis=2)
    Y = scipy.signal.sosfiltfilt(sos, Y, axis=0)
    y = motion.voltage if target is None else target(motion.voltage)
    y = scipy.signal.sosfiltfilt(sos, y, axis=0)
    kept = kept_samples(motion)
    row_mask = fitted_rows(motion, Y[kept], coulomb, settings)
    Y, y = Y[kept], y[kept]
    joints, parameters = Y.shape[1], Y.shape[2]
    rows = tuple(int(row_mask[:, j].sum()) for j in range(joints))
    if min(rows) < MIN_ROWS_PER_PARAMETER * parameters / joints:
        raise ValueError(
            f"the log is too short for {parameters} parameters: {min(rows)} usable samples "
            f"on a joint after filtering ({motion.cutoff_hz:g} Hz), at least "
            f"{int(np.ceil(MIN_ROWS_PER_PARAMETER * parameters / joints))} are required "
            "(a longer log, or one that moves every joint faster than stiction_velocity)"
        )
    A, b = stacked_rows(Y, row_mask), np.concatenate(
        [y[row_mask[:, j], j] for j in range(joints)]
    )
    owner = np.concatenate([np.full(rows[j], j) for j in range(joints)])
    norms = np.linalg.norm(A, axis=0)
    unexcited = [names[i] for i in np.flatnonzero(norms == 0.0)]
    if unexcited:
        raise ValueError(
            f"the log does not excite {', '.join(unexcited)}: their regressor columns are 0; "
            "a log that moves every joint is required"
        )
    condition = scaled_condition(A)
    if not np.isfinite(condition) or condition > 1e12:
        raise ValueError(
            f"the log does not identify {parameters} parameters: its scaled regressor has "
            f"condition number {condition:.3g}; an exciting log is required "
            "(posfb identify plan)"
        )
    Z = None
    if reference is not None:
        Z = _instrument_rows(reference, regressor, voltage_columns, motion, sos, kept, row_mask)
    first, _ = solve_scaled(A, b, Z)
    residual = b - A @ first
    sigma = np.empty(joints)
    for j in range(joints):
        own = owner == j
        involved = int(np.count_nonzero(np.any(A[own] != 0.0, axis=0)))
        sigma[j] = np.sqrt(residual[own] @ residual[own] / max(rows[j] - involved, 1))
    sigma = np.where(sigma > 0.0, sigma, np.finfo(float).tiny)
    weight = 1.0 / sigma[owner, None]
    weighted_A, weighted_b = A * weight, b * weight[:, 0]
    values, unscaled = solve_scaled(
        weighted_A, weighted_b, None if Z is None else Z * weight
    )
    weighted_residual = weighted_b - weighted_A @ values
    scale = weighted_residual @ weighted_residual / (b.size - parameters)
    covariance = scale * unscaled
    return Estimate(
        names=tuple(names),
        values=values,
        covariance=covariance,
        joint_sigma=sigma * np.sqrt(scale),
        rows=rows,
        condition_number=condition,
        cutoff_hz=motion.cutoff_hz,
        cutoff_rule=settings.rule,
    )
