"""Linear closed loops of the nominal linear part (Eq. 2 with ``h = 0``):
``M0* q~'' + B* q~' = u`` (error coordinates, reference terms cancel) under a
position-only controller ``u = G (C x + D q~)`` of ``models.design.realisation``.

``output_gain`` ``G`` picks the torque from the filter's outputs: ``I`` for
``tau_LC`` (Eq. 13), ``[I, -alpha I]`` for ``tau_LC + tau_NC`` with the gain frozen at
``alpha`` (Eq. 19). The sampled-data loop holds ``u`` over each period (ZOH) and
applies the discretised filter's output at the sample instant (no extra delay),
as the controller LeafSystems do. ``sampled_data_loop`` adds the loop's inputs (a held
torque disturbance, the measurement error) and outputs (``q~``, ``u``), and
``stationary_deviations`` their stationary standard deviations: the predicted tracking
error and voltage that ``analysis.tuning`` minimises and bounds.

``LoopEffects`` adds the linear effects a scenario can set between the filter and the
arm (``held_plant``; none: the loop above, to the bit):

- a compliant gear (``models.gear`` with the backlash left out): Spong's flexible joint,
  linear in ``d = theta_m - q``, so it is its own linearisation; in the nominal model's
  volts (rows divided by ``kappa``), per compliant joint ``J q_m'' = u - k (q_m - q) -
  c (q_m' - q')`` and the link ``M_L q'' + B q' = k (q_m - q) + c (q_m' - q')`` with
  ``M_L = M0* - diag(J)`` (``M0*`` holds the reflected rotor inertia, which the gear
  moves to the motor); the encoder reads ``q`` or, at ``sensor.location: motor``, ``q_m``;
- the armature lag (``diagrams.actuator``): ``tau v_m' = v - v_m`` on the voltage of
  each lagged joint, states added before discretisation;
- the compute delay ``tau`` (``0 < tau <= T_s``): ``u_(k-1)`` applies on ``[t_k, t_k +
  tau)`` and ``u_k`` on ``[t_k + tau, t_(k+1))``, the delayed hold of Franklin, Powell &
  Workman, "Digital Control of Dynamic Systems", 3rd ed., 1998 (time delays):
  ``x_(k+1) = Phi x_k + Gamma0 u_k + Gamma1 u_(k-1)``, ``Gamma0 = int_0^(T - tau) e^(As)
  ds B``, ``Gamma1 = e^(A (T - tau)) int_0^tau e^(As) ds B``, ``u_(k-1)`` a state (at
  ``tau = T_s``: ``Gamma0 = 0``, one whole sample of delay);
- the sensor delay of ``d`` samples (``diagrams.wiring``): the filter reads the
  measurement of ``t_(k-d)``, ``d`` unit delays (``n`` states each) on the output.

The model error ``w`` acts on the link, held from ``t_k`` (neither lagged nor delayed).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.linalg

from posfb.models.design.discretise import zero_order_hold
from posfb.models.design.realisation import ContinuousFilter, DiscreteFilter


def _plant(M0: np.ndarray, B: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """State ``[q~, q~']``: ``(A_p, B_p, C_q)`` of the nominal linear part."""
    n = len(M0)
    M0_inv = np.linalg.inv(M0)
    zero, eye = np.zeros((n, n)), np.eye(n)
    return (
        np.block([[zero, eye], [zero, -M0_inv @ B]]),
        np.vstack([zero, M0_inv]),
        np.hstack([eye, zero]),
    )


def continuous_closed_loop(
    M0: np.ndarray, B: np.ndarray, controller: ContinuousFilter, output_gain: np.ndarray
) -> np.ndarray:
    """State matrix of plant and continuous filter, state ``[q~, q~', x]``."""
    A_p, B_p, C_q = _plant(M0, B)
    return np.block(
        [
            [A_p + B_p @ output_gain @ controller.D @ C_q, B_p @ output_gain @ controller.C],
            [controller.B @ C_q, controller.A],
        ]
    )


@dataclass(frozen=True, eq=False)
class SampledLoop:
    """The sampled-data loop, state ``x_k = [q~_k, q~'_k, s_k]`` (with ``LoopEffects``:
    ``held_transition``'s), with two inputs:

    ``x_{k+1} = A x_k + B_w w_k + B_n n_k``, ``q~_k = C_q x_k``, ``u_k = C_u x_k + D_un n_k``,

    ``w`` a torque disturbance held over the period like ``u`` (the model error ``h``
    of Eq. 2, in volts) and ``n`` the error of the position measurement (the encoder's
    quantisation), which the filter reads with ``q~``."""

    A: np.ndarray
    B_w: np.ndarray
    B_n: np.ndarray
    C_q: np.ndarray
    C_u: np.ndarray
    D_un: np.ndarray


@dataclass(frozen=True)
class CompliantGear:
    """A compliant gear's linear part (``models.gear`` with ``b = 0``) in the nominal
    model's units: per joint ``stiffness = k / kappa`` (V/rad; 0: a rigid joint),
    ``damping = c / kappa`` (V s/rad) and ``motor_inertia = J_m / kappa`` (V s^2/rad,
    the reflected rotor inertia); ``motor_sensor``: the encoder reads ``q_m``."""

    stiffness: tuple[float, ...]
    damping: tuple[float, ...]
    motor_inertia: tuple[float, ...]
    motor_sensor: bool = False

    @property
    def compliant(self) -> np.ndarray:
        """Which joints are compliant (``k > 0``)."""
        return np.asarray(self.stiffness, dtype=float) > 0.0


@dataclass(frozen=True)
class LoopEffects:
    """The linear effects between the filter and the arm (module docstring):
    ``delay_samples`` (whole periods on the measurement), ``compute_delay`` (s, ``0 <= tau
    <= T_s``), ``electrical_time_constant`` (s per joint; empty or 0: no lag) and a
    compliant ``gear`` (``None``: rigid). The defaults: none, the ideal held loop."""

    delay_samples: int = 0
    compute_delay: float = 0.0
    electrical_time_constant: tuple[float, ...] = ()
    gear: CompliantGear | None = None

    @property
    def lagged(self) -> np.ndarray:
        """Which joints have a lag (``tau > 0``)."""
        return np.asarray(self.electrical_time_constant, dtype=float) > 0.0

    @property
    def ideal(self) -> bool:
        """No effect is on: the ideal held loop."""
        return not self.describe()

    def describe(self) -> list[str]:
        """The effects that are on, in words (empty: none)."""
        words = []
        if self.gear is not None and np.any(self.gear.compliant):
            where = "motor" if self.gear.motor_sensor else "link"
            words.append(f"compliant gear (encoder on the {where})")
        if np.any(self.lagged):
            words.append(f"electrical lag {_values(self.electrical_time_constant)} s")
        if self.compute_delay > 0.0:
            words.append(f"compute delay {self.compute_delay:g} s")
        if self.delay_samples > 0:
            words.append(f"sensor delay {self.delay_samples} sample(s)")
        return words


#: No effect: the ideal held loop.
NO_EFFECTS = LoopEffects()


def _values(values: tuple[float, ...]) -> str:
    """One number when every joint has it, else the list."""
    if len(set(values)) == 1:
        return f"{values[0]:g}"
    return "[" + ", ".join(f"{v:g}" for v in values) + "]"


@dataclass(frozen=True, eq=False)
class HeldPlant:
    """The plant held over one period, state ``xi`` (``[q~, q~']``, then the motors' and
    the lag's states where ``LoopEffects`` add them)::

        xi_(k+1) = Phi xi_k + Gamma u_k + previous u_(k-1) + Gamma_w w_k
        y_k = C_y xi_k (the measurement, read ``delay_samples`` periods later)
        q~_k = C_q xi_k

    ``previous`` is ``None`` without a compute delay (no ``u_(k-1)`` state). It does not
    depend on the controller, so a search over designs computes it once per plant."""

    Phi: np.ndarray
    Gamma: np.ndarray
    previous: np.ndarray | None
    Gamma_w: np.ndarray
    C_y: np.ndarray
    C_q: np.ndarray
    delay_samples: int


def _mechanics(
    M0: np.ndarray, B: np.ndarray, gear: CompliantGear | None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B_u, B_w, C_y)`` of the arm in continuous time, state ``[q, q_m, q', q_m']``
    (``q_m`` of the compliant joints only; rigid: ``[q~, q~']``, ``_plant``)."""
    n = len(M0)
    if gear is None or not np.any(gear.compliant):
        A_p, B_p, C_q = _plant(M0, B)
        return A_p, B_p, B_p, C_q
    compliant = gear.compliant
    S = np.eye(n)[compliant]  # m x n: picks the compliant joints
    rigid = np.diag((~compliant).astype(float))
    k, c, J = (np.asarray(v, dtype=float)[compliant] for v in
               (gear.stiffness, gear.damping, gear.motor_inertia))  # fmt: skip
    link = M0 - S.T @ np.diag(J) @ S
    if np.any(J <= 0.0) or np.min(np.linalg.eigvalsh((link + link.T) / 2.0)) <= 0.0:
        joints = np.flatnonzero(compliant).tolist()
        raise ValueError(
            f"plant.gear_stiffness > 0 at joints {joints} with motor inertias J_m/kappa = "
            f"{np.round(J, 6).tolist()} V s^2/rad: M0* - J_m/kappa (the link's inertia) is not "
            "positive definite, so the compliant joint cannot be linearised on this nominal "
            "model; a smaller plant.parameters.rotor_inertia (0 < J_m/kappa < M0*[j, j]) "
            "is required"
        )
    mass = scipy.linalg.block_diag(link, np.diag(J))
    stiffness = _coupling(S, k)
    damping = _coupling(S, c) + scipy.linalg.block_diag(B, np.zeros((len(S), len(S))))
    size = len(mass)
    mass_inv = np.linalg.inv(mass)
    A = np.block([[np.zeros((size, size)), np.eye(size)],
                  [-mass_inv @ stiffness, -mass_inv @ damping]])  # fmt: skip
    voltage = np.vstack([rigid, S])  # a rigid joint's voltage drives its link, else the motor
    on_link = np.vstack([np.eye(n), np.zeros((len(S), n))])
    zero = np.zeros((size, n))
    sensed = np.hstack([rigid, S.T] if gear.motor_sensor else [np.eye(n), np.zeros((n, len(S)))])
    return (
        A,
        np.vstack([zero, mass_inv @ voltage]),
        np.vstack([zero, mass_inv @ on_link]),
        np.hstack([sensed, np.zeros((n, size))]),
    )


def _coupling(S: np.ndarray, values: np.ndarray) -> np.ndarray:
    """The gear's spring (or damper) ``values`` between each compliant link and its motor,
    coordinates ``[q, q_m]``: ``[[S^T V S, -S^T V], [-V S, V]]``, ``V = diag(values)``."""
    V = np.diag(values)
    return np.block([[S.T @ V @ S, -S.T @ V], [-V @ S, V]])


def _with_lag(
    A: np.ndarray, B_u: np.ndarray, B_w: np.ndarray, C_y: np.ndarray, taus: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``tau v_m' = v - v_m`` before each lagged joint's input (``taus > 0``), states
    ``v_m`` appended."""
    lagged = taus > 0.0
    L = np.eye(len(taus))[lagged]
    rate = np.diag(1.0 / taus[lagged])
    size, extra = len(A), len(L)
    A = np.block([[A, B_u @ L.T], [np.zeros((extra, size)), -rate]])
    B_u = np.vstack([B_u @ np.diag((~lagged).astype(float)), rate @ L])
    return (
        A,
        B_u,
        np.vstack([B_w, np.zeros((extra, B_w.shape[1]))]),
        np.hstack([C_y, np.zeros((len(C_y), extra))]),
    )


def held_plant(
    M0: np.ndarray, B: np.ndarray, sample_time: float, effects: LoopEffects = NO_EFFECTS
) -> HeldPlant:
    """``M0 q~'' + B q~' = u`` with ``u`` held over ``sample_time`` and ``effects``
    (``HeldPlant``; module docstring for each effect's model)."""
    n = len(M0)
    A, B_u, B_w, C_y = _mechanics(M0, B, effects.gear)
    if np.any(effects.lagged):
        taus = np.asarray(effects.electrical_time_constant, dtype=float)
        if len(taus) != n:
            raise ValueError(
                f"actuator.electrical_time_constant = {list(taus)}; {n} values (one per "
                "joint) are required"
            )
        A, B_u, B_w, C_y = _with_lag(A, B_u, B_w, C_y, taus)
    C_q = np.hstack([np.eye(n), np.zeros((n, len(A) - n))])
    delay = effects.compute_delay
    if not 0.0 <= delay <= sample_time:
        raise ValueError(
            f"actuator.compute_delay = {delay!r}; 0 <= delay <= timing.sample_time = "
            f"{sample_time!r} is required"
        )
    if delay == 0.0 and B_w is B_u:  # the ideal hold: one exponential, as before
        Phi, Gamma = zero_order_hold(A, B_u, sample_time)
        return HeldPlant(Phi, Gamma, None, Gamma, C_y, C_q, effects.delay_samples)
    Phi, Gamma_w = zero_order_hold(A, B_w, sample_time)
    if delay == 0.0:
        return HeldPlant(Phi, zero_order_hold(A, B_u, sample_time)[1], None, Gamma_w, C_y, C_q,
                         effects.delay_samples)  # fmt: skip
    late, Gamma0 = zero_order_hold(A, B_u, sample_time - delay)
    Gamma1 = late @ zero_order_hold(A, B_u, delay)[1]
    return HeldPlant(Phi, Gamma0, Gamma1, Gamma_w, C_y, C_q, effects.delay_samples)


def _layout(plant: HeldPlant, controller: DiscreteFilter) -> tuple[int, int, int, int]:
    """``(plant states, previous-voltage states, delay states, size)`` of the loop state
    ``[xi_k, u_(k-1), y_(k-1) .. y_(k-d), s_k]``."""
    size, n = len(plant.Phi), plant.Gamma.shape[1]
    previous = 0 if plant.previous is None else n
    delayed = plant.delay_samples * n
    return size, previous, delayed, size + previous + delayed + len(controller.A)


def _reading(plant: HeldPlant, controller: DiscreteFilter) -> np.ndarray:
    """``R`` of the filter's input ``y_(k-d) = R X_k`` (``X_k`` the loop state)."""
    size, previous, delayed, total = _layout(plant, controller)
    n = plant.Gamma.shape[1]
    R = np.zeros((n, total))
    if plant.delay_samples == 0:
        R[:, :size] = plant.C_y
    else:
        start = size + previous + delayed - n
        R[:, start : start + n] = np.eye(n)
    return R


def held_transition(
    plant: HeldPlant, controller: DiscreteFilter, output_gain: np.ndarray
) -> np.ndarray:
    """The one-period transition matrix of the held plant and the discrete filter, state
    ``[xi_k, u_(k-1), y_(k-1) .. y_(k-d), s_k]`` (``HeldPlant``; the middle blocks only
    with a compute delay, a sensor delay): ``held_transitions`` of the one plant."""
    return held_transitions([plant], controller, output_gain)[0]


def held_transitions(
    plants: Sequence[HeldPlant], controller: DiscreteFilter, output_gain: np.ndarray
) -> np.ndarray:
    """``held_transition`` of each of ``plants`` (held alike: one layout of the loop
    state), stacked, assembled in place on the stack (a tuner asks for thousands): each
    block is the product it is for one plant, one matrix of the stack at a time."""
    size, previous, delayed, total = _layout(plants[0], controller)
    if any(_layout(plant, controller) != (size, previous, delayed, total) for plant in plants):
        raise ValueError("plants are held differently (loop states of another layout); "
                         "plants held alike are required")  # fmt: skip
    n = plants[0].Gamma.shape[1]
    R = np.stack([_reading(plant, controller) for plant in plants])
    states = size + previous + delayed
    voltage = output_gain @ controller.D @ R  # u_k = voltage X_k + gain C s_k
    voltage[:, :, states:] += output_gain @ controller.C
    A = np.zeros((len(plants), total, total))
    A[:, :size, :size] = np.stack([plant.Phi for plant in plants])
    A[:, :size] += np.stack([plant.Gamma for plant in plants]) @ voltage
    if previous:
        A[:, :size, size : size + n] += np.stack([plant.previous for plant in plants])
        A[:, size : size + n] = voltage
    if delayed:
        start = size + previous
        A[:, start : start + n, :size] = np.stack([plant.C_y for plant in plants])
        A[:, start + n : states, start : states - n] = np.eye(delayed - n)
    A[:, states:] = controller.B @ R
    A[:, states:, states:] += controller.A
    return A


def held_loop(plant: HeldPlant, controller: DiscreteFilter, output_gain: np.ndarray) -> SampledLoop:
    """The held plant and the discrete filter over one period (``SampledLoop``); the
    measurement error ``n`` enters with the reading the filter takes."""
    size, previous, delayed, total = _layout(plant, controller)
    n = plant.Gamma.shape[1]
    states = size + previous + delayed
    feedthrough = output_gain @ controller.D
    C_u = feedthrough @ _reading(plant, controller)
    C_u[:, states:] += output_gain @ controller.C
    B_n = np.zeros((total, n))
    B_n[:size] = plant.Gamma @ feedthrough
    B_n[size : size + previous] = feedthrough if previous else 0.0
    B_n[states:] = controller.B
    B_w = np.zeros((total, plant.Gamma_w.shape[1]))
    B_w[:size] = plant.Gamma_w
    C_q = np.zeros((n, total))
    C_q[:, :size] = plant.C_q
    return SampledLoop(
        A=held_transition(plant, controller, output_gain),
        B_w=B_w,
        B_n=B_n,
        C_q=C_q,
        C_u=C_u,
        D_un=feedthrough,
    )


def sampled_data_loop(
    M0: np.ndarray,
    B: np.ndarray,
    controller: DiscreteFilter,
    output_gain: np.ndarray,
    sample_time: float,
    effects: LoopEffects = NO_EFFECTS,
) -> SampledLoop:
    """The plant (held input, ``effects``) and the discrete filter over one period
    (``SampledLoop``)."""
    return held_loop(held_plant(M0, B, sample_time, effects), controller, output_gain)


def sampled_data_closed_loop(
    M0: np.ndarray,
    B: np.ndarray,
    controller: DiscreteFilter,
    output_gain: np.ndarray,
    sample_time: float,
    effects: LoopEffects = NO_EFFECTS,
) -> np.ndarray:
    """One-period transition matrix of the plant (held input, ``effects``) and the
    discrete filter, state ``[q~_k, q~'_k, s_k]`` without effects (``held_transition``)."""
    return held_transition(held_plant(M0, B, sample_time, effects), controller, output_gain)


def stationary_deviations(
    loop: SampledLoop,
    disturbance_std: np.ndarray,
    noise_std: np.ndarray,
    disturbance_pole: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """Per-joint standard deviations of ``q~`` and ``u`` in the loop's stationary state.

    ``n`` is white with per-joint standard deviations ``noise_std``; ``w`` is a
    first-order Gauss-Markov sequence ``w_{k+1} = p w_k + sqrt(1 - p^2) e_k`` with
    ``p = disturbance_pole`` (0: white) and per-joint standard deviations
    ``disturbance_std``. The loop augmented with ``w`` solves
    ``X = A X A^T + B N B^T`` (the discrete Lyapunov equation: the squared H2 norms
    weighted by the inputs' intensities). Requires a stable loop (spectral radius < 1)."""
    states, joints = len(loop.A), len(disturbance_std)
    A = np.block(
        [[loop.A, loop.B_w], [np.zeros((joints, states)), disturbance_pole * np.eye(joints)]]
    )
    drive = np.vstack(
        [np.zeros((states, joints)), math.sqrt(1.0 - disturbance_pole**2) * np.eye(joints)]
    )
    W = np.diag(np.square(disturbance_std))
    N = np.diag(np.square(noise_std))
    B_n = np.vstack([loop.B_n, np.zeros((joints, loop.B_n.shape[1]))])
    X = scipy.linalg.solve_discrete_lyapunov(A, drive @ W @ drive.T + B_n @ N @ B_n.T)
    C_q = np.hstack([loop.C_q, np.zeros((len(loop.C_q), joints))])
    C_u = np.hstack([loop.C_u, np.zeros((len(loop.C_u), joints))])
    q = np.diag(C_q @ X @ C_q.T)
    u = np.diag(C_u @ X @ C_u.T + loop.D_un @ N @ loop.D_un.T)
    return np.sqrt(np.maximum(q, 0.0)), np.sqrt(np.maximum(u, 0.0))


def spectral_radius(matrix: np.ndarray) -> float:
    """Largest eigenvalue modulus (``< 1``: the discrete loop is asymptotically stable)."""
    return float(np.max(np.abs(np.linalg.eigvals(matrix))))


def spectral_radii(matrices: Sequence[np.ndarray]) -> np.ndarray:
    """``spectral_radius`` of each of ``matrices`` (all of one size): one batched LAPACK
    call, the same numbers as one call each (numpy runs the same routine on each matrix)."""
    if len(matrices) == 0:
        return np.zeros(0)
    return np.max(np.abs(np.linalg.eigvals(np.stack(matrices))), axis=-1)
