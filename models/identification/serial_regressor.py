"""The linear-in-parameters dynamics of any serial revolute URDF arm (issue 29).

Every joint's torque equation of Eq. 2 (``models.serial_model``; the voltage ``u_j`` times
the motor constant ``kappa_j``) is linear in the arm's standard parameters::

    kappa_j u_j = [M_links(q) q'' + c(q, q') - tau_g(q)]_j + Jr_j q''_j + b_j q'_j
                  + fc_j sgn(q'_j)
                = Y_j(q, q', q'') pi

(Atkeson, An & Hollerbach 1986, "Estimation of inertial parameters of manipulator loads
and links"). ``M_links`` is the links' mass matrix without the rotor inertia, ``Jr_j`` the
reflected rotor inertia (rotor inertia x gear ratio^2, which Drake adds to ``M``),
``b_j`` the viscous damping, ``fc_j`` the Coulomb level; ``sgn(0) = 0``, as
``SerialArmModel.F`` has it.

The standard vector ``pi`` (``parameter_names``) is, per moving link ``i`` from the base
to the tip, ``INERTIAL_PARAMETERS``::

    [m, m cx, m cy, m cz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz]

the mass, the first moment ``m c`` (``c``: the centre of mass) and the rotational
inertia *about the link frame's origin*, all in the link frame (Drake's body frame: the
URDF's link frame); ``Ixy, Ixz, Iyz`` are entries of the inertia matrix (URDF's and
Drake's convention, ``Ixy = -sum m x y``). Bodies welded to a link (a ``payload`` at the
tip) are folded into it. Then, per joint, ``DRIVE_PARAMETERS``: the reflected rotor
inertia (kg m^2), the damping (N m s/rad) and the Coulomb level (N m).

``SerialRegressor.inertial_columns`` evaluates ``Y`` with the Newton-Euler recursion in
the link frames, vectorised over samples: joint velocities and accelerations outward
(the base accelerated by ``-g``, so gravity enters as an inertial force), the 6 x 10
matrix of each link's wrench about its origin,
``f = m a + (w' x + w x w x) h``, ``n = I w' + w x (I w) + h x a`` (with ``a`` the
acceleration of the link origin), and that wrench carried inward to the axis of the
link's own joint and of every joint before it.

Not every standard parameter changes the torques, and some do so only in fixed
combinations (a base joint's rotor inertia and the first link's inertia about that
axis both multiply ``q''_1`` alone). ``base_parameters`` finds, from the regressor at
random states, the base parameters ``beta = K pi`` with ``Y pi = Y_base beta``
(Gautier 1990, "Numerical calculation of the base inertial parameters of robots").
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from pydrake.math import RigidTransform
from pydrake.multibody.tree import RevoluteJoint
from pydrake.systems.framework import Context

from posfb.models.plant import Arm, read_parameters
from posfb.models.validation import shown

#: The standard inertial parameters of one link, in the order of ``pi`` (module docstring).
INERTIAL_PARAMETERS = ("m", "mcx", "mcy", "mcz", "Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz")

#: The drive parameters of one joint, in the order of ``pi`` (module docstring).
DRIVE_PARAMETERS = ("rotor_inertia", "damping", "coulomb")

#: Speeds (rad/s) and accelerations (rad/s^2) of ``SerialRegressor.sample_states``: drawn
#: uniformly in +- these. Only their spread matters to ``base_parameters`` (its columns
#: are normalised), not their size.
SAMPLE_SPEED = 2.0
SAMPLE_ACCELERATION = 10.0

#: Default relative tolerance of ``base_parameters`` on the QR diagonal.
BASE_TOLERANCE = 1e-8


def _skew(vectors: np.ndarray) -> np.ndarray:
    """``[w]x`` of each row of ``vectors`` (``(..., 3)`` to ``(..., 3, 3)``)."""
    x, y, z = vectors[..., 0], vectors[..., 1], vectors[..., 2]
    out = np.zeros((*vectors.shape, 3))
    out[..., 0, 1], out[..., 0, 2] = -z, y
    out[..., 1, 0], out[..., 1, 2] = z, -x
    out[..., 2, 0], out[..., 2, 1] = -y, x
    return out


def _double_cross(w: np.ndarray, r: np.ndarray) -> np.ndarray:
    """``w x (w x r)`` of each row of ``w`` (``(N, 3)``) and a fixed ``r`` (``(3,)``):
    ``w (w . r) - r |w|^2``."""
    return w * (w @ r)[:, None] - r * np.einsum("ni,ni->n", w, w)[:, None]


def _inertia_map(w: np.ndarray) -> np.ndarray:
    """``L(w)`` with ``I w = L(w) [Ixx, Iyy, Izz, Ixy, Ixz, Iyz]`` (``(N, 3, 6)``)."""
    x, y, z = w[:, 0], w[:, 1], w[:, 2]
    out = np.zeros((w.shape[0], 3, 6))
    out[:, 0, 0], out[:, 0, 3], out[:, 0, 4] = x, y, z
    out[:, 1, 1], out[:, 1, 3], out[:, 1, 5] = y, x, z
    out[:, 2, 2], out[:, 2, 4], out[:, 2, 5] = z, x, y
    return out


def _axis_rotations(axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """Rotations by ``angles`` (``(N,)``) about the unit ``axis``: Rodrigues' formula."""
    k = _skew(axis)
    s, c = np.sin(angles)[:, None, None], np.cos(angles)[:, None, None]
    return np.eye(3) + s * k + (1.0 - c) * (k @ k)


