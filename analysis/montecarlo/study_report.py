"""Statistics, figures and a Markdown report of a Monte-Carlo store.

The data and its conventions (which runs enter the RMS statistics, what "beats
PID" means) are ``analysis.montecarlo.results``. Every median and 95th
percentile comes with a percentile-bootstrap 95 % interval and every share with
a Wilson 95 % interval (``analysis.uncertainty.statistics``, seeded, so the same
store writes the same report). Inside/outside: the sample's identified plant
against the Assumption-1 bounds of the controller design
(``analysis.uncertainty.coverage``). The answers come in sections of their own:
per-sample sampled-data stability (``stability``), the loops' margins over the
plants (``margins``), sensitivity (``sensitivity``) and whether N was enough
(``convergence``).
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass, replace
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
from posfb.analysis.common.side_by_side import Call, available_cores, beside
from posfb.analysis.montecarlo import convergence, margins, sensitivity, stability
from posfb.analysis.montecarlo.records import FINISHED, STATUSES
from posfb.analysis.montecarlo.results import (
    JointStats,
    StudyData,
    beats,
    joint_stats,
    load,
    ok_values,
    status_counts,
)
from posfb.analysis.montecarlo.store import ResultStore
from posfb.analysis.uncertainty.statistics import (
    MIN_INFERENCE_ROWS,
    Interval,
    proportion_interval,
)
from posfb.diagrams.scenario import (
    Identified,
    IdentifiedFromUrdf,
    Scenario,
    Theta,
    UrdfModel,
    Wave,
)
from posfb.models.controllers import PAPER_BASELINE, PAPER_CONTROLLER

#: A run "saturates often" when more than this share of its control samples
#: command a voltage beyond the limit.
SATURATION_SHARE = 0.1

#: Payload bins of the median line of ``rms_vs_payload`` (``payload_medians``).
PAYLOAD_BINS = 12

#: Box plots' median line: black, above the box's face.
MEDIAN_STYLE = {"color": "black", "linewidth": 1.6, "zorder": 4}

#: Figure files written next to every report (each as .png and .svg); ``rms_vs_radius``
#: joins them when some controller has a designed loop (``stability``).
FIGURES = (
    "rms_distributions", "rms_vs_payload", "rms_inside_outside", "sensitivity", "convergence",
    "ecdf",
)  # fmt: skip


def _nominal_text(base: Scenario) -> str:
    """The nominal model the controllers keep, in words."""
    nominal = base.nominal_model
    if isinstance(nominal, UrdfModel):
        return f"the nominal model Drake computes from {Path(nominal.urdf).name}"
    if isinstance(nominal, IdentifiedFromUrdf):
        return f"the theta model identified from {Path(nominal.urdf).name}"
    if isinstance(nominal, Theta):
        return "the given nominal theta model"
    if isinstance(nominal, Identified):
        return f"the theta model identified from a log ({Path(nominal.file).name})"
    return "the nominal Table 1 model"


def plot_distributions(data: StudyData, out: Path) -> Figure:
    """Box plots (median in black above the box) of the RMS error per controller and
    joint, with up to ``MAX_DOTS`` of the samples as dots beside them (``thinned``);
    saved as ``rms_distributions`` into ``out`` and returned."""
    figure, axes = joint_panels(data.joints)
    everything = np.ones(len(data.samples), dtype=bool)
    for joint, axis in enumerate(axes):
        values = [ok_values(data, c, joint, everything) for c in data.controllers]
        positions = np.arange(1, len(values) + 1)
        kept = [(p, v) for p, v in zip(positions, values, strict=True) if v.size]
        if kept:
            axis.boxplot([v for _, v in kept], positions=[p for p, _ in kept], showfliers=False,
                         medianprops=MEDIAN_STYLE, zorder=3)  # fmt: skip
        jitter = np.random.default_rng(0)
        for position, v in zip(positions, values, strict=True):
            (dots,) = thinned(v)
            axis.plot(position + jitter.uniform(-0.15, 0.15, dots.size), dots, ".",
                      markersize=3, alpha=dot_alpha(dots.size), zorder=2)  # fmt: skip
        axis.set_xticks(positions, data.controllers)
        label_joint_panel(axis, joint, "RMS tracking error (rad)")
    figure.suptitle("RMS tracking error over the sampled plants (runs that finished)", y=1.02)
    save_report_figure(figure, out, "rms_distributions")
    return figure


def payload_medians(payload: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The median of ``values`` in ``PAYLOAD_BINS`` payload bins of equal counts: the bins'
    median payloads and the medians (one bin when the payload does not vary)."""
    order = np.argsort(payload, kind="stable")
    bins = [b for b in np.array_split(order, min(PAYLOAD_BINS, payload.size)) if b.size]
    return (np.array([np.median(payload[b]) for b in bins]),
            np.array([np.median(values[b]) for b in bins]))  # fmt: skip


