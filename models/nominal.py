"""The nominal model the controllers are designed from: one of two forms (issue 13).

* ``LumpedParameters``: the paper's two-link theta model of Table 1
  (``models.lumped``, closed forms; the paper's results are computed with it);
* ``UrdfNominal``: any serial revolute arm, its ``M*, C*, G*, B*, F*`` and ``M0*``
  computed by Drake from a *nominal* URDF (``models.serial_model``).

Everything downstream (design, controllers, bounds) asks this module for the
joint count and for a model object with ``M0()``, ``M(q)``, ``B()``, ``G(q)``,
``coriolis(q, v)``, ``coulomb_levels()`` and ``inverse_dynamics``.
"""

from __future__ import annotations

import threading
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from posfb.models.description import Description
from posfb.models.lumped import LumpedModel, LumpedParameters
from posfb.models.serial_model import SerialArmModel
from posfb.models.urdf_check import check_serial_urdf

if TYPE_CHECKING:
    from posfb.models.trajectory import Trajectory

#: Joints of the paper's lumped model.
LUMPED_JOINTS = 2


@dataclass(frozen=True)
class UrdfNominal:
    """A nominal model computed by Drake from the serial URDF arm at ``urdf``.

    ``joints`` (filled in from the file, validated on construction) is its joint
    count; the file is checked by ``models.urdf_check.check_serial_urdf`` with what
    ``description`` (the scenario's, ``models.description``) adds."""

    urdf: str
    description: Description = field(default_factory=Description)

    def __post_init__(self) -> None:
        chain = check_serial_urdf(Path(self.urdf), self.description)
        object.__setattr__(self, "_joints", len(chain.joints))

    @property
    def joints(self) -> int:
        return self._joints  # type: ignore[attr-defined]


NominalModel = LumpedParameters | UrdfNominal


def joint_count(nominal: NominalModel) -> int:
    """The number of joints of ``nominal``."""
    if isinstance(nominal, UrdfNominal):
        return nominal.joints
    return LUMPED_JOINTS


#: Each thread's ``SerialArmModel`` per nominal URDF (a model holds a Context, so
#: threads, e.g. a Dask worker's, must not share one).
_thread_models = threading.local()


def nominal_model(nominal: NominalModel) -> LumpedModel | SerialArmModel:
    """The model object of ``nominal``. A ``UrdfNominal``'s ``SerialArmModel`` is built
    once per file and thread, and reused."""
    if not isinstance(nominal, UrdfNominal):
        return LumpedModel(nominal)
    models = _thread_models.__dict__.setdefault("by_urdf", {})
    key = (nominal.urdf, nominal.description)
    if key not in models:
        models[key] = SerialArmModel(nominal.urdf, nominal.description)
    return models[key]


class LinearPart:
    """The nominal linear part of ``model`` (Eq. 2 with ``h = 0``): ``M*(q) = M0*`` and
    ``B*`` kept, ``C*``, ``G*`` and ``F*`` zero; the model a controller's law is
    linearised on (``models.controllers.linearise``)."""

    def __init__(self, model: LumpedModel | SerialArmModel) -> None:
        self._M0, self._B = model.M0(), model.B()
        self.size = len(self._M0)

    def M0(self) -> np.ndarray:
        """``M0*``."""
        return self._M0.copy()

    def M(self, q: np.ndarray) -> np.ndarray:
        """``M0*`` at every ``q``."""
        return self._M0.copy()

    def coriolis(self, q: np.ndarray, qdot: np.ndarray) -> np.ndarray:
        """0: ``C*`` belongs to ``h``."""
        return np.zeros(self.size)

    def G(self, q: np.ndarray) -> np.ndarray:
        """0: ``G*`` belongs to ``h``."""
        return np.zeros(self.size)

    def B(self) -> np.ndarray:
        """``B*``."""
        return self._B.copy()

    def coulomb_levels(self) -> np.ndarray:
        """0: ``F*`` belongs to ``h``."""
        return np.zeros(self.size)

    def inverse_dynamics(self, q: np.ndarray, qdot: np.ndarray, qddot: np.ndarray) -> np.ndarray:
        """``M0* qddot + B* qdot``."""
        return self._M0 @ np.asarray(qddot, dtype=float) + self._B @ np.asarray(qdot, dtype=float)


def trajectory_voltages(
    model: LumpedModel | SerialArmModel, trajectory: Trajectory, times: Iterable[float]
) -> np.ndarray:
    """The armature voltages (V) ``model`` needs to follow ``trajectory`` exactly: its
    inverse dynamics (Eq. 2, gravity and friction included) at ``(q_d, qdot_d, qddot_d)``
    of each of ``times``, one row per instant."""
    return np.array([model.inverse_dynamics(*trajectory.evaluate(float(t))) for t in times])


def is_nominal_model(value: object) -> bool:
    """Whether ``value`` is one of the two nominal-model forms."""
    return isinstance(value, LumpedParameters | UrdfNominal)
