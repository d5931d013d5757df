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

The verdict on a run (``run_verdict``), from best to worst (``RUN_STATUSES``):

* ``diverged``: the runner stopped it (``|q~|`` beyond ``timing.divergence_bound``, a
  non-finite state, an integrator failure; ``diagrams.runner``);
* ``lost``: it reached its end, but some joint's RMS error over the run's second half
  (the samples ``k > N0/2``) exceeds ``timing.lost_fraction`` of the path's excursion,
  or ``timing.lost_bound`` (rad) if that is smaller: the arm is far from its path on
  average once the start-up transient is over. The path's excursion is the largest half
  peak-to-peak of any joint's ``q_d`` over the path's first ``diagrams.sections.DURATION``
  seconds (the paper's run) or the run if longer (``path_excursion``): the size of the
  motion asked for, the same for a run of any length, a short one still in the path's
  soft start included; a joint that does not move is judged against the path's size,
  and a path that does not move at all against ``timing.lost_bound`` alone;
* ``saturated``: it reached its end and stayed near its path, but on more than
  ``timing.saturated_share`` of the second half's samples some commanded voltage is
  beyond its limit (``saturated_fraction``'s test): the loop spends that time open, at
  the actuator's limit, a share that no designed loop reaches;
* ``ok``: none of these.

A run both lost and saturated is ``lost``; its message names both. The second half
leaves out the start: a controller that starts far from the path (or at the limit) and
then converges is ``ok``. The defaults, and where their numbers come from, are
``diagrams.sections``'s (``LOST_BOUND``, ``LOST_FRACTION``, ``SATURATED_SHARE``). The
runner decides ``diverged`` because it stops the run; ``lost`` and ``saturated`` are
judgements on the whole logs, made here from the same samples as the metrics.
``run_verdict`` is the one judge: ``analysis.api.Run``, ``results.json``, the tables,
``compare``, ``tune``'s check runs, the Monte-Carlo store and the reports all report its
verdict, never the runner's own status.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

from posfb.diagrams.runner import ClosedLoopResult
from posfb.diagrams.sections import DURATION, Timing
from posfb.models.trajectory import Trajectory

#: A run's statuses, best first (module docstring); a Monte-Carlo store adds
#: ``error`` for a run that raised (``analysis.montecarlo.records``).
RUN_STATUSES = ("ok", "saturated", "lost", "diverged")

#: The statuses of a run that reached its end: its metrics cover the whole duration.
FINISHED_STATUSES = ("ok", "saturated", "lost")

#: The statuses of a run that reached its end without tracking its path: ``posfb simulate``
#: and ``compare`` exit with ``analysis.common.errors.EXIT_NOT_TRACKED`` (``posfb.simulate``
#: warns about every run that is not ``ok``, these and ``diverged``).
NOT_TRACKED_STATUSES = ("saturated", "lost")


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


def saturated_samples(
    u_commanded: np.ndarray, voltage_limit: float | Sequence[float]
) -> np.ndarray:
    """Per sample (row of ``u_commanded``, V), whether some joint's commanded voltage is
    beyond its ``voltage_limit`` (one for all joints or one per joint)."""
    return np.any(np.abs(np.asarray(u_commanded, dtype=float)) > voltage_limit, axis=1)


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
    saturated = saturated_samples(commanded, voltage_limit)
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


@dataclass(frozen=True)
class Verdict:
    """A run's ``status`` (one of ``RUN_STATUSES``) and the ``message`` that says why
    it is not ``ok`` (empty when it is)."""

    status: str
    message: str

    def sentence(self) -> str:
        """Why the run is not ``ok``, beginning with what happened (empty when it is ``ok``):
        the message of a ``lost`` or ``saturated`` run starts with that word already, a
        ``diverged`` run's (the runner's) gets it in front."""
        if self.status == "diverged":
            return f"diverged: {self.message}" if self.message else "diverged"
        return self.message


#: Most points at which ``path_excursion`` evaluates the path: the paper's 20 s run at
#: its 10 ms sample time; a sine of 4 rad/s sampled that finely has its peak within 2e-4
#: of its amplitude.
PATH_POINTS = 2000


def path_excursion(trajectory: Trajectory, duration: float) -> float:
    """The path's excursion (rad): the largest half peak-to-peak ``(max - min) / 2`` of any
    joint's desired position over the path's first ``max(duration, DURATION)`` seconds
    (``diagrams.sections.DURATION``, the paper's run), evaluated at ``PATH_POINTS + 1``
    evenly spaced instants; 0 for a path that does not move. Over that horizon and not
    only the run's, so that a short run, still in the path's soft start, is judged
    against the motion the path asks for, as a long one is."""
    times = np.linspace(0.0, max(duration, DURATION), PATH_POINTS + 1)
    path = np.array([trajectory.evaluate(float(t))[0] for t in times])
    return float(np.max(np.ptp(path, axis=0)) / 2)


def lost_threshold(excursion: float, timing: Timing) -> float:
    """The RMS error (rad) above which a joint is lost on a path of ``excursion`` (rad,
    ``path_excursion``): ``timing.lost_fraction`` of it, at most ``timing.lost_bound``;
    ``timing.lost_bound`` on a path that does not move."""
    if excursion <= 0.0:
        return timing.lost_bound
    return min(timing.lost_bound, timing.lost_fraction * excursion)


def judge(
    q_error: np.ndarray,
    u_commanded: np.ndarray,
    voltage_limit: float | Sequence[float],
    excursion: float,
    timing: Timing,
) -> Verdict:
    """The verdict on a run that reached its end (module docstring), from its samples
    ``k = 1..N0`` (rows; one column per joint): the true error ``q_error`` (rad) and the
    commanded voltage (V), on a path of ``excursion`` (rad, ``path_excursion``), with the
    bounds ``timing.lost_bound``, ``timing.lost_fraction`` and ``timing.saturated_share``.
    The second half is the rows ``k > N0/2``."""
    error = np.asarray(q_error, dtype=float)
    if error.ndim != 2 or error.shape[0] == 0:
        raise ValueError(f"q_error has shape {error.shape}; at least one sample is required")
    half = error.shape[0] // 2
    late_rms = rms(error[half:])
    share = float(np.mean(saturated_samples(np.asarray(u_commanded)[half:], voltage_limit)))
    threshold = lost_threshold(excursion, timing)
    reasons = []
    worst = int(np.argmax(late_rms))
    lost = bool(late_rms[worst] > threshold)
    if lost:
        reasons.append(
            f"lost its path: RMS(q~{worst + 1}) over the run's second half = "
            f"{late_rms[worst]:.3g} rad > {threshold:.3g} rad (timing.lost_fraction = "
            f"{timing.lost_fraction:g} of the path's excursion {excursion:.3g} rad, at most "
            f"timing.lost_bound = {timing.lost_bound:g} rad)"
        )
    saturated = share > timing.saturated_share
    if saturated:
        reasons.append(
            f"saturated: a commanded voltage beyond its limit on {100 * share:.1f} % of the "
            f"second half's samples > timing.saturated_share = "
            f"{100 * timing.saturated_share:g} %"
        )
    status = "lost" if lost else "saturated" if saturated else "ok"
    return Verdict(status, "; ".join(reasons))


def run_verdict(result: ClosedLoopResult) -> Verdict:
    """The verdict on a closed-loop run (module docstring): the runner's ``diverged``
    as it is, otherwise ``judge`` of its logged samples ``k = 1..K`` with the
    scenario's ``timing`` bounds."""
    if result.status != "ok":
        return Verdict(result.status, result.message)
    if len(result.times) < 2:
        return Verdict("ok", "")
    config = result.config
    return judge(
        result.q_error[1:],
        result.u_commanded[1:],
        config.voltage_limit,
        path_excursion(config.trajectory, config.timing.duration),
        config.timing,
    )