def plot_against_payload(data: StudyData, out: Path) -> Figure:
    """RMS error against the sampled tip payload, per joint, one colour per controller:
    the median over payload bins as a line (``payload_medians``) and up to ``MAX_DOTS``
    samples as faint dots (``thinned``); saved as ``rms_vs_payload`` and returned."""
    figure, axes = joint_panels(data.joints)
    for joint, axis in enumerate(axes):
        for k, controller in enumerate(data.controllers):
            values = data.rms_q[controller][:, joint]
            ok = np.isfinite(values)
            if not np.any(ok):
                continue
            colour = f"C{k}"
            dots, payload = thinned(values[ok], data.payload[ok])
            axis.plot(payload, dots, ".", color=colour, markersize=3,
                      alpha=dot_alpha(dots.size))  # fmt: skip
            axis.plot(*payload_medians(data.payload[ok], values[ok]), "-", color=colour,
                      linewidth=1.8, label=f"{controller} (median)")  # fmt: skip
        label_joint_panel(axis, joint, "RMS tracking error (rad)", "tip payload (kg)")
    legend_below(figure)
    figure.suptitle("RMS tracking error against the sampled tip payload (runs that finished)",
                    y=1.02)  # fmt: skip
    save_report_figure(figure, out, "rms_vs_payload")
    return figure


def plot_inside_outside(data: StudyData, out: Path) -> Figure:
    """RMS error per controller for plants inside (blue) and outside (orange) the
    Assumption-1 bounds; each box's median in black, drawn above the box; saved as
    ``rms_inside_outside`` and returned."""
    figure, axes = joint_panels(data.joints)
    groups = ((data.inside, "inside", "tab:blue"), (~data.inside, "outside", "tab:orange"))
    for joint, axis in enumerate(axes):
        for offset, (mask, name, colour) in zip((-0.2, 0.2), groups, strict=True):
            kept = [
                (k, v)
                for k, c in enumerate(data.controllers)
                if (v := ok_values(data, c, joint, mask)).size
            ]
            if not kept:
                continue
            boxes = axis.boxplot(
                [v for _, v in kept],
                positions=[k + offset for k, _ in kept],
                widths=0.35,
                patch_artist=True,
                medianprops=MEDIAN_STYLE,
            )
            for box in boxes["boxes"]:
                box.set_facecolor(colour)
                box.set_alpha(0.6)
            axis.plot([], [], "s", color=colour, label=f"{name} ({int(np.sum(mask))} plants)")
        axis.set_xticks(range(len(data.controllers)), data.controllers)
        label_joint_panel(axis, joint, "RMS tracking error (rad)")
    legend_below(figure)
    figure.suptitle("Plants inside vs outside the Assumption-1 bounds of the design", y=1.02)
    save_report_figure(figure, out, "rms_inside_outside")
    return figure


def _number(value: float) -> str:
    return "-" if not np.isfinite(value) else f"{value:.4g}"


def _interval(interval: Interval, count: int) -> str:
    """The estimate with its interval; the estimate alone below ``MIN_INFERENCE_ROWS``."""
    if not np.isfinite(interval.estimate):
        return "-"
    return interval.without_interval(count).text(4)


def _share(interval: Interval) -> str:
    """A proportion and its interval in percent."""
    if not np.isfinite(interval.estimate):
        return "-"
    return f"{100 * interval.estimate:.1f} % [{100 * interval.low:.1f}, {100 * interval.high:.1f}]"


@dataclass(frozen=True)
class Answers:
    """What the report computes from a store before writing it."""

    stats: list[JointStats]
    loops: list[stability.LoopStability]
    margins: list[margins.MarginSummary]
    ranked: list[sensitivity.Sensitivity]
    settled: list[convergence.Convergence]


