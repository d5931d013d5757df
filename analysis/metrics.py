"""The figures of merit of Tables 3-4 (Sec. 4.2) and a few more for robustness.

The paper's RMS (Sec. 4.2, below Table 3)::

    RMS(x) = sqrt( (1/N0) sum_{k=1}^{N0} |x(k T_s)|^2 )

over the ``N0`` samples ``k = 1..N0`` (``t = 0`` excluded). ``q~ = q - q_d`` is
taken from the *true* joint position (the encoder's quantisation is part of the
error, not hidden by it). ``u`` is the *applied* armature voltage (after the
+-24 V saturation), as the paper measured the voltage at the motor; the
commanded voltage only enters ``saturated_fraction``.

A second error, ``rms_q_measured``, is the RMS of ``q_m - q_d`` with ``q_m`` the
encoder's reading at ``t_k`` (quantised, offset, noisy, on the motor shaft where
``sensor.location: motor``): the only error a hardware experiment can compute, and so
the one the paper's Tables 3-4 report from its motor-shaft encoders (Sec. 4.1). It
differs from the true error by the encoder's quantisation on a rigid arm, and by the
gear's deflection where the encoder reads the motor (``models.gear``).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

from posfb.diagrams.closed_loop import ClosedLoopResult


def rms(x: np.ndarray) -> np.ndarray | float:
    """The paper's RMS of the samples ``x(k T_s)``, ``k = 1..N0`` (the rows of ``x``).

    A 1-D ``x`` gives a float, a 2-D ``x`` (samples x channels) one value per column.
    """
    samples = np.asarray(x, dtype=float)
    if samples.ndim not in (1, 2) or samples.shape[0] == 0:
        raise ValueError(f"x has shape {samples.shape}; at least one sample is required")
    value = np.sqrt(np.mean(samples**2, axis=0))
    return float(value) if samples.ndim == 1 else value


@dataclass(frozen=True)
class RunMetrics:
    """One closed-loop run's figures of merit over the samples ``k = 1..N0``.

    ``rms_q``: RMS of the true tracking error per joint (rad); ``rms_u``: RMS of the
    applied voltage per joint (V); ``max_abs_q_err``: largest ``|q~_j(k T_s)|`` (rad);
    ``saturated_fraction``: share of samples where some commanded voltage exceeds
    the limit; ``wall_time_s``: wall time of the simulation (build excluded);
    ``rms_q_measured``: RMS of the measured error ``q_m - q_d`` per joint (rad; module
    docstring).
    """

    rms_q: tuple[float, ...]
    rms_u: tuple[float, ...]
    max_abs_q_err: float
    saturated_fraction: float
    wall_time_s: float
    rms_q_measured: tuple[float, ...]

    def as_dict(self) -> dict[str, object]:
        """JSON-ready: tuples become lists."""
        return {key: list(v) if isinstance(v, tuple) else v for key, v in asdict(self).items()}


def compute_metrics(
    q_error: np.ndarray,
    u_applied: np.ndarray,
    u_commanded: np.ndarray,
    voltage_limit: float | Sequence[float],
    wall_time_s: float,
    measured_error: np.ndarray,
) -> RunMetrics:
    """``RunMetrics`` from sample arrays (rows ``k = 1..N0``, one column per joint: the
    true error ``q_error``, the voltages and the ``measured_error``); ``voltage_limit``
    is one limit for all joints or one per joint."""
    error, applied, commanded, measured = (
        np.asarray(a, dtype=float) for a in (q_error, u_applied, u_commanded, measured_error)
    )
    rms_q, rms_u = rms(error), rms(applied)
    saturated = np.any(np.abs(commanded) > voltage_limit, axis=1)
    return RunMetrics(
        rms_q=tuple(float(v) for v in rms_q),
        rms_u=tuple(float(v) for v in rms_u),
        max_abs_q_err=float(np.max(np.abs(error))),
        saturated_fraction=float(np.mean(saturated)),
        wall_time_s=float(wall_time_s),
        rms_q_measured=tuple(float(v) for v in rms(measured)),
    )


def run_metrics(result: ClosedLoopResult) -> RunMetrics:
    """The metrics of a closed-loop run over its samples ``k = 1..K`` (NaN where the run
    stopped before its second sample)."""
    if len(result.times) < 2:
        nan = (math.nan,) * result.config.joints
        return RunMetrics(nan, nan, math.nan, math.nan, result.wall_time_s, nan)
    return compute_metrics(
        result.q_error[1:],
        result.u_applied[1:],
        result.u_commanded[1:],
        result.config.voltage_limit,
        result.wall_time_s,
        result.q_measured[1:] - result.q_desired[1:],
    )
