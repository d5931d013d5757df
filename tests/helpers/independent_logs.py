"""Encoder logs for the identification tests made without posfb's plant code or Drake.

The arm is simulated by Pinocchio (``pinocchio.aba``; the URDF's fixed joints merged into
their parent bodies), with posfb's model of each arm joint ``j``::

    M(q) q'' + c(q, q') + g(q) + J_j q''_j = kappa_j u_j - b_j q'_j - f_cj tanh(q'_j / v_s)

``J_j`` the reflected rotor inertia (``drake:rotor_inertia`` x ``drake:gear_ratio``^2, put
in Pinocchio's ``model.armature``), ``kappa_j`` the motor constant
(``posfb:motor_constant``), ``b_j`` the damping (``<dynamics damping>``), ``f_cj`` the
Coulomb level (``posfb:coulomb_friction``), ``v_s = FRICTION_VELOCITY`` (the plant's
default ``PlantConfig.friction_velocity``), gravity 9.81 m/s^2 along -z and the URDF's root
link at the world origin. The Coulomb term is the plant's tanh-smoothed one;
``SerialArmModel.inverse_dynamics`` (posfb's nominal Eq. 2) writes it ``f_c sgn q'``,
which differs from the tanh by less than 5e-9 f_c where ``|q'| >= 0.1`` rad/s and
equals it in double precision where ``|q'| >= 0.2`` rad/s.

A log (``simulate_log``) runs a reference (``fourier_reference``) in closed loop: the
arm ``true_urdf`` (``perturbed_urdf`` writes one) is integrated by classic RK4 with
``substeps`` steps per sample period under the held voltage, an encoder quantises its
positions, and a computed-torque controller of the nominal URDF computes each sample's
voltage (``simulate_log``).

Speed (one Python loop over samples and substeps, four ``aba`` calls per RK4 step): a
4-joint ``spatial_arm_urdf`` arm at a 1 ms sample time with 10 substeps took 9.4 s of wall
time per 10 s simulated (0.94 s per simulated s) on the 2-core development machine while
another test run shared it; 4 substeps took 0.40 s and 2 substeps 0.23 s per simulated s,
with true positions within 1e-9 rad of the 10-substep run's over 2 s.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

#: The namespaces of posfb's and Drake's URDF elements.
POSFB_NS = "urn:posfb:urdf"
DRAKE_NS = "http://drake.mit.edu"
ET.register_namespace("posfb", POSFB_NS)
ET.register_namespace("drake", DRAKE_NS)

#: The smoothing velocity of the Coulomb term (rad/s; ``PlantConfig.friction_velocity``).
FRICTION_VELOCITY = 0.01

#: The URDF joint types of an arm joint.
ARM_JOINTS = ("revolute", "continuous")

#: The largest centre-of-mass shift ``perturbed_urdf`` draws per axis, at spread 1 (m).
COM_SHIFT = 0.05


def _value(element: ET.Element | None, default: float) -> float:
    """``element``'s ``value`` attribute as a number; ``default`` without the element."""
    return default if element is None else float(element.get("value", "nan"))


def _damping(joint: ET.Element) -> float:
    """``joint``'s ``<dynamics damping>`` (0 where it has none)."""
    dynamics = joint.find("dynamics")
    return 0.0 if dynamics is None else float(dynamics.get("damping", 0.0))


def _actuator(robot: ET.Element, joint: str) -> ET.Element | None:
    """The ``<actuator>`` of the first ``<transmission>`` driving ``joint``."""
    for transmission in robot.findall("transmission"):
        driven = transmission.find("joint")
        if driven is not None and driven.get("name") == joint:
            return transmission.find("actuator")
    return None


def _arm_joints(robot: ET.Element) -> list[ET.Element]:
    """The arm joints of ``robot`` from the base to the tip: each revolute/continuous
    joint ordered by the number of arm joints between it and the root link."""
    moving = [j for j in robot.findall("joint") if j.get("type") in ARM_JOINTS]
    parent_joint = {j.find("child").get("link"): j for j in robot.findall("joint")}

    def depth(joint: ET.Element) -> int:
        above = parent_joint.get(joint.find("parent").get("link"))
        if above is None:
            return 0
        return depth(above) + (above.get("type") in ARM_JOINTS)

    depths = [depth(j) for j in moving]
    if sorted(depths) != list(range(len(moving))):
        raise ValueError("the URDF's revolute/continuous joints are not one serial chain")
    return [joint for _, joint in sorted(zip(depths, moving, strict=True), key=lambda x: x[0])]


