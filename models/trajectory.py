"""Desired joint trajectories ``q_d(t)`` with their first two derivatives, and a
Drake system that outputs ``[q_d, qdot_d, qddot_d]``.

Two forms, both answering ``evaluate(t) -> (q_d, qdot_d, qddot_d)``:

* ``WaveTrajectory``: the Sec. 4.2 form, per joint
  ``offset + s(t) (amplitude + wave_amplitude sin(frequency t))`` with the
  soft start ``s(t) = 1 - exp(-2 t^3)``; derivatives are analytic (product rule).
  The paper's trajectory is ``PAPER_TRAJECTORY``::

      q1d(t) = -pi/2 + pi/4 (1 - e^{-2t^3}) + pi/9 (1 - e^{-2t^3}) sin(4t)
      q2d(t) =         pi/3 (1 - e^{-2t^3}) + pi/6 (1 - e^{-2t^3}) sin(3t)

* ``SplineTrajectory``: a Drake ``PiecewisePolynomial`` and its derivative
  polynomials (exact derivatives of the spline, never finite differences of
  samples). ``from_waypoints`` is the clamped cubic through given points with
  zero velocity at both ends; ``from_samples`` is the not-a-knot interpolating
  cubic through sampled positions (a CSV file). Outside its time span a spline
  holds its end point at rest (``qdot_d = qddot_d = 0``), so a run may start
  before or last longer than the path.

``sampled_source`` turns any of them into a C++ ``TrajectorySource`` exact at the
control instants, where the closed loop reads it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from pydrake.systems.primitives import TrajectorySource
from pydrake.trajectories import PiecewisePolynomial

from posfb.models.validation import require_finite

#: Fewest samples of a not-a-knot cubic (``from_samples``).
MIN_SPLINE_SAMPLES = 4

Derivatives = tuple[np.ndarray, np.ndarray, np.ndarray]


class Trajectory(Protocol):
    """A desired trajectory of ``joints`` joints: ``(q_d, qdot_d, qddot_d)`` at time
    ``t`` (s)."""

    @property
    def joints(self) -> int: ...

    def evaluate(self, t: float) -> Derivatives: ...


@dataclass(frozen=True)
class JointWave:
    """One joint's ``offset + s(t) (amplitude + wave_amplitude sin(frequency t))``
    (rad, rad, rad, rad/s)."""

    offset: float
    amplitude: float
    wave_amplitude: float
    frequency: float

    def __post_init__(self) -> None:
        for name in ("offset", "amplitude", "wave_amplitude", "frequency"):
            require_finite(name, getattr(self, name))


#: Sec. 4.2, joint 1 then joint 2.
PAPER_TRAJECTORY = (
    JointWave(offset=-np.pi / 2, amplitude=np.pi / 4, wave_amplitude=np.pi / 9, frequency=4.0),
    JointWave(offset=0.0, amplitude=np.pi / 3, wave_amplitude=np.pi / 6, frequency=3.0),
)


def desired(t: float, waves: tuple[JointWave, ...] = PAPER_TRAJECTORY) -> Derivatives:
    """``q_d(t)``, ``qdot_d(t)``, ``qddot_d(t)`` of the wave form (Sec. 4.2, analytic)."""
    e = np.exp(-2.0 * t**3)
    s, ds, dds = 1.0 - e, 6.0 * t**2 * e, (12.0 * t - 36.0 * t**4) * e
    offset = np.array([w.offset for w in waves])
    amplitude = np.array([w.amplitude for w in waves])
    wave = np.array([w.wave_amplitude for w in waves])
    omega = np.array([w.frequency for w in waves])
    sine, cosine = np.sin(omega * t), np.cos(omega * t)
    f, df, ddf = amplitude + wave * sine, wave * omega * cosine, -wave * omega**2 * sine
    return offset + s * f, ds * f + s * df, dds * f + 2.0 * ds * df + s * ddf


@dataclass(frozen=True)
class WaveTrajectory:
    """The Sec. 4.2 form with one ``JointWave`` per joint (default: the paper's)."""

    waves: tuple[JointWave, ...] = PAPER_TRAJECTORY

    def __post_init__(self) -> None:
        if len(self.waves) == 0:
            raise ValueError("trajectory.joints is empty; one wave per joint is required")

    @property
    def joints(self) -> int:
        return len(self.waves)

    def evaluate(self, t: float) -> Derivatives:
        return desired(t, self.waves)


def _require_times(key: str, times: np.ndarray, fewest: int) -> None:
    if times.ndim != 1 or len(times) < fewest:
        raise ValueError(f"{key} has {times.size} entries; at least {fewest} are required")
    if not np.all(np.isfinite(times)):
        raise ValueError(f"{key} = {times.tolist()} is not finite; finite times are required")
    steps = np.diff(times)
    if np.any(steps <= 0.0):
        k = int(np.argmax(steps <= 0.0))
        raise ValueError(
            f"{key} is not strictly increasing: entry {k + 1} = {times[k + 1]!r} follows "
            f"{times[k]!r}; strictly increasing times are required"
        )


def _require_positions(key: str, positions: np.ndarray, count: int) -> None:
    if positions.ndim != 2 or positions.shape[0] != count or positions.shape[1] == 0:
        raise ValueError(
            f"{key} has shape {list(positions.shape)}; {count} rows of one position (rad) "
            "per joint are required"
        )
    if not np.all(np.isfinite(positions)):
        raise ValueError(f"{key} has a non-finite entry; finite positions (rad) are required")


class SplineTrajectory:
    """A ``PiecewisePolynomial`` ``q_d(t)`` (rows: joints) with its exact derivatives;
    held at rest at its end points outside ``[start_time, end_time]``."""

    def __init__(self, spline: PiecewisePolynomial) -> None:
        if spline.rows() == 0 or spline.cols() != 1:
            raise ValueError(
                f"spline is {spline.rows()} x {spline.cols()}; a column (n x 1) is required"
            )
        self.spline = spline
        self.joints = spline.rows()
        self.velocity = spline.derivative(1)
        self.acceleration = spline.derivative(2)
        self.start_time = spline.start_time()
        self.end_time = spline.end_time()

    @classmethod
    def from_waypoints(
        cls, times: Sequence[float], positions: Sequence[Sequence[float]]
    ) -> SplineTrajectory:
        """The clamped cubic (continuous acceleration, zero velocity at both ends)
        through ``positions[i]`` at ``times[i]`` (at least two waypoints)."""
        t = np.asarray(times, dtype=float)
        _require_times("trajectory.times", t, 2)
        q = np.asarray(positions, dtype=float)
        _require_positions("trajectory.positions", q, len(t))
        zero = np.zeros((q.shape[1], 1))
        return cls(PiecewisePolynomial.CubicWithContinuousSecondDerivatives(t, q.T, zero, zero))

    @classmethod
    def from_samples(
        cls, times: Sequence[float], positions: Sequence[Sequence[float]], source: str
    ) -> SplineTrajectory:
        """The not-a-knot interpolating cubic through sampled positions (continuous
        acceleration; velocity and acceleration are the spline's own derivatives)."""
        t = np.asarray(times, dtype=float)
        _require_times(f"{source}: time column", t, MIN_SPLINE_SAMPLES)
        q = np.asarray(positions, dtype=float)
        _require_positions(f"{source}: position columns", q, len(t))
        return cls(PiecewisePolynomial.CubicWithContinuousSecondDerivatives(t, q.T, False))

    def evaluate(self, t: float) -> Derivatives:
        if t < self.start_time or t > self.end_time:
            end = self.start_time if t < self.start_time else self.end_time
            rest = np.zeros(self.joints)
            return self.spline.value(end).ravel(), rest, rest.copy()
        return (
            self.spline.value(t).ravel(),
            self.velocity.value(t).ravel(),
            self.acceleration.value(t).ravel(),
        )


def sampled_source(trajectory: Trajectory, sample_time: float, samples: int) -> TrajectorySource:
    """A C++ ``TrajectorySource`` of ``[q_d, qdot_d, qddot_d]`` (size 3n): ``trajectory``
    evaluated at ``t_k = k T_s``, ``k = 0..samples``, joined by a first-order hold.

    Exact wherever it is read at a sample instant (a segment evaluated at its own start
    returns its sample to the bit); the closed loop reads it only there (the controller's
    update and the loggers), so no Python runs for it during a simulation. The last
    sample is never read at its own end time: callers ask for two samples more than they
    read."""
    times = np.arange(samples + 1) * sample_time
    values = np.column_stack([np.concatenate(trajectory.evaluate(float(t))) for t in times])
    source = TrajectorySource(PiecewisePolynomial.FirstOrderHold(times, values))
    source.set_name("desired_trajectory")
    return source