def _rotated_rows(x: np.ndarray, terms: np.ndarray, w: np.ndarray) -> np.ndarray:
    """``R^T x`` of each row of ``x`` (``(N, ..., 3)``) with ``R = sum_i w_i terms_i``
    (``terms``: ``(3, 3, 3)``; ``w``: ``(N, ..., 3)`` broadcasting with ``x``, ``w_0 = 1``):
    ``x R``, one product with the fixed ``[R_0 | R_1 | R_2]``."""
    y = x @ terms.transpose(1, 0, 2).reshape(3, 9)
    return y[..., :3] + w[..., 1:2] * y[..., 3:6] + w[..., 2:3] * y[..., 6:]


def _row_outward(rho: np.ndarray, terms: np.ndarray, w: np.ndarray, p: np.ndarray) -> np.ndarray:
    """``rho X`` of each row ``rho = [rho_f, rho_n]`` (``(N, K, 6)``), ``X`` the map of a
    wrench ``[f; n]`` of a child frame (about its origin, in it) to its parent's, ``[R f;
    R n + p x R f]`` (``R = sum_i w_i terms_i``, ``w``: ``(N, 3)``; ``p``: ``(N, 3)``, the
    child's origin): ``[(rho_f + rho_n x p) R, rho_n R]``."""
    force, moment = rho[..., :3], rho[..., 3:]
    p = p[:, None, :]
    turned = np.stack(
        [
            moment[..., 1] * p[..., 2] - moment[..., 2] * p[..., 1],
            moment[..., 2] * p[..., 0] - moment[..., 0] * p[..., 2],
            moment[..., 0] * p[..., 1] - moment[..., 1] * p[..., 0],
        ],
        axis=-1,
    )
    both = np.concatenate([turned + force, moment], axis=1)
    rows = rho.shape[1]
    rotated = _rotated_rows(both, terms, w[:, None, :])
    return np.concatenate([rotated[:, :rows], rotated[:, rows:]], axis=2)


def _pose(transform: RigidTransform) -> tuple[np.ndarray, np.ndarray]:
    return transform.rotation().matrix().copy(), transform.translation().copy()


def _states(name: str, value: object, size: int) -> np.ndarray:
    """``value`` as a finite ``(N, size)`` array (a single ``(size,)`` state is one sample)."""
    array = np.atleast_2d(np.asarray(value, dtype=float))
    if array.ndim != 2 or array.shape[1] != size or array.shape[0] == 0:
        raise ValueError(
            f"{name} has shape {np.shape(value)}; (N, {size}) samples (or one ({size},) state) "
            "are required"
        )
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} = {shown(array)} has non-finite entries; finite values required")
    return array


