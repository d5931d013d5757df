"""``posfb identify --log``: a model of a scenario's arm from its encoder log, with its
uncertainty, warnings and (given a second log) its validation (issue 29).

The arm is the scenario's: where its nominal model is theta of Sec. 4.1 (``!Table1``,
``!Theta``, ``!IdentifiedFromUrdf``, ``!Identified``) the log identifies theta_1..theta_11
of Eq. 4 in volts (``models.identification.theta``) with the nominal model's ``l1`` and
``g``. The encoder's step for the coarse-encoder check comes from the log's counts
where it gives them, else from the scenario's ``sensor.encoder_counts``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from posfb.analysis.identification.log import EncoderLog, read_log
from posfb.diagrams.closed_loop import ClosedLoopConfig
from posfb.diagrams.resolve import LoadedScenario, resolve
from posfb.models.identification.estimate import FilterSettings
from posfb.models.identification.model_file import save_model
from posfb.models.identification.theta import ThetaIdentification, identify_theta
from posfb.models.identification.theta_regressor import theta_regressor
from posfb.models.identification.validation import DEFAULT_WINDOW, Validation, validate
from posfb.models.lumped import LumpedParameters


@dataclass(frozen=True)
class Identification:
    """The outcome of ``identify_log``: the log, the theta identification and, where a
    second log was given, its ``validation``."""

    log: EncoderLog
    theta: ThetaIdentification
    validation: Validation | None = None

    @property
    def warnings(self) -> tuple[str, ...]:
        return self.theta.warnings

    def as_dict(self) -> dict[str, object]:
        """What ``posfb identify --log ... --json`` prints."""
        estimate = self.theta.estimate
        result: dict[str, object] = dict(estimate.as_dict())
        result["std"] = estimate.std_dict()
        result["model"] = {
            name: float(v) for name, v in zip(estimate.names, self.theta.model_values, strict=True)
        }
        result["condition_number"] = estimate.condition_number
        result["cutoff_hz"] = estimate.cutoff_hz
        result["rows"] = list(estimate.rows)
        result["validation"] = (
            None
            if self.validation is None
            else {
                "voltage_nrmse_percent": [float(x) for x in self.validation.voltage_nrmse],
                "output_nrmse_percent": [float(x) for x in self.validation.output_nrmse],
                "window_s": self.validation.window,
            }
        )
        result["warnings"] = list(self.warnings)
        return result

    def save(self, path: str | Path) -> None:
        """Write the model file ``nominal_model: !Identified {file: ...}`` reads."""
        save_model(self.theta.model_file(self.log.source), Path(path))

    def report(self) -> str:
        """The estimate as a table (value, standard error, relative), the condition
        number, the validation and the warnings."""
        estimate = self.theta.estimate
        lines = [
            f"identified from {self.log.source}: {self.log.time.size} samples at "
            f"{self.log.sample_time:g} s, filters at {estimate.cutoff_hz:g} Hz, rows used per "
            f"joint {', '.join(str(r) for r in estimate.rows)}",
            f"condition number of the scaled regressor: {estimate.condition_number:.3g}",
            f"{'':8s} {'estimate':>12s} {'std':>10s} {'rel. std':>9s} {'model':>12s}",
        ]
        for name, value, std, relative, model in zip(
            estimate.names,
            estimate.values,
            estimate.std,
            estimate.relative_std,
            self.theta.model_values,
            strict=True,
        ):
            lines.append(
                f"{name:8s} {value:12.6g} {std:10.3g} {100 * min(relative, 1e6):8.2f}% "
                f"{model:12.6g}"
            )
        if self.validation is not None:
            checked = self.validation
            lines.append(
                "validation NRMSE per joint: voltage "
                + ", ".join(f"{x:.2f} %" for x in checked.voltage_nrmse)
                + f"; output error ({checked.window:g} s windows) "
                + ", ".join(f"{x:.2f} %" for x in checked.output_nrmse)
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


def theta_nominal(loaded: LoadedScenario) -> tuple[LumpedParameters, ClosedLoopConfig]:
    """The scenario's theta nominal model and its closed-loop settings; any other
    nominal model is refused (one line)."""
    config = resolve(loaded).config
    nominal = config.design.nominal
    if not isinstance(nominal, LumpedParameters):
        raise ValueError(
            f"nominal_model of {loaded.source} is not theta of Sec. 4.1 (!Table1, !Theta, "
            "!IdentifiedFromUrdf or !Identified); identification from a log and its plan "
            "are built for the paper's two-joint theta model"
        )
    return nominal, config


def identify_log(
    loaded: LoadedScenario,
    log: str | Path,
    *,
    validation_log: str | Path | None = None,
    settings: FilterSettings | None = None,
    window: float = DEFAULT_WINDOW,
) -> Identification:
    """theta of the scenario's arm from ``log`` (module docstring), validated on
    ``validation_log`` when given."""
    settings = settings or FilterSettings()
    nominal, config = theta_nominal(loaded)
    counts = tuple(config.sensor.encoder_counts)
    record = read_log(log, joints=2, counts_per_revolution=counts)
    step = record.quantisation_step
    if step is None and all(c > 0 for c in counts):
        step = 2.0 * np.pi / np.asarray(counts, dtype=float)
    theta = identify_theta(
        record.time,
        record.q,
        record.u,
        l1=nominal.l1,
        g=nominal.g,
        quantisation_step=step,
        settings=settings,
    )
    checked = None
    if validation_log is not None:
        second = read_log(validation_log, joints=2, counts_per_revolution=counts)
        checked = validate(
            second.time,
            second.q,
            second.u,
            lambda q, v, a: theta_regressor(q, v, a, nominal.l1, nominal.g),
            theta.model_values,
            settings=settings,
            window=window,
        )
    return Identification(record, theta, checked)
