"""posfb's 20 s closed loop against a plain NumPy loop of the same physics, a compiled
(numba) lower bound, and the floor that Drake's own costs put under it.

    .venv/bin/python bench/bench_numpy_loop.py [--repeat 3] [--no-step-check] [--find-step]

Per controller (computed torque + PID, Lin+LC, the proposed controller at the paper's
alpha* = 4 and at alpha* = 2.75), on the paper's nominal scenario (T_s = 0.01 s, 20000-count
encoder, +-24 V, 20 s of the Sec. 4.2 trajectory, shipped URDF), it prints one Markdown
table row:

* **posfb s**: ``ClosedLoopRunner.run``'s ``wall_time_s``, best of ``--repeat`` (the
  diagram built once, as in ``bench_closed_loop.py``);
* **NumPy arrays s**: the same closed loop as a plain NumPy loop, the state, the RK4
  stages and the plant in arrays (``LumpedModel``'s matrices, ``np.linalg.solve``: how
  the loop of issue 11's premise was written), best of ``--repeat``, and its time over
  posfb's (posfb's speed-up);
* **NumPy scalar s**: the same loop with the plant written out in scalar ``math``
  (below), best of ``--repeat``, and posfb's time over it;
* **numba ms**: the same loop compiled with numba (controllers re-implemented, below), best
  of ``--repeat`` after one compiling call, and posfb's time over it; skipped with a line
  saying so when ``import numba`` fails (``pip install -e .[bench]``);
* **evals**, **steps**: derivative evaluations and steps of Drake's integrator in one run
  (RK3 with error control at 3e-3, steps capped at T_s: posfb's default), from the
  integrator's statistics on a Simulator configured as ``ClosedLoopRunner.run`` does;
* **us/eval** = posfb s / evals, **us/update** = posfb s / updates (2001 controller
  updates: ``run`` simulates one sample past 20 s);
* **floor s** = evals x (MultibodyPlant's own cost per derivative evaluation) + updates x
  (the Python callback floor), and posfb s / floor s. MultibodyPlant's cost is measured
  on the arm's plant alone (inputs fixed) under a fixed-step explicit Euler Simulator, so
  it is all C++ (wall / evaluations); the callback floor is a trivial Python
  ``LeafSystem`` whose periodic update reads two input ports and writes its state output,
  simulated alone for many periods (wall / updates);
* **arm floor s** = the same with posfb's whole arm (MultibodyPlant, the motor and
  Coulomb ``SymbolicVectorSystem``s, mux and demux) in place of the bare plant, and
  posfb s / arm floor s: what is left above it is the closed loop's own share (the
  controller's Python beyond the callback floor, the encoder, the holds, saturation,
  the logger, and RK3's error control and event bookkeeping per step);
* **C++ arm bound / floor**: ``evals x`` (the all-C++ ``MultilayerPerceptron`` arm's
  cost, ``arm_cost(variant, "perceptron")``) ``+ updates x``
  (the callback floor), over the Drake floor: the least a run could cost with that
  arm, a free controller, encoder and integrator.
  Above 1.3, issue 11's "within 1.3x of the Drake floor" is out of reach at posfb's
  evaluation count.

**The NumPy loops.** The plant is the lumped model of Sec. 4.1 with theta *identified from
the shipped URDF* (``models.theta_of_plant.identify_urdf``: it reproduces the MultibodyPlant's
accelerations exactly, rotor inertia included) and the true plant's smooth Coulomb law
``theta_6|11 tanh(v / v_s)``, ``v_s = 0.01 rad/s``, in place of the model's ``sgn``
(``LumpedModel.forward_dynamics`` has no smooth-friction option). It is written twice:
``array_rhs`` with ``LumpedModel``'s matrices and ``np.linalg.solve`` on 2-element
arrays, and ``make_rhs`` written out in scalar ``math`` (CPython's float arithmetic is
about 16x faster than 2-element ndarrays here). The script checks the scalar one against
the Drake arm's own derivatives before timing, and prints how far the two loops' sampled
positions drift apart (round-off). Per period: quantise (round to nearest count), call posfb's
controller (``make_controller(kind)._start`` / ``._step``, the very Python methods the
Drake diagram calls), saturate, hold the voltage, and take ``m`` fixed RK4 steps.

**The RK4 step: h = T_s / 30 = 0.333 ms** (``STEPS_PER_PERIOD``), chosen as the largest
``T_s / m`` that is both

1. stable: the stiffest eigenvalue of the plant's Jacobian is that of the friction at
   zero velocity, ``max_q |eig(M*(q)^-1 (B* + diag(theta_6, theta_11) / v_s))|`` =
   7.2e3 1/s, so RK4 (real-axis limit 2.785) needs ``h <= 0.388 ms``, ``m >= 26``.
   Below that the loop does not blow up (``tanh`` saturates) but chatters near zero
   velocity: PID's RMS(q~2) is 0.0056 rad at m = 10 and 0.0125 at m = 20 against
   0.0154 for m >= 25 (20000 counts);
2. accurate: the state after 20 s is within 1e-4 rad of the run at h / 2. With the
   ideal encoder (quantisation flips counts on 1e-9 rad differences, which makes the
   final state of quantised runs differ by ~3e-4 rad even between m = 50 and 100 for
   alpha* = 4: sensitivity of the loop, not integration error), measured
   ``|q(20.01 s; m) - q(20.01 s; 2m)|``: alpha* = 4: 1.5e-4 (m = 25), 1.4e-4 (26),
   1.3e-4 (27), 1.2e-4 (28, 29), 1.0e-4 (30), 4.7e-5 (40); PID 3.3e-6, alpha* = 2.75
   2.2e-6, Lin+LC < 1e-8 at m = 30.

``--find-step`` repeats that search (about 20 s); by default the script re-checks
criterion 2 at the chosen step (``--no-step-check`` skips it).

**The numba bound** is written independently of posfb's code: the plant, the trajectory,
the encoder, RK4 and all three controllers (Eq. 26 PID; Lin+LC's discrete filter and
feedforward; the proposed controller's filter, running maxima, Eq. 18 bound and alpha
update) are re-implemented in one jitted loop; only numbers come from posfb (theta, the
discrete filter matrices of ``cached_design``, the PID gains and the Sec. 3 bounds). It
uses the same step as the NumPy loop; its RMS errors and its largest difference from the
NumPy loop's samples are printed next to the others'. It is a lower bound for *this*
physics and step, not for posfb's adaptive integrator.

**Agreement with posfb** (measured with the FOH filters, the default before issue 20).
The NumPy loop's RMS(q~) is within 1.5 % of posfb's for PID,
Lin+LC and alpha* = 4. For alpha* = 2.75 joint 2 differs by ~9 %: its RMS (a few 1e-4
rad, about one count) depends on which counts flip, and posfb's own value moves by as
much with the integrator accuracy (3.91e-4 at 3e-3, 4.08e-4 at 1e-4, 3.67e-4 at 1e-6 rad);
with an ideal encoder the NumPy loop and posfb at accuracy 1e-6 agree within 0.5 % for
Lin+LC and both alpha*. (PID with an ideal encoder is not comparable: at t_1 the hanging
arm has moved by round-off only, and the sign of that 1e-15 rad step picks the sign of
PID's Coulomb compensation, +-1.6 V.)
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import dataclass, replace

import numpy as np
from pydrake.math import RigidTransform
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.analysis import ApplySimulatorConfig, Simulator, SimulatorConfig
from pydrake.systems.framework import DiagramBuilder, LeafSystem
from pydrake.systems.primitives import ConstantVectorSource

from posfb.analysis.common.metrics import run_metrics
from posfb.diagrams.loop_config import ClosedLoopConfig
from posfb.diagrams.resolve import load_scenario, resolve
from posfb.diagrams.runner import ClosedLoopRunner
from posfb.models.controllers import cached_design, make_controller
from posfb.models.lumped import LumpedModel, LumpedParameters
from posfb.models.plant import apply_parameters, build_arm_diagram
from posfb.models.theta_of_plant import identify_urdf
from posfb.models.trajectory import WaveTrajectory

try:
    import numba
except ImportError:  # the compiled bound is optional (pyproject's "bench" extra)
    numba = None

#: RK4 steps per control period (module docstring: the largest stable, accurate step).
STEPS_PER_PERIOD = 30

#: Criterion 2 of the step choice: |q(20 s; h) - q(20 s; h/2)| (rad), ideal encoder.
STEP_TOLERANCE = 1e-4

#: RK4's stability limit on the negative real axis (|h lambda|).
RK4_REAL_LIMIT = 2.785

#: (label, scenario settings) of every benchmarked variant, as in bench_closed_loop.py.
VARIANTS = [
    ("pid", ("controller.kind=pid",)),
    ("lin_lc", ("controller.kind=lin_lc",)),
    ("proposed", ("controller.kind=proposed",)),
    ("proposed, alpha*=2.75", ("controller.kind=proposed", "controller.alpha_star=2.75")),
]

KIND_CODES = {"pid": 0, "lin_lc": 1, "proposed": 2}


@dataclass(frozen=True)
class Variant:
    """One benchmarked controller: its resolved config and the true plant's theta."""

    label: str
    settings: tuple[str, ...]
    config: ClosedLoopConfig
    payload_mass: float
    theta: LumpedParameters

    @property
    def kind(self) -> str:
        return self.config.controller

    @property
    def updates(self) -> int:
        """Controller updates in one run: t_0 .. t_N0 (``run`` stops at t_N0+1)."""
        return self.config.samples + 1


