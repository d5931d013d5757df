"""Were there enough samples? The report's convergence section.

For every controller and joint: the relative half-width of the bootstrap 95 %
interval of the median and of the 95th percentile of the RMS error, and how far
each statistic still moved over the second half of the samples (in sample
order, the order a resumed study adds them). The report calls N *enough* for a
statistic when its interval's half-width is at most ``PRECISION`` of its value;
this is the report's stated criterion, not a universal one.

Figures: ``convergence`` (the running median and 95th percentile against the
number of finished runs) and ``ecdf`` (the empirical distribution of the RMS
error per controller).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from posfb.analysis.common.plots import (
    joint_panels,
    label_joint_panel,
    legend_below,
    save_report_figure,
)
from posfb.analysis.montecarlo.results import JointStats, StudyData
from posfb.analysis.uncertainty.statistics import Interval, ecdf, running_quantiles

#: N is "enough" for a statistic whose 95 % interval half-width is at most this share of it.
PRECISION = 0.10

#: The statistics followed: median and 95th percentile.
QUANTILES = (0.5, 0.95)


@dataclass(frozen=True)
class Convergence:
    """How well one controller's joint statistics are pinned down by the samples."""

    controller: str
    joint: int
    runs: int
    median_precision: float  # interval half-width / median
    p95_precision: float
    median_drift: float  # largest |running - final| / final over the second half
    p95_drift: float


def _precision(interval: Interval) -> float:
    if not np.isfinite(interval.estimate) or interval.estimate == 0.0:
        return float("nan")
    return (interval.high - interval.low) / 2.0 / abs(interval.estimate)


def _drift(values: np.ndarray) -> tuple[float, float]:
    """Largest relative move of the running median and p95 over the second half."""
    counts, running = running_quantiles(values, QUANTILES)
    if counts.size == 0:
        return float("nan"), float("nan")
    final = running[-1]
    late = counts >= counts[-1] / 2
    moves = np.abs(running[late] - final) / np.where(final != 0.0, np.abs(final), np.nan)
    return float(np.max(moves[:, 0])), float(np.max(moves[:, 1]))


def convergence(data: StudyData, stats: list[JointStats]) -> list[Convergence]:
    """The convergence of every controller's joint statistics (``stats`` from
    ``results.joint_stats``)."""
    found = []
    for entry in stats:
        median_drift, p95_drift = _drift(data.rms_q[entry.controller][:, entry.joint - 1])
        found.append(
            Convergence(
                controller=entry.controller,
                joint=entry.joint,
                runs=entry.count,
                median_precision=_precision(entry.median_interval),
                p95_precision=_precision(entry.p95_interval),
                median_drift=median_drift,
                p95_drift=p95_drift,
            )
        )
    return found


def _percent(value: float) -> str:
    return "-" if not np.isfinite(value) else f"{100 * value:.1f} %"


def markdown(found: list[Convergence], samples: int) -> list[str]:
    """The section's Markdown lines."""
    enough = [
        entry.median_precision <= PRECISION and entry.p95_precision <= PRECISION for entry in found
    ]
    worst = max((e.p95_precision for e in found if np.isfinite(e.p95_precision)), default=np.nan)
    verdict = (
        f"**{samples} samples are enough** by this criterion for every controller and joint."
        if all(enough)
        else f"**{samples} samples are not enough** for {len(enough) - sum(enough)} of "
        f"{len(enough)} controller-joint statistics by this criterion (the widest 95th-"
        f"percentile interval is ±{_percent(worst)}); the 95th percentile needs about "
        f"{_samples_needed(worst, samples)} samples for ±{PRECISION:.0%}."
    )
    lines = [
        "## Were there enough samples?",
        "",
        "Half-width of the 95 % bootstrap interval relative to the statistic, and the largest "
        "relative move of the running statistic over the second half of the samples "
        f"(figure `convergence`). Criterion: half-width <= {PRECISION:.0%}. {verdict}",
        "",
        "| controller | joint | runs | median ± | median moved | 95th pct ± | 95th pct moved |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for entry in found:
        lines.append(
            f"| {entry.controller} | {entry.joint} | {entry.runs} | "
            f"{_percent(entry.median_precision)} | {_percent(entry.median_drift)} | "
            f"{_percent(entry.p95_precision)} | {_percent(entry.p95_drift)} |"
        )
    lines += ["", "![convergence](convergence.png)", "", "![ecdf](ecdf.png)", ""]
    return lines


def _samples_needed(precision: float, samples: int) -> str:
    """Interval widths shrink like 1/sqrt(N): the N that reaches ``PRECISION``."""
    if not np.isfinite(precision) or precision <= PRECISION:
        return str(samples)
    return f"{int(np.ceil(samples * (precision / PRECISION) ** 2)):,}"


def plot(data: StudyData, out: Path) -> tuple[Figure, Figure]:
    """Write ``convergence`` and ``ecdf`` (PNG and SVG) into ``out``; return both figures
    (each with its legend below the panels)."""
    figure, axes = joint_panels(data.joints, sharey=False)
    for joint, axis in enumerate(axes):
        for k, controller in enumerate(data.controllers):
            counts, running = running_quantiles(data.rms_q[controller][:, joint], QUANTILES)
            colour = f"C{k}"
            axis.plot(counts, running[:, 0], color=colour, label=f"{controller} median")
            axis.plot(counts, running[:, 1], "--", color=colour, label=f"{controller} 95th pct")
        label_joint_panel(axis, joint, "RMS tracking error (rad)", "finished runs (sample order)")
    legend_below(figure)
    figure.suptitle("Running median and 95th percentile: did the statistics settle?", y=1.02)
    save_report_figure(figure, out, "convergence")
    settled = figure

    figure, axes = joint_panels(data.joints)
    for joint, axis in enumerate(axes):
        for controller in data.controllers:
            values, probability = ecdf(data.rms_q[controller][:, joint])
            axis.step(values, probability, where="post", label=controller)
        label_joint_panel(
            axis, joint, "share of finished runs", "RMS tracking error (rad)", log="x"
        )
    legend_below(figure)
    figure.suptitle("Empirical distribution of the RMS error per controller", y=1.02)
    save_report_figure(figure, out, "ecdf")
    return settled, figure
