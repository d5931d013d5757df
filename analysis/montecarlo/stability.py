"""Which sampled plants the designed loops destabilise: the report's per-sample
sampled-data section.

Each sample stores, per controller with a loop of Sec. 3 (the proposed
controller and Lin+LC), the spectral radius ``rho`` of that loop closed around
the sample's own linear part ``M0, B`` with the filters as designed on the
nominal model and the sample's linear effects (compute and sensor delay, lag,
compliant gear: ``analysis.common.loop_effects``; ``models.design.plant_spectral_radii``;
on the nominal model it is the design report's number). ``rho >= 1``: the held,
sampled linear loop is unstable on that plant, and the nonlinear run typically oscillates (a limit
cycle bounded by friction and saturation) rather than diverging.

The section counts the plants with ``rho >= 1`` (Wilson 95 % interval of the
share), compares the RMS error of the two groups (medians with bootstrap 95 %
intervals) and gives Spearman's rho of the RMS error with ``rho``; figure
``rms_vs_radius`` plots one against the other.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from posfb.analysis.common.plots import (
    dot_alpha,
    joint_panels,
    label_joint_panel,
    legend_below,
    save_report_figure,
    thinned,
)
from posfb.analysis.montecarlo.results import StudyData, ok_values
from posfb.analysis.uncertainty.statistics import (
    MIN_INFERENCE_ROWS,
    Interval,
    RankCorrelation,
    median_interval,
    proportion_interval,
    spearman_ranking,
)


@dataclass(frozen=True)
class LoopStability:
    """One controller's loops over the sampled plants (``unstable``: ``rho >= 1``)."""

    controller: str
    plants: int
    unstable: int
    unstable_share: Interval
    largest: float
    smallest: float
    median_rms: dict[tuple[bool, int], Interval]  # (unstable, joint 1..n) -> median RMS
    correlation: dict[int, RankCorrelation | None]  # joint -> RMS against rho


def loop_stability(data: StudyData) -> list[LoopStability]:
    """The per-sample stability of every controller that has a designed loop."""
    found = []
    for controller in data.controllers:
        radius = data.radius[controller]
        known = np.isfinite(radius)
        if not np.any(known):
            continue
        unstable = known & (radius >= 1.0)
        medians = {}
        for flag in (False, True):
            for joint in range(data.joints):
                values = ok_values(data, controller, joint, unstable if flag else known & ~unstable)
                count = int(np.count_nonzero(np.isfinite(values)))
                medians[flag, joint + 1] = median_interval(values).without_interval(count)
        correlation = {}
        for joint in range(data.joints):
            ranking = spearman_ranking({"rho": radius}, data.rms_q[controller][:, joint])
            correlation[joint + 1] = ranking[0] if ranking else None
        found.append(
            LoopStability(
                controller=controller,
                plants=int(np.sum(known)),
                unstable=int(np.sum(unstable)),
                unstable_share=proportion_interval(int(np.sum(unstable)), int(np.sum(known))),
                largest=float(np.max(radius[known])),
                smallest=float(np.min(radius[known])),
                median_rms=medians,
                correlation=correlation,
            )
        )
    return found


def _median(interval: Interval) -> str:
    return "-" if not np.isfinite(interval.estimate) else interval.text(3)


def markdown(found: list[LoopStability]) -> list[str]:
    """The section's Markdown lines (none when no controller has a designed loop)."""
    if not found:
        return []
    joints = len(found[0].correlation)
    medians_header = "".join(f" median RMS j{j} rho < 1 | rho >= 1 |" for j in range(1, joints + 1))
    lines = [
        "## Per-sample sampled-data stability",
        "",
        "Spectral radius rho of each designed loop (filters of the nominal design, held "
        "over T_s) closed around each sampled plant's linear part; rho >= 1 is an unstable "
        "sampled loop on that plant. Shares with Wilson 95 % intervals, median RMS (rad, "
        "finished runs) with bootstrap 95 % intervals.",
        "",
        "| controller | rho range | plants with rho >= 1 | share [95 % CI] |"
        + medians_header
        + f" Spearman(RMS j{joints}, rho) |",
        "|---|---:|---:|---:|" + "---:|---:|" * joints + "---:|",
    ]
    for entry in found:
        share = entry.unstable_share
        correlation = entry.correlation[joints]
        if correlation is None:
            rank = "-"
        elif correlation.count < MIN_INFERENCE_ROWS:
            rank = f"{correlation.rho:+.2f} (no p, n < {MIN_INFERENCE_ROWS})"
        else:
            rank = f"{correlation.rho:+.2f} (p = {correlation.p_value:.2g})"
        lines.append(
            f"| {entry.controller} | {entry.smallest:.4f} - {entry.largest:.4f} | "
            f"{entry.unstable} of {entry.plants} | {100 * share.estimate:.1f} % "
            f"[{100 * share.low:.1f}, {100 * share.high:.1f}] | "
            + " | ".join(
                _median(entry.median_rms[(flag, joint)])
                for joint in range(1, joints + 1)
                for flag in (False, True)
            )
            + f" | {rank} |"
        )
    lines += ["", "![rms_vs_radius](rms_vs_radius.png)", ""]
    return lines


def plot(data: StudyData, found: list[LoopStability], out: Path) -> Figure:
    """RMS error against the loop's spectral radius, per joint, one colour per controller
    (up to ``MAX_DOTS`` samples each, ``analysis.common.plots.thinned``); saved as
    ``rms_vs_radius`` into ``out`` and returned."""
    figure, axes = joint_panels(data.joints, width=11.0)
    for joint, axis in enumerate(axes):
        for entry in found:
            radius = data.radius[entry.controller]
            values = data.rms_q[entry.controller][:, joint]
            ok = np.isfinite(values) & np.isfinite(radius)
            dots, radii = thinned(values[ok], radius[ok])
            axis.plot(radii, dots, ".", markersize=4, alpha=dot_alpha(dots.size),
                      label=entry.controller)  # fmt: skip
        axis.axvline(1.0, color="black", linestyle="--", linewidth=0.8)
        label_joint_panel(
            axis, joint, "RMS tracking error (rad)",
            "spectral radius of the designed sampled loop on the plant",
        )  # fmt: skip
    legend_below(figure)
    figure.suptitle("Error against per-sample sampled-data stability (rho >= 1: unstable)", y=1.02)
    save_report_figure(figure, out, "rms_vs_radius")
    return figure
