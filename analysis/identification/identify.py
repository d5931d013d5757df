"""``posfb identify --log``: a model of a scenario's arm from its encoder log, with its
uncertainty, warnings and (given a second log) its validation (issue 29).

The arm is the scenario's: where its nominal model is theta of Sec. 4.1 (``!Table1``,
``!Theta``, ``!IdentifiedFromUrdf``, ``!Identified`` of theta) the log identifies
theta_1..theta_11 of Eq. 4 in volts (``models.identification.theta``) with the nominal
model's ``l1`` and ``g``; where it is a URDF (``!UrdfModel``, ``!Identified`` of a URDF)
the base parameters of that arm in torque units, with its motor constants, and the
closest physically consistent arm (``models.identification.serial``), which ``save``
writes as a URDF beside the model file. The encoder's step for the coarse-encoder check
comes from the log's counts where it gives them, else from the scenario's
``sensor.encoder_counts``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from posfb.analysis.identification.log import EncoderLog, read_log
from posfb.diagrams.loop_config import ClosedLoopConfig
from posfb.diagrams.resolve import LoadedScenario, resolve
from posfb.models.identification.checks import unit_warning
from posfb.models.identification.consistent import write_urdf
from posfb.models.identification.estimate import Estimate, FilterSettings
from posfb.models.identification.model_file import IdentifiedModelFile, save_model
from posfb.models.identification.serial import (
    SerialIdentification,
    SerialModel,
    identify_serial,
)
from posfb.models.identification.theta import ThetaIdentification, identify_theta
from posfb.models.identification.theta_regressor import theta_regressor
from posfb.models.identification.validation import DEFAULT_WINDOW, Validation, validate
from posfb.models.lumped import LumpedParameters


@dataclass(frozen=True)
class Identification:
    """The outcome of ``identify_log``: the scenario, the log, the theta identification
    and, where a second log was given, its ``validation``."""

    scenario: LoadedScenario
    log: EncoderLog
    theta: ThetaIdentification | None = None
    serial: SerialIdentification | None = None
    validation: Validation | None = None
    #: What comparing the log with the scenario's own model says (``unit_warning``).
    checks: tuple[str, ...] = ()

    @property
    def estimate(self) -> Estimate:
        return self.theta.estimate if self.theta is not None else self.serial.estimate

    @property
    def model_values(self) -> np.ndarray:
        """The parameters of the model written: bounded theta, or the consistent arm's
        base parameters."""
        if self.theta is not None:
            return self.theta.model_values
        return self.serial.model_values

    @property
    def warnings(self) -> tuple[str, ...]:
        found = self.theta.warnings if self.theta is not None else self.serial.warnings
        return (*found, *self.checks)

    def as_dict(self) -> dict[str, object]:
        """What ``posfb identify --log ... --json`` prints: for the paper's arm
        ``theta1`` .. ``theta11`` at the top level, for a URDF arm ``parameters``; then
        ``std``, ``model`` (the values the model holds) and the common keys."""
        estimate = self.estimate
        result: dict[str, object] = {}
        if self.theta is not None:
            result.update(estimate.as_dict())
        else:
            result["parameters"] = estimate.as_dict()
        result["std"] = estimate.std_dict()
        result["model"] = {
            name: float(v) for name, v in zip(estimate.names, self.model_values, strict=True)
        }
        result["condition_number"] = estimate.condition_number
        result["cutoff_hz"] = estimate.cutoff_hz
        result["cutoff_rule"] = estimate.cutoff_rule
        result["estimator"] = (
            "least_squares" if self.log.reference is None else "instrumental_variables"
        )
        result["rows"] = list(estimate.rows)
        result["validation"] = (
            None
            if self.validation is None
            else {
                "voltage_nrmse_percent": _listed(self.validation.voltage_nrmse),
                "nominal_voltage_nrmse_percent": _listed(self.validation.nominal_voltage_nrmse),
                "encoder_floor_nrmse_percent": _listed(self.validation.encoder_floor_nrmse),
                "removed_percent": _listed(self.validation.removed_percent),
                "output_nrmse_percent": _listed(self.validation.output_nrmse),
                "window_s": self.validation.window,
            }
        )
        result["warnings"] = list(self.warnings)
        return result

    def save(self, path: str | Path) -> None:
        """Write the model file ``nominal_model: !Identified {file: ...}`` reads (for a
        URDF arm, with the consistent arm's URDF beside it: ``MODEL.urdf``; ``urdf_path``).
        Both are written whole or not at all (``analysis.common.outputs.atomic_file``)."""
        from posfb.analysis.common.outputs import atomic_file

        path = Path(path)
        if self.theta is not None:
            with atomic_file(path) as temporary:
                save_model(self.theta.model_file(self.log.source), temporary)
            return
        urdf = self.urdf_path(path)
        with atomic_file(urdf) as urdf_temporary, atomic_file(path) as temporary:
            write_urdf(
                self.serial.model.urdf, self.serial.consistent, urdf_temporary,
                motor_constant=self.serial.motor_constant,
                description=self.serial.model.description, declared=self.serial.declared,
            )  # fmt: skip
            save_model(
                IdentifiedModelFile.of_estimate(
                    "urdf", self.estimate, self.model_values, self.log.source, self.warnings,
                    urdf=urdf.name,
                ),
                temporary,
            )  # fmt: skip

    def urdf_path(self, path: str | Path) -> Path | None:
        """The URDF ``save(path)`` writes beside the model file (``None`` for theta)."""
        return None if self.theta is not None else Path(path).with_suffix(".urdf")

    def save_study(
        self,
        path: str | Path,
        *,
        model: str | Path | None = None,
        samples: int = 100,
        experiment: LoadedScenario | None = None,
    ) -> Path:
        """Write a Monte-Carlo study whose ``samples`` plants are drawn from this
        identification's uncertainty (``analysis.identification.study_out``); with
        ``model`` (a file ``save`` wrote) its controllers use the identified model. Its
        samples run ``experiment`` (a scenario file of the same true arm; default: the
        identification's scenario)."""
        from posfb.analysis.identification.study_out import (
            plant_posterior,
            require_same_arm,
            write_study,
        )

        if not (isinstance(samples, int) and samples > 0):
            raise ValueError(f"samples = {samples!r}; an integer > 0 is required")
        if experiment is not None:
            require_same_arm(self.scenario, experiment)
        posterior = plant_posterior(self, self.scenario)
        return write_study(
            posterior,
            self.scenario if experiment is None else experiment,
            Path(path),
            model=None if model is None else Path(model),
            samples=samples,
        )

    def report(self) -> str:
        """The estimate as a table (value, standard error, relative), the condition
        number, the validation and the warnings."""
        estimate = self.estimate
        lines = [
            f"identified from {self.log.source}: {self.log.time.size} samples at "
            f"{self.log.sample_time:g} s, rows used per joint "
            f"{', '.join(str(r) for r in estimate.rows)}; "
            + ("instrumental variables (the log's reference)" if self.log.reference is not None
               else "least squares (the log has no reference)"),  # fmt: skip
            f"filters' cutoff {estimate.cutoff_words}",
            f"condition number of the scaled regressor: {estimate.condition_number:.3g}",
            f"{'':8s} {'estimate':>12s} {'std':>10s} {'rel. std':>9s} {'model':>12s}",
        ]
        for name, value, std, relative, model in zip(
            estimate.names,
            estimate.values,
            estimate.std,
            estimate.relative_std,
            self.model_values,
            strict=True,
        ):
            lines.append(
                f"{name:8s} {value:12.6g} {std:10.3g} {100 * min(relative, 1e6):8.2f}% "
                f"{model:12.6g}"
            )
        if self.serial is not None:
            lines += [f"  {name} = {text}" for name, text in zip(
                estimate.names, self.serial.model.base.descriptions, strict=False
            )]  # fmt: skip
            lines.append(
                "motor constants (joint 1's nominal, the others identified): "
                + ", ".join(f"{k:.4g}" for k in self.serial.motor_constant)
                + " N m/V"
            )
        if self.validation is not None:
            checked = self.validation
            lines.append(
                "validation NRMSE per joint: voltage "
                + ", ".join(f"{x:.2f} %" for x in checked.voltage_nrmse)
                + f"; output error ({checked.window:g} s windows) "
                + ", ".join(f"{x:.2f} %" for x in checked.output_nrmse)
            )
            if checked.nominal_voltage_nrmse is not None:
                lines.append(
                    "  the nominal model's voltage NRMSE on that log: "
                    + ", ".join(f"{x:.2f} %" for x in checked.nominal_voltage_nrmse)
                    + "; the identified model removes "
                    + ", ".join(f"{x:.0f} %" for x in checked.removed_percent)
                    + " of its error"
                )
            if checked.encoder_floor_nrmse is not None:
                lines.append(
                    "  the encoder's floor (what a perfect model would still show): "
                    + ", ".join(f"{x:.2f} %" for x in checked.encoder_floor_nrmse)
                )
        lines += [f"warning: {w}" for w in self.warnings]
        return "\n".join(lines)

    def figure(self, path: str | Path) -> None:
        """Draw the validation (measured against predicted voltage and position per
        joint) into ``path`` (.svg or .png)."""
        from posfb.analysis.identification.figures import validation_figure

        if self.validation is None:
            raise ValueError("no validation to draw: identify with a second log (validate)")
        validation_figure(self.validation, Path(path))


def _listed(values: np.ndarray | None) -> list[float] | None:
    return None if values is None else [float(x) for x in values]


def serial_model(config: ClosedLoopConfig) -> SerialModel:
    """The regressor of the scenario's URDF nominal model (``!UrdfModel``)."""
    from posfb.models.plant import PlantConfig, build_arm_diagram

    nominal = config.design.nominal
    _, arm, context = build_arm_diagram(
        PlantConfig(urdf=nominal.urdf, description=nominal.description)
    )
    return SerialModel.of_arm(arm, context, nominal.urdf, nominal.description)


def identify_log(
    loaded: LoadedScenario,
    log: str | Path,
    *,
    validation_log: str | Path | None = None,
    settings: FilterSettings | None = None,
    window: float = DEFAULT_WINDOW,
    progress: Callable[[str], None] | None = None,
) -> Identification:
    """The scenario's arm from ``log`` (module docstring), validated on
    ``validation_log`` when given; ``progress`` gets a line at each step."""
    say = progress or (lambda text: None)
    settings = settings or FilterSettings()
    config = resolve(loaded).config
    counts = tuple(config.sensor.encoder_counts)
    say(f"reading {log}")
    record = read_log(log, joints=config.joints, counts_per_revolution=counts)
    step = record.quantisation_step
    if step is None and all(c > 0 for c in counts):
        step = 2.0 * np.pi / np.asarray(counts, dtype=float)
    second = (
        None
        if validation_log is None
        else read_log(validation_log, joints=config.joints, counts_per_revolution=counts)
    )
    nominal = config.design.nominal
    say(f"fitting the model to {len(record.time)} samples")
    if isinstance(nominal, LumpedParameters):
        theta = identify_theta(
            record.time, record.q, record.u, l1=nominal.l1, g=nominal.g,
            quantisation_step=step, settings=settings, reference=record.reference,
        )  # fmt: skip
        result = Identification(loaded, record, theta=theta)
        regressor, target = (lambda q, v, a: theta_regressor(q, v, a, nominal.l1, nominal.g)), None
        described = (nominal.theta, None)
    else:
        model = serial_model(config)
        serial = identify_serial(
            model, record.time, record.q, record.u, quantisation_step=step, settings=settings,
            reference=record.reference,
        )  # fmt: skip
        result = Identification(loaded, record, serial=serial)
        size = model.base.size
        regressor, target = model.columns, serial.torque
        described = (model.base.combine(model.nominal), model.torque)
    say("checking the units against the nominal model")
    checked_units = unit_warning(
        record.time, record.q, record.u, regressor, described[0], described[1],
        replace(settings, cutoff_hz=result.estimate.cutoff_hz),
    )  # fmt: skip
    result = replace(result, checks=tuple(checked_units))
    values = result.model_values if result.theta is not None else result.model_values[:size]
    if second is None:
        return result
    say(f"validating on {validation_log}")
    checked = validate(
        second.time, second.q, second.u, regressor, values,
        target=target, window=window, nominal=described, quantisation_step=step,
        settings=replace(settings, cutoff_hz=result.estimate.cutoff_hz),
    )  # fmt: skip
    return replace(result, validation=checked)
