"""Figures 4-7 of the paper from simulated runs (matplotlib, no display needed).

* ``positions_and_voltages`` (Figs. 4, 6): (a), (b) joint positions with the
  desired trajectory; (c), (d) applied armature voltages.
* ``tracking_errors`` (Figs. 5, 7): (a), (b) ``q~ = q - q_d`` over the whole
  run; (c), (d) a 4 s close-up (8-12 s for a 20 s run).

Line styles follow the paper (PID solid, Lin+LC dashed, the proposed controller
dotted, the desired trajectory dash-dotted); each controller's style and legend label
are its ``ControllerSpec``'s (``models.controllers.registry``).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import matplotlib
import numpy as np
from matplotlib.axes import Axes
from matplotlib.figure import Figure

from posfb.diagrams.closed_loop import ClosedLoopResult

DESIRED_STYLE = {"linestyle": "-.", "color": "black", "linewidth": 0.9}


def closeup_window(duration: float) -> tuple[float, float]:
    """The paper's 8-12 s close-up, or the middle fifth of a shorter run."""
    if duration >= 12.0:
        return 8.0, 12.0
    return 0.4 * duration, 0.6 * duration


def _line(
    name: str, result: ClosedLoopResult, label_suffix: Mapping[str, str] | None
) -> tuple[dict[str, object], str]:
    """The line style and legend entry of ``results[name]``: its controller's
    (``ControllerSpec``), with any suffix given for ``name``. A run under a name other
    than its kind (a named entry, e.g. the paper's controller twice) is labelled with
    that name and takes the next colour of matplotlib's cycle instead of its kind's."""
    spec = result.config.spec
    label = spec.label + (label_suffix or {}).get(name, "")
    if name == spec.kind:
        return dict(spec.style), label
    style = {key: value for key, value in spec.style.items() if key != "color"}
    return style, f"{name}: {label}"


