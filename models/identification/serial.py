"""Any serial URDF arm identified from a log of positions and voltages (issue 29).

The voltage equation of joint ``j`` (``models.serial_model``, Eq. 2 times ``kappa_j``)::

    kappa_j u_j = Y_j(q, q', q'') pi = Y_b,j(q, q', q'') beta

with ``pi`` the links' standard inertial parameters and each joint's reflected rotor
inertia, viscous and Coulomb friction (``serial_regressor``), ``beta = K pi`` their base
(identifiable) combinations. The voltages scale every parameter together, so one
scale must come from outside the log: joint 1's **motor constant** ``kappa_1`` is the
nominal URDF's (a datasheet's torque constant times the gear ratio). Every other
joint's is identified as its ratio ``s_j = kappa_j / kappa_j,nominal``: the links'
parameters are shared between the joints' equations, so a motor constant that is off
shows as a misfit no shared ``beta`` can explain (measured on a 4-link arm with motor
constants 8-12 % off: with the nominal ones the base parameters were 7-80 standard
errors off and Lin+LC on the model no better than on the unperturbed URDF on a joint).
The equations ``Y_b,1 beta = kappa_1 u_1`` and ``Y_b,j beta - s_j kappa_j,nom u_j = 0``
(``j >= 2``) are linear in ``(beta, s_2 .. s_n)``; ``estimate.fit_log`` solves them with
the voltage columns filtered as the others.
The physically consistent standard parameters closest to ``beta`` (in its standard
errors, regularised towards the nominal URDF: ``consistent.fit_consistent``) are what
``write_urdf`` writes and the controllers then use. First moments and inertias beyond
what the description's links allow are flagged by name (``plausible``).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from posfb.models.description import Description
from posfb.models.identification.checks import IDENTIFIABLE_RELATIVE_STD, estimate_warnings
from posfb.models.identification.consistent import ConsistentModel, fit_consistent
from posfb.models.identification.estimate import Estimate, FilterSettings, Reference, fit_log
from posfb.models.identification.plausible import implausible, standard_bounds
from posfb.models.identification.serial_regressor import (
    BaseParameters,
    SerialRegressor,
    base_parameters,
    true_parameters,
)
from posfb.models.plant import Arm, read_parameters


@dataclass(frozen=True)
class SerialModel:
    """A serial arm's regressor, its base parameters, its motor constants, the nominal
    standard parameters (the prior of the consistent fit) and its ``urdf``."""

    regressor: SerialRegressor
    base: BaseParameters
    motor_constant: np.ndarray
    nominal: np.ndarray
    urdf: str
    description: Description = field(default_factory=Description)

    @classmethod
    def of_arm(
        cls, arm: Arm, root_context, urdf: str, description: Description | None = None
    ) -> SerialModel:
        """The model of ``arm`` (built from ``urdf`` with what ``description``, the
        scenario's, adds to it) with the parameters in ``root_context``."""
        regressor = SerialRegressor.of_arm(arm, root_context)
        return cls(
            urdf=str(urdf),
            description=description or Description(),
            regressor=regressor,
            base=base_parameters(regressor),
            motor_constant=np.asarray(read_parameters(arm, root_context).motor_constant),
            nominal=true_parameters(arm, root_context),
        )

    def columns(self, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        """The base regressor ``Y_b(q, q', q'')``, ``(N, n, p_base)``."""
        return self.base.columns(self.regressor.torque_columns(q, v, a))

    def torque(self, voltage: np.ndarray) -> np.ndarray:
        """``kappa u``: the joint torques of the voltages ``(N, n)`` (nominal motor
        constants)."""
        return voltage * self.motor_constant

    def reference_torque(self, voltage: np.ndarray) -> np.ndarray:
        """The fit's target: joint 1's torque ``kappa_1 u_1``, 0 for the other joints."""
        y = np.zeros_like(voltage)
        y[:, 0] = self.motor_constant[0] * voltage[:, 0]
        return y

    def ratio_columns(self, voltage: np.ndarray) -> np.ndarray:
        """The columns of ``s_2 .. s_n``: ``-kappa_j,nom u_j`` in joint ``j``'s row."""
        samples, joints = voltage.shape
        columns = np.zeros((samples, joints, joints - 1))
        for j in range(1, joints):
            columns[:, j, j - 1] = -self.motor_constant[j] * voltage[:, j]
        return columns

    def fit_columns(self, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        """The columns ``identify`` fits on a log with the controller's reference, for a
        motion the nominal arm makes: the base regressor, then the ratio columns of the
        nominal voltage ``(N, n, p_base + n - 1)`` (what ``identify plan`` conditions)."""
        return np.concatenate(
            [self.columns(q, v, a), self.ratio_columns(self.voltage(q, v, a))], axis=2
        )

    def ratio_names(self) -> tuple[str, ...]:
        return tuple(f"{joint}.motor_constant_ratio" for joint in self.regressor.joints[1:])

    def voltage(self, q: np.ndarray, v: np.ndarray, a: np.ndarray) -> np.ndarray:
        """The nominal arm's voltage for a motion (``(N, n)``, vectorised)."""
        return (self.regressor.torque_columns(q, v, a) @ self.nominal) / self.motor_constant

    def coulomb(self) -> dict[int, int]:
        """Base-parameter index -> joint, for each joint's Coulomb level."""
        found = {}
        for j, joint in enumerate(self.regressor.joints):
            name = f"{joint}.coulomb"
            if name in self.base.names:
                found[self.base.names.index(name)] = j
        return found


@dataclass(frozen=True)
class SerialIdentification:
    """The estimate (the base parameters, then the motor-constant ratios of joints
    2..n where fitted), the consistent model, the identified motor constants, the
    warnings and the joints whose motor constants are kept as ``declared``."""

    model: SerialModel
    estimate: Estimate
    consistent: ConsistentModel
    motor_constant: np.ndarray
    warnings: tuple[str, ...]
    declared: tuple[str, ...] = ()

    @property
    def model_values(self) -> np.ndarray:
        """The consistent arm's base parameters, then the ratios the model takes (1 for
        the joints in ``declared``: their motor constants are the description's)."""
        if self.estimate.values.size == self.model.base.size:  # no ratios fitted
            return self.consistent.beta
        ratios = self.motor_constant[1:] / self.model.motor_constant[1:]
        return np.concatenate([self.consistent.beta, ratios])

    def torque(self, voltage: np.ndarray) -> np.ndarray:
        """``kappa u`` with the identified motor constants."""
        return voltage * self.motor_constant


def _identified_ratios(estimate: Estimate, size: int) -> tuple[np.ndarray, list[str]]:
    """The motor-constant ratios the model takes: the estimate's where identifiable
    (relative standard error at most ``IDENTIFIABLE_RELATIVE_STD``), else 1 (the declared
    constant), and the names of the joints kept so. An identifiable ratio that is not
    positive is refused: the log's voltages are not this arm's in volts."""
    values, relative = estimate.values[size:], estimate.relative_std[size:]
    names = [name.removesuffix(".motor_constant_ratio") for name in estimate.names[size:]]
    identified = relative <= IDENTIFIABLE_RELATIVE_STD
    if np.any(identified & (values <= 0.0)):
        raise ValueError(
            f"the log gives motor-constant ratios {np.round(values, 4).tolist()} for joints "
            f"{', '.join(names)} (relative to joint 1's nominal one), with standard errors "
            f"{np.round(estimate.std[size:], 4).tolist()} at the filters' cutoff "
            f"{estimate.cutoff_words}; positive ones are "
            "required: a log of this arm, its voltages in volts, is required"
        )
    kept = [name for name, ok in zip(names, identified, strict=True) if not ok]
    return np.where(identified, values, 1.0), kept


def identify_serial(
    model: SerialModel,
    time: np.ndarray,
    q_measured: np.ndarray,
    voltage: np.ndarray,
    *,
    quantisation_step: np.ndarray | None = None,
    settings: FilterSettings | None = None,
    reference: Reference | None = None,
) -> SerialIdentification:
    """The base parameters of ``model``'s arm from a log (module docstring); with the
    controller's ``reference``, by instrumental variables and with the motor-constant
    ratios, else by least squares with the declared motor constants."""
    settings = (settings or FilterSettings()).with_rule(
        time, q_measured, reference, quantisation_step
    )
    fit_ratios = reference is not None
    if reference is not None:
        reference = replace(
            reference, voltage=model.voltage(reference.q, reference.qdot, reference.qddot)
        )

    def fit(q: np.ndarray) -> Estimate:
        return fit_log(
            time, q, voltage, model.columns,
            (*model.base.names, *(model.ratio_names() if fit_ratios else ())),
            coulomb=model.coulomb(), target=model.reference_torque if fit_ratios else model.torque,
            voltage_columns=model.ratio_columns if fit_ratios else None, settings=settings,
            reference=reference,
        )  # fmt: skip

    estimate = fit(q_measured)
    warnings = estimate_warnings(
        estimate, None if fit_ratios else fit, q_measured, quantisation_step
    )
    if not fit_ratios:
        warnings.append(
            "motor constants kept as declared: the log has no reference (q<j>_desired_rad), "
            "so the ratios of joints 2.. to joint 1's cannot be fitted without the encoder's "
            "bias; a log with the controller's reference fits them"
        )
    size = model.base.size
    ratios, kept = np.ones(len(model.regressor.joints) - 1), []
    if fit_ratios:
        ratios, kept = _identified_ratios(estimate, size)
        if kept:
            warnings.append(
                f"motor constants of {', '.join(kept)} kept as declared: their ratios are "
                "not identifiable from this log (above)"
            )
    motor_constant = model.motor_constant * np.concatenate([[1.0], ratios])
    consistent = fit_consistent(
        model.base, estimate.values[:size], estimate.covariance[:size, :size], model.nominal
    )
    if not consistent.converged:
        warnings.append("the consistent fit did not converge; its model is the last iterate")
    misfit = np.abs(consistent.standard_errors)
    if np.any(misfit > 3.0):
        worst = int(np.argmax(misfit))
        warnings.append(
            f"no physically consistent arm matches the estimate within 3 standard errors: "
            f"{estimate.names[worst]} is {misfit[worst]:.1f} away (the model written is the "
            "closest consistent one)"
        )
    warnings += implausible(
        model.base, standard_bounds(model.regressor, model.nominal), estimate.values[:size],
        estimate.std[:size], consistent.standard,
    )  # fmt: skip
    declared = tuple(model.regressor.joints[1:]) if not fit_ratios else tuple(kept)
    return SerialIdentification(
        model, estimate, consistent, motor_constant, tuple(warnings), declared
    )
