"""Evidence for the report: why a run differs from the paper.

* ``sampled_data_scan``: spectral radius and oscillation frequency of the
  sampled-data loop of the proposed controller (``models.design.closed_loop``)
  for a range of ``alpha*``, on the design model (Table 1) and on the true arm
  linearised at several elbow angles, with and without the payload.
* ``choose_alpha_star``: the smallest change to the paper's ``alpha*`` that makes
  every one of those loops stable.
* ``pid_mismatch_prediction``: the tracking error that the model mismatch alone
  forces on computed torque + PID (Eq. 26), from its linear error dynamics
  ``e'' + K_v e' + K_p e + K_I int e = -M*(q_d)^-1 (u_true - u_model)(t)``.
* ``peak_frequency``: the dominant frequency of a logged error.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.signal

from posfb.analysis.paper.experiment import CASES, payload_mass
from posfb.models.controllers import cached_design
from posfb.models.design import ControllerConfig
from posfb.models.design.closed_loop import sampled_data_closed_loop
from posfb.models.lumped import LumpedModel, LumpedParameters
from posfb.models.nominal import trajectory_voltages
from posfb.models.plant import apply_parameters, build_arm_diagram
from posfb.models.theta_of_plant import identify
from posfb.models.trajectory import Trajectory

#: Elbow angles (rad) at which the true arm is linearised: the trajectory's q2 range.
ELBOW_ANGLES = (0.0, math.pi / 6, math.pi / 3, math.pi / 2)


def true_lumped(case: str) -> LumpedParameters:
    """theta of the URDF arm of ``case`` (identified exactly, ``models.theta_of_plant``)."""
    _, arm, context = build_arm_diagram()
    apply_parameters(arm, context, arm.default_parameters.with_payload(payload_mass(case)))
    return identify(arm, context)


@dataclass(frozen=True)
class LoopEigen:
    """Largest eigenvalue modulus of a sampled-data loop and its frequency (Hz)."""

    radius: float
    frequency: float


@dataclass(frozen=True)
class ScanRow:
    """One ``alpha*``: the design model's loop and, per case, the worst true-arm loop."""

    alpha_star: float
    design: LoopEigen
    true_arm: dict[str, LoopEigen]

    @property
    def worst_radius(self) -> float:
        return max(loop.radius for loop in self.true_arm.values())


def _loop_eigen(matrix: np.ndarray, sample_time: float) -> LoopEigen:
    eigenvalues = np.linalg.eigvals(matrix)
    largest = eigenvalues[np.argmax(np.abs(eigenvalues))]
    return LoopEigen(
        float(abs(largest)), float(abs(np.angle(largest)) / (2.0 * math.pi * sample_time))
    )


def sampled_data_scan(
    alpha_stars: tuple[float, ...], config: ControllerConfig | None = None
) -> list[ScanRow]:
    """The proposed controller's sampled-data loop (``alpha = alpha*``, ZOH, no
    extra delay) for each ``alpha*`` in ``alpha_stars``; everything else from
    ``config`` (default: the paper's)."""
    config = ControllerConfig() if config is None else config
    T = config.sample_time
    true_models = {case: LumpedModel(true_lumped(case)) for case in CASES}
    rows = []
    for alpha_star in alpha_stars:
        changed = config.with_alpha_star(alpha_star)
        design = cached_design(changed)
        filt = design.proposed_filter
        # outputs [eta~, phi, p, pbar]: u = eta~ - alpha* phi (the bound filter is open loop)
        gain = np.hstack([np.eye(2), -alpha_star * np.eye(2), np.zeros((2, filt.C.shape[0] - 4))])
        loop = _loop_eigen(sampled_data_closed_loop(design.M0, design.B, filt, gain, T), T)
        worst = {}
        for case, model in true_models.items():
            loops = [
                _loop_eigen(
                    sampled_data_closed_loop(
                        model.M(np.array([0.0, q2])), model.B(), filt, gain, T
                    ),
                    T,
                )
                for q2 in ELBOW_ANGLES
            ]
            worst[case] = max(loops, key=lambda e: e.radius)
        rows.append(ScanRow(alpha_star, loop, worst))
    return rows


def choose_alpha_star(rows: list[ScanRow]) -> float | None:
    """The largest scanned ``alpha*`` whose loops on the true arm (every case, every
    elbow angle) are all stable; ``None`` if none is."""
    stable = [row.alpha_star for row in rows if row.worst_radius < 1.0]
    return max(stable) if stable else None


