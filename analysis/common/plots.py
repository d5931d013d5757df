"""Figures 4-7 of the paper from simulated runs (matplotlib, no display needed).

* ``positions_and_voltages`` (Figs. 4, 6): (a), (b) joint positions with the
  desired trajectory; (c), (d) applied armature voltages.
* ``tracking_errors`` (Figs. 5, 7): (a), (b) the error over the whole run; (c), (d) a
  4 s close-up (8-12 s for a 20 s run). By default ``|q~|`` on a log axis, so that a
  controller with errors a hundred times smaller than another's stays readable;
  ``scale="linear"`` draws the paper's signed ``q~ = q - q_d``.

Line styles follow the paper (PID solid, Lin+LC dashed, the proposed controller
dotted, the desired trajectory dash-dotted); each controller's style and legend label
are its ``ControllerSpec``'s (``models.controllers.registry``; the label as
``label_for`` gives it for the run's settings). A line whose spec has no colour (a
user's plug-in), a named entry and a line whose colour another line of the figure
already has take the first colour of ``PALETTE`` that no registered kind and no other
line holds. The legend sits below the panels, never over a curve (``legend_below``).

The Monte-Carlo report's figures share the rest: one panel per joint (``joint_panels``,
``label_joint_panel``), at most ``MAX_DOTS`` samples drawn as dots (``thinned``,
``dot_alpha``) and ``save_report_figure``.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Literal

import matplotlib
import numpy as np
from matplotlib.axes import Axes
from matplotlib.colors import to_hex
from matplotlib.figure import Figure
from matplotlib.layout_engine import ConstrainedLayoutEngine

from posfb.analysis.common.outputs import atomic_file
from posfb.diagrams.runner import ClosedLoopResult
from posfb.models.controllers.registry import PALETTE, registered_colours

DESIRED_STYLE = {"linestyle": "-.", "color": "black", "linewidth": 0.9}

#: The error axes' scales ``tracking_errors`` draws: ``|q~|`` on a log axis, or the
#: signed ``q~`` on a linear one (the paper's Figs. 5/7).
ERROR_SCALES = ("log", "linear")

#: On the log error axes, the lower limit is this share of the smallest run's RMS error
#: of the joint (the dips of ``|q~|`` at its zero crossings would otherwise set it).
LOG_FLOOR = 1e-2


def closeup_window(duration: float) -> tuple[float, float]:
    """The paper's 8-12 s close-up, or the middle fifth of a shorter run."""
    if duration >= 12.0:
        return 8.0, 12.0
    return 0.4 * duration, 0.6 * duration


def line_styles(
    results: Mapping[str, ClosedLoopResult], label_suffix: Mapping[str, str] | None = None
) -> dict[str, tuple[dict[str, object], str]]:
    """The line style and legend entry of every run of ``results``, by name: its
    controller's (``ControllerSpec.style``, ``label_for`` its settings), with any suffix
    given for the name. A run under a name other than its kind (a named entry, e.g. the
    paper's controller twice) is labelled ``name: label``. Every line gets a colour no
    other line of the figure has (module docstring)."""
    lines: dict[str, tuple[dict[str, object], str]] = {}
    taken: set[str] = set()
    for name, result in results.items():
        spec = result.config.spec
        label = spec.label_for(result.config.design) + (label_suffix or {}).get(name, "")
        style = dict(spec.style)
        colour = style.get("color")
        if name != spec.kind:
            label = f"{name}: {label}"
            colour = None
        if colour is None or to_hex(colour) in taken:
            style["color"] = colour = _free_colour(taken)
        taken.add(to_hex(colour))
        lines[name] = style, label
    return lines


def _free_colour(taken: set[str]) -> str:
    """The first ``PALETTE`` colour that neither a registered kind nor a line in
    ``taken`` (hex colours) holds; once every one is held by a kind, the first no line
    holds; once every one is drawn, the next in turn."""
    kinds = {to_hex(colour) for colour in registered_colours()}
    for held in (kinds | taken, taken):
        free = [colour for colour in PALETTE if to_hex(colour) not in held]
        if free:
            return free[0]
    return PALETTE[len(taken) % len(PALETTE)]


def legend_below(figure: Figure, columns: int = 6) -> None:
    """One legend for the whole figure, below its panels (outside every axes): the
    labelled lines of all its axes, each label once, in ``columns`` columns at most.
    A constrained-layout figure makes room for it; otherwise it hangs below the
    figure's edge, inside the tight bounding box ``save_report_figure`` writes. Nothing
    without a label."""
    entries: dict[str, object] = {}
    for axis in figure.axes:
        for handle, label in zip(*axis.get_legend_handles_labels(), strict=True):
            entries.setdefault(label, handle)
    if not entries:
        return
    options = {"ncols": min(columns, len(entries)), "fontsize": "small", "frameon": False}
    if isinstance(figure.get_layout_engine(), ConstrainedLayoutEngine):
        figure.legend(list(entries.values()), list(entries), loc="outside lower center",
                      **options)  # fmt: skip
    else:
        figure.legend(list(entries.values()), list(entries), loc="upper center",
                      bbox_to_anchor=(0.5, 0.0), **options)  # fmt: skip


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
    styles = line_styles(results, label_suffix)
    for kind, result in results.items():
        style, label = styles[kind]
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
    legend_below(figure)
    figure.suptitle(title)
    return figure


