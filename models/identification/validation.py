"""An identified model checked on a second log (``posfb identify --validate``).

Two figures per joint, each an NRMSE in percent, ``100 RMS(predicted - measured) /
RMS(measured - mean(measured))`` (0 %: perfect; 100 %: no better than the mean):

* **voltage**: the model's voltage ``Y(q, q', q'') p`` along the second log's filtered
  motion against the voltage it applied, both through the identification's filter
  (``estimate.fit_log``'s steps 1-2, its edges cut);
* **output error**: the model driven by the second log's voltages (held over each
  sample), started from the log's filtered state at the start of each window of
  ``window`` s and simulated to its end (RK4 in steps of at most ``RK4_STEP``, a whole
  number per sample period),
  against the measured positions. An arm driven open loop drifts away from any
  record of it (a double pendulum is chaotic), so a whole log simulated from its first
  sample says more about the drift than about the model; windows of about a second
  are the usual compromise (state the window with the figure).

The forward dynamics come from the regressor itself: the voltage is linear in ``q''``,
so ``M(q) = [Y(q, q', e_i) p - Y(q, q', 0) p]_i`` and ``h(q, q') = Y(q, q', 0) p``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.signal

from posfb.models.identification.estimate import (
    FilterSettings,
    Motion,
    filtered_motion,
    kept_samples,
    lowpass,
)

#: The longest RK4 step of the output-error simulation (s): four per sample period at the
#: paper's 10 ms, one at 1 ms (the arm's dynamics are slower than either by far).
RK4_STEP = 0.0025

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
    simulated positions); to read the voltage figure by, where given, the nominal
    model's on the same log (``nominal_voltage_nrmse``) and the encoder's floor
    (``encoder_floor_nrmse``: the figure one more dose of the encoder's quantisation
    error moves the model's own prediction by, what a perfect model still shows)."""

    voltage_nrmse: np.ndarray
    output_nrmse: np.ndarray
    window: float
    time: np.ndarray
    voltage: np.ndarray
    predicted_voltage: np.ndarray
    position_time: np.ndarray
    position: np.ndarray
    simulated_position: np.ndarray
    nominal_voltage_nrmse: np.ndarray | None = None
    encoder_floor_nrmse: np.ndarray | None = None

    @property
    def removed_percent(self) -> np.ndarray | None:
        """Per joint, the share (percent) of the nominal model's voltage error the
        model removes: ``100 (1 - NRMSE / nominal NRMSE)``."""
        if self.nominal_voltage_nrmse is None:
            return None
        return 100.0 * (1.0 - self.voltage_nrmse / self.nominal_voltage_nrmse)


def _accelerations(
    regressor: Regressor, values: np.ndarray, q: np.ndarray, v: np.ndarray, u: np.ndarray
) -> np.ndarray:
    """``q''`` of the model at the states ``(q, v)`` (M, n) under voltages ``u``."""
    samples, joints = q.shape
    # One regressor call for h (q'' = 0) and the n columns of M (q'' = e_i), stacked.
    units = np.concatenate([np.zeros((1, joints)), np.eye(joints)])
    stacked = regressor(
        np.tile(q, (joints + 1, 1)), np.tile(v, (joints + 1, 1)), np.repeat(units, samples, axis=0)
    ) @ values
    y = stacked.reshape(joints + 1, samples, joints)
    h = y[0]
    M = np.transpose(y[1:] - h, (1, 2, 0))
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
    (windows, steps, n), held over each sample (RK4 in steps of at most ``RK4_STEP``)."""
    windows, steps, joints = voltages.shape
    q, v = q_start.copy(), v_start.copy()
    out = np.empty((windows, steps + 1, joints))
    out[:, 0] = q
    substeps = max(1, math.ceil(sample_time / RK4_STEP - 1e-9))
    h = sample_time / substeps

    def f(q: np.ndarray, v: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return v, _accelerations(regressor, values, q, v, u)

    for k in range(steps):
        u = voltages[:, k]
        for _ in range(substeps):
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
    nominal: tuple[np.ndarray, Callable[[np.ndarray], np.ndarray] | None] | None = None,
    quantisation_step: np.ndarray | None = None,
) -> Validation:
    """The model ``values`` of ``y = regressor(...) p`` checked on a log (module
    docstring); ``target`` maps voltages to ``y`` as in ``fit_log``. ``nominal`` (its
    values and target) adds the nominal model's voltage figure, ``quantisation_step``
    (rad per count) the encoder's floor (one more uniform dose of one step, seeded)."""
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

    def voltage_figure(
        motion: Motion, values: np.ndarray, target: Callable | None
    ) -> tuple[np.ndarray, np.ndarray]:
        """The predicted and the measured ``y`` of ``values`` along ``motion``."""
        predicted = scipy.signal.sosfiltfilt(
            sos, regressor(motion.q, motion.qdot, motion.qddot) @ values, axis=0
        )[kept]
        seen = motion.voltage if target is None else target(motion.voltage)
        return predicted, scipy.signal.sosfiltfilt(sos, seen, axis=0)[kept]

    predicted, measured = voltage_figure(motion, values, target)
    nominal_nrmse = floor = None
    if nominal is not None:
        nominal_nrmse = nrmse(*voltage_figure(motion, *nominal))
    if quantisation_step is not None:
        dose = np.random.default_rng(0).uniform(-0.5, 0.5, q_measured.shape)
        again = filtered_motion(time, q_measured + dose * quantisation_step, voltage, settings)
        floor = nrmse(voltage_figure(again, values, target)[0], predicted) * (
            np.std(predicted, axis=0) / np.std(measured, axis=0)
        )
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
        nominal_voltage_nrmse=nominal_nrmse,
        encoder_floor_nrmse=floor,
    )
