"""The guide's table of margins (``docs/margins/table.md``): the paper's design beside
Lin+LC, PID, the two position-only baselines and the tuned designs of the shipped
scenarios, one row per (scenario, controller), from ``posfb.design``.

    python -m posfb.analysis.design.margins_table docs/margins/rows.yaml > docs/margins/table.md

The rows (``docs/margins/rows.yaml``, ``RowsFile``) are the guide's choice, not the
package's. ``tests/models/design/test_margins.py`` regenerates the table and compares, so
the committed table is the code's output. A labelled row (``alpha* = 3.25``) is the second
Monte-Carlo study's setting (``paper_uncertainty_alpha_star``), not a default.
"""

# No "from __future__ import annotations": Drake's YAML reads the field types at runtime.

import math
import sys
from dataclasses import dataclass, field
from pathlib import Path

from posfb.analysis.common.shipped import shipped_files
from posfb.analysis.design.linear_loop import LinearDesign, linear_design
from posfb.analysis.design.margins_report import radius_text
from posfb.diagrams.resolve import load_scenario, resolve
from posfb.models.design.margins import LoopMargins


@dataclass
class Row:
    """One row: a shipped ``scenario`` (by name), a ``controller`` kind, settings applied
    first (``KEY=VALUE``) and a ``note`` for a labelled setting."""

    scenario: str = ""
    controller: str = ""
    settings: list[str] = field(default_factory=list)
    note: str = ""


@dataclass
class RowsFile:
    """A rows file (YAML): ``rows``, in table order."""

    rows: list[Row] = field(default_factory=list)


def read_rows(path: Path) -> list[Row]:
    """The rows of the YAML file at ``path`` (``RowsFile``)."""
    from posfb.diagrams.yaml_schema import load_typed, read_text

    return load_typed(RowsFile, read_text(path, "rows file"), str(path)).rows


HEADER = (
    "| scenario | controller | radius | delay margin | disk margin | disk gain | "
    "disk phase | peak abs S | peak abs T | smallest loop-at-a-time gain, phase |\n"
    "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"
)


def _number(value: float, form: str) -> str:
    return "inf" if math.isinf(value) else format(value, form)


def row_text(row: Row, loop: LinearDesign, margins: LoopMargins) -> str:
    """``row`` as one Markdown table row."""
    name = loop.label + (f" ({row.note})" if row.note else "")
    head = f"| {row.scenario} | {name} | {radius_text(margins.radius)} |"
    if not margins.stable:
        return head + " unstable | | | | | | |"
    channels = margins.at_input.channels + margins.at_output.channels
    gain = min(c.gain_margin for c in channels)
    phase = min(abs(c.phase_margin_deg) for c in channels)
    delay = margins.delay_margin_s
    delay_text = "inf" if math.isinf(delay) else (
        f"{delay * 1e3:.2f} ms ({delay / margins.sample_time:.2f} T_s)")  # fmt: skip
    return (
        f"{head} {delay_text} | {margins.disk_margin:.3f} | "
        f"x{_number(margins.disk_gain_margin, '.2f')} | "
        f"{margins.disk_phase_margin_deg:.1f} deg | {margins.peak_sensitivity:.2f} | "
        f"{margins.peak_complementary_sensitivity:.2f} | x{_number(gain, '.2f')}, "
        f"{phase:.1f} deg |"
    )


def table(rows: list[Row]) -> str:
    """The Markdown table of ``rows`` (module docstring)."""
    files = shipped_files("scenario")
    lines = [HEADER]
    for row in rows:
        kind = f"controller.kind={row.controller}"
        loaded = load_scenario(str(files[row.scenario]), [kind, *row.settings])
        loop = linear_design(resolve(loaded))
        lines.append(row_text(row, loop, loop.margins()))
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    print(table(read_rows(Path(sys.argv[1]))), end="")