def tracking_errors(
    results: Mapping[str, ClosedLoopResult],
    title: str,
    label_suffix: Mapping[str, str] | None = None,
    scale: Literal["log", "linear"] = "log",
) -> Figure:
    """Figs. 5/7: the error of every joint over the run and in the close-up window:
    ``|q~|`` on a log axis (``scale="log"``, from ``LOG_FLOOR`` times the smallest run's
    RMS error of the joint) or the signed ``q~`` (``"linear"``, the paper's)."""
    if scale not in ERROR_SCALES:
        raise ValueError(f"scale = {scale!r}; one of {', '.join(ERROR_SCALES)} is required")
    first = next(iter(results.values()))
    joints = first.q_true.shape[1]
    figure, axes = _joint_grid(joints, sharex=False)
    start, stop = closeup_window(float(first.times[-1]))
    styles = line_styles(results, label_suffix)
    for kind, result in results.items():
        error = np.abs(result.q_error) if scale == "log" else result.q_error
        window = (result.times >= start) & (result.times <= stop)
        style, label = styles[kind]
        for j in range(joints):
            axes[0, j].plot(result.times, error[:, j], label=label, **style)
            axes[1, j].plot(result.times[window], error[window, j], **style)
    name = "|q~{}|" if scale == "log" else "q~{}"
    for j in range(joints):
        axes[0, j].set_title(f"({_panel_letter(j)}) joint {j + 1}: t = 0-{first.times[-1]:g} s")
        axes[1, j].set_title(
            f"({_panel_letter(joints + j)}) joint {j + 1}: t = {start:g}-{stop:g} s"
        )
        for row in range(2):
            axes[row, j].set_ylabel(f"{name.format(j + 1)} (rad)")
            if scale == "log":
                _log_error_axis(axes[row, j], results, j)
            else:
                axes[row, j].axhline(0.0, color="grey", linewidth=0.5)
        axes[1, j].set_xlabel("t (s)")
    legend_below(figure)
    figure.suptitle(title)
    return figure


def _log_error_axis(axis: Axes, results: Mapping[str, ClosedLoopResult], joint: int) -> None:
    """A log ``|q~|`` axis (``log_scale``) whose lower limit is ``LOG_FLOOR`` times the
    smallest positive RMS error of ``joint`` among ``results``."""
    log_scale(axis, empty="no error to draw")
    if axis.get_yscale() != "log":
        return
    rms = [float(np.sqrt(np.nanmean(r.q_error[:, joint] ** 2))) for r in results.values()]
    positive = [value for value in rms if np.isfinite(value) and value > 0.0]
    if positive:
        axis.set_ylim(bottom=LOG_FLOOR * min(positive))
    axis.grid(True, which="both", alpha=0.3)


def save(
    figure: Figure, directory: Path, stem: str, dpi: int = 100, tight: bool = False
) -> list[Path]:
    """Write ``stem.png`` (at ``dpi``; 1100 x 700 px for the Figs. 4-7 layout) and
    ``stem.svg`` into ``directory``, each atomically (``analysis.common.outputs.atomic_file``:
    an interrupted write leaves the previous file). The SVG carries no date and fixed
    element ids, so re-running on the same data rewrites identical files."""
    paths = [directory / f"{stem}.png", directory / f"{stem}.svg"]
    # Lay the figure out once for both files (each savefig would run its layout engine
    # and measure its tight box again): matplotlib's idiom, a draw without rendering, the
    # tight box of that layout, and the layout engine off, the positions kept.
    shown_dpi = figure.get_dpi()
    figure.set_dpi(dpi)  # laid out at the PNG's resolution, as its savefig would
    figure.draw_without_rendering()
    pad = matplotlib.rcParams["savefig.pad_inches"]
    bbox = figure.get_tightbbox().padded(pad) if tight else None
    engine = figure.get_layout_engine()
    figure.set_layout_engine("none")
    with matplotlib.rc_context({"svg.hashsalt": "posfb"}):
        with atomic_file(paths[0]) as png:
            figure.savefig(png, dpi=dpi, bbox_inches=bbox)
        with atomic_file(paths[1]) as svg:
            figure.savefig(svg, bbox_inches=bbox, metadata={"Date": None})
    figure.set_dpi(shown_dpi)  # the caller's figure as it was
    if engine is not None:
        figure.set_layout_engine(engine)
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

#: The most samples a report figure draws as dots per controller and group (``thinned``).
MAX_DOTS = 200


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


def thinned(values: np.ndarray, *others: np.ndarray) -> tuple[np.ndarray, ...]:
    """At most ``MAX_DOTS`` of ``values`` (and the matching entries of ``others``), a
    seeded random subset in sample order: enough dots to show the spread, few enough
    that they do not merge into a band. The statistics drawn with them use every value."""
    if values.size <= MAX_DOTS:
        return (values, *others)
    kept = np.sort(np.random.default_rng(0).choice(values.size, MAX_DOTS, replace=False))
    return (values[kept], *(other[kept] for other in others))


def dot_alpha(count: int) -> float:
    """The opacity of ``count`` overlaid dots: 0.5 up to 20 dots, then falling as
    ``1 / sqrt(count)`` (about 0.16 at ``MAX_DOTS``), never below 0.15."""
    return float(np.clip(0.5 * np.sqrt(20.0 / max(count, 1)), 0.15, 0.5))
