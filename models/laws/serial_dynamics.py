"""A serial URDF arm's rigid-body dynamics as CasADi ``SX`` expressions, read from its
Drake plant, so that the laws on any URDF arm print as C (``posfb codegen``).

The plant (with the parameters of a Context) gives, per body, how it hangs from its
parent (the joint's frames on parent and child, a revolute axis or a weld's fixed pose),
its mass, centre of mass and rotational inertia, the actuators' reflected rotor
inertias and the gravity vector; nothing of the arm is written here. The arm joint
torques of

    tau = M(q) qdd + c(q, qd) + tau_G(q)          (physical units, N m)

(``M`` with the reflected rotor inertia ``I_r g^2`` on its diagonal, as Drake's
``CalcMassMatrix``; ``c`` the Coriolis/centrifugal term, Drake's ``CalcBiasTerm``;
``tau_G = -CalcGravityGeneralizedForces``) come from the recursive Newton-Euler
algorithm in the world frame:

* forward, from the base: a body's rotation ``R``, origin ``p``, angular velocity
  ``w``, angular acceleration ``w'`` and origin acceleration; a revolute joint of
  world axis ``a`` adds ``a qd`` and ``a qdd + w_parent x a qd``; the base accelerates
  at ``-g`` (gravity, when asked for);
* backward, from the tip: each body's wrench about the world origin, ``f = m a_com``,
  ``n = I w' + w x I w + p_com x f``, summed over the bodies outboard of a joint;
  the joint's torque is ``a . (n - o x f)`` about its origin ``o``.

``models.laws.nominal.UrdfModel`` divides by the motor constants (Eq. 2 in volts) and
adds ``B*`` and ``F*``. The test compares every term with Drake's at random states.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import Context

#: The Drake joint types a serial arm's bodies hang from.
REVOLUTE, WELD = "revolute", "weld"


@dataclass(frozen=True)
class _Body:
    """One body of the arm: how it hangs from body ``parent`` (an index into the
    list, ``-1`` the world) and its inertia (all in its parent's and its own frame)."""

    parent: int
    R_PF: np.ndarray
    p_PF: np.ndarray
    axis: np.ndarray | None  # the revolute axis in F (= M); None for a weld
    joint: int | None  # the arm joint's index in q; None for a weld
    R_FM: np.ndarray  # a weld's fixed rotation (identity for a revolute joint)
    p_FM: np.ndarray
    R_MC: np.ndarray
    p_MC: np.ndarray
    mass: float
    com: np.ndarray  # in the body frame
    inertia: np.ndarray  # about the centre of mass, in the body frame


def _pose(frame, context: Context) -> tuple[np.ndarray, np.ndarray]:
    """A frame's fixed pose in its body, ``(R, p)``."""
    X = frame.CalcPoseInBodyFrame(context)
    return X.rotation().matrix(), X.translation()


def _rodrigues(axis: np.ndarray, angle: ca.SX) -> ca.SX:
    """The rotation by ``angle`` about the unit ``axis``."""
    K = ca.DM(np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]],
                        [-axis[1], axis[0], 0.0]]))  # fmt: skip
    return ca.DM.eye(3) + ca.sin(angle) * K + (1.0 - ca.cos(angle)) * ca.mtimes(K, K)


def _point_acceleration(a_O: ca.SX, dw: ca.SX, w: ca.SX, r: ca.SX) -> ca.SX:
    """The acceleration of the point at ``r`` from a point ``O`` of the same body (both
    fixed in it), ``a_O + w' x r + w x (w x r)``."""
    return a_O + ca.cross(dw, r) + ca.cross(w, ca.cross(w, r))