def _motion(size: int, **arrays: object) -> list[np.ndarray]:
    """The named state arrays (``_states``), all with the same number of samples."""
    states = [_states(name, value, size) for name, value in arrays.items()]
    shapes = {name: state.shape for name, state in zip(arrays, states, strict=True)}
    if len(set(shapes.values())) > 1:
        listed = ", ".join(f"{name} {shape}" for name, shape in shapes.items())
        raise ValueError(f"the states have shapes {listed}; the same shape is required")
    return states


def _plant_context(arm: Arm, root_context: Context) -> Context:
    if not isinstance(arm, Arm):
        raise ValueError(f"arm = {arm!r}; a models.plant.Arm (build_arm_diagram) is required")
    try:
        return arm.plant.GetMyContextFromRoot(root_context)
    except (RuntimeError, TypeError):
        raise ValueError(
            f"root_context = {root_context!r}; a root Context of the diagram that holds the "
            f"arm {arm.config.urdf} is required"
        ) from None


def standard_names(links: tuple[str, ...], joints: tuple[str, ...]) -> tuple[str, ...]:
    """The names of ``pi``'s entries: ``<link>.<INERTIAL_PARAMETERS>`` per link, then
    ``<joint>.<DRIVE_PARAMETERS>`` per joint."""
    inertial = [f"{link}.{name}" for link in links for name in INERTIAL_PARAMETERS]
    drive = [f"{joint}.{name}" for joint in joints for name in DRIVE_PARAMETERS]
    return (*inertial, *drive)


