"""Which drawn parameter drives which error: the report's sensitivity section.

For every controller and joint, the RMS tracking error of the finished runs is
ranked against every parameter the study varies (``varied_scalars``) by
Spearman's rank correlation, with its p-value and a bootstrap 95 % interval
(``uncertainty.statistics.spearman_ranking``). A rank correlation measures a monotone
association, one parameter at a time: two parameters that act together, or a
parameter whose effect is not monotone, are better read from Sobol' indices,
which the report adds when the study is a Saltelli design
(``sampling: saltelli``): first-order (the share of the error's variance that
one parameter explains alone) and total-order (alone and in interaction), with
SALib's 95 % intervals. The Sobol' indices need every run of the design;
with a failed run there is no response for its row, and they are not computed.

Figure ``sensitivity``: one panel per (controller, joint), a horizontal bar per
parameter (the ``TOP`` strongest), its rho with the interval as an error bar.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from posfb.analysis.common.plots import save_report_figure
from posfb.analysis.montecarlo.results import StudyData
from posfb.analysis.uncertainty.statistics import (
    MIN_INFERENCE_ROWS,
    RankCorrelation,
    SobolIndex,
    sobol_indices,
    spearman_ranking,
)

#: Parameters shown per (controller, joint) in the table and the figure.
TOP = 6

#: A rank correlation is called significant below this p-value (two-sided).
SIGNIFICANCE = 0.01


@dataclass(frozen=True)
class Sensitivity:
    """The ranking of one controller's joint error (``joint`` 1..n)."""

    controller: str
    joint: int
    ranking: list[RankCorrelation]
    sobol: list[SobolIndex] | None
    sobol_note: str


def sensitivities(data: StudyData) -> list[Sensitivity]:
    """The Spearman ranking (and Sobol' indices for a Saltelli design) of every
    controller's RMS error at each joint against the varied parameters."""
    saltelli = data.study.sampling == "saltelli"
    names = list(data.inputs)
    found = []
    for controller in data.controllers:
        for joint in range(data.joints):
            response = data.rms_q[controller][:, joint]
            ranking = spearman_ranking(data.inputs, response) if names else []
            sobol, note = None, ""
            if saltelli:
                sobol, note = _sobol(names, response, data)
            found.append(Sensitivity(controller, joint + 1, ranking, sobol, note))
    return found


def _sobol(
    names: list[str], response: np.ndarray, data: StudyData
) -> tuple[list[SobolIndex] | None, str]:
    """Sobol' indices of ``response`` when every row of the design has one."""
    missing = int(np.sum(~np.isfinite(response)))
    if missing:
        return None, f"{missing} runs did not finish; Sobol' indices need every run"
    if len(response) != data.study.samples or not np.array_equal(
        data.samples, np.arange(data.study.samples)
    ):
        return None, "the design is incomplete (unfinished study); Sobol' indices need every row"
    try:
        return sobol_indices(names, response), ""
    except ValueError as error:
        return None, str(error)


def markdown(found: list[Sensitivity]) -> list[str]:
    """The section's Markdown lines."""
    lines = [
        "## Sensitivity: which parameter drives which error",
        "",
        "Spearman rank correlation of each varied parameter with the RMS tracking error "
        f"(finished runs), strongest {TOP} per controller and joint; 95 % bootstrap "
        f"interval in brackets; **bold** where p < {SIGNIFICANCE:g}; no interval or p with "
        f"fewer than {MIN_INFERENCE_ROWS} runs.",
        "",
        "| controller | joint | parameter | rho [95 % CI] | p | runs |",
        "|---|---:|---|---:|---:|---:|",
    ]
    for entry in found:
        if not entry.ranking:
            lines.append(f"| {entry.controller} | {entry.joint} | - | - | - | 0 |")
        for rank in entry.ranking[:TOP]:
            if rank.count < MIN_INFERENCE_ROWS:
                rho, p = f"{rank.rho:+.3f} (too few runs for an interval)", "-"
            else:
                rho = f"{rank.rho:+.3f} [{rank.low:+.3f}, {rank.high:+.3f}]"
                p = f"{rank.p_value:.2g}"
                if rank.p_value < SIGNIFICANCE:
                    rho = f"**{rho}**"
            lines.append(
                f"| {entry.controller} | {entry.joint} | `{rank.parameter}` | {rho} | "
                f"{p} | {rank.count} |"
            )
    with_sobol = [entry for entry in found if entry.sobol is not None or entry.sobol_note]
    if with_sobol:
        lines += [
            "",
            "Sobol' indices (Saltelli design; SALib, 95 % half-widths):",
            "",
            "| controller | joint | parameter | first order | total order |",
            "|---|---:|---|---:|---:|",
        ]
        for entry in with_sobol:
            if entry.sobol is None:
                lines.append(f"| {entry.controller} | {entry.joint} | {entry.sobol_note} | | |")
                continue
            for index in entry.sobol[:TOP]:
                lines.append(
                    f"| {entry.controller} | {entry.joint} | `{index.parameter}` | "
                    f"{index.first:.3f} ± {index.first_conf:.3f} | "
                    f"{index.total:.3f} ± {index.total_conf:.3f} |"
                )
    lines += ["", "![sensitivity](sensitivity.png)", ""]
    return lines


def plot(found: list[Sensitivity], controllers: tuple[str, ...], joints: int, out: Path) -> None:
    """Tornado bars of the strongest rank correlations, one panel per controller and joint."""
    width = 6 * max(joints, 2)
    figure = Figure(figsize=(width, 2.6 * len(controllers) + 0.8), layout="constrained")
    axes = np.atleast_2d(figure.subplots(len(controllers), joints, squeeze=False))
    for entry in found:
        axis = axes[controllers.index(entry.controller), entry.joint - 1]
        shown = entry.ranking[:TOP][::-1]
        positions = np.arange(len(shown))
        rho = np.array([rank.rho for rank in shown])
        # A percentile interval need not contain its estimate: clip the bars at zero.
        error = np.clip(
            [[rank.rho - rank.low for rank in shown], [rank.high - rank.rho for rank in shown]],
            0.0,
            None,
        )
        colours = ["tab:red" if value > 0 else "tab:blue" for value in rho]
        axis.barh(positions, rho, xerr=error if shown else None, color=colours, alpha=0.7)
        axis.set_yticks(positions, [rank.parameter for rank in shown], fontsize=8)
        axis.axvline(0.0, color="black", linewidth=0.8)
        axis.set_xlim(-1.0, 1.0)
        axis.set_title(f"{entry.controller}, joint {entry.joint}", fontsize=10)
        axis.grid(True, axis="x", alpha=0.3)
    for axis in axes[-1]:
        axis.set_xlabel("Spearman rho with the RMS error (95 % CI)")
    figure.suptitle("What drives the tracking error")
    save_report_figure(figure, out, "sensitivity")
