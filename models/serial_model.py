"""The nominal model of Eq. 2 for any serial URDF arm, computed by Drake (issue 13).

Eq. 2 in posfb's units (volts; reading note 9: each joint's equation of motion
divided by its motor constant ``kappa_j``)::

    M*(q) q'' + C*(q, q') q' + G*(q) + B* q' + F*(q') = u

with ``K = diag(kappa)`` and the arm's ``MultibodyPlant`` (rotor inertia
reflected through the gear ratio, as Drake adds it to the mass matrix)::

    M*(q)     = K^-1 M(q)                          CalcMassMatrix
    C*(q, v)v = K^-1 c(q, v)                       CalcBiasTerm (Coriolis, centrifugal)
    G*(q)     = -K^-1 tau_g(q)                     CalcGravityGeneralizedForces
    B*        = K^-1 diag(joint damping)           <dynamics damping>
    F*(v)     = K^-1 diag(f_c) sgn v               <posfb:coulomb_friction>

``M0*``, the constant part the augmented system of Eq. 5-6 uses, is defined for
any arm as the mean of ``M*(q)`` over a full turn of every joint: the constant
term of its Fourier series. For a serial chain of revolute joints every entry of
``M(q)`` is a trigonometric polynomial of degree at most 2 in each joint angle
(products of two rotations: Jacobian columns, rotated link inertias), and it does
not depend on ``q_1``; a uniform grid of ``MEAN_GRID`` angles per joint
``q_2 .. q_n`` averages such a polynomial exactly (``MEAN_GRID >= 3`` suffices: a
uniform grid of ``N`` angles averages every frequency below ``N`` to zero but the
constant; the test compares grids of 3 and 6). The grid is that smallest one: ``3^(n-1)``
evaluations, 243 for six joints (issue 45; the 4 angles used before gave the same ``M0*``
to 1e-14, at four times the cost). For the two-link arm this is Table 1's
``M0* = [[theta1 + theta2, theta2], [theta7, theta7 + theta9]]``: its
``M1*(q) = cos q2 [[2 theta3, theta3], [theta8, 0]]`` has mean 0.

The URDF is checked first (``models.urdf_check.check_serial_urdf``): one serial
chain of revolute/continuous joints, each with its motor stage.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from pathlib import Path

import numpy as np
from pydrake.autodiffutils import ExtractGradient, InitializeAutoDiff
from pydrake.multibody.parsing import Parser
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import Context

from posfb.models.description import Description, prepare_urdf
from posfb.models.urdf_check import add_urdf_models, check_serial_urdf, weld_base

#: Angles per joint of the grid that averages ``M*(q)`` into ``M0*`` (module docstring).
MEAN_GRID = 3


class SerialArmModel:
    """``M*, C*, G*, B*, F*`` and ``M0*`` of a serial URDF arm (module docstring).

    ``joints`` lists the arm joints from the base to the tip; vectors are in that
    order. One ``MultibodyPlant`` and Context per model: not for concurrent use.
    ``of_plant`` gives the model of a plant already built, with the parameters of a
    given Context (a sampled plant)."""

    def __init__(self, urdf: str | Path, description: Description | None = None) -> None:
        chain = check_serial_urdf(Path(urdf), description)
        plant = MultibodyPlant(time_step=0.0)
        add_urdf_models(Parser(plant), prepare_urdf(Path(urdf), description))
        weld_base(plant, chain.base)
        plant.Finalize()
        self._setup(
            plant, plant.CreateDefaultContext(), chain.joints, chain.motor_constant, chain.coulomb
        )

    @classmethod
    def of_plant(
        cls,
        plant: MultibodyPlant,
        context: Context,
        joints: Sequence[str],
        motor_constant: Sequence[float],
        coulomb: Sequence[float],
    ) -> SerialArmModel:
        """The model of ``plant`` with the parameters in its ``context`` (which the model
        then owns and changes: pass a copy), the arm ``joints`` and their motor stages
        (motor constants in N m/V, Coulomb levels in N m)."""
        model = cls.__new__(cls)
        model._setup(plant, context, tuple(joints), motor_constant, coulomb)
        return model

    def _setup(
        self,
        plant: MultibodyPlant,
        context: Context,
        joints: tuple[str, ...],
        motor_constant: Sequence[float],
        coulomb: Sequence[float],
    ) -> None:
        self.joints = joints
        self.size = len(joints)
        self._plant, self._context = plant, context
        # Position and velocity index of each arm joint (Drake orders them its own way).
        self._q_index = [plant.GetJointByName(j).position_start() for j in joints]
        self._v_index = [plant.GetJointByName(j).velocity_start() for j in joints]
        kappa = np.array(motor_constant, dtype=float)
        self.motor_constant = kappa
        self._scale = 1.0 / kappa
        damping = np.array([plant.GetJointByName(j).GetDamping(context) for j in joints])
        self._B = np.diag(damping * self._scale)
        self._coulomb = np.array(coulomb, dtype=float) * self._scale
        self._M0: np.ndarray | None = None
        self._autodiff: tuple[MultibodyPlant, Context] | None = None

    @property
    def plant(self) -> MultibodyPlant:
        """The arm's plant (its parameters are ``context``'s)."""
        return self._plant

    @property
    def context(self) -> Context:
        """The Context holding the model's parameters (its state is scratch: every call
        sets it)."""
        return self._context

    def _set_state(self, q: np.ndarray, v: np.ndarray | None = None) -> None:
        positions = np.zeros(self._plant.num_positions())
        positions[self._q_index] = q
        self._plant.SetPositions(self._context, positions)
        velocities = np.zeros(self._plant.num_velocities())
        if v is not None:
            velocities[self._v_index] = v
        self._plant.SetVelocities(self._context, velocities)

    def M(self, q: np.ndarray) -> np.ndarray:
        """``M*(q)`` (V s^2/rad), row ``j`` divided by ``kappa_j``."""
        self._set_state(np.asarray(q, dtype=float))
        mass = self._plant.CalcMassMatrix(self._context)
        return self._scale[:, None] * mass[np.ix_(self._v_index, self._v_index)]

    def coriolis(self, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
        """``C*(q, q') q'`` (V)."""
        self._set_state(np.asarray(q, dtype=float), np.asarray(qdot, dtype=float))
        return self._scale * self._plant.CalcBiasTerm(self._context)[self._v_index]

    def G(self, q: np.ndarray) -> np.ndarray:
        """``G*(q)`` (V); Drake returns the generalized force *of* gravity, its negative."""
        self._set_state(np.asarray(q, dtype=float))
        force = self._plant.CalcGravityGeneralizedForces(self._context)
        return -self._scale * force[self._v_index]

    def B(self) -> np.ndarray:
        """``B*`` (V s/rad)."""
        return self._B.copy()

    def coulomb_levels(self) -> np.ndarray:
        """The Coulomb levels of ``F*`` (V)."""
        return self._coulomb.copy()

    def F(self, qdot: np.ndarray) -> np.ndarray:
        """``F*(q') = diag(f_c*) sgn q'`` (V)."""
        return self._coulomb * np.sign(qdot)

    def M0(self) -> np.ndarray:
        """``M0*``: the mean of ``M*(q)`` over a full turn of every joint (computed once)."""
        if self._M0 is None:
            self._M0 = self.mean_mass_matrix(MEAN_GRID)
        return self._M0.copy()

    def mean_mass_matrix(self, grid: int) -> np.ndarray:
        """The mean of ``M*(q)`` over ``grid`` equally spaced angles of each joint
        ``q_2 .. q_n`` (``q_1`` does not change ``M``)."""
        if grid < 1:
            raise ValueError(f"grid = {grid!r}; at least 1 angle per joint is required")
        angles = 2.0 * np.pi * np.arange(grid) / grid
        total = np.zeros((self.size, self.size))
        points = itertools.product(angles, repeat=self.size - 1)
        count = 0
        for rest in points:
            total += self.M(np.array([0.0, *rest]))
            count += 1
        return total / count

    def mass_matrix_derivatives(self, q: np.ndarray) -> np.ndarray:
        """``dM*/dq`` at ``q``: ``[i, j, k] = d M*_ij / d q_k``, exact (Drake's AutoDiffXd
        plant)."""
        if self._autodiff is None:
            plant = self._plant.ToAutoDiffXd()
            context = plant.CreateDefaultContext()
            context.SetTimeStateAndParametersFrom(self._context)
            self._autodiff = (plant, context)
        plant, context = self._autodiff
        positions = np.zeros(plant.num_positions())
        positions[self._q_index] = q
        seeded = InitializeAutoDiff(positions)
        plant.SetPositions(context, seeded)
        mass = plant.CalcMassMatrix(context)[np.ix_(self._v_index, self._v_index)]
        size = len(mass)  # ExtractGradient's rows are the entries in column-major order
        gradient = ExtractGradient(mass)[:, self._q_index].reshape(size, size, -1)
        return self._scale[:, None, None] * gradient.transpose(1, 0, 2)

    def christoffel(self, q: np.ndarray) -> np.ndarray:
        """``[i, j, k] = c_ijk / kappa_i`` with the Christoffel symbols of the physical
        ``M``, ``c_ijk = (dM_ij/dq_k + dM_ik/dq_j - dM_jk/dq_i) / 2``."""
        physical = (
            self.mass_matrix_derivatives(np.asarray(q, dtype=float))
            * (self.motor_constant[:, None, None])
        )
        symbols = 0.5 * (physical + physical.transpose(0, 2, 1) - physical.transpose(2, 1, 0))
        return self._scale[:, None, None] * symbols

    def C(self, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
        """The Coriolis/centrifugal matrix ``C*(q, q') = christoffel(q) q'`` (Christoffel
        form; ``C*(q, q') q'`` is ``coriolis``; for the two-link arm it is Table 1's ``C*``)."""
        return self.christoffel(q) @ np.asarray(qdot, dtype=float)

    def inverse_dynamics(
        self, q: np.ndarray, qdot: np.ndarray, qddot: np.ndarray, friction: bool = True
    ) -> np.ndarray:
        """The voltage of Eq. 2 for ``(q, q', q'')``; ``friction``: include ``F*``."""
        u = self.M(q) @ qddot + self.coriolis(q, qdot) + self.G(q) + self.B() @ qdot
        return u + self.F(qdot) if friction else u
