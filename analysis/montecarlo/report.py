"""Statistics, figures and a Markdown report of a Monte-Carlo store.

Conventions (stated in the report too):

* The RMS statistics use the runs with status ``ok`` only: a diverged run stops
  early, so its RMS covers a different time span; it counts as a failure
  (``diverged`` or ``error``) instead.
* "The paper's controller beats PID" on a sample when ``proposed`` finished
  (``ok``) and either PID did not, or the proposed controller's tracking error
  ``||(rms_q1, rms_q2)||`` is smaller. The share is over the samples where
  neither run is an ``error``.
* Inside/outside: the sample's identified plant against the Assumption-1 bounds
  of the controller design (``analysis.montecarlo.coverage``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from posfb.analysis.montecarlo.config import Study
from posfb.analysis.montecarlo.coverage import BOUND_NAMES
from posfb.analysis.montecarlo.records import STATUSES
from posfb.analysis.montecarlo.store import ResultStore
from posfb.analysis.plots import save
from posfb.diagrams.scenario import Wave

#: A run "saturates often" when more than this share of its control samples
#: command a voltage beyond the limit.
SATURATION_SHARE = 0.1

#: Figure files written next to the report (each as .png and .svg).
FIGURES = ("rms_distributions", "rms_vs_payload", "rms_inside_outside")


@dataclass(frozen=True)
class StudyData:
    """A store's results as arrays aligned by sample (row ``i`` is ``samples[i]``).

    ``rms_q[controller]`` has shape ``(n, 2)`` and ``saturated[controller]`` (the share
    of control samples with a commanded voltage beyond the limit) shape ``(n,)``, NaN
    where the run is not ``ok``; ``status[controller]`` holds the status strings."""

    study: Study
    meta: dict[str, str]
    samples: np.ndarray
    payload: np.ndarray
    inside: np.ndarray
    exceeded: dict[str, int]
    code_versions: tuple[str, ...]
    controllers: tuple[str, ...]
    rms_q: dict[str, np.ndarray]
    saturated: dict[str, np.ndarray]
    status: dict[str, np.ndarray]
    messages: dict[str, list[str]]


@dataclass(frozen=True)
class JointStats:
    """RMS tracking error (rad) of one controller at one joint over its ``ok`` runs."""

    controller: str
    joint: int
    count: int
    mean: float
    median: float
    p95: float
    max: float


def load(store: ResultStore) -> StudyData:
    """Read every finished sample of ``store``."""
    study = store.study()
    samples = store.sample_rows()
    index = {row["sample"]: i for i, row in enumerate(samples)}
    n = len(samples)
    rms_q = {c: np.full((n, 2), np.nan) for c in study.controllers}
    saturated = {c: np.full(n, np.nan) for c in study.controllers}
    status = {c: np.full(n, "error", dtype=object) for c in study.controllers}
    messages: dict[str, list[str]] = {c: [] for c in study.controllers}
    for run in store.run_rows():
        i, controller = index[run["sample"]], run["controller"]
        status[controller][i] = run["status"]
        if run["status"] == "ok":
            rms_q[controller][i] = (run["rms_q1"], run["rms_q2"])
            saturated[controller][i] = run["saturated_fraction"]
        elif run["message"]:
            messages[controller].append(f"sample {run['sample']}: {run['message']}")
    return StudyData(
        study=study,
        meta=store.meta(),
        samples=np.array([row["sample"] for row in samples], dtype=int),
        payload=np.array([row["payload_mass"] for row in samples], dtype=float),
        inside=np.array([row["inside_bounds"] for row in samples], dtype=bool),
        exceeded={
            name: sum(row["bound_ratios"][name] > 1.0 for row in samples) for name in BOUND_NAMES
        },
        code_versions=tuple(sorted({row["code_version"] for row in samples})),
        controllers=tuple(study.controllers),
        rms_q=rms_q,
        saturated=saturated,
        status=status,
        messages=messages,
    )


def joint_stats(data: StudyData) -> list[JointStats]:
    """Mean, median, 95th percentile and max of the RMS error per controller and joint."""
    stats = []
    for controller in data.controllers:
        for joint in (0, 1):
            values = data.rms_q[controller][:, joint]
            values = values[np.isfinite(values)]
            if values.size == 0:
                stats.append(JointStats(controller, joint + 1, 0, *(4 * [float("nan")])))
                continue
            stats.append(
                JointStats(
                    controller=controller,
                    joint=joint + 1,
                    count=int(values.size),
                    mean=float(np.mean(values)),
                    median=float(np.median(values)),
                    p95=float(np.percentile(values, 95)),
                    max=float(np.max(values)),
                )
            )
    return stats


def status_counts(data: StudyData) -> dict[str, dict[str, int]]:
    """``{controller: {status: count}}``."""
    return {c: {s: int(np.sum(data.status[c] == s)) for s in STATUSES} for c in data.controllers}


def beats(data: StudyData, challenger: str = "proposed", baseline: str = "pid") -> tuple[int, int]:
    """``(wins, comparable)``: samples where ``challenger`` beats ``baseline`` (module
    docstring) and samples where neither run is an error."""
    ours, theirs = data.status[challenger], data.status[baseline]
    comparable = (ours != "error") & (theirs != "error")
    ours_error = np.linalg.norm(data.rms_q[challenger], axis=1)
    theirs_error = np.linalg.norm(data.rms_q[baseline], axis=1)
    better = (ours == "ok") & ((theirs != "ok") | (ours_error < theirs_error))
    return int(np.sum(better & comparable)), int(np.sum(comparable))


def _save(figure: Figure, out: Path, name: str) -> None:
    save(figure, out, name, dpi=120, tight=True)


def _two_joint_axes() -> tuple[Figure, np.ndarray]:
    """A figure (no pyplot state, no GUI backend) with one panel per joint."""
    figure = Figure(figsize=(10, 4))
    return figure, figure.subplots(1, 2, sharey=True)


def _ok_values(data: StudyData, controller: str, joint: int, mask: np.ndarray) -> np.ndarray:
    values = data.rms_q[controller][mask, joint]
    return values[np.isfinite(values)]


def plot_distributions(data: StudyData, out: Path) -> None:
    """Box plots (with every sample as a dot) of the RMS error per controller and joint."""
    figure, axes = _two_joint_axes()
    everything = np.ones(len(data.samples), dtype=bool)
    for joint, axis in enumerate(axes):
        values = [_ok_values(data, c, joint, everything) for c in data.controllers]
        positions = np.arange(1, len(values) + 1)
        kept = [(p, v) for p, v in zip(positions, values, strict=True) if v.size]
        if kept:
            axis.boxplot([v for _, v in kept], positions=[p for p, _ in kept], showfliers=False)
        jitter = np.random.default_rng(0)
        for position, v in zip(positions, values, strict=True):
            axis.plot(position + jitter.uniform(-0.15, 0.15, v.size), v, ".", alpha=0.4)
        axis.set_xticks(positions, data.controllers)
        axis.set_yscale("log")
        axis.set_title(f"joint {joint + 1}")
        axis.set_ylabel("RMS tracking error (rad)")
        axis.grid(True, which="both", alpha=0.3)
    figure.suptitle("RMS tracking error over the sampled plants (runs that finished)", y=1.02)
    _save(figure, out, "rms_distributions")


def plot_against_payload(data: StudyData, out: Path) -> None:
    """RMS error against the sampled tip payload, per joint, one colour per controller."""
    figure, axes = _two_joint_axes()
    for joint, axis in enumerate(axes):
        for controller in data.controllers:
            values = data.rms_q[controller][:, joint]
            ok = np.isfinite(values)
            axis.plot(data.payload[ok], values[ok], ".", alpha=0.6, label=controller)
        axis.set_yscale("log")
        axis.set_xlabel("tip payload (kg)")
        axis.set_ylabel("RMS tracking error (rad)")
        axis.set_title(f"joint {joint + 1}")
        axis.grid(True, which="both", alpha=0.3)
    axes[0].legend()
    _save(figure, out, "rms_vs_payload")


def plot_inside_outside(data: StudyData, out: Path) -> None:
    """RMS error per controller for plants inside (blue) and outside (orange) the
    Assumption-1 bounds."""
    figure, axes = _two_joint_axes()
    groups = ((data.inside, "inside", "tab:blue"), (~data.inside, "outside", "tab:orange"))
    for joint, axis in enumerate(axes):
        for offset, (mask, name, colour) in zip((-0.2, 0.2), groups, strict=True):
            kept = [
                (k, v)
                for k, c in enumerate(data.controllers)
                if (v := _ok_values(data, c, joint, mask)).size
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
        axis.set_yscale("log")
        axis.set_title(f"joint {joint + 1}")
        axis.set_ylabel("RMS tracking error (rad)")
        axis.grid(True, which="both", alpha=0.3)
    axes[0].legend()
    figure.suptitle("Plants inside vs outside the Assumption-1 bounds of the design", y=1.02)
    _save(figure, out, "rms_inside_outside")


def _number(value: float) -> str:
    return "-" if not np.isfinite(value) else f"{value:.4g}"


def markdown(data: StudyData, title: str = "Monte-Carlo robustness study") -> str:
    """The report as Markdown (figures referenced by relative path)."""
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
        f"{', '.join(data.controllers)}; controllers keep the nominal Table 1 model"
        f"{design}. Code: {', '.join(data.code_versions) or data.meta.get('code_version', '?')}.",
        "",
        "## RMS tracking error (rad), runs that finished",
        "",
        "| controller | joint | runs | mean | median | 95th pct | max |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for s in joint_stats(data):
        lines.append(
            f"| {s.controller} | {s.joint} | {s.count} | {_number(s.mean)} | "
            f"{_number(s.median)} | {_number(s.p95)} | {_number(s.max)} |"
        )
    lines += [
        "",
        "## Failures and saturation",
        "",
        "| controller | ok | diverged | error | runs saturated > "
        f"{SATURATION_SHARE:.0%} of the time | largest saturated share |",
        "|---|---:|---:|---:|---:|---:|",
    ]
    for controller, counts in status_counts(data).items():
        row = " | ".join(str(counts[status]) for status in STATUSES)
        shares = data.saturated[controller]
        often = int(np.sum(shares > SATURATION_SHARE))
        largest = _number(float(np.nanmax(shares))) if np.any(np.isfinite(shares)) else "-"
        lines.append(f"| {controller} | {row} | {often} | {largest} |")
    failures = [m for c in data.controllers for m in data.messages[c][:3]]
    if failures:
        lines += ["", "First failure messages per controller:", ""]
        lines += [f"- {m}" for m in failures]
    if {"proposed", "pid"} <= set(data.controllers):
        wins, comparable = beats(data)
        share = f"{100 * wins / comparable:.1f} %" if comparable else "-"
        lines += [
            "",
            "## The paper's controller against PID",
            "",
            f"The proposed controller beats computed torque + PID on **{wins} of "
            f"{comparable}** samples ({share}): it finished and its tracking error "
            "`||(rms_q1, rms_q2)||` is smaller, or PID did not finish.",
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
        "| controller | median RMS j1 inside | outside | median RMS j2 inside | outside "
        "| failures inside | outside |",
        "|---|---:|---:|---:|---:|---:|---:|",
    ]
    for controller in data.controllers:
        medians = [
            _number(float(np.median(v))) if (v := _ok_values(data, controller, j, m)).size else "-"
            for j in (0, 1)
            for m in (data.inside, ~data.inside)
        ]
        failed = data.status[controller] != "ok"
        lines.append(
            f"| {controller} | {' | '.join(medians)} | {int(np.sum(failed & data.inside))} | "
            f"{int(np.sum(failed & ~data.inside))} |"
        )
    lines += ["", "## Figures", ""]
    lines += [f"![{name}]({name}.png)" for name in FIGURES]
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
    plot_distributions(data, out)
    plot_against_payload(data, out)
    plot_inside_outside(data, out)
    path = out / "report.md"
    path.write_text(markdown(data))
    return path