def pid_mismatch_prediction(
    case: str,
    trajectory: Trajectory,
    duration: float,
    sample_time: float,
    config: ControllerConfig | None = None,
) -> tuple[float, float]:
    """RMS (samples ``k = 1..N0``) of the PID error forced by the model mismatch alone.

    ``Delta u(t)`` is the voltage the true arm of ``case`` needs along the desired
    trajectory minus what the nominal model says (friction excluded); each joint's
    error obeys ``e'' + K_v e' + K_p e + K_I int e = -(M*(q_d)^-1 Delta u)_j``,
    i.e. ``E(s) = -s F(s) / (s^3 + K_v s^2 + K_p s + K_I)``."""
    config = ControllerConfig() if config is None else config
    nominal, true = LumpedModel(config.nominal), LumpedModel(true_lumped(case))
    times = np.arange(round(duration / sample_time) + 1) * sample_time
    forcing = np.empty((len(times), 2))
    for k, t in enumerate(times):
        q, qdot, qddot = trajectory.evaluate(float(t))
        mismatch = true.inverse_dynamics(q, qdot, qddot, friction=False) - nominal.inverse_dynamics(
            q, qdot, qddot, friction=False
        )
        forcing[k] = -np.linalg.solve(nominal.M(q), mismatch)
    gains = config.pid
    rms = []
    for j in range(2):
        system = scipy.signal.lti([1.0, 0.0], [1.0, gains.Kv[j], gains.Kp[j], gains.KI[j]])
        _, error, _ = scipy.signal.lsim(system, forcing[:, j], times)
        rms.append(float(np.sqrt(np.mean(error[1:] ** 2))))
    return rms[0], rms[1]


def peak_frequency(signal: np.ndarray, sample_time: float, above: float = 0.0) -> float:
    """Frequency (Hz) of the largest spectral line of ``signal`` above ``above`` Hz
    (mean removed)."""
    values = np.asarray(signal, dtype=float)
    spectrum = np.abs(np.fft.rfft(values - values.mean()))
    frequencies = np.fft.rfftfreq(len(values), sample_time)
    spectrum[frequencies <= above] = 0.0
    return float(frequencies[int(np.argmax(spectrum))])


def model_voltage_rms(
    parameters: LumpedParameters, trajectory: Trajectory, duration: float, sample_time: float
) -> tuple[float, float]:
    """RMS (samples ``k = 1..N0``) of the voltage the lumped model with ``parameters``
    needs to follow the desired trajectory exactly (Sec. 4.1, Coulomb friction
    included): what any controller that tracks well must apply."""
    model = LumpedModel(parameters)
    times = np.arange(1, round(duration / sample_time) + 1) * sample_time
    voltages = trajectory_voltages(model, trajectory, times)
    return tuple(float(v) for v in np.sqrt(np.mean(voltages**2, axis=0)))


def band_rms(signal: np.ndarray, sample_time: float, above: float) -> float:
    """RMS of the part of ``signal`` (mean removed) above ``above`` Hz (Parseval)."""
    values = np.asarray(signal, dtype=float)
    spectrum = np.fft.rfft(values - values.mean())
    frequencies = np.fft.rfftfreq(len(values), sample_time)
    weights = np.where((frequencies == 0) | (frequencies == 0.5 / sample_time), 1.0, 2.0)
    power = weights * np.abs(spectrum) ** 2 / len(values) ** 2
    return float(np.sqrt(power[frequencies > above].sum()))


def reversal_share(
    trajectory: Trajectory, times: np.ndarray, error: np.ndarray, joint: int, window: float
) -> tuple[float, float]:
    """``(share of sum(error^2), share of the samples)`` within ``window`` seconds after
    the desired velocity of ``joint`` changes sign (rows ``k = 1..N0``). A share of
    the squared error well above the share of the time locates the error at the
    reversals, where Coulomb friction switches."""
    velocity = np.array([trajectory.evaluate(float(t))[1][joint] for t in times])
    flips = times[1:][np.sign(velocity[1:]) != np.sign(velocity[:-1])]
    after = np.zeros(len(times), dtype=bool)
    for flip in flips:
        after |= (times >= flip) & (times < flip + window)
    squared = np.asarray(error, dtype=float) ** 2
    return float(squared[after].sum() / squared.sum()), float(after.mean())
