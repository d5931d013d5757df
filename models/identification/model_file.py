"""The file ``posfb identify --out MODEL.yaml`` writes and ``nominal_model: !Identified
{file: MODEL.yaml}`` reads: an identified model with its uncertainty.

``kind: theta`` holds theta_1..theta_11 of Sec. 4.1 in volts (``values``, the model
the controllers use: the weighted least-squares estimate, bounded where a value left
its physical sign, ``models.identification.theta``), their standard errors ``std``,
the covariance of the estimate (``covariance``, in ``names`` order) and the ``l1``,
``g`` the regressor used. ``kind: urdf`` holds a serial arm's base parameters (torque
units, ``names`` are their pivot parameters) and ``urdf``, the physically consistent
arm written beside the file (relative to it), which the controllers use. ``log``,
``condition_number``, ``cutoff_hz`` and ``warnings`` say where it came from. Read and
written with Drake's typed YAML.
"""

# No "from __future__ import annotations": Drake's YAML reads the field types at runtime.

from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from pydrake.common.yaml import yaml_dump_typed, yaml_load_typed

from posfb.models.validation import require_regular_file

if TYPE_CHECKING:
    from posfb.models.identification.estimate import Estimate

#: The kinds of identified model a file can hold.
MODEL_KINDS = ("theta", "urdf")


@dataclass
class IdentifiedModelFile:
    """One identified model (module docstring)."""

    kind: str = "theta"
    names: list[str] = field(default_factory=list)
    values: list[float] = field(default_factory=list)
    std: list[float] = field(default_factory=list)
    covariance: list[list[float]] = field(default_factory=list)
    l1: float = 0.0
    g: float = 0.0
    urdf: str = ""
    log: str = ""
    condition_number: float = 0.0
    cutoff_hz: float = 0.0
    warnings: list[str] = field(default_factory=list)

    @classmethod
    def of_estimate(
        cls,
        kind: str,
        estimate: "Estimate",
        values: Iterable[float],
        log: str,
        warnings: Iterable[str],
        **fields: object,
    ) -> "IdentifiedModelFile":
        """The file of an identification: its ``estimate`` (``estimate.Estimate``: names,
        std, covariance, condition number, cutoff), the model ``values`` written, the
        ``log`` it came from, its ``warnings``, and the kind's own ``fields`` (``l1``,
        ``g`` of theta; ``urdf`` of a serial arm)."""
        return cls(
            kind=kind,
            names=list(estimate.names),
            values=[float(v) for v in values],
            std=[float(s) for s in estimate.std],
            covariance=[[float(c) for c in row] for row in estimate.covariance],
            log=log,
            condition_number=float(estimate.condition_number),
            cutoff_hz=float(estimate.cutoff_hz),
            warnings=list(warnings),
            **fields,
        )

    def check(self, source: str) -> "IdentifiedModelFile":
        """Refuse a file whose parts do not fit together (one line naming ``source``)."""
        size = len(self.names)
        if self.kind not in MODEL_KINDS:
            raise ValueError(f"{source}: kind = {self.kind!r}; one of {MODEL_KINDS} is allowed")
        if size == 0 or len(self.values) != size or len(self.std) != size:
            raise ValueError(
                f"{source}: names, values and std need one entry per parameter "
                f"({size}, {len(self.values)}, {len(self.std)})"
            )
        if len(self.covariance) != size or any(len(row) != size for row in self.covariance):
            raise ValueError(f"{source}: covariance must be {size} x {size} (one row per name)")
        if (self.kind == "urdf") != bool(self.urdf):
            raise ValueError(f"{source}: urdf is required with kind: urdf, and only with it")
        return self


def save_model(model: IdentifiedModelFile, path: Path) -> None:
    """Write ``model`` to ``path`` as typed YAML with a header comment."""
    header = (
        "# An identified model written by posfb identify (models.identification.model_file).\n"
        "# Use it in a scenario as  nominal_model: !Identified {file: " + path.name + "}\n"
    )
    path.write_text(header + yaml_dump_typed(model))


def load_model(path: Path) -> IdentifiedModelFile:
    """The model in ``path`` (checked; a missing or malformed file is one line)."""
    require_regular_file("identified model file", path)
    try:
        model = yaml_load_typed(schema=IdentifiedModelFile, data=path.read_text())
    except RuntimeError as error:
        first = str(error).splitlines()[0]
        raise ValueError(f"{path}: not an identified model file ({first})") from None
    return model.check(str(path))