@dataclass(frozen=True, eq=False)
class Reference:
    """A reference trajectory sampled at ``time`` (N,): positions ``q`` (rad),
    velocities ``qd`` (rad/s) and accelerations ``qdd`` (rad/s^2), each (N, n)."""

    time: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray

    @property
    def sample_time(self) -> float:
        """The sample period (s)."""
        return float(self.time[1] - self.time[0])


class PinocchioArm:
    """A URDF arm's Pinocchio model with its drives (module docstring): vectors are in
    the order of ``joints``, the arm joints from the base to the tip."""

    def __init__(self, urdf: Path) -> None:
        robot = ET.parse(urdf).getroot()
        arm = _arm_joints(robot)
        self.joints = tuple(j.get("name") for j in arm)
        for joint in arm:  # one angle, not Pinocchio's (cos, sin), for a continuous joint
            if joint.get("type") == "continuous":
                joint.set("type", "revolute")
                ET.SubElement(joint, "limit", lower="-1e9", upper="1e9", effort="0", velocity="0")
        self.model = pin.buildModelFromXML(ET.tostring(robot, encoding="unicode"))
        # The Pinocchio velocity index of each arm joint, found by name.
        index = [self.model.joints[self.model.getJointId(name)].idx_v for name in self.joints]
        if self.model.nq != len(arm) or index != list(range(len(arm))):
            raise ValueError(
                f"Pinocchio's model has {self.model.nq} coordinates and indexes the arm joints "
                f"{self.joints} as {index}; one angle per arm joint, base to tip, is required"
            )
        actuators = [_actuator(robot, name) for name in self.joints]
        if None in actuators:
            raise ValueError(f"joints {self.joints}: each needs a transmission actuator")
        self.motor_constant = np.array(
            [_value(a.find(f"{{{POSFB_NS}}}motor_constant"), np.nan) for a in actuators]
        )
        self.coulomb = np.array(
            [_value(j.find(f"{{{POSFB_NS}}}coulomb_friction"), np.nan) for j in arm]
        )
        self.damping = np.array([_damping(j) for j in arm])
        self.model.armature = np.array(
            [
                _value(a.find(f"{{{DRAKE_NS}}}rotor_inertia"), 0.0)
                * _value(a.find(f"{{{DRAKE_NS}}}gear_ratio"), 1.0) ** 2
                for a in actuators
            ]
        )
        if not np.all(np.isfinite(self.motor_constant) & np.isfinite(self.coulomb)):
            raise ValueError(f"joints {self.joints}: a motor constant or Coulomb level is missing")
        self.data = self.model.createData()

    def friction(self, qd: np.ndarray) -> np.ndarray:
        """The joint friction torque opposing ``qd``: ``b qd + f_c tanh(qd / v_s)`` (N m)."""
        return self.damping * qd + self.coulomb * np.tanh(qd / FRICTION_VELOCITY)

    def voltage(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """The inverse dynamics in volts: ``(RNEA(q, qd, qdd) + J qdd + friction(qd)) /
        kappa`` (Pinocchio's ``rnea`` adds the armature term ``J qdd``)."""
        torque = pin.rnea(self.model, self.data, q, qd, qdd) + self.friction(qd)
        return torque / self.motor_constant

    def acceleration(self, q: np.ndarray, qd: np.ndarray, drive: np.ndarray) -> np.ndarray:
        """The forward dynamics ``q''`` under the motor torque ``drive = kappa u`` (N m)."""
        return pin.aba(self.model, self.data, q, qd, drive - self.friction(qd))


@dataclass(frozen=True, eq=False)
class IndependentLog:
    """A closed-loop run: ``time`` (N,), the true and the encoder's positions ``q_true``,
    ``q_measured`` (rad) and the voltage ``u_applied`` held from each sample to the next
    (V), each (N, n), and the ``reference`` the controller followed."""

    time: np.ndarray
    q_true: np.ndarray
    q_measured: np.ndarray
    u_applied: np.ndarray
    reference: Reference

    def write_csv(self, path: Path) -> Path:
        """Write the log as a CSV with posfb's log columns (``analysis.common.export``):
        ``time_s``, ``q{j}_desired_rad``, ``q{j}_rad``, ``q{j}_measured_rad``,
        ``u{j}_applied_V``, ``q{j}_desired_velocity_rad_per_s`` and
        ``q{j}_desired_acceleration_rad_per_s2``, ``j = 1..n``; returns ``path``."""
        joints = range(1, self.q_true.shape[1] + 1)
        names = ["time_s"] + [
            pattern.format(j=j)
            for pattern in (
                "q{j}_desired_rad",
                "q{j}_rad",
                "q{j}_measured_rad",
                "u{j}_applied_V",
                "q{j}_desired_velocity_rad_per_s",
                "q{j}_desired_acceleration_rad_per_s2",
            )
            for j in joints
        ]
        table = np.column_stack(
            [
                self.time,
                self.reference.q,
                self.q_true,
                self.q_measured,
                self.u_applied,
                self.reference.qd,
                self.reference.qdd,
            ]
        )
        np.savetxt(path, table, fmt="%.17g", delimiter=",", header=",".join(names), comments="")
        return path


def perturbed_urdf(nominal: Path, target: Path, seed: int, spread: float = 0.15) -> Path:
    """Write to ``target`` the "true arm": ``nominal``'s URDF with, per arm joint from the
    base to the tip, its child link's mass and rotational inertia (the whole matrix, so it
    stays physically valid) times ``1 + U(-spread, spread)``, its centre of mass shifted by
    ``U(-spread, spread) * COM_SHIFT`` per axis of the link frame, and the joint's damping,
    Coulomb level, motor constant and rotor inertia each times ``1 + U(-spread, spread)``
    (absent elements stay absent); seeded by ``seed``. Returns ``target``."""
    tree = ET.parse(nominal)
    robot = tree.getroot()
    links = {link.get("name"): link for link in robot.findall("link")}
    rng = np.random.default_rng(seed)
    for joint in _arm_joints(robot):
        mass, inertia, damping, coulomb, motor, rotor = 1.0 + rng.uniform(-spread, spread, 6)
        shift = rng.uniform(-spread, spread, 3) * COM_SHIFT
        inertial = links[joint.find("child").get("link")].find("inertial")
        if inertial is not None:
            _scale(inertial.find("mass"), ("value",), mass)
            _scale(inertial.find("inertia"), ("ixx", "ixy", "ixz", "iyy", "iyz", "izz"), inertia)
            origin = inertial.find("origin")
            if origin is None:
                origin = ET.SubElement(inertial, "origin")
            xyz = np.array(origin.get("xyz", "0 0 0").split(), dtype=float) + shift
            origin.set("xyz", " ".join(f"{x:.17g}" for x in xyz))
        _scale(joint.find("dynamics"), ("damping",), damping)
        _scale(joint.find(f"{{{POSFB_NS}}}coulomb_friction"), ("value",), coulomb)
        actuator = _actuator(robot, joint.get("name"))
        if actuator is not None:
            _scale(actuator.find(f"{{{POSFB_NS}}}motor_constant"), ("value",), motor)
            _scale(actuator.find(f"{{{DRAKE_NS}}}rotor_inertia"), ("value",), rotor)
    tree.write(target, encoding="utf-8", xml_declaration=True)
    return target


def _scale(element: ET.Element | None, attributes: tuple[str, ...], factor: float) -> None:
    """Multiply ``element``'s numeric ``attributes`` (those it has) by ``factor``."""
    if element is None:
        return
    for name in attributes:
        if name in element.attrib:
            element.set(name, f"{float(element.get(name)) * factor:.17g}")


def fourier_reference(
    joints: int,
    duration: float,
    sample_time: float,
    seed: int,
    amplitude: float = 0.6,
    harmonics: int = 5,
    base_hz: float = 0.1,
) -> Reference:
    """A random finite Fourier series per joint (Swevers et al. 1997), sampled every
    ``sample_time`` over ``[0, duration]``::

        q_j(t) = c_j + sum_k a_jk sin(2 pi k f t) + b_jk cos(2 pi k f t),  k = 1..harmonics

    with ``f = base_hz``, ``c_j ~ U(-1/2, 1/2) amplitude`` and ``a_jk, b_jk ~ U(-1, 1)
    amplitude / (2 k H)``, ``H = sum_k 1/k``: ``|q_j| <= 1.5 amplitude``, and each harmonic
    contributes at most ``amplitude 2 pi f / H`` to the velocity. Seeded by ``seed``."""
    rng = np.random.default_rng(seed)
    k = np.arange(1, harmonics + 1)
    scale = amplitude / (2.0 * k * np.sum(1.0 / k))
    offset = rng.uniform(-0.5, 0.5, joints) * amplitude
    a, b = rng.uniform(-1.0, 1.0, (2, joints, harmonics)) * scale
    time = np.arange(round(duration / sample_time) + 1) * sample_time
    omega = 2.0 * np.pi * base_hz * k
    sin, cos = np.sin(np.outer(time, omega)), np.cos(np.outer(time, omega))
    return Reference(
        time=time,
        q=offset + sin @ a.T + cos @ b.T,
        qd=(cos * omega) @ a.T - (sin * omega) @ b.T,
        qdd=-(sin * omega**2) @ a.T - (cos * omega**2) @ b.T,
    )


def simulate_log(
    true_urdf: Path,
    nominal_urdf: Path,
    reference: Reference,
    *,
    counts: int,
    voltage_limit: float = 1e6,
    substeps: int = 10,
    controller_hz: float = 5.0,
) -> IndependentLog:
    """Run ``reference`` in closed loop on the arm ``true_urdf`` (module docstring) and
    log it.

    The arm starts at ``reference.q[0]`` with velocity ``reference.qd[0]``. At each sample
    ``t_k`` the encoder reads ``q_m = round(q / s) s``, ``s = 2 pi / counts``; the
    controller, computed torque on ``nominal_urdf``'s model and drives, sets::

        v_est = (q_m[k] - q_m[k-1]) / T          (v_est = qd_d at k = 0)
        a     = qdd_d + Kp (q_d - q_m) + Kd (qd_d - v_est),   Kp = w^2, Kd = 2 w
        u     = clip(voltage_nominal(q_m, qd_d, a), -voltage_limit, voltage_limit)

    with ``w = 2 pi controller_hz``, ``T`` the sample time and ``voltage_nominal``
    ``PinocchioArm.voltage`` (rigid body, rotor, damping and Coulomb terms, the last two
    at the desired velocity). ``u`` is held over ``[t_k, t_k+1)``, over which classic RK4
    integrates the arm in ``substeps`` steps."""
    plant, nominal = PinocchioArm(true_urdf), PinocchioArm(nominal_urdf)
    if plant.joints != nominal.joints:
        raise ValueError(f"true arm joints {plant.joints} != nominal joints {nominal.joints}")
    period, limit = reference.sample_time, voltage_limit
    omega = 2.0 * np.pi * controller_hz
    kp, kd = omega**2, 2.0 * omega
    step = 2.0 * np.pi / counts
    samples, joints = reference.q.shape
    q_true = np.empty((samples, joints))
    q_measured = np.empty((samples, joints))
    u_applied = np.empty((samples, joints))
    q, v = reference.q[0].copy(), reference.qd[0].copy()
    previous = np.round(q / step) * step - period * reference.qd[0]
    for k in range(samples):
        if k:
            drive = plant.motor_constant * u_applied[k - 1]
            q, v = _rk4(plant, q, v, drive, period / substeps, substeps)
        measured = np.round(q / step) * step
        error = reference.q[k] - measured
        rate_error = reference.qd[k] - (measured - previous) / period
        command = reference.qdd[k] + kp * error + kd * rate_error
        u = np.clip(nominal.voltage(measured, reference.qd[k], command), -limit, limit)
        q_true[k], q_measured[k], u_applied[k] = q, measured, u
        previous = measured
    return IndependentLog(reference.time, q_true, q_measured, u_applied, reference)


def _rk4(
    arm: PinocchioArm, q: np.ndarray, v: np.ndarray, drive: np.ndarray, h: float, steps: int
) -> tuple[np.ndarray, np.ndarray]:
    """``arm``'s state after ``steps`` classic RK4 steps of ``h`` under the motor torque
    ``drive`` (N m), held."""
    for _ in range(steps):
        a1 = arm.acceleration(q, v, drive)
        q2, v2 = q + 0.5 * h * v, v + 0.5 * h * a1
        a2 = arm.acceleration(q2, v2, drive)
        q3, v3 = q + 0.5 * h * v2, v + 0.5 * h * a2
        a3 = arm.acceleration(q3, v3, drive)
        q4, v4 = q + h * v3, v + h * a3
        a4 = arm.acceleration(q4, v4, drive)
        q = q + h / 6.0 * (v + 2.0 * v2 + 2.0 * v3 + v4)
        v = v + h / 6.0 * (a1 + 2.0 * a2 + 2.0 * a3 + a4)
    return q, v
