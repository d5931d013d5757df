"""Statistics, figures and a Markdown report of a Monte-Carlo store.

The data and its conventions (which runs enter the RMS statistics, what "beats
PID" means) are ``analysis.montecarlo.results``. Every median and 95th
percentile comes with a percentile-bootstrap 95 % interval and every share with
a Wilson 95 % interval (``analysis.montecarlo.statistics``, seeded, so the same
store writes the same report). Inside/outside: the sample's identified plant
against the Assumption-1 bounds of the controller design
(``analysis.montecarlo.coverage``). The answers come in sections of their own:
per-sample sampled-data stability (``stability``), sensitivity
(``sensitivity``) and whether N was enough (``convergence``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from posfb.analysis.montecarlo import convergence, sensitivity, stability
from posfb.analysis.montecarlo.records import STATUSES
from posfb.analysis.montecarlo.results import (
    JointStats,
    StudyData,
    beats,
    joint_stats,
    load,
    ok_values,
    status_counts,
)
from posfb.analysis.montecarlo.statistics import (
    MIN_INFERENCE_ROWS,
    Interval,
    proportion_interval,
)
from posfb.analysis.montecarlo.store import ResultStore
from posfb.analysis.plots import joint_panels, label_joint_panel, save_report_figure
from posfb.diagrams.scenario import IdentifiedFromUrdf, Scenario, Theta, UrdfModel, Wave

#: A run "saturates often" when more than this share of its control samples
#: command a voltage beyond the limit.
SATURATION_SHARE = 0.1

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
    return "the nominal Table 1 model"


def plot_distributions(data: StudyData, out: Path) -> None:
    """Box plots (with every sample as a dot) of the RMS error per controller and joint."""
    figure, axes = joint_panels(data.joints)
    everything = np.ones(len(data.samples), dtype=bool)
    for joint, axis in enumerate(axes):
        values = [ok_values(data, c, joint, everything) for c in data.controllers]
        positions = np.arange(1, len(values) + 1)
        kept = [(p, v) for p, v in zip(positions, values, strict=True) if v.size]
        if kept:
            axis.boxplot([v for _, v in kept], positions=[p for p, _ in kept], showfliers=False)
        jitter = np.random.default_rng(0)
        for position, v in zip(positions, values, strict=True):
            axis.plot(position + jitter.uniform(-0.15, 0.15, v.size), v, ".", alpha=0.4)
        axis.set_xticks(positions, data.controllers)
        label_joint_panel(axis, joint, "RMS tracking error (rad)")
    figure.suptitle("RMS tracking error over the sampled plants (runs that finished)", y=1.02)
    save_report_figure(figure, out, "rms_distributions")


def plot_against_payload(data: StudyData, out: Path) -> None:
    """RMS error against the sampled tip payload, per joint, one colour per controller."""
    figure, axes = joint_panels(data.joints)
    for joint, axis in enumerate(axes):
        for controller in data.controllers:
            values = data.rms_q[controller][:, joint]
            ok = np.isfinite(values)
            axis.plot(data.payload[ok], values[ok], ".", alpha=0.6, label=controller)
        label_joint_panel(axis, joint, "RMS tracking error (rad)", "tip payload (kg)")
    axes[0].legend()
    save_report_figure(figure, out, "rms_vs_payload")


def plot_inside_outside(data: StudyData, out: Path) -> None:
    """RMS error per controller for plants inside (blue) and outside (orange) the
    Assumption-1 bounds."""
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
            )
            for box in boxes["boxes"]:
                box.set_facecolor(colour)
                box.set_alpha(0.6)
            axis.plot([], [], "s", color=colour, label=f"{name} ({int(np.sum(mask))} plants)")
        axis.set_xticks(range(len(data.controllers)), data.controllers)
        label_joint_panel(axis, joint, "RMS tracking error (rad)")
    if axes[0].get_legend_handles_labels()[0]:
        axes[0].legend()
    figure.suptitle("Plants inside vs outside the Assumption-1 bounds of the design", y=1.02)
    save_report_figure(figure, out, "rms_inside_outside")


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
    ranked: list[sensitivity.Sensitivity]
    settled: list[convergence.Convergence]


def answers(data: StudyData) -> Answers:
    stats = joint_stats(data)
    return Answers(
        stats=stats,
        loops=stability.loop_stability(data),
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
        "Shares of the runs with Wilson 95 % intervals.",
        "",
        "| controller | ok | diverged | error | failed share [95 % CI] | runs saturated > "
        f"{SATURATION_SHARE:.0%} of the time [95 % CI] | largest saturated share |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for controller, counts in status_counts(data).items():
        row = " | ".join(str(counts[status]) for status in STATUSES)
        runs = sum(counts.values())
        failed = _share(proportion_interval(runs - counts["ok"], runs))
        shares = data.saturated[controller]
        often = int(np.sum(shares > SATURATION_SHARE))
        saturated = f"{often} ({_share(proportion_interval(often, runs))})"
        largest = _number(float(np.nanmax(shares))) if np.any(np.isfinite(shares)) else "-"
        lines.append(f"| {controller} | {row} | {failed} | {saturated} | {largest} |")
    failures = [m for c in data.controllers for m in data.messages[c][:3]]
    if failures:
        lines += ["", "First failure messages per controller:", ""]
        lines += [f"- {m}" for m in failures]
    if {"proposed", "pid"} <= set(data.controllers):
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
        failed = data.status[controller] != "ok"
        lines.append(
            f"| {controller} | {' | '.join(medians)} | {int(np.sum(failed & data.inside))} | "
            f"{int(np.sum(failed & ~data.inside))} |"
        )
    lines += ["", *stability.markdown(loops)]
    lines += sensitivity.markdown(ranked)
    lines += convergence.markdown(settled, n)
    lines += ["## Figures", ""]
    lines += [f"![{name}]({name}.png)" for name in FIGURES[:3]]
    lines += [
        "",
        "RMS statistics use finished (`ok`) runs; a diverged run stops early and counts "
        "as a failure instead.",
        "",
    ]
    return "\n".join(lines)


def write_report(store: ResultStore, out: str | Path) -> Path:
    """Write ``report.md`` and the figures (PNG and SVG) into ``out``; return the
    report's path."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    data = load(store)
    if len(data.samples) == 0:
        raise ValueError(f"{store.path} holds no finished samples yet; nothing to report")
    found = answers(data)
    plot_distributions(data, out)
    plot_against_payload(data, out)
    plot_inside_outside(data, out)
    if found.loops:
        stability.plot(data, found.loops, out)
    sensitivity.plot(found.ranked, data.controllers, data.joints, out)
    convergence.plot(data, out)
    path = out / "report.md"
    path.write_text(markdown(data, found))
    return path