def answers(data: StudyData, with_margins: bool = True) -> Answers:
    """What the report computes (without ``with_margins``, no margins: the report
    computes them beside its figures, ``write_report``)."""
    stats = joint_stats(data)
    return Answers(
        stats=stats,
        loops=stability.loop_stability(data),
        margins=margins.margin_summaries(data) if with_margins else [],
        ranked=sensitivity.sensitivities(data),
        settled=convergence.convergence(data, stats),
    )


def markdown(
    data: StudyData, found: Answers | None = None, title: str = "Monte-Carlo robustness study"
) -> str:
    """The report as Markdown (figures referenced by relative path)."""
    found = answers(data) if found is None else found
    stats, loops, ranked, settled = found.stats, found.loops, found.ranked, found.settled
    study, n = data.study, len(data.samples)
    design = (
        ""
        if study.alpha_star is None
        else f" and the paper's design except **alpha* = {study.alpha_star:g}** (the paper: 4)"
    )
    base = study.base_scenario()
    counts = study.encoder_counts or base.sensor.encoder_counts
    drawn = "".join(f", {key} drawn" for key in study.draws)
    paper = base.trajectory == Wave()
    trajectory = "the Sec. 4.2 trajectory" if paper else f"a {type(base.trajectory).__name__} path"
    missing = study.samples - n
    unfinished = (
        [f"**Unfinished study: {missing} of {study.samples} samples are missing**; "
         "`posfb montecarlo run` with the same study and store resumes it.", ""]
        if missing > 0 else []
    )  # fmt: skip
    lines = [
        f"# {title}",
        "",
        *unfinished,
        f"{n} sampled plants (seed {study.seed}, {base.timing.duration:g} s of "
        f"{trajectory} at T_s = {base.timing.sample_time:g} s each, encoder counts "
        f"{counts}{drawn}), every plant run under "
        f"{', '.join(data.controllers)}; controllers keep {_nominal_text(base)}"
        f"{design}. Code: {', '.join(data.code_versions) or data.meta.get('code_version', '?')}.",
        "",
        "## RMS tracking error (rad), runs that finished",
        "",
        "Medians and 95th percentiles with their percentile-bootstrap 95 % intervals "
        f"(none with fewer than {MIN_INFERENCE_ROWS} runs).",
        "",
        "| controller | joint | runs | mean | median [95 % CI] | 95th pct [95 % CI] | max |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for s in stats:
        lines.append(
            f"| {s.controller} | {s.joint} | {s.count} | {_number(s.mean)} | "
            f"{_interval(s.median_interval, s.count)} | {_interval(s.p95_interval, s.count)} | "
            f"{_number(s.max)} |"
        )
    lines += [
        "",
        "## Failures and saturation",
        "",
        "Shares of the runs with Wilson 95 % intervals. A run is `saturated` or `lost` "
        "when it finished but spent most of its second half at the voltage limit or far "
        "from its path (`analysis/metrics.py`); failed: it did not finish (`diverged`, "
        "`error`).",
        "",
        f"| controller | {' | '.join(STATUSES)} | failed share [95 % CI] | runs saturated > "
        f"{SATURATION_SHARE:.0%} of the time [95 % CI] | largest saturated share |",
        "|---|" + "---:|" * (len(STATUSES) + 3),
    ]
    for controller, counts in status_counts(data).items():
        row = " | ".join(str(counts[status]) for status in STATUSES)
        runs = sum(counts.values())
        finished = sum(counts[status] for status in FINISHED)
        failed = _share(proportion_interval(runs - finished, runs))
        shares = data.saturated[controller]
        often = int(np.sum(shares > SATURATION_SHARE))
        saturated = f"{often} ({_share(proportion_interval(often, runs))})"
        largest = _number(float(np.nanmax(shares))) if np.any(np.isfinite(shares)) else "-"
        lines.append(f"| {controller} | {row} | {failed} | {saturated} | {largest} |")
    failures = [m for c in data.controllers for m in data.messages[c][:3]]
    if failures:
        lines += ["", "First messages of the runs that are not `ok`, per controller:", ""]
        lines += [f"- {m}" for m in failures]
    if {PAPER_CONTROLLER, PAPER_BASELINE} <= set(data.controllers):
        wins, comparable = beats(data)
        share = _share(proportion_interval(wins, comparable)) if comparable else "-"
        lines += [
            "",
            "## The paper's controller against PID",
            "",
            f"The proposed controller beats computed torque + PID on **{wins} of "
            f"{comparable}** samples ({share}, Wilson 95 % interval): it finished and its "
            "tracking error `||(rms_q1, .., rms_qn)||` is smaller, or PID did not finish.",
        ]
    inside = int(np.sum(data.inside))
    lines += [
        "",
        "## Inside vs outside the Assumption-1 bounds",
        "",
        f"{inside} of {n} plants lie inside the bounds the controllers were designed with "
        "(every `||dX|| / D_X <= 1`). Plants exceeding each bound: "
        + ", ".join(f"`{k}` {v}" for k, v in data.exceeded.items())
        + ".",
        "",
        "| controller | "
        + "".join(f"median RMS j{j + 1} inside | outside | " for j in range(data.joints))
        + "failures inside | outside |",
        "|---|" + "---:|---:|" * data.joints + "---:|---:|",
    ]
    for controller in data.controllers:
        medians = [
            _number(float(np.median(v))) if (v := ok_values(data, controller, j, m)).size else "-"
            for j in range(data.joints)
            for m in (data.inside, ~data.inside)
        ]
        failed = ~np.isin(data.status[controller], FINISHED)
        lines.append(
            f"| {controller} | {' | '.join(medians)} | {int(np.sum(failed & data.inside))} | "
            f"{int(np.sum(failed & ~data.inside))} |"
        )
    lines += ["", *stability.markdown(loops)]
    lines += margins.markdown(found.margins, n)
    lines += sensitivity.markdown(ranked)
    lines += convergence.markdown(settled, n)
    lines += ["## Figures", ""]
    lines += [f"![{name}]({name}.png)" for name in FIGURES[:3]]
    lines += [
        "",
        "RMS statistics use the runs that finished (`ok`, `saturated`, `lost`); a diverged "
        "run stops early and counts as a failure instead.",
        "",
    ]
    return "\n".join(lines)


def draw_figure(plot: Callable[..., object], arguments: tuple[object, ...], say: object) -> None:
    """``plot(*arguments)`` in a worker process (``analysis.common.side_by_side``): a
    figure written to its folder, nothing sent back."""
    plot(*arguments)


def write_report(
    store: ResultStore, out: str | Path, progress: Callable[[str], None] | None = None
) -> Path:
    """Write ``report.md`` and the figures (PNG and SVG) into ``out``; return the
    report's path. ``progress`` gets a line at each step.

    The sensitivity figure (a panel per controller and joint) and each controller's
    margins over the sampled plants are computed in processes of their own
    (``analysis.common.side_by_side.beside``, one per core) while this one draws the
    others: the same work on the same inputs, so the same report (issue 45)."""
    say = progress or (lambda text: None)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    say(f"reading {store.path}")
    data = load(store)
    if len(data.samples) == 0:
        raise ValueError(f"{store.path} holds no finished samples yet; nothing to report")
    say(f"the statistics, radii and margins of {len(data.samples)} samples")
    found = answers(data, with_margins=False)
    pending = beside(
        [
            Call("the sensitivity figure", draw_figure,
                 (sensitivity.plot, (found.ranked, data.controllers, data.joints, out))),
            *(Call(f"the margins of {inputs[1][0]} over the sampled plants",
                   margins.summaries_in_process, inputs)
              for inputs in margins.margin_inputs(data)),
        ],
        available_cores(),
        preload=[__name__],
    )  # fmt: skip
    figures = [
        lambda: plot_distributions(data, out),
        lambda: plot_against_payload(data, out),
        lambda: plot_inside_outside(data, out),
        *([lambda: stability.plot(data, found.loops, out)] if found.loops else []),
        lambda: convergence.plot(data, out),
    ]
    try:
        for number, draw in enumerate(figures, start=1):
            say(f"figure {number} of {len(figures)}")
            draw()
    except Exception:
        with contextlib.suppress(Exception):  # the work beside ends before the error leaves
            pending()
        raise
    say("the margins and the sensitivity figure")
    found = replace(found, margins=[summary for each in pending()[1:] for summary in each])
    path = out / "report.md"
    path.write_text(markdown(data, found))
    return path