def load_variant(label: str, settings: tuple[str, ...]) -> Variant:
    resolved = resolve(load_scenario(None, settings))
    config = resolved.config
    if not isinstance(config.trajectory, WaveTrajectory):
        raise SystemExit("the benchmark needs the Sec. 4.2 wave trajectory")
    if config.noisy or config.sensor.delay_samples or any(config.sensor_state.zero_offset):
        raise SystemExit("the benchmark needs a sensor without noise, delay or offset")
    if resolved.overrides:
        raise SystemExit("the benchmark needs the URDF's own parameters")
    theta = identify_urdf(config.plant.urdf, resolved.payload_mass)
    return Variant(label, settings, config, resolved.payload_mass, theta)


# --------------------------------------------------------------------------- NumPy loop


def make_rhs(theta: LumpedParameters, v_s: float):
    """``(q1, q2, v1, v2, u1, u2) -> (q1'', q2'')`` of the true plant: the lumped model
    (volts) with Coulomb friction ``theta_6|11 tanh(v / v_s)``."""
    th1, th2, th3, th4, th5, th6, th7, th8, th9, th10, th11 = (float(x) for x in theta.theta)
    ratio = theta.g / theta.l1
    cos, sin, tanh = math.cos, math.sin, math.tanh
    m22 = th7 + th9

    def rhs(q1, q2, v1, v2, u1, u2):
        c2, s2, c12 = cos(q2), sin(q2), cos(q1 + q2)
        m11 = th1 + th2 + 2.0 * th3 * c2
        m12 = th2 + th3 * c2
        m21 = th7 + th8 * c2
        r1 = (
            u1 + th3 * s2 * (v1 * v2 + (v1 + v2) * v2) - th4 * cos(q1) - ratio * th3 * c12
            - th5 * v1 - th6 * tanh(v1 / v_s)
        )  # fmt: skip
        r2 = u2 - th8 * s2 * v1 * v1 - ratio * th8 * c12 - th10 * v2 - th11 * tanh(v2 / v_s)
        det = m11 * m22 - m12 * m21
        return (m22 * r1 - m12 * r2) / det, (m11 * r2 - m21 * r1) / det

    return rhs


