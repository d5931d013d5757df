"""``report.md`` and ``errors.png`` of the realism study (``analysis.realism``).

The report states, from the stores alone: each effect's range and source; each
controller's median RMS error per joint with each effect beside the ideal arm and the
paper's table; the share of the (log) gap to the paper each effect closes
(``findings.gap_share``); how often the paper's ranking holds; the strongest drawn key
of each effect (Spearman, ``analysis.montecarlo.sensitivity``); and a verdict per
effect and joint from the bands of ``findings``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from posfb.analysis.common.plots import joint_panels, legend_below, save_report_figure
from posfb.analysis.common.provenance import code_version
from posfb.analysis.montecarlo.sensitivity import sensitivities
from posfb.analysis.realism.findings import (
    CLEAR_RATIO,
    EXPLAINS,
    NEGLIGIBLE,
    OVERSHOOTS,
    Findings,
    StudyFindings,
    findings,
)
from posfb.analysis.realism.spec import COMBINED, IDEAL, RealismStudies
from posfb.analysis.uncertainty.statistics import MIN_INFERENCE_ROWS
from posfb.diagrams.scenario import yaml_value

if TYPE_CHECKING:
    from matplotlib.figure import Figure

TABLE_NAMES = {"nominal": "Table 3 (nominal arm)", "payload": "Table 4 (0.288 kg payload)"}


def _mrad(value: float) -> str:
    return "-" if not math.isfinite(value) else f"{value * 1e3:.3g}"


def _percent(value: float) -> str:
    return "-" if not math.isfinite(value) else f"{value * 100:+.0f} %"


def _draws_text(study_draws: dict) -> str:
    """Each drawn key with its distribution as the study file writes it, whatever its
    kind (``!Uniform {min: 0.0001, max: 0.002}``, ``!Gaussian {...}``, ...)."""
    parts = []
    for key, distribution in study_draws.items():
        fields = ", ".join(
            f"{name}: {yaml_value(value)}"
            for name, value in vars(distribution).items()
            if value is not None and value is not False  # unset keys, relative: false
        )
        parts.append(f"`{key}` `!{type(distribution).__name__} {{{fields}}}`")
    return "; ".join(parts)


def _effects_section(studies: RealismStudies) -> list[str]:
    lines = [
        "## The effects and their ranges",
        "",
        "| study | settings | drawn | samples | source of the range |",
        "|---|---|---|---:|---|",
    ]
    for effect in studies.spec.effects:
        settings = ", ".join(f"`{s}`" for s in effect.settings) or "-"
        lines.append(
            f"| {effect.name}: {effect.label} | {settings} | {_draws_text(effect.draws) or '-'} "
            f"| {effect.samples} | {' '.join(effect.source.split())} |"
        )
    if studies.spec.combined:
        lines.append(
            f"| {COMBINED} | every setting of {', '.join(studies.spec.combined)} | all their "
            f"draws at once | {studies.spec.combined_samples} | as above |"
        )
    return [*lines, ""]


def _joint_tables(found: Findings, cell: Callable[[StudyFindings, str, int], str]) -> list[str]:
    """Per joint, a table of every study (rows, after the paper's) by controller, each
    cell ``cell(study, controller, joint)``."""
    table = TABLE_NAMES[found.studies.spec.paper_table]
    lines = []
    for joint in range(found.joints):
        lines += [
            "",
            f"**Joint {joint + 1}**",
            "",
            "| study | " + " | ".join(found.controllers) + " |",
            "|---|" + "---:|" * len(found.controllers),
        ]
        paper = " | ".join(_mrad(found.paper_value(c, joint)) for c in found.controllers)
        lines.append(f"| paper ({table}) | {paper} |")
        for name, study in found.found.items():
            cells = " | ".join(cell(study, c, joint) for c in found.controllers)
            lines.append(f"| {name} | {cells} |")
    return [*lines, ""]


def _true_cell(study: StudyFindings, controller: str, joint: int) -> str:
    """The median true error, and the runs that did not finish where any."""
    errors = study.errors[controller]
    text = _mrad(errors.median(joint))
    if errors.unfinished:
        text += f" ({errors.unfinished}/{study.samples} unfinished)"
    return text


def _measured_cell(study: StudyFindings, controller: str, joint: int) -> str:
    """The median measured error, and how many finished runs recorded it where not all."""
    errors = study.errors[controller]
    text = _mrad(errors.measured_median(joint))
    finished, recorded = study.samples - errors.unfinished, errors.measured_count(joint)
    if recorded < finished:
        text += f" ({recorded}/{finished} recorded)"
    return text


def _errors_section(found: Findings) -> list[str]:
    table = TABLE_NAMES[found.studies.spec.paper_table]
    lines = ["## RMS tracking error with each effect", ""]
    lines.append(
        f"Median over the samples of RMS(q̃j) in mrad (the true link error; runs that "
        f"finished), `n/N` runs that did not finish where any; the paper's {table} first. "
        "With the encoder on the motor the paper measured `θ_m - q_d`, not `q - q_d`: the "
        "two differ by the gear's deflection `τ_g / k` plus at most the backlash `b` (the "
        "next section gives the measured error)."
    )
    return lines + _joint_tables(found, _true_cell)


def _measured_section(found: Findings) -> list[str]:
    table = TABLE_NAMES[found.studies.spec.paper_table]
    lines = [
        "## The error the encoder reads",
        "",
        f"Median over the samples of RMS(q_m,j - q_d,j) in mrad, with `q_m` the encoder's "
        f"reading (`analysis.common.metrics`): the error a hardware experiment computes, as the "
        f"paper's {table} was. It is the true error plus the encoder's quantisation where "
        "the encoder reads the link, and the error of the motor angle where it reads the "
        "motor. `m/N` gives the samples that recorded it where not every finished one did "
        "(a store written before schema version 3).",
    ]
    return lines + _joint_tables(found, _measured_cell)


def _gap_section(found: Findings) -> list[str]:
    with_paper = [c for c in found.controllers if found.paper_name(c) is not None]
    header = " | ".join(f"{c} q̃{j + 1}" for c in with_paper for j in range(found.joints))
    lines = [
        "## How much of the gap each effect closes",
        "",
        "`log(median / ideal) / log(paper / ideal)`: 0 % no change, 100 % the paper's "
        "hardware value, negative away from it, above 100 % past it.",
        "",
        f"| study | {header} |",
        "|---|" + "---:|" * (len(with_paper) * found.joints),
    ]
    for name in found.found:
        if name == IDEAL:
            continue
        cells = [_percent(found.share(name, c, j)) for c in with_paper for j in range(found.joints)]
        lines.append(f"| {name} | {' | '.join(cells)} |")
    return [*lines, ""]


def _ranking_section(found: Findings) -> list[str]:
    lines = [
        "## Does the paper's ranking survive?",
        "",
        f"The paper's pairs (values apart by more than {CLEAR_RATIO:g}x; a run that did not "
        "finish ranks last):",
        "",
    ]
    for joint in range(found.joints):
        pairs = ", ".join(f"{a} < {b}" for a, b in found.pairs(joint)) or "none"
        lines.append(f"- joint {joint + 1}: {pairs}")
    lineups = found.lineups()
    titles = ["the paper's own"] + [
        f"{stand_in} for {paper}" for stand_in, paper in found.studies.spec.stand_ins.items()
    ]
    header = " | ".join(f"joint {j + 1}, {title}" for title in titles for j in range(found.joints))
    lines += [
        "",
        "Samples in which every pair holds, with the paper's controllers and with each "
        "stand-in in its paper controller's place:",
        "",
        f"| study | {header} |",
        "|---|" + "---:|" * (found.joints * len(lineups)),
    ]
    for name in found.found:
        cells = []
        for lineup in lineups:
            for joint in range(found.joints):
                agree, total = found.agreement(name, joint, lineup)
                cells.append(f"{agree}/{total}")
        lines.append(f"| {name} | {' | '.join(cells)} |")
    return [*lines, ""]


def _sensitivity_section(found: Findings) -> list[str]:
    joints = range(found.joints)
    lines = [
        "## Which drawn value matters",
        "",
        "In each study that draws more than one key: the drawn key with the strongest "
        "Spearman rank correlation with each controller's RMS error "
        "(analysis.montecarlo.sensitivity), and its rho; with fewer than "
        f"{MIN_INFERENCE_ROWS} runs it describes these samples, without an interval.",
        "",
        "| study | controller | " + " | ".join(f"joint {j + 1}" for j in joints) + " | runs |",
        "|---|---|" + "---|" * found.joints + "---:|",
    ]
    for name, study in found.found.items():
        if len(study.data.inputs) < 2 or study.samples < 3:
            continue
        ranked = {(e.controller, e.joint): e.ranking for e in sensitivities(study.data)}
        for controller in found.controllers:
            cells, runs = [], 0
            for joint in joints:
                ranking = ranked.get((controller, joint + 1))
                if not ranking:
                    cells.append("-")
                    continue
                cells.append(f"`{ranking[0].parameter}` {ranking[0].rho:+.2f}")
                runs = max(runs, ranking[0].count)
            lines.append(f"| {name} | {controller} | {' | '.join(cells)} | {runs} |")
    return [*lines, ""]


def verdict(share: float) -> str:
    """The band of a gap share (``findings``)."""
    if not math.isfinite(share):
        return "no comparison"
    if share > OVERSHOOTS:
        return "overshoots the hardware"
    if share >= EXPLAINS:
        return "explains most of the gap"
    if share > NEGLIGIBLE:
        return "explains part of the gap"
    if share < -NEGLIGIBLE:
        return "moves away from the hardware"
    return "explains none of it"


def _verdict_section(found: Findings) -> list[str]:
    lines = [
        "## Verdict per effect",
        "",
        f'From the gap shares: at least {EXPLAINS:.0%} of the log gap "explains most of the '
        f'gap" (beyond {OVERSHOOTS:.0%} "overshoots"), more than {NEGLIGIBLE:.0%} "explains '
        'part", within ±10 % "none of it", below -10 % "moves away".',
        "",
    ]
    for name in found.found:
        if name == IDEAL:
            continue
        parts = []
        for c in found.controllers:
            if found.paper_name(c) is None:
                continue
            words = [f"q̃{j + 1} {verdict(found.share(name, c, j))}" for j in range(found.joints)]
            parts.append(f"{c}: " + ", ".join(words))
        lines.append(f"- **{found.studies.label(name)}** — " + "; ".join(parts) + ".")
    return [*lines, ""]


def plot_errors(found: Findings, out: Path) -> Figure:
    """Every sample's RMS error per study (rows) and controller (colours), one panel per
    joint, with the paper's values as vertical lines in the controller's colour; a title,
    and one legend below the panels. Returns the figure (written to ``out``)."""
    names = list(found.found)
    figure, axes = joint_panels(found.joints, sharey=True, width=12.0)
    figure.set_figheight(0.45 * len(names) + 1.5)
    colours = {c: f"C{i}" for i, c in enumerate(found.controllers)}
    offsets = np.linspace(-0.25, 0.25, len(found.controllers))
    for joint, axis in enumerate(axes):
        for offset, controller in zip(offsets, found.controllers, strict=True):
            for row, name in enumerate(names):
                values = found.found[name].errors[controller].rms[:, joint]
                values = values[np.isfinite(values)]
                axis.plot(
                    values, np.full(values.size, row + offset), "o", ms=3,
                    color=colours[controller], alpha=0.7,
                    label=controller if row == 0 else None,
                )  # fmt: skip
            if controller in found.paper:  # a stand-in shares its paper controller's line
                axis.axvline(
                    found.paper_value(controller, joint), color=colours[controller], ls="--"
                )
        axis.set_xscale("log")
        axis.set_yticks(range(len(names)), names)
        axis.invert_yaxis()
        axis.set_xlabel(f"RMS(q̃{joint + 1}) (rad); dashed: the paper's hardware")
        axis.set_title(f"joint {joint + 1}")
        axis.grid(True, which="both", alpha=0.3)
    figure.suptitle("RMS tracking error of every sample, per study and controller")
    legend_below(figure)
    save_report_figure(figure, out, "errors")
    return figure


def markdown(found: Findings, command: str) -> str:
    spec = found.studies.spec
    missing = [n for n in found.studies.studies if n not in found.found]
    unfinished = [
        f"{s.name}: {s.samples} of {s.expected} samples ("
        + (
            f"`--only {s.name}` completes it)"
            if s.resumable
            else f"stored by an earlier posfb, which cannot be resumed: `--only {s.name}` "
            "into a fresh `--out` runs it again)"
        )
        for s in found.found.values()
        if s.samples < s.expected
    ]
    lines = [
        "# How far from hardware? Non-idealities against the paper's measurements",
        "",
        f"Regenerate: `{command}` ({code_version()}). An explanation, not a calibration: "
        "no default of posfb changes; every range is the literature's for small geared "
        "DC-motor arms, with its source. The arm is the paper's (the URDF identified from "
        "Table 1, with the scenario's payload) in every study, so each change is the "
        f"effect's own. Compared with the paper's {TABLE_NAMES[spec.paper_table]}, "
        "hardware measurements: orderings and ratios, not digits.",
        "",
    ]
    if missing or unfinished:
        lines += [
            "**Incomplete:** " + "; ".join([*(f"{n}: not run" for n in missing), *unfinished]),
            "",
        ]
    lines += _effects_section(found.studies)
    lines += _errors_section(found)
    lines += ["![RMS error of every sample, per study and controller](errors.png)", ""]
    lines += _measured_section(found)
    lines += _gap_section(found)
    lines += _ranking_section(found)
    lines += _verdict_section(found)
    lines += _sensitivity_section(found)
    lines += [
        "## The studies",
        "",
        "Each study is a Monte-Carlo study (`analysis.montecarlo`) whose store keeps its "
        "canonical YAML: `posfb montecarlo report --db STORES/NAME.sqlite --out DIR` "
        "reports one, `posfb montecarlo replay --db STORES/NAME.sqlite --sample K --out "
        "DIR` runs one sample again and checks it against its stored rows.",
        "",
    ]
    return "\n".join(lines)


def write_report(studies: RealismStudies, stores: Path, out: Path, command: str) -> Path:
    """``out/report.md`` and ``out/errors.png`` from the stores in ``stores``."""
    found = findings(studies, stores)
    out.mkdir(parents=True, exist_ok=True)
    plot_errors(found, out)
    path = out / "report.md"
    path.write_text(markdown(found, command))
    return path
