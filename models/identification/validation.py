"""An identified model checked on a second log (``posfb identify --validate``).

Two figures per joint, each an NRMSE in percent, ``100 RMS(predicted - measured) /
RMS(measured - mean(measured))`` (0 %: perfect; 100 %: no better than the mean):

* **voltage**: the model's voltage ``Y(q, q', q'') p`` along the second log's filtered
  motion against the voltage it applied, both through the identification's filter
  (``estimate.fit_log``'s steps 1-2, its edges cut);
* **output error**: the model driven by the second log's voltages (held over each
  sample), started from the log's filtered state at the start of each window of
  ``window`` s and simulated to its end (RK4, ``SUBSTEPS`` steps per sample period),
  against the measured positions. An arm driven open loop drifts away from any
  record of it (a double pendulum is chaotic), so a whole log simulated from its first
  sample says more about the drift than about the model; windows of about a second
  are the usual compromise (state the window with the figure).

The forward dynamics come from the regressor itself: the voltage is linear in ``q''``,
so ``M(q) = [Y(q, q', e_i) p - Y(q, q', 0) p]_i`` and ``h(q, q') = Y(q, q', 0) p``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.signal

from posfb.models.identification.estimate import (
    FilterSettings,
    filtered_motion,
    kept_samples,
    lowpass,
)

#: RK4 steps per sample period in the output-error simulation.
SUBSTEPS = 4

#: The default output-error window (s).
DEFAULT_WINDOW = 1.0

Regressor = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]


def nrmse(predicted: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """Per column: ``100 RMS(predicted - measured) / RMS(measured - mean)`` (percent)."""
    spread = np.sqrt(np.mean((measured - measured.mean(axis=0)) ** 2, axis=0))
    error = np.sqrt(np.mean((predicted - measured) ** 2, axis=0))
    return 100.0 * error / np.where(spread > 0.0, spread, np.inf)


@dataclass(frozen=True)
class Validation:
    """The NRMSE per joint of the voltage and of the windowed output error, the window
    and the traces a figure draws (times, measured and predicted voltage; measured and
    simulated positions)."""

    voltage_nrmse: np.ndarray
    output_nrmse: np.ndarray
    window: float
    time: np.ndarray
    voltage: np.ndarray
    predicted_voltage: np.ndarray
    position_time: np.ndarray
    position: np.ndarray
    simulated_position: np.ndarray


def _accelerations(
    regressor: Regressor, values: np.ndarray, q: np.ndarray, v: np.ndarray, u: np.ndarray
) -> np.ndarray:
    """``q''`` of the model at the states ``(q, v)`` (M, n) under voltages ``u``."""
    samples, joints = q.shape
    zero = np.zeros_like(q)
    h = regressor(q, v, zero) @ values
    M = np.empty((samples, joints, joints))
    for i in range(joints):
        unit = np.zeros_like(q)
        unit[:, i] = 1.0
        M[:, :, i] = regressor(q, v, unit) @ values - h
    return np.linalg.solve(M, (u - h)[:, :, None])[:, :, 0]


def _simulate_windows(
    regressor: Regressor,
    values: np.ndarray,
    q_start: np.ndarray,
    v_start: np.ndarray,
    voltages: np.ndarray,
    sample_time: float,
) -> np.ndarray:
    """Positions (windows, steps + 1, n) from each window's start under its voltages
    (windows, steps, n), held over each sample (RK4 with ``SUBSTEPS`` steps)."""
    windows, steps, joints = voltages.shape
    q, v = q_start.copy(), v_start.copy()
    out = np.empty((windows, steps + 1, joints))
    out[:, 0] = q
    h = sample_time / SUBSTEPS

    def f(q: np.ndarray, v: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return v, _accelerations(regressor, values, q, v, u)

    for k in range(steps):
        u = voltages[:, k]
        for _ in range(SUBSTEPS):
            k1q, k1v = f(q, v, u)
            k2q, k2v = f(q + 0.5 * h * k1q, v + 0.5 * h * k1v, u)
            k3q, k3v = f(q + 0.5 * h * k2q, v + 0.5 * h * k2v, u)
            k4q, k4v = f(q + h * k3q, v + h * k3v, u)
            q = q + h / 6.0 * (k1q + 2 * k2q + 2 * k3q + k4q)
            v = v + h / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v)
        out[:, k + 1] = q
    return out


def validate(
    time: np.ndarray,
    q_measured: np.ndarray,
    voltage: np.ndarray,
    regressor: Regressor,
    values: np.ndarray,
    *,
    target: Callable[[np.ndarray], np.ndarray] | None = None,
    settings: FilterSettings | None = None,
    window: float = DEFAULT_WINDOW,
) -> Validation:
    """The model ``values`` of ``y = regressor(...) p`` checked on a log (module
    docstring); ``target`` maps voltages to ``y`` as in ``fit_log``."""
    settings = settings or FilterSettings()
    sample_time = float(time[1] - time[0])
    steps = int(round(window / sample_time))
    if not (np.isfinite(window) and steps >= 1):
        raise ValueError(
            f"window = {window!r} s; at least one sample period ({sample_time:g} s) is required"
        )
    motion = filtered_motion(time, q_measured, voltage, settings)
    sos = lowpass(motion.cutoff_hz, sample_time)
    kept = kept_samples(motion)
    kept = np.arange(kept[0], kept[-1] + 1)
    predicted = scipy.signal.sosfiltfilt(
        sos, regressor(motion.q, motion.qdot, motion.qddot) @ values, axis=0
    )[kept]
    voltage_seen = motion.voltage if target is None else target(motion.voltage)
    measured = scipy.signal.sosfiltfilt(sos, voltage_seen, axis=0)[kept]
    starts = np.arange(kept[0], kept[-1] - steps, steps)
    if starts.size == 0:
        raise ValueError(
            f"window = {window:g} s is longer than the log's usable part "
            f"({kept.size * sample_time:g} s); a shorter window or a longer log is required"
        )
    drive = voltage if target is None else target(voltage)
    held = np.stack([drive[s : s + steps] for s in starts])
    simulated = _simulate_windows(
        regressor, values, motion.q[starts], motion.qdot[starts], held, sample_time
    )
    index = starts[:, None] + np.arange(steps + 1)[None, :]
    recorded = q_measured[index]
    return Validation(
        voltage_nrmse=nrmse(predicted, measured),
        output_nrmse=nrmse(
            simulated.reshape(-1, q_measured.shape[1]), recorded.reshape(-1, q_measured.shape[1])
        ),
        window=steps * sample_time,
        time=time[kept],
        voltage=measured,
        predicted_voltage=predicted,
        position_time=time[index].reshape(-1),
        position=recorded.reshape(-1, q_measured.shape[1]),
        simulated_position=simulated.reshape(-1, q_measured.shape[1]),
    )