def check_physics(variant: Variant, samples: int = 50) -> float:
    """Largest |qddot| difference between ``make_rhs`` and the Drake arm (true plant,
    motor, friction) over random states and voltages, relative to the largest |qddot|."""
    config = variant.config
    diagram, arm, context = build_arm_diagram(config.plant)
    apply_parameters(arm, context, arm.default_parameters.with_payload(variant.payload_mass))
    rhs = make_rhs(variant.theta, config.plant.friction_velocity)
    plant = arm.plant
    plant_context = plant.GetMyMutableContextFromRoot(context)
    voltage = diagram.get_input_port(0)
    offset = _plant_state_offset(diagram, arm, context)
    rng = np.random.default_rng(0)
    worst = scale = 0.0
    for _ in range(samples):
        q = rng.uniform(-np.pi, np.pi, 2)
        v = rng.uniform(-0.05, 0.05, 2) * rng.choice([1.0, 100.0])  # near and far from 0
        u = rng.uniform(-24.0, 24.0, 2)
        plant.SetPositions(plant_context, q)
        plant.SetVelocities(plant_context, v)
        voltage.FixValue(context, u)
        derivatives = diagram.EvalTimeDerivatives(context).get_vector().CopyToVector()
        drake_qddot = derivatives[offset + 2 : offset + 4]
        ours = np.array(rhs(*q, *v, *u))
        worst = max(worst, float(np.max(np.abs(ours - drake_qddot))))
        scale = max(scale, float(np.max(np.abs(drake_qddot))))
    return worst / scale


def _plant_state_offset(diagram, arm, context) -> int:
    """Index of the MultibodyPlant's first state in the diagram's continuous state."""
    marker = np.arange(diagram.num_continuous_states(), dtype=float) + 1000.0
    probe = context.Clone()
    probe.SetContinuousState(marker)
    plant_state = arm.plant.GetPositionsAndVelocities(arm.plant.GetMyContextFromRoot(probe))
    return int(plant_state[0] - 1000.0)


@dataclass(frozen=True)
class LoopRun:
    wall_s: float
    q: np.ndarray  # true q at t_0 .. t_N0 (rows)
    final: np.ndarray  # [q, v] at t_N0+1

    def rms(self, variant: Variant) -> np.ndarray:
        """The paper's RMS of q~ over k = 1..N0."""
        T = variant.config.sample_time
        trajectory = variant.config.trajectory
        q_d = np.array([trajectory.evaluate(k * T)[0] for k in range(len(self.q))])
        return np.sqrt(np.mean((self.q[1:] - q_d[1:]) ** 2, axis=0))


def numpy_loop(variant: Variant, m: int = STEPS_PER_PERIOD, counts: int | None = None) -> LoopRun:
    """The closed loop with posfb's controller on the NumPy plant, ``m`` RK4 steps per
    period; ``counts`` overrides the encoder's (0: ideal)."""
    config = variant.config
    rhs = make_rhs(variant.theta, config.plant.friction_velocity)
    controller = make_controller(config.controller, config.design)
    trajectory = config.trajectory
    T = config.sample_time
    h = T / m
    half, sixth = 0.5 * h, h / 6.0
    counts1, counts2 = config.sensor_state.encoder_counts if counts is None else (counts, counts)
    step1 = 2.0 * math.pi / counts1 if counts1 else 0.0
    step2 = 2.0 * math.pi / counts2 if counts2 else 0.0
    limit1, limit2 = config.voltage_limit
    updates = variant.updates
    q_log = np.empty((updates, 2))
    q1, q2 = (float(x) for x in trajectory.evaluate(0.0)[0])
    v1 = v2 = 0.0
    memory = None
    start = time.perf_counter()
    for k in range(updates):
        t = k * T
        q_log[k, 0], q_log[k, 1] = q1, q2
        measured = np.array(
            [
                step1 * round(q1 / step1) if step1 else q1,
                step2 * round(q2 / step2) if step2 else q2,
            ]
        )
        desired = np.concatenate(trajectory.evaluate(t))
        if memory is None:
            memory = controller._start(measured, desired)
        voltage, _ = controller._step(measured, desired, memory)
        u1 = min(max(float(voltage[0]), -limit1), limit1)
        u2 = min(max(float(voltage[1]), -limit2), limit2)
        for _ in range(m):
            a1, a2 = rhs(q1, q2, v1, v2, u1, u2)
            w1, w2 = v1 + half * a1, v2 + half * a2
            b1, b2 = rhs(q1 + half * v1, q2 + half * v2, w1, w2, u1, u2)
            x1, x2 = v1 + half * b1, v2 + half * b2
            c1, c2 = rhs(q1 + half * w1, q2 + half * w2, x1, x2, u1, u2)
            y1, y2 = v1 + h * c1, v2 + h * c2
            d1, d2 = rhs(q1 + h * x1, q2 + h * x2, y1, y2, u1, u2)
            q1 += sixth * (v1 + 2.0 * (w1 + x1) + y1)
            q2 += sixth * (v2 + 2.0 * (w2 + x2) + y2)
            v1 += sixth * (a1 + 2.0 * (b1 + c1) + d1)
            v2 += sixth * (a2 + 2.0 * (b2 + c2) + d2)
    wall = time.perf_counter() - start
    return LoopRun(wall, q_log, np.array([q1, q2, v1, v2]))