def _panel_letter(index: int) -> str:
    """``a, b, ..., z, aa, ab, ...``: the label of panel ``index`` (0-based)."""
    return (
        _panel_letter(index // 26 - 1) + chr(ord("a") + index % 26)
        if index >= 26
        else (chr(ord("a") + index))
    )


def _joint_grid(joints: int, sharex: bool) -> tuple[Figure, np.ndarray]:
    """Two rows of one panel per joint (Figs. 4-7 for two joints: 1100 x 700 px)."""
    figure = Figure(figsize=(5.5 * max(joints, 2), 7), layout="constrained")
    return figure, figure.subplots(2, joints, sharex=sharex, squeeze=False)


def positions_and_voltages(
    results: Mapping[str, ClosedLoopResult],
    title: str,
    label_suffix: Mapping[str, str] | None = None,
) -> Figure:
    """Figs. 4/6: positions with the desired trajectory, then applied voltages (one
    column per joint)."""
    first = next(iter(results.values()))
    joints = first.q_true.shape[1]
    figure, axes = _joint_grid(joints, sharex=True)
    for j in range(joints):
        axes[0, j].plot(first.times, first.q_desired[:, j], label="desired", **DESIRED_STYLE)
    for kind, result in results.items():
        style, label = _line(kind, result, label_suffix)
        for j in range(joints):
            axes[0, j].plot(result.times, result.q_true[:, j], label=label, **style)
            axes[1, j].plot(result.times, result.u_applied[:, j], **style)
    for j in range(joints):
        axes[0, j].set_title(f"({_panel_letter(j)}) joint {j + 1} position")
        axes[0, j].set_ylabel(f"q{j + 1} (rad)")
        axes[1, j].set_title(
            f"({_panel_letter(joints + j)}) joint {j + 1} armature voltage (applied)"
        )
        axes[1, j].set_ylabel(f"u{j + 1} (V)")
        axes[1, j].set_xlabel("t (s)")
    axes[0, 0].legend(loc="best", fontsize="small")
    figure.suptitle(title)
    return figure


def tracking_errors(
    results: Mapping[str, ClosedLoopResult],
    title: str,
    label_suffix: Mapping[str, str] | None = None,
) -> Figure:
    """Figs. 5/7: ``q~`` of every joint over the run and in the close-up window."""
    first = next(iter(results.values()))
    joints = first.q_true.shape[1]
    figure, axes = _joint_grid(joints, sharex=False)
    start, stop = closeup_window(float(first.times[-1]))
    for kind, result in results.items():
        error = result.q_error
        window = (result.times >= start) & (result.times <= stop)
        style, label = _line(kind, result, label_suffix)
        for j in range(joints):
            axes[0, j].plot(result.times, error[:, j], label=label, **style)
            axes[1, j].plot(result.times[window], error[window, j], **style)
    for j in range(joints):
        axes[0, j].set_title(f"({_panel_letter(j)}) joint {j + 1}: t = 0-{first.times[-1]:g} s")
        axes[1, j].set_title(
            f"({_panel_letter(joints + j)}) joint {j + 1}: t = {start:g}-{stop:g} s"
        )
        for row in range(2):
            axes[row, j].set_ylabel(f"q~{j + 1} (rad)")
            axes[row, j].axhline(0.0, color="grey", linewidth=0.5)
        axes[1, j].set_xlabel("t (s)")
    axes[0, 0].legend(loc="best", fontsize="small")
    figure.suptitle(title)
    return figure


def save(
    figure: Figure, directory: Path, stem: str, dpi: int = 100, tight: bool = False
) -> list[Path]:
    """Write ``stem.png`` (at ``dpi``; 1100 x 700 px for the Figs. 4-7 layout) and
    ``stem.svg`` into ``directory``. The SVG carries no date and fixed element ids,
    so re-running on the same data rewrites identical files."""
    paths = [directory / f"{stem}.png", directory / f"{stem}.svg"]
    bbox = "tight" if tight else None
    with matplotlib.rc_context({"svg.hashsalt": "posfb"}):
        figure.savefig(paths[0], dpi=dpi, bbox_inches=bbox)
        figure.savefig(paths[1], bbox_inches=bbox, metadata={"Date": None})
    return paths


def log_scale(axis: Axes, which: str = "y", empty: str = "no finished runs") -> None:
    """A log scale on ``which`` (``"x"`` or ``"y"``) when the axis's lines hold a
    positive value; otherwise the axis stays linear and says ``empty`` (a log axis
    with no positive data cannot be drawn)."""
    values = [np.asarray(getattr(line, f"get_{which}data")(), dtype=float) for line in axis.lines]
    if any(np.any(np.isfinite(v) & (v > 0.0)) for v in values):
        getattr(axis, f"set_{which}scale")("log")
    else:
        axis.text(0.5, 0.5, empty, transform=axis.transAxes, ha="center", va="center")


#: Resolution (dpi) of the Monte-Carlo report's figures.
REPORT_DPI = 120


def joint_panels(
    joints: int, sharey: bool = True, width: float = 10.0
) -> tuple[Figure, np.ndarray]:
    """A figure (no pyplot state, no GUI backend) with one panel per joint, ``width``
    inches for two joints and as much again per two more."""
    figure = Figure(figsize=(width * max(joints, 2) / 2, 4))
    return figure, figure.subplots(1, joints, sharey=sharey, squeeze=False)[0]


def label_joint_panel(
    axis: Axes, joint: int, ylabel: str, xlabel: str | None = None, log: str = "y"
) -> None:
    """Finish the panel of ``joint`` (0-based): a log scale on ``log`` (``log_scale``),
    the axis labels, the title ``joint <n>`` and a grid."""
    log_scale(axis, log)
    if xlabel is not None:
        axis.set_xlabel(xlabel)
    axis.set_ylabel(ylabel)
    axis.set_title(f"joint {joint + 1}")
    axis.grid(True, which="both", alpha=0.3)


def save_report_figure(figure: Figure, directory: Path, stem: str) -> list[Path]:
    """``save`` at ``REPORT_DPI`` with a tight bounding box (the report's figures)."""
    return save(figure, directory, stem, dpi=REPORT_DPI, tight=True)
