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

``M(q)`` (``mass_matrix``) is built by composite rigid bodies on the same placements
(``_placements``, the forward pass's positions): each body's mass ``m``, first moment
``h = sum m r`` and second moment ``J = sum (I + m (|r|^2 1 - r r^T))`` about the world
origin are summed over it and all bodies outboard; turning that composite at rest about
joint ``i`` (axis ``a_i`` through ``o_i``) at a unit angular acceleration takes
``f = a_i x (h - m o_i)`` and ``n = J a_i - h x (a_i x o_i)`` about the origin, so
``M_ji = a_j . (n - o_j x f)`` for each joint ``j`` it hangs from. It equals the
torques' Jacobian in the acceleration, with fewer operations.

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


@dataclass(frozen=True)
class _Placement:
    """A body's placement in the world at ``q`` (``SX``): its frame ``C``'s rotation and
    origin; its parent's origin, the joint's frames' origins ``F`` (on the parent) and
    ``M`` (on the child) and, for a revolute joint, its axis in the world."""

    R_WC: ca.SX
    p_WC: ca.SX
    p_WP: ca.SX | None = None
    p_WF: ca.SX | None = None
    axis: ca.SX | None = None
    p_WM: ca.SX | None = None


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

    def _placements(self, q: ca.SX) -> list[_Placement]:
        """Each body's placement at ``q`` in the world (``_Placement``), base first: the
        forward pass's positions, shared by ``torques`` and ``mass_matrix`` (the same
        expressions, so ``casadi.cse`` computes them once in a law that has both)."""
        placed: dict[int, _Placement] = {-1: _Placement(ca.SX.eye(3), ca.SX.zeros(3))}
        for k, body in enumerate(self._bodies):
            R_WP, p_WP = placed[body.parent].R_WC, placed[body.parent].p_WC
            R_WF = ca.mtimes(R_WP, ca.DM(body.R_PF))
            p_WF = p_WP + ca.mtimes(R_WP, ca.DM(body.p_PF))
            if body.axis is None:
                axis, R_WM = None, ca.mtimes(R_WF, ca.DM(body.R_FM))
            else:
                axis = ca.mtimes(R_WF, ca.DM(body.axis))
                R_WM = ca.mtimes(R_WF, _rodrigues(body.axis, q[body.joint]))
            p_WM = p_WF + ca.mtimes(R_WF, ca.DM(body.p_FM))
            R_WC = ca.mtimes(R_WM, ca.DM(body.R_MC))
            p_WC = p_WM + ca.mtimes(R_WM, ca.DM(body.p_MC))
            placed[k] = _Placement(R_WC, p_WC, p_WP, p_WF, axis, p_WM)
        return [placed[k] for k in range(len(self._bodies))]

    def torques(self, q: ca.SX, v: ca.SX, a: ca.SX, gravity: bool = True) -> ca.SX:
        """The arm joint torques ``M(q) a + c(q, v) + tau_G(q)`` (N m; ``tau_G`` only with
        ``gravity``), by the recursive Newton-Euler algorithm (module docstring)."""
        zero = ca.SX.zeros(3)
        base = ca.DM(-self._gravity) if gravity else ca.DM.zeros(3)
        motion = {-1: (zero, zero, ca.SX(base))}
        joint_data, wrenches = {}, []
        for k, (body, place) in enumerate(zip(self._bodies, self._placements(q), strict=True)):
            w_P, dw_P, a_P = motion[body.parent]
            a_F = _point_acceleration(a_P, dw_P, w_P, place.p_WF - place.p_WP)
            if body.axis is None:
                w, dw = w_P, dw_P
            else:
                j, axis = body.joint, place.axis
                w = w_P + axis * v[j]
                dw = dw_P + axis * a[j] + ca.cross(w_P, axis * v[j])
                joint_data[k] = (j, axis, place.p_WM)
            a_M = _point_acceleration(a_F, dw, w, place.p_WM - place.p_WF)
            a_C = _point_acceleration(a_M, dw, w, place.p_WC - place.p_WM)
            motion[k] = (w, dw, a_C)
            R_WC, p_WC = place.R_WC, place.p_WC
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
        """``M(q)`` (N m s^2/rad), reflected rotor inertia included, by the composite
        rigid bodies (module docstring): each joint's column is the wrench that turning the
        bodies outboard of it at a unit angular acceleration (at rest) needs, read on the
        axes of the joints it hangs from."""
        placements = self._placements(q)
        count = len(self._bodies)
        mass = [body.mass for body in self._bodies]
        first, second = [], []  # sum m r and sum m (|r|^2 I - r r^T) about the world origin
        for body, place in zip(self._bodies, placements, strict=True):
            com = place.p_WC + ca.mtimes(place.R_WC, ca.DM(body.com))
            rotated = ca.mtimes([place.R_WC, ca.DM(body.inertia), place.R_WC.T])
            first.append(body.mass * com)
            second.append(rotated + body.mass * (ca.dot(com, com) * ca.SX.eye(3)
                                                 - ca.mtimes(com, com.T)))  # fmt: skip
        for k in reversed(range(count)):  # each body's sums over itself and all outboard
            parent = self._bodies[k].parent
            if parent >= 0:
                mass[parent] = mass[parent] + mass[k]
                first[parent] = first[parent] + first[k]
                second[parent] = second[parent] + second[k]
        M = [[ca.SX(0)] * self.joints for _ in range(self.joints)]
        for k, (body, place) in enumerate(zip(self._bodies, placements, strict=True)):
            if body.joint is None:
                continue
            axis, origin = place.axis, place.p_WM
            force = ca.cross(axis, first[k] - mass[k] * origin)
            moment = ca.mtimes(second[k], axis) - ca.cross(first[k], ca.cross(axis, origin))
            inboard = k
            while inboard >= 0:
                joint = self._bodies[inboard].joint
                if joint is not None:
                    at = placements[inboard]
                    M[joint][body.joint] = M[body.joint][joint] = ca.dot(
                        at.axis, moment - ca.cross(at.p_WM, force))
                inboard = self._bodies[inboard].parent
        return ca.blockcat(M) + ca.diag(ca.DM(self.reflected_inertia))