def array_rhs(theta: LumpedParameters, v_s: float):
    """``(q, v, u) -> qddot`` of the same true plant, written the way NumPy is usually
    written: posfb's ``LumpedModel`` matrices and ``np.linalg.solve`` (2-element arrays)."""
    model = LumpedModel(theta)
    B, levels = model.B(), model.coulomb_levels()

    def rhs(q: np.ndarray, v: np.ndarray, u: np.ndarray) -> np.ndarray:
        force = u - model.C(q, v) @ v - model.G(q) - B @ v - levels * np.tanh(v / v_s)
        return np.linalg.solve(model.M(q), force)

    return rhs


def numpy_array_loop(variant: Variant, m: int = STEPS_PER_PERIOD) -> LoopRun:
    """``numpy_loop`` with the state, the RK4 stages and the plant in NumPy arrays
    (``array_rhs``): the plain NumPy loop of issue 11's premise. Same controller calls,
    quantiser, saturation and step."""
    config = variant.config
    rhs = array_rhs(variant.theta, config.plant.friction_velocity)
    controller = make_controller(config.controller, config.design)
    trajectory = config.trajectory
    T = config.sample_time
    h = T / m
    steps = np.array([2.0 * math.pi / c if c else 0.0 for c in config.sensor_state.encoder_counts])
    quantised = steps > 0.0
    limit = np.array(config.voltage_limit)
    updates = variant.updates
    q_log = np.empty((updates, 2))
    q = trajectory.evaluate(0.0)[0].astype(float)
    v = np.zeros(2)
    memory = None
    start = time.perf_counter()
    for k in range(updates):
        q_log[k] = q
        measured = np.where(quantised, steps * np.round(q / np.where(quantised, steps, 1.0)), q)
        desired = np.concatenate(trajectory.evaluate(k * T))
        if memory is None:
            memory = controller._start(measured, desired)
        voltage, _ = controller._step(measured, desired, memory)
        u = np.clip(voltage, -limit, limit)
        for _ in range(m):
            a = rhs(q, v, u)
            w = v + 0.5 * h * a
            b = rhs(q + 0.5 * h * v, w, u)
            x = v + 0.5 * h * b
            c = rhs(q + 0.5 * h * w, x, u)
            y = v + h * c
            d = rhs(q + h * x, y, u)
            q = q + h / 6.0 * (v + 2.0 * (w + x) + y)
            v = v + h / 6.0 * (a + 2.0 * (b + c) + d)
    wall = time.perf_counter() - start
    return LoopRun(wall, q_log, np.concatenate([q, v]))


def rk4_step_limit(variant: Variant) -> float:
    """The largest RK4 step that is linearly stable at the stiffest point (zero velocity,
    worst configuration): 2.785 / max |eig(M*^-1 (B* + diag(f_c) / v_s))|."""
    theta, v_s = variant.theta, variant.config.plant.friction_velocity
    model = LumpedModel(theta)
    stiffness = model.B() + np.diag(model.coulomb_levels()) / v_s
    largest = 0.0
    for q2 in np.linspace(-np.pi, np.pi, 721):
        jacobian = np.linalg.solve(model.M(np.array([0.0, q2])), stiffness)
        largest = max(largest, float(np.max(np.abs(np.linalg.eigvals(jacobian)))))
    return RK4_REAL_LIMIT / largest


def halving_difference(variant: Variant, m: int) -> float:
    """|q(end; T_s/m) - q(end; T_s/2m)| (rad), ideal encoder."""
    coarse = numpy_loop(variant, m, counts=0).final[:2]
    fine = numpy_loop(variant, 2 * m, counts=0).final[:2]
    return float(np.max(np.abs(coarse - fine)))


def find_step(variants: list[Variant]) -> int:
    """The smallest m (largest h = T_s/m) meeting both criteria of the module docstring."""
    T = variants[0].config.sample_time
    limit = min(rk4_step_limit(v) for v in variants)
    m = math.ceil(T / limit)
    print(f"RK4 stability: h <= {limit * 1e3:.3f} ms, so m >= {m}")
    # The hardest variant first: a candidate stops at its first failure.
    ordered = sorted(variants, key=lambda v: v.label != "proposed")
    while True:
        differences = []
        for variant in ordered:
            difference = halving_difference(variant, m)
            differences.append(f"{variant.label} {difference:.2e}")
            if difference > STEP_TOLERANCE:
                break
        print(f"m = {m} (h = {T / m * 1e3:.3f} ms): " + ", ".join(differences), flush=True)
        if len(differences) == len(ordered) and difference <= STEP_TOLERANCE:
            return m
        m += 1


# --------------------------------------------------------------------------- numba bound


