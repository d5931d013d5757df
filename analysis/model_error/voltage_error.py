"""The size of a model error in the quantity the controllers feel: the voltage the model
predicts along the experiment's desired trajectory.

For a model ``theta_m`` of an arm whose true theta is ``theta`` (Eq. 4, both in volts),
joint ``j``'s error along the desired path ``q_d(kT_s)``, ``k = 0 .. N-1``, is

    e_j = RMS_k( Y_j(q_d, qdot_d, qddot_d) (theta_m - theta) ) / RMS_k( Y_j(...) theta )

(``Y`` of ``models.identification.theta_regressor``): 0 for an exact model, 0.1 for a
model whose voltage is off by a tenth of the voltage the path needs. One number per
joint that weighs every theta by how much the experiment uses it (theta_9, 2e-5 V s^2,
counts for nothing; theta_1, most of joint 1's inertia, counts a lot).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from posfb.models.identification.theta_regressor import theta_regressor


@dataclass(frozen=True)
class DesiredPath:
    """The regressor of Eq. 4 along an experiment's desired trajectory, ``(N, 2, 11)``."""

    regressor: np.ndarray

    @classmethod
    def of_trajectory(
        cls, trajectory: object, sample_time: float, samples: int, l1: float, g: float
    ) -> DesiredPath:
        """``trajectory`` (``models.trajectory.Trajectory``) at ``k T_s``."""
        values = [trajectory.evaluate(k * sample_time) for k in range(samples)]
        q, v, a = (np.array([value[i] for value in values], dtype=float) for i in range(3))
        return cls(theta_regressor(q, v, a, l1, g))

    def voltage_error(self, model: np.ndarray, truth: np.ndarray) -> np.ndarray:
        """``e_j`` per joint (module docstring) of ``model`` against ``truth``; rows of
        several models or truths give one row each."""
        model, truth = np.atleast_2d(model), np.atleast_2d(truth)
        error = np.einsum("njp,mp->mnj", self.regressor, model - truth)
        voltage = np.einsum("njp,mp->mnj", self.regressor, truth)
        rms = lambda x: np.sqrt(np.mean(x**2, axis=1))  # noqa: E731
        return rms(error) / rms(voltage)