@dataclass(frozen=True, eq=False)
class SerialRegressor:
    """The kinematics of a serial revolute arm, read from Drake once (``of_arm``), and its
    regressor ``Y(q, q', q'')`` (module docstring), vectorised over samples.

    Per joint ``j`` (base to tip), with ``P`` the frame of the moving link before it (the
    world for joint 1) and ``B`` the frame of the link it moves: ``parent_rotation`` and
    ``parent_position``, the pose ``X_PF`` of the joint's frame ``F`` in ``P`` (through
    any welded bodies); ``child_rotation`` and ``child_position``, the pose ``X_BM`` of
    its frame ``M`` in ``B``; ``axes``, the joint axis in ``F`` (= ``M``). The joint rotates
    ``M`` relative to ``F`` by ``q_j`` about the axis: ``X_PB = X_PF R(axis, q_j) X_BM^-1``.
    ``gravity`` is the plant's gravity vector in the world (m/s^2); ``lower`` and
    ``upper`` the joint limits (rad, infinite for a continuous joint)."""

    links: tuple[str, ...]
    joints: tuple[str, ...]
    parent_rotation: np.ndarray
    parent_position: np.ndarray
    child_rotation: np.ndarray
    child_position: np.ndarray
    axes: np.ndarray
    gravity: np.ndarray
    lower: np.ndarray
    upper: np.ndarray

    @classmethod
    def of_arm(cls, arm: Arm, root_context: Context) -> SerialRegressor:
        """The regressor of ``arm`` (``models.plant.build_arm_diagram``) with the joint
        frames in ``root_context`` (a Context of the diagram that holds it)."""
        context = _plant_context(arm, root_context)
        plant = arm.plant
        bodies = [plant.GetBodyByName(name) for name in arm.layout.links]
        parent_frames = [plant.world_frame()] + [body.body_frame() for body in bodies[:-1]]
        frames = []
        for name, parent in zip(arm.layout.joints, parent_frames, strict=True):
            joint = plant.GetJointByName(name)
            if not isinstance(joint, RevoluteJoint):
                raise ValueError(
                    f"arm joint {name!r} is a {joint.type_name()} joint; revolute is required"
                )
            X_PF = plant.CalcRelativeTransform(context, parent, joint.frame_on_parent())
            X_BM = joint.frame_on_child().CalcPoseInBodyFrame(context)
            axis = np.asarray(joint.revolute_axis(), dtype=float)
            frames.append(
                (
                    *_pose(X_PF),
                    *_pose(X_BM),
                    axis / np.linalg.norm(axis),
                    float(joint.position_lower_limits()[0]),
                    float(joint.position_upper_limits()[0]),
                )
            )
        R_PF, p_PF, R_BM, p_BM, axes, lower, upper = (
            np.array(x) for x in zip(*frames, strict=True)
        )
        return cls(
            links=tuple(arm.layout.links),
            joints=tuple(arm.layout.joints),
            parent_rotation=R_PF,
            parent_position=p_PF,
            child_rotation=R_BM,
            child_position=p_BM,
            axes=axes,
            gravity=np.asarray(plant.gravity_field().gravity_vector(), dtype=float).copy(),
            lower=lower,
            upper=upper,
        )

    @property
    def size(self) -> int:
        """``n``: the number of joints."""
        return len(self.joints)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """The names of the standard vector's ``13 n`` entries (``standard_names``)."""
        return standard_names(self.links, self.joints)

    def sample_states(
        self, samples: int, seed: int | np.random.Generator = 0
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``samples`` random ``(q, q', q'')``, each ``(samples, n)``: ``q`` uniform over
        each joint's limits (a full turn ``[-pi, pi]`` where a limit is infinite),
        ``q'`` and ``q''`` uniform in ``+-SAMPLE_SPEED`` and ``+-SAMPLE_ACCELERATION``;
        ``seed``: an integer or a numpy Generator."""
        if isinstance(samples, bool) or not isinstance(samples, int | np.integer) or samples < 1:
            raise ValueError(f"samples = {samples!r}; an integer >= 1 is required")
        if isinstance(seed, np.random.Generator):
            rng = seed
        elif isinstance(seed, int | np.integer) and not isinstance(seed, bool) and seed >= 0:
            rng = np.random.default_rng(int(seed))
        else:
            raise ValueError(
                f"seed = {seed!r}; an integer >= 0 or a numpy.random.Generator is required"
            )
        bounded = np.isfinite(self.lower) & np.isfinite(self.upper)
        low = np.where(bounded, self.lower, -np.pi)
        high = np.where(bounded, self.upper, np.pi)
        shape = (int(samples), self.size)
        q = rng.uniform(low, high, size=shape)
        v = rng.uniform(-SAMPLE_SPEED, SAMPLE_SPEED, size=shape)
        a = rng.uniform(-SAMPLE_ACCELERATION, SAMPLE_ACCELERATION, size=shape)
        return q, v, a

    @functools.cached_property
    def _joint_terms(self) -> tuple[np.ndarray, np.ndarray]:
        """Per joint ``j``, ``X_PB(q_j)`` in Rodrigues' terms (``R(axis, q) = E + sin q K
        + (1 - cos q) K^2``): ``rotations[j]`` stacks ``R_PF K^i R_BM^T`` (``(3, 3, 3)``,
        ``i = 0, 1, 2``) and ``offsets[j]`` ``R_PF K^i (-R_BM^T p_BM)`` (``(3, 3)``), so
        ``R_PB = sum_i w_i R_i`` and ``p_PB = p_PF + sum_i w_i p_i`` with ``w = (1,
        sin q, 1 - cos q)``."""
        rotations, offsets = [], []
        for j in range(self.size):
            K = _skew(self.axes[j])
            powers = np.stack([np.eye(3), K, K @ K])
            rotations.append(self.parent_rotation[j] @ powers @ self.child_rotation[j].T)
            back = -self.child_rotation[j].T @ self.child_position[j]
            offsets.append(self.parent_rotation[j] @ powers @ back)
        return np.stack(rotations), np.stack(offsets)

    def inertial_columns(self, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        """``Y`` of the links, ``(N, n, 10 n)``: ``tau = Y @ pi_links`` is the torque
        ``M_links(q) q'' + c(q, q') - tau_g(q)`` (Drake's inverse dynamics without rotor
        inertia and friction, N m) for the ``(N, n)`` states ``q, v = q', a = q''``.

        Outward, per joint, the link's velocity, angular acceleration and origin
        acceleration, with ``X_PB`` in Rodrigues' terms (``_joint_terms``: products with
        fixed matrices, not one 3 x 3 product per sample) and a cross product with a fixed
        vector ``p`` as the product with ``[p]x`` from the right (``w x p = w @ [p]x``).
        Then joint ``k``'s torque from link ``i >= k``'s wrench block (``_link_block``,
        about B_i's origin, in B_i) is ``rho_ki @ block_i``: ``rho_kk = c_k = [z x r; z]``
        (``z`` the axis, ``r`` from the joint's point to the link's origin: the moment
        about the axis, ``z . (n + r x f)``) and ``rho_ki = rho_k,i-1 X_i``, with ``X_i``
        carrying a wrench of B_i to B_i-1 (``_row_outward``): the rows of joints
        ``1 .. i`` are carried outward together, a row of 6 per joint and sample rather
        than a 6 x 10 block per link carried inward."""
        n = self.size
        q, v, a = _motion(n, q=q, v=v, a=a)
        samples = q.shape[0]
        rotations, offsets = self._joint_terms
        omega = np.zeros((samples, 3))
        omega_dot = np.zeros((samples, 3))
        accel = np.broadcast_to(-self.gravity, (samples, 3)).copy()
        weights, placements, blocks = [], [], []
        for j in range(n):
            w = np.stack([np.ones(samples), np.sin(q[:, j]), 1.0 - np.cos(q[:, j])], axis=1)

            def into_b(x: np.ndarray, j: int = j, w: np.ndarray = w) -> np.ndarray:
                """``R_PB^T x`` of each row ``x`` (a vector of P, in B)."""
                return _rotated_rows(x, rotations[j], w)

            p_PF = self.parent_position[j]
            z = self.child_rotation[j] @ self.axes[j]  # the axis in B
            r = -self.child_position[j]  # from the joint's point to B's origin, in B
            # Acceleration of the joint's point (fixed in P and in B), in P:
            joint_accel = accel + omega_dot @ _skew(p_PF) + _double_cross(omega, p_PF)
            inherited = into_b(omega)
            omega = inherited + z * v[:, j : j + 1]
            omega_dot = (
                into_b(omega_dot) + z * a[:, j : j + 1] + (inherited @ _skew(z)) * v[:, j : j + 1]
            )
            accel = into_b(joint_accel) + omega_dot @ _skew(r) + _double_cross(omega, r)
            weights.append(w)
            placements.append(p_PF + w @ offsets[j])
            blocks.append(self._link_block(omega, omega_dot, accel))
        Y = np.zeros((samples, n, 10 * n))
        rho = np.zeros((samples, 0, 6))
        for i in range(n):
            if i > 0:
                rho = _row_outward(rho, rotations[i], weights[i], placements[i])
            z = self.child_rotation[i] @ self.axes[i]
            own = np.concatenate([np.cross(z, -self.child_position[i]), z])
            rho = np.concatenate([rho, np.broadcast_to(own, (samples, 1, 6))], axis=1)
            Y[:, : i + 1, 10 * i : 10 * i + 10] = rho @ blocks[i]
        return Y

    @staticmethod
    def _link_block(omega: np.ndarray, omega_dot: np.ndarray, accel: np.ndarray) -> np.ndarray:
        """The ``(N, 6, 10)`` matrix of a link's wrench ``[f; n]`` about its origin, in its
        frame, in ``[m, h, I]`` (Atkeson et al. 1986): ``f = m a + ([w']x + [w]x^2) h``,
        ``n = L(w') I + [w]x L(w) I + h x a``."""
        samples = omega.shape[0]
        block = np.zeros((samples, 6, 10))
        w = _skew(omega)
        block[:, :3, 0] = accel
        block[:, :3, 1:4] = _skew(omega_dot) + omega[:, :, None] * omega[:, None, :]
        block[:, :3, 1:4] -= np.einsum("ni,ni->n", omega, omega)[:, None, None] * np.eye(3)
        block[:, 3:, 1:4] = -_skew(accel)
        block[:, 3:, 4:] = _inertia_map(omega_dot) + w @ _inertia_map(omega)
        return block

    def drive_columns(self, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        """``Y`` of the drives, ``(N, n, 3 n)``: joint ``j``'s row has ``q''_j``, ``q'_j``
        and ``sgn(q'_j)`` in the columns of its rotor inertia, damping and Coulomb level."""
        n = self.size
        v, a = _motion(n, v=v, a=a)
        Y = np.zeros((v.shape[0], n, 3 * n))
        for j in range(n):
            Y[:, j, 3 * j] = a[:, j]
            Y[:, j, 3 * j + 1] = v[:, j]
            Y[:, j, 3 * j + 2] = np.sign(v[:, j])
        return Y

    def torque_columns(self, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        """The full regressor ``(N, n, 13 n)``: ``kappa_j u_j = Y[:, j] @ pi`` with ``pi``
        the standard vector (``parameter_names``; ``true_parameters``)."""
        return np.concatenate([self.inertial_columns(q, v, a), self.drive_columns(v, a)], axis=2)


def true_parameters(arm: Arm, root_context: Context) -> np.ndarray:
    """The standard vector ``pi`` (``13 n``, module docstring) of ``arm`` with the
    parameters in ``root_context``: each link's spatial inertia and those of the bodies
    welded to it, about and in the link frame (Drake), then the reflected rotor inertia,
    damping and Coulomb level of each joint (``models.plant.read_parameters``)."""
    context = _plant_context(arm, root_context)
    plant = arm.plant
    inertial = []
    for name in arm.layout.links:
        link = plant.GetBodyByName(name)
        mass, first, inertia = 0.0, np.zeros(3), np.zeros((3, 3))
        for body in plant.GetBodiesWeldedTo(link):
            R_LB, p_LB = _pose(
                plant.CalcRelativeTransform(context, link.body_frame(), body.body_frame())
            )
            spatial = body.CalcSpatialInertiaInBodyFrame(context)
            m = float(spatial.get_mass())
            com_B = np.asarray(spatial.get_com(), dtype=float)
            about_origin = spatial.CalcRotationalInertia().CopyToFullMatrix3()
            central = about_origin - m * (com_B @ com_B * np.eye(3) - np.outer(com_B, com_B))
            com_L = p_LB + R_LB @ com_B
            mass += m
            first += m * com_L
            inertia += R_LB @ central @ R_LB.T + m * (
                com_L @ com_L * np.eye(3) - np.outer(com_L, com_L)
            )
        inertial.append(
            [mass, *first, inertia[0, 0], inertia[1, 1], inertia[2, 2],
             inertia[0, 1], inertia[0, 2], inertia[1, 2]]
        )  # fmt: skip
    drive = read_parameters(arm, root_context)
    drives = np.column_stack([drive.rotor_inertia, drive.damping, drive.coulomb])
    return np.concatenate([np.ravel(inertial), drives.ravel()])


@dataclass(frozen=True, eq=False)
class BaseParameters:
    """The base parameters ``beta = K pi`` of a regressor (``base_parameters``).

    ``independent``: the indices (into ``pi``, ``standard_names``) of the standard
    parameters whose columns span the regressor; ``K`` (``(p_base, p_full)``): the map
    with ``Y pi = Y[..., independent] K pi`` for every state, so ``K[:, independent]``
    is the identity and each other column says how that parameter regroups into the
    base ones (a zero column: a parameter that changes no torque). ``names``: each base
    parameter's name (its independent parameter's), ``descriptions``: the combination
    it stands for, e.g. ``"link2.Izz + 0.0625 link3.m"``. ``links`` and ``joints``: the
    arm's names, base to tip; ``tolerance``: the one ``base_parameters`` used."""

    independent: tuple[int, ...]
    K: np.ndarray
    names: tuple[str, ...]
    descriptions: tuple[str, ...]
    standard_names: tuple[str, ...]
    links: tuple[str, ...]
    joints: tuple[str, ...]
    tolerance: float

    @property
    def size(self) -> int:
        """``p_base``: the number of base parameters."""
        return len(self.independent)

    def columns(self, Y_full: np.ndarray) -> np.ndarray:
        """``Y_base``: the independent columns of a full regressor (``(..., 13 n)``)."""
        Y = np.asarray(Y_full, dtype=float)
        if Y.ndim < 1 or Y.shape[-1] != len(self.standard_names):
            raise ValueError(
                f"Y_full has shape {Y.shape}; a last axis of {len(self.standard_names)} (one "
                "column per standard parameter) is required"
            )
        return Y[..., list(self.independent)]

    def combine(self, standard: np.ndarray) -> np.ndarray:
        """``beta = K pi`` of a standard vector ``pi`` (``true_parameters``)."""
        pi = np.asarray(standard, dtype=float)
        if pi.shape != (len(self.standard_names),):
            raise ValueError(
                f"standard has shape {pi.shape}; ({len(self.standard_names)},) (one entry per "
                "standard parameter) is required"
            )
        return self.K @ pi


def _description(row: np.ndarray, names: tuple[str, ...], pivot: int) -> str:
    terms = [names[pivot]]
    for index in np.flatnonzero(row):
        if index == pivot:
            continue
        value = float(row[index])
        sign = "-" if value < 0.0 else "+"
        magnitude = f"{abs(value):.6g}"
        terms.append(f"{sign} {names[index]}" if magnitude == "1" else
                     f"{sign} {magnitude} {names[index]}")  # fmt: skip
    return " ".join(terms)


def base_parameters(
    regressor: SerialRegressor,
    samples: int = 200,
    seed: int | np.random.Generator = 0,
    tolerance: float = BASE_TOLERANCE,
) -> BaseParameters:
    """The base parameters of ``regressor``'s full torque regressor (Gautier 1990).

    ``W`` stacks ``torque_columns`` at ``samples`` random states
    (``SerialRegressor.sample_states(samples, seed)``; ``samples * n`` rows), each column
    scaled to unit norm (a zero column changes no torque). Its rank ``r`` is the number of
    diagonal entries of ``R`` in a QR decomposition with column pivoting
    (``scipy.linalg.qr(pivoting=True)``) with ``|R_kk| > tolerance * |R_00|``. The
    independent columns are chosen in ``pi``'s order, as Gautier does: a column is kept
    where its ``|R_kk|`` in the QR decomposition without pivoting (its distance from the
    span of the columns before it) exceeds ``tolerance`` times the largest, so a link's
    parameters are kept and the later links' (and the drives') regroup into them. Both
    counts must agree. The dependent columns are then ``W_d = W_i K_d`` (least squares;
    entries of ``K_d`` below ``tolerance`` in the normalised columns are round-off of an
    exact relation and set to 0). ``tolerance``: in ``(0, 1)``; the default ``1e-8``
    lies far from both sides: on the shipped and generated arms, 50 to 200 random states
    give ``|R_kk|`` below 1e-15 for the dependent columns and above 0.4 (relative) for
    the independent ones."""
    if not isinstance(regressor, SerialRegressor):
        raise ValueError(f"regressor = {regressor!r}; a SerialRegressor is required")
    if not (isinstance(tolerance, float | int) and 0.0 < tolerance < 1.0):
        raise ValueError(f"tolerance = {tolerance!r}; a number in (0, 1) is required")
    q, v, a = regressor.sample_states(samples, seed)
    W = regressor.torque_columns(q, v, a).reshape(-1, 13 * regressor.size)
    names = regressor.parameter_names
    scale = np.linalg.norm(W, axis=0)
    live = np.flatnonzero(scale > tolerance * scale.max())
    unit = W[:, live] / scale[live]
    pivoted = np.abs(np.diag(scipy.linalg.qr(unit, mode="r", pivoting=True)[0]))
    rank = int(np.count_nonzero(pivoted > tolerance * pivoted[0]))
    ordered = np.abs(np.diag(scipy.linalg.qr(unit, mode="r")[0]))
    kept = np.flatnonzero(ordered > tolerance * ordered.max())
    if kept.size != rank:
        raise ValueError(
            f"tolerance = {tolerance!r} finds rank {rank} with pivoting and {kept.size} "
            f"columns in order among {samples} samples; more samples or another tolerance "
            "is required"
        )
    dropped = np.setdiff1d(np.arange(live.size), kept)
    mapping = np.linalg.lstsq(unit[:, kept], unit[:, dropped], rcond=None)[0]
    mapping[np.abs(mapping) < tolerance] = 0.0
    independent = live[kept]
    K = np.zeros((rank, W.shape[1]))
    K[np.arange(rank), independent] = 1.0
    K[:, live[dropped]] = mapping * scale[live[dropped]] / scale[independent][:, None]
    return BaseParameters(
        independent=tuple(int(i) for i in independent),
        K=K,
        names=tuple(names[i] for i in independent),
        descriptions=tuple(
            _description(K[row], names, int(independent[row])) for row in range(rank)
        ),
        standard_names=names,
        links=regressor.links,
        joints=regressor.joints,
        tolerance=float(tolerance),
    )