def _make_kernel(njit):
    """The whole closed loop as one compiled function (independent of posfb's code)."""

    @njit(cache=False)
    def plant_rhs(p, q1, q2, v1, v2, u1, u2):
        # p: theta_1..theta_11, g/l1, v_s
        c2, s2, c12 = math.cos(q2), math.sin(q2), math.cos(q1 + q2)
        m11 = p[0] + p[1] + 2.0 * p[2] * c2
        m12 = p[1] + p[2] * c2
        m21 = p[6] + p[7] * c2
        m22 = p[6] + p[8]
        r1 = (
            u1 + p[2] * s2 * (v1 * v2 + (v1 + v2) * v2) - p[3] * math.cos(q1)
            - p[11] * p[2] * c12 - p[4] * v1 - p[5] * math.tanh(v1 / p[12])
        )  # fmt: skip
        r2 = (
            u2 - p[7] * s2 * v1 * v1 - p[11] * p[7] * c12 - p[9] * v2
            - p[10] * math.tanh(v2 / p[12])
        )  # fmt: skip
        det = m11 * m22 - m12 * m21
        return (m22 * r1 - m12 * r2) / det, (m11 * r2 - m21 * r1) / det

    @njit(cache=False)
    def desired(w, t, out):
        # w rows: offset, amplitude, wave amplitude, frequency; out: q_d, qdot_d, qddot_d
        e = math.exp(-2.0 * t**3)
        s, ds, dds = 1.0 - e, 6.0 * t * t * e, (12.0 * t - 36.0 * t**4) * e
        for j in range(2):
            sine, cosine = math.sin(w[3, j] * t), math.cos(w[3, j] * t)
            f = w[1, j] + w[2, j] * sine
            df = w[2, j] * w[3, j] * cosine
            ddf = -w[2, j] * w[3, j] ** 2 * sine
            out[j] = w[0, j] + s * f
            out[2 + j] = ds * f + s * df
            out[4 + j] = dds * f + 2.0 * ds * df + s * ddf

    @njit(cache=False)
    def model_terms(n, q1, q2, v1, v2, a1, a2, b1, b2, with_m0):
        # Nominal model (n: theta_1..11, g/l1): M1(q) a (+ M0 a if with_m0) + C(q, v) b + G(q)
        c2, s2, c12 = math.cos(q2), math.sin(q2), math.cos(q1 + q2)
        x1 = 2.0 * n[2] * c2 * a1 + n[2] * c2 * a2
        x2 = n[7] * c2 * a1
        if with_m0:
            x1 += (n[0] + n[1]) * a1 + n[1] * a2
            x2 += n[6] * a1 + (n[6] + n[8]) * a2
        x1 += -n[2] * v2 * s2 * b1 - n[2] * (v1 + v2) * s2 * b2
        x2 += n[7] * v1 * s2 * b1
        x1 += n[3] * math.cos(q1) + n[11] * n[2] * c12
        x2 += n[11] * n[7] * c12
        return x1, x2

    @njit(cache=False)
    def sign(x):
        return 1.0 if x > 0.0 else (-1.0 if x < 0.0 else 0.0)

    @njit(cache=False)
    def loop(kind, p, n, w, T, m, updates, step, limit, A, B, C, D, initial, gains, bounds, nc):
        q1, q2, v1, v2 = 0.0, 0.0, 0.0, 0.0
        d = np.empty(6)
        desired(w, 0.0, d)
        q1, q2 = d[0], d[1]
        q_log = np.empty((updates, 2))
        states = A.shape[0]
        s = np.zeros(states)
        s_next = np.zeros(states)
        y = np.zeros(C.shape[0])
        e = np.zeros(2)
        prev = np.zeros(2)
        integral = np.zeros(2)
        p_max = np.zeros(2)
        pbar_max = np.zeros(2)
        alpha_y = nc[2]
        h = T / m
        half, sixth = 0.5 * h, h / 6.0
        for k in range(updates):
            q_log[k, 0], q_log[k, 1] = q1, q2
            desired(w, k * T, d)
            mq1 = step[0] * np.rint(q1 / step[0]) if step[0] > 0.0 else q1
            mq2 = step[1] * np.rint(q2 / step[1]) if step[1] > 0.0 else q2
            e[0], e[1] = mq1 - d[0], mq2 - d[1]
            if kind == 0:  # computed torque + PID (Eq. 26), backward-difference velocity
                if k == 0:
                    prev[0], prev[1] = mq1, mq2
                qd1, qd2 = (mq1 - prev[0]) / T, (mq2 - prev[1]) / T
                c1 = d[4] - gains[1, 0] * (qd1 - d[2]) - gains[0, 0] * e[0]
                c1 -= gains[2, 0] * integral[0]
                c2 = d[5] - gains[1, 1] * (qd2 - d[3]) - gains[0, 1] * e[1]
                c2 -= gains[2, 1] * integral[1]
                u1, u2 = model_terms(n, mq1, mq2, qd1, qd2, c1, c2, qd1, qd2, True)
                u1 += n[4] * qd1 + n[5] * sign(qd1)
                u2 += n[9] * qd2 + n[10] * sign(qd2)
                prev[0], prev[1] = mq1, mq2
                integral[0] += T * e[0]
                integral[1] += T * e[1]
            else:  # tau_Lin + tau_LC (+ tau_NC)
                if k == 0:
                    for i in range(states):
                        s[i] = initial[i, 0] * e[0] + initial[i, 1] * e[1]
                for i in range(C.shape[0]):
                    acc = D[i, 0] * e[0] + D[i, 1] * e[1]
                    for j in range(states):
                        acc += C[i, j] * s[j]
                    y[i] = acc
                for i in range(states):
                    acc = B[i, 0] * e[0] + B[i, 1] * e[1]
                    for j in range(states):
                        acc += A[i, j] * s[j]
                    s_next[i] = acc
                s[:] = s_next
                # tau_Lin (Eq. 4, at the measured q) + tau_d (Eq. 7) + eta
                u1, u2 = model_terms(n, mq1, mq2, d[2], d[3], d[4], d[5], d[2], d[3], True)
                u1 += n[5] * sign(d[2]) + n[4] * d[2] + y[0]
                u2 += n[10] * sign(d[3]) + n[9] * d[3] + y[1]
                if kind == 2:
                    for j in range(2):
                        p_max[j] = max(p_max[j], abs(y[4 + j]))
                        pbar_max[j] = max(pbar_max[j], abs(y[6 + j]))
                    c = nc[0]
                    U1 = math.sqrt(p_max[0] ** 2 + p_max[1] ** 2) / c
                    U2 = math.sqrt(pbar_max[0] ** 2 + pbar_max[1] ** 2) / c**2
                    cq = math.cos(mq2)
                    a11, a12, a21 = 2.0 * n[2] * cq, n[2] * cq, n[7] * cq
                    fro2 = a11 * a11 + a12 * a12 + a21 * a21
                    det = -a12 * a21
                    m1_norm = math.sqrt(0.5 * (fro2 + math.sqrt(max(fro2**2 - 4.0 * det**2, 0.0))))
                    vd = math.sqrt(d[2] ** 2 + d[3] ** 2)
                    ad = math.sqrt(d[4] ** 2 + d[5] ** 2)
                    # bounds: delta_M0, delta_M1, delta_C, delta_G, delta_B, delta_F, k_C1, |F|
                    delta_bar = (
                        m1_norm * U2 + (bounds[1] + bounds[0]) * (U2 + ad)
                        + bounds[4] * (U1 + vd) + (bounds[6] + bounds[2]) * U1 * (U1 + 2.0 * vd)
                        + bounds[2] * vd * vd + bounds[3] + bounds[5] + 2.0 * bounds[7]
                    )  # fmt: skip
                    U_x = math.sqrt(e[0] ** 2 + e[1] ** 2 + U1 * U1 + y[0] ** 2 + y[1] ** 2)
                    alpha = nc[1] - math.sqrt(alpha_y)
                    phi = math.sqrt(y[2] ** 2 + y[3] ** 2)
                    forcing = nc[4] * U_x * (delta_bar + phi * math.sqrt(alpha_y))
                    alpha_y = max(0.0, nc[3] * alpha_y - forcing)
                    u1 -= alpha * y[2]
                    u2 -= alpha * y[3]
            u1 = min(max(u1, -limit[0]), limit[0])
            u2 = min(max(u2, -limit[1]), limit[1])
            for _ in range(m):
                a1, a2 = plant_rhs(p, q1, q2, v1, v2, u1, u2)
                w1, w2 = v1 + half * a1, v2 + half * a2
                b1, b2 = plant_rhs(p, q1 + half * v1, q2 + half * v2, w1, w2, u1, u2)
                x1, x2 = v1 + half * b1, v2 + half * b2
                c1, c2 = plant_rhs(p, q1 + half * w1, q2 + half * w2, x1, x2, u1, u2)
                y1, y2 = v1 + h * c1, v2 + h * c2
                d1, d2 = plant_rhs(p, q1 + h * x1, q2 + h * x2, y1, y2, u1, u2)
                q1 += sixth * (v1 + 2.0 * (w1 + x1) + y1)
                q2 += sixth * (v2 + 2.0 * (w2 + x2) + y2)
                v1 += sixth * (a1 + 2.0 * (b1 + c1) + d1)
                v2 += sixth * (a2 + 2.0 * (b2 + c2) + d2)
        return q_log, np.array([q1, q2, v1, v2])

    return loop