class SerialArmDynamics:
    """The arm joint torques of a serial arm's plant (module docstring) as ``SX``
    expressions; ``joints`` names the arm joints in the order of ``q``."""

    def __init__(self, plant: MultibodyPlant, context: Context, joints: tuple[str, ...]) -> None:
        self.joints = len(joints)
        arm = {plant.GetJointByName(name).index(): k for k, name in enumerate(joints)}
        inboard = {}
        for index in plant.GetJointIndices():
            joint = plant.get_joint(index)
            inboard[joint.child_body().index()] = joint
        world = plant.world_body().index()
        order, bodies, position = [world], [], {world: -1}
        while order:
            parent = order.pop(0)
            for child, joint in sorted(inboard.items()):
                if joint.parent_body().index() != parent or child in position:
                    continue
                position[child] = len(bodies)
                bodies.append(self._body(plant, context, joint, position[parent], arm))
                order.append(child)
        if len(position) != plant.num_bodies():
            raise ValueError(f"the plant has {plant.num_bodies() - len(position)} bodies "
                             "not joined to the world; a serial arm is required")  # fmt: skip
        self._bodies = bodies
        self._gravity = np.asarray(plant.gravity_field().gravity_vector(), dtype=float)
        reflected = np.zeros(self.joints)
        for index in plant.GetJointActuatorIndices():
            actuator = plant.get_joint_actuator(index)
            if actuator.joint().index() in arm:
                reflected[arm[actuator.joint().index()]] = actuator.calc_reflected_inertia(context)
        self.reflected_inertia = reflected

    @staticmethod
    def _body(plant: MultibodyPlant, context: Context, joint, parent: int,
              arm: dict) -> _Body:  # fmt: skip
        kind = joint.type_name()
        if kind not in (REVOLUTE, WELD):
            raise ValueError(f"joint {joint.name()!r} is a {kind} joint; a serial arm has "
                             f"{REVOLUTE} and {WELD} joints only")  # fmt: skip
        R_PF, p_PF = _pose(joint.frame_on_parent(), context)
        R_CM, p_CM = _pose(joint.frame_on_child(), context)
        R_MC = R_CM.T
        if kind == REVOLUTE:
            if joint.index() not in arm:
                raise ValueError(f"revolute joint {joint.name()!r} is not one of the arm's")
            axis, index = np.asarray(joint.revolute_axis(), dtype=float), arm[joint.index()]
            R_FM, p_FM = np.eye(3), np.zeros(3)
        else:
            axis, index = None, None
            X_FM = joint.X_FM()
            R_FM, p_FM = X_FM.rotation().matrix(), X_FM.translation()
        inertia = joint.child_body().CalcSpatialInertiaInBodyFrame(context)
        com = np.asarray(inertia.get_com(), dtype=float)
        about_com = inertia.Shift(com).CalcRotationalInertia().CopyToFullMatrix3()
        return _Body(parent, R_PF, p_PF, axis, index, R_FM, p_FM, R_MC, -R_MC @ p_CM,
                     float(inertia.get_mass()), com, about_com)  # fmt: skip

    def torques(self, q: ca.SX, v: ca.SX, a: ca.SX, gravity: bool = True) -> ca.SX:
        """The arm joint torques ``M(q) a + c(q, v) + tau_G(q)`` (N m; ``tau_G`` only with
        ``gravity``), by the recursive Newton-Euler algorithm (module docstring)."""
        zero = ca.SX.zeros(3)
        base = ca.DM(-self._gravity) if gravity else ca.DM.zeros(3)
        frames = {-1: (ca.SX.eye(3), zero, zero, zero, ca.SX(base))}
        joint_data, wrenches = {}, []
        for k, body in enumerate(self._bodies):
            R_WP, p_WP, w_P, dw_P, a_P = frames[body.parent]
            R_WF = ca.mtimes(R_WP, ca.DM(body.R_PF))
            p_WF = p_WP + ca.mtimes(R_WP, ca.DM(body.p_PF))
            a_F = _point_acceleration(a_P, dw_P, w_P, p_WF - p_WP)
            if body.axis is None:
                R_WM = ca.mtimes(R_WF, ca.DM(body.R_FM))
                w, dw = w_P, dw_P
            else:
                j = body.joint
                axis = ca.mtimes(R_WF, ca.DM(body.axis))
                R_WM = ca.mtimes(R_WF, _rodrigues(body.axis, q[j]))
                w = w_P + axis * v[j]
                dw = dw_P + axis * a[j] + ca.cross(w_P, axis * v[j])
            p_WM = p_WF + ca.mtimes(R_WF, ca.DM(body.p_FM))
            a_M = _point_acceleration(a_F, dw, w, p_WM - p_WF)
            R_WC = ca.mtimes(R_WM, ca.DM(body.R_MC))
            p_WC = p_WM + ca.mtimes(R_WM, ca.DM(body.p_MC))
            a_C = _point_acceleration(a_M, dw, w, p_WC - p_WM)
            frames[k] = (R_WC, p_WC, w, dw, a_C)
            if body.joint is not None:
                joint_data[k] = (body.joint, axis, p_WM)
            r_com = ca.mtimes(R_WC, ca.DM(body.com))
            a_com = _point_acceleration(a_C, dw, w, r_com)
            I_W = ca.mtimes([R_WC, ca.DM(body.inertia), R_WC.T])
            force = body.mass * a_com
            moment = (ca.mtimes(I_W, dw) + ca.cross(w, ca.mtimes(I_W, w))
                      + ca.cross(p_WC + r_com, force))  # fmt: skip
            wrenches.append([force, moment])
        tau = [ca.SX(0)] * self.joints
        for k in reversed(range(len(self._bodies))):
            force, moment = wrenches[k]
            if k in joint_data:
                j, axis, origin = joint_data[k]
                tau[j] = ca.dot(axis, moment - ca.cross(origin, force))
            parent = self._bodies[k].parent
            if parent >= 0:
                wrenches[parent][0] = wrenches[parent][0] + force
                wrenches[parent][1] = wrenches[parent][1] + moment
        return ca.vertcat(*tau) + ca.DM(self.reflected_inertia) * a

    def mass_matrix(self, q: ca.SX) -> ca.SX:
        """``M(q)`` (N m s^2/rad), reflected rotor inertia included: the torques'
        Jacobian in the acceleration, which they are linear in."""
        a = ca.SX.sym("a", self.joints)
        return ca.jacobian(self.torques(q, ca.SX.zeros(self.joints), a, gravity=False), a)