class NumbaBound:
    """The compiled closed loop; ``arguments(variant)`` extracts posfb's numbers."""

    def __init__(self) -> None:
        self._loop = _make_kernel(numba.njit)

    @staticmethod
    def arguments(variant: Variant, m: int = STEPS_PER_PERIOD, updates: int | None = None):
        config = variant.config
        theta, nominal = variant.theta, config.design.nominal
        p = np.array([*theta.theta, theta.g / theta.l1, config.plant.friction_velocity])
        n = np.array([*nominal.theta, nominal.g / nominal.l1])
        waves = config.trajectory.waves
        w = np.array(
            [[getattr(wave, name) for wave in waves]
             for name in ("offset", "amplitude", "wave_amplitude", "frequency")]
        )  # fmt: skip
        counts = config.sensor_state.encoder_counts
        step = np.array([2.0 * math.pi / c if c else 0.0 for c in counts])
        limit = np.array(config.voltage_limit, dtype=float)
        gains = np.array([config.design.pid.Kp, config.design.pid.Kv, config.design.pid.KI])
        bounds = np.zeros(8)
        nc = np.zeros(5)
        kind = KIND_CODES[config.controller]
        if kind == 0:
            f = None
        else:
            design = cached_design(config.design)
            f = design.lin_lc_filter if kind == 1 else design.proposed_filter
        if kind == 2:
            b = design.bounds
            bounds = np.array(
                [b.delta_M0, b.delta_M1, b.delta_C, b.delta_G, b.delta_B, b.delta_F, b.k_C1,
                 b.F_norm]
            )  # fmt: skip
            nl = config.design.nonlinear
            decay = math.exp(-config.sample_time / nl.K_alpha)
            nc = np.array(
                [design.bound_filter.c, nl.alpha_star, (nl.alpha_star - nl.alpha0) ** 2, decay,
                 2.0 * design.coupling_norm * (1.0 - decay)]
            )  # fmt: skip
        matrices = (
            [np.zeros((1, 1)), np.zeros((1, 2)), np.zeros((1, 1)), np.zeros((1, 2)),
             np.zeros((1, 2))]
            if f is None
            else [np.ascontiguousarray(x, dtype=float) for x in (f.A, f.B, f.C, f.D, f.initial)]
        )  # fmt: skip
        return (
            kind, p, n, w, config.sample_time, m,
            variant.updates if updates is None else updates, step, limit, *matrices, gains,
            bounds, nc,
        )  # fmt: skip

    def run(self, variant: Variant, repeat: int) -> tuple[float, LoopRun]:
        arguments = self.arguments(variant)
        self._loop(*self.arguments(variant, updates=2))  # compile (once) / warm up
        walls, result = [], None
        for _ in range(repeat):
            start = time.perf_counter()
            result = self._loop(*arguments)
            walls.append(time.perf_counter() - start)
        q_log, final = result
        return min(walls), LoopRun(min(walls), q_log, final)


# --------------------------------------------------------------------------- Drake side


@dataclass(frozen=True)
class PosfbRun:
    wall_s: float
    rms: np.ndarray
    evaluations: int
    steps: int


def posfb_run(variant: Variant, repeat: int) -> PosfbRun:
    """posfb's best wall time of ``repeat`` runs, its RMS and the integrator's counts."""
    resolved = resolve(load_scenario(None, variant.settings))
    runner = ClosedLoopRunner(resolved.config)
    parameters = resolved.true_parameters(runner.arm.default_parameters)
    results = [runner.run(parameters) for _ in range(repeat)]
    if any(result.status != "ok" for result in results):
        raise SystemExit(f"{variant.label}: posfb's run diverged: {results[0].message}")
    return PosfbRun(
        wall_s=min(result.wall_time_s for result in results),
        rms=np.array(run_metrics(results[0]).rms_q),
        evaluations=results[0].derivative_evaluations,
        steps=results[0].integrator_steps,
    )


def _fixed_step_euler(step: float) -> SimulatorConfig:
    return SimulatorConfig(
        integration_scheme="explicit_euler", max_step_size=step, use_error_control=False
    )


def plant_cost(variant: Variant, duration: float = 2.0, step: float = 1e-4) -> float:
    """Seconds per derivative evaluation of the arm's MultibodyPlant alone (continuous,
    inputs fixed at zero), under a fixed-step explicit Euler Simulator (all C++)."""
    plant = MultibodyPlant(0.0)
    Parser(plant).AddModels(variant.config.plant.urdf)
    plant.WeldFrames(plant.world_frame(), plant.GetFrameByName("base"), RigidTransform())
    plant.Finalize()
    context = plant.CreateDefaultContext()
    plant.get_actuation_input_port().FixValue(context, np.zeros(plant.num_actuators()))
    plant.get_applied_generalized_force_input_port().FixValue(
        context, np.zeros(plant.num_velocities())
    )
    plant.SetPositions(context, variant.config.trajectory.evaluate(0.0)[0])
    return _cost_per_evaluation(plant, context, duration, step)


def arm_cost(
    variant: Variant, blocks: str = "symbolic", duration: float = 2.0, step: float = 1e-4
) -> float:
    """The same for posfb's whole arm (plant, state demux, and the motor and Coulomb
    friction ``blocks`` of ``models.drive``: ``perceptron`` is the cheapest all-C++
    motor and friction with per-Context parameters that Drake offers)."""
    config = replace(variant.config.plant, motor_friction_blocks=blocks)
    diagram, arm, context = build_arm_diagram(config)
    diagram.get_input_port(0).FixValue(context, np.zeros(arm.size))
    plant = arm.plant
    plant.SetPositions(
        plant.GetMyMutableContextFromRoot(context), variant.config.trajectory.evaluate(0.0)[0]
    )
    return _cost_per_evaluation(diagram, context, duration, step)


def _cost_per_evaluation(system, context, duration: float, step: float) -> float:
    best = math.inf
    for _ in range(3):
        context.SetTime(0.0)
        simulator = Simulator(system, context.Clone())
        ApplySimulatorConfig(_fixed_step_euler(step), simulator)
        simulator.Initialize()
        start = time.perf_counter()
        simulator.AdvanceTo(duration)
        wall = time.perf_counter() - start
        best = min(best, wall / simulator.get_integrator().get_num_derivative_evaluations())
    return best


class _TrivialController(LeafSystem):
    """Periodic update reading two inputs (2 and 6 wide), writing a 2-wide state output."""

    def __init__(self, period: float) -> None:
        super().__init__()
        self._q = self.DeclareVectorInputPort("q_measured", 2)
        self._desired = self.DeclareVectorInputPort("desired", 6)
        state = self.DeclareDiscreteState(2)
        self.DeclareStateOutputPort("voltage", state)
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)

    def _update(self, context, discrete_state) -> None:
        q = self._q.Eval(context)
        desired = self._desired.Eval(context)
        discrete_state.get_mutable_vector(0).SetFromVector(q - desired[0:2])


def callback_floor(period: float, updates: int = 20000) -> float:
    """Seconds per periodic Python update of ``_TrivialController`` simulated alone."""
    builder = DiagramBuilder()
    controller = builder.AddSystem(_TrivialController(period))
    q = builder.AddSystem(ConstantVectorSource(np.zeros(2)))
    desired = builder.AddSystem(ConstantVectorSource(np.ones(6)))
    builder.Connect(q.get_output_port(0), controller.get_input_port(0))
    builder.Connect(desired.get_output_port(0), controller.get_input_port(1))
    diagram = builder.Build()
    best = math.inf
    for _ in range(3):
        simulator = Simulator(diagram)
        simulator.Initialize()
        start = time.perf_counter()
        # Updates at t = 0, T, ..., (updates - 1) T; the one at the end time is not run.
        simulator.AdvanceTo(updates * period - 0.5 * period)
        best = min(best, (time.perf_counter() - start) / updates)
    return best


# --------------------------------------------------------------------------- main


def _percent(a: np.ndarray, b: np.ndarray) -> str:
    return ", ".join(f"{100.0 * (x - y) / y:+.1f} %" for x, y in zip(a, b, strict=True))


def _pair(values: np.ndarray) -> str:
    return f"{values[0]:.3e}, {values[1]:.3e}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--no-step-check", action="store_true")
    parser.add_argument("--find-step", action="store_true")
    args = parser.parse_args()
    variants = [load_variant(label, settings) for label, settings in VARIANTS]
    first = variants[0]
    T = first.config.sample_time
    m = STEPS_PER_PERIOD
    if args.find_step:
        m = find_step(variants)
        print(f"chosen: m = {m}\n")
    print(
        f"Physics check: NumPy right-hand side vs the Drake arm's derivatives, largest "
        f"relative |qddot| difference {check_physics(first):.1e}"
    )
    limit = rk4_step_limit(first)
    print(
        f"RK4 step h = T_s / {m} = {T / m * 1e3:.3f} ms (stability limit {limit * 1e3:.3f} ms); "
        f"NumPy loop: {4 * m * first.updates} derivative evaluations, {first.updates} updates"
    )
    if not args.no_step_check:
        checks = ", ".join(f"{v.label} {halving_difference(v, m):.1e}" for v in variants)
        print(f"|q(20.01 s; h) - q(20.01 s; h/2)| (rad, ideal encoder): {checks}")
    cost = plant_cost(first)
    whole_arm = arm_cost(first)
    mlp_arm = arm_cost(first, "perceptron")
    floor = callback_floor(T)
    print(
        f"MultibodyPlant alone: {cost * 1e6:.2f} us per derivative evaluation "
        f"(posfb's arm with motor and friction blocks: {whole_arm * 1e6:.2f} us; all-C++ "
        f"MultilayerPerceptron arm: {mlp_arm * 1e6:.2f} us); "
        f"Python callback floor: {floor * 1e6:.2f} us per update"
    )
    bound = None
    if numba is None:
        print("numba is not installed: the compiled bound is skipped (pip install -e .[bench])")
    else:
        bound = NumbaBound()
    print(f"\n20 s closed loop, nominal arm, best of {args.repeat}\n")
    print(
        "| controller | posfb s | NumPy arrays s | arrays / posfb | NumPy scalar s | "
        "posfb / scalar | numba ms | posfb / numba | evals | steps | us/eval | us/update | "
        "floor s | posfb / floor | arm floor s | posfb / arm floor | C++ arm bound / floor |"
    )
    print("|---|" + "---:|" * 16, flush=True)
    accuracy = []
    for variant in variants:
        posfb = posfb_run(variant, args.repeat)
        loops = [numpy_loop(variant, m) for _ in range(args.repeat)]
        numpy_wall = min(loop.wall_s for loop in loops)
        numpy_rms = loops[0].rms(variant)
        arrays = [numpy_array_loop(variant, m) for _ in range(args.repeat)]
        arrays_wall = min(loop.wall_s for loop in arrays)
        array_gap = float(np.max(np.abs(arrays[0].q - loops[0].q)))
        compiled = ("skipped", "-")
        compiled_rms = agreement = "-"
        if bound is not None:
            wall, run = bound.run(variant, args.repeat)
            compiled = (f"{wall * 1e3:.1f}", f"{posfb.wall_s / wall:.0f}")
            compiled_rms = _pair(run.rms(variant))
            agreement = f"{np.max(np.abs(run.q - loops[0].q)):.1e}"
        updates = variant.updates
        drake_floor = posfb.evaluations * cost + updates * floor
        arm_floor = posfb.evaluations * whole_arm + updates * floor
        mlp_floor = posfb.evaluations * mlp_arm + updates * floor
        print(
            f"| {variant.label} | {posfb.wall_s:.3f} | {arrays_wall:.2f} | "
            f"{arrays_wall / posfb.wall_s:.1f} | {numpy_wall:.3f} | "
            f"{posfb.wall_s / numpy_wall:.2f} | {compiled[0]} | {compiled[1]} | "
            f"{posfb.evaluations} | {posfb.steps} | "
            f"{posfb.wall_s / posfb.evaluations * 1e6:.1f} | "
            f"{posfb.wall_s / updates * 1e6:.0f} | {drake_floor:.3f} | "
            f"{posfb.wall_s / drake_floor:.1f} | {arm_floor:.3f} | "
            f"{posfb.wall_s / arm_floor:.1f} | {mlp_floor / drake_floor:.2f} |",
            flush=True,
        )
        accuracy.append(
            f"| {variant.label} | {_pair(posfb.rms)} | {_pair(numpy_rms)} | "
            f"{_percent(numpy_rms, posfb.rms)} | {array_gap:.1e} | {compiled_rms} | "
            f"{agreement} |"
        )
    print("\nRMS(q~) over k = 1..N0 (rad, joint 1, joint 2)\n")
    print(
        "| controller | posfb | NumPy scalar loop | scalar vs posfb | "
        "max abs(q_arrays - q_scalar) rad | numba | max abs(q_numba - q_scalar) rad |"
    )
    print("|---|---|---|---|---:|---|---:|")
    print("\n".join(accuracy))


if __name__ == "__main__":
    main()
