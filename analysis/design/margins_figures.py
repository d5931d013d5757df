"""The figures of ``posfb design --margins --out DIR``: the loop's frequency responses with
its margins marked, up to the Nyquist frequency ``pi / T_s`` (``models.design.margins``
computes the margins; this module only draws them).

- ``margins_bode``: per joint, the loop-at-a-time transfer ``l_j`` at the plant input
  (the loop opened at joint ``j``, the other joints closed), magnitude in dB and phase,
  the gain crossover with its phase margin and the phase crossover with its gain margin
  marked;
- ``margins_nyquist``: per joint, ``l_j`` in the complex plane near ``-1``, with the
  circle of radius ``min |1 + l_j|`` around ``-1`` (how close the channel comes) and the
  unit circle;
- ``margins_sensitivity``: the largest singular value of ``S`` and ``T`` at both breaks
  in dB, the peaks marked, the disk margin's frequency marked.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from posfb.analysis.design.linear_loop import LinearDesign
from posfb.models.design.margins import LoopMargins, frequency_grid, loop_at_a_time

#: Points of the drawn frequency grid.
DRAWN_POINTS = 2000

#: Each figure's file stem, in the order they are written.
STEMS = ("margins_bode", "margins_nyquist", "margins_sensitivity")


def _loops(design: LinearDesign, omega: np.ndarray) -> dict[str, np.ndarray]:
    """The loop transfer at ``omega`` broken at the plant input and at the output."""
    plant = design.loop.plant.response(omega)
    controller = design.loop.controller.response(omega)
    return {"input": -controller @ plant, "output": -plant @ controller}


def _title(figure: Figure, design: LinearDesign, what: str) -> None:
    figure.suptitle(f"{what}: {design.label}, T_s = {design.sample_time:g} s "
                    f"(nominal linear plant held over T_s)")  # fmt: skip


def _per_joint(design: LinearDesign) -> tuple[np.ndarray, np.ndarray, int, int]:
    """The drawn grid, the loop at the plant input on it, and the panels' columns (up to
    three, so that a six-joint arm stays readable) and rows: one panel per joint."""
    omega = frequency_grid(design.sample_time, DRAWN_POINTS)
    columns = min(design.joints, 3)
    return omega, _loops(design, omega)["input"], columns, math.ceil(design.joints / columns)


def margins_bode(design: LinearDesign, margins: LoopMargins) -> Figure:
    """Bode plot of each joint's loop-at-a-time transfer at the plant input (module
    docstring)."""
    omega, F, columns, rows = _per_joint(design)
    figure = Figure(figsize=(4.2 * columns, 5.2 * rows), layout="constrained")
    grid = figure.subfigures(rows, columns, squeeze=False)
    nyquist = math.pi / design.sample_time
    for j, channel in enumerate(margins.at_input.channels):
        magnitude_axis, phase_axis = grid[j // columns, j % columns].subplots(2, 1, sharex=True)
        response = loop_at_a_time(F, j)
        magnitude_axis.semilogx(omega, 20.0 * np.log10(np.abs(response)), color="tab:blue")
        phase = np.degrees(np.unwrap(np.angle(response)))
        phase -= 360.0 * np.round((phase[0] + 90.0) / 360.0)  # start near -90 deg
        phase_axis.semilogx(omega, phase, color="tab:blue")
        magnitude_axis.axhline(0.0, color="0.5", linewidth=0.8)
        for level in (-180.0, -540.0, 180.0):
            if phase.min() - 20.0 <= level <= phase.max() + 20.0:
                phase_axis.axhline(level, color="0.5", linewidth=0.8)
        notes = []
        if math.isfinite(channel.phase_margin_deg):
            wc = channel.crossover_rad_per_s
            at = float(np.interp(wc, omega, phase))
            magnitude_axis.axvline(wc, color="tab:green", linestyle="--", linewidth=1.0)
            phase_axis.plot([wc, wc], [at, at - channel.phase_margin_deg], color="tab:green",
                            linewidth=2.5)  # fmt: skip
            notes.append(("tab:green", f"PM {channel.phase_margin_deg:.1f} deg at {wc:.3g} rad/s"))
        if math.isfinite(channel.gain_margin):
            wp = channel.phase_crossover_rad_per_s
            phase_axis.axvline(wp, color="tab:red", linestyle=":", linewidth=1.2)
            decibels = 20.0 * math.log10(channel.gain_margin)
            magnitude_axis.plot([wp, wp], [-decibels, 0.0], color="tab:red", linewidth=2.5)
            notes.append(("tab:red", f"GM x{channel.gain_margin:.3g} ({decibels:.1f} dB) at "
                          f"{wp:.3g} rad/s"))  # fmt: skip
        for k, (colour, note) in enumerate(notes):
            magnitude_axis.text(0.02, 0.05 + 0.09 * k, note, transform=magnitude_axis.transAxes,
                                color=colour, fontsize="small")  # fmt: skip
        for axis in (magnitude_axis, phase_axis):
            axis.set_xlim(omega[0], nyquist)
            axis.grid(True, which="both", alpha=0.3)
        magnitude_axis.set_title(f"joint {j + 1} (loop at a time)")
        magnitude_axis.set_ylabel("|l| (dB)")
        phase_axis.set_ylabel("arg l (deg)")
        phase_axis.set_xlabel("frequency (rad/s), up to Nyquist")
    _title(figure, design, "Loop transfer at the plant input")
    return figure


def margins_nyquist(design: LinearDesign, margins: LoopMargins) -> Figure:
    """Nyquist plot of each joint's loop-at-a-time transfer near ``-1`` (module
    docstring)."""
    omega, F, columns, rows = _per_joint(design)
    n = design.joints
    figure = Figure(figsize=(4.2 * columns, 4.4 * rows), layout="constrained")
    axes = figure.subplots(rows, columns, squeeze=False).ravel()
    circle = np.exp(1j * np.linspace(0.0, 2.0 * math.pi, 400))
    for j in range(n):
        axis = axes[j]
        response = loop_at_a_time(F, j)
        distance = float(np.min(np.abs(1.0 + response)))
        axis.plot(response.real, response.imag, color="tab:blue", label="l(e^{jwT}), w >= 0")
        axis.plot(response.real, -response.imag, color="tab:blue", alpha=0.35,
                  label="w < 0")  # fmt: skip
        axis.plot(circle.real, circle.imag, color="0.6", linewidth=0.8, label="unit circle")
        axis.plot(-1.0 + distance * circle.real, distance * circle.imag, color="tab:red",
                  linestyle="--", label="closest approach to -1")  # fmt: skip
        axis.plot([-1.0], [0.0], "x", color="tab:red", markersize=8)
        reach = max(2.5, 1.2 + distance)
        axis.set_xlim(-reach, reach * 0.6)
        axis.set_ylim(-reach * 0.8, reach * 0.8)
        axis.set_aspect("equal")
        axis.grid(True, alpha=0.3)
        axis.set_title(f"joint {j + 1}: min |1 + l| = {distance:.3f}")
        axis.set_xlabel("Re l")
        axis.set_ylabel("Im l")
    for axis in axes[n:]:
        axis.set_visible(False)
    axes[0].legend(fontsize="small", loc="lower left")
    _title(figure, design, "Nyquist, loop at a time at the plant input")
    return figure


def margins_sensitivity(design: LinearDesign, margins: LoopMargins) -> Figure:
    """``sigma_max(S)`` and ``sigma_max(T)`` at both breaks (module docstring)."""
    omega = frequency_grid(design.sample_time, DRAWN_POINTS)
    loops = _loops(design, omega)
    eye = np.eye(design.joints)
    figure = Figure(figsize=(9.0, 4.2), layout="constrained")
    axes = figure.subplots(1, 2, sharey=True)
    for axis, found in zip(axes, margins.breaks, strict=True):
        S = np.linalg.inv(eye + loops[found.where])
        for matrix, name, colour, peak in (
            (S, "S", "tab:blue", found.peak_sensitivity),
            (eye - S, "T", "tab:orange", found.peak_complementary_sensitivity),
        ):
            gain = 20.0 * np.log10(np.linalg.norm(matrix, 2, axis=(1, 2)))
            label = f"max sigma({name}), peak {peak:.2f} ({20 * math.log10(peak):.1f} dB)"
            axis.semilogx(omega, gain, color=colour, label=label)
        axis.axvline(found.disk_frequency_rad_per_s, color="tab:red", linestyle=":",
                     label=f"disk margin {found.disk_margin:.3f} here")  # fmt: skip
        axis.axhline(20.0 * math.log10(2.0), color="0.5", linewidth=0.8, linestyle="--",
                     label="6 dB")  # fmt: skip
        axis.set_xlim(omega[0], math.pi / design.sample_time)
        axis.grid(True, which="both", alpha=0.3)
        axis.set_title(f"broken at the plant {found.where}")
        axis.set_xlabel("frequency (rad/s), up to Nyquist")
        axis.legend(fontsize="small", loc="lower right")
    axes[0].set_ylabel("gain (dB)")
    _title(figure, design, "Sensitivity and complementary sensitivity")
    return figure


def write_margin_figures(out: Path, design: LinearDesign, margins: LoopMargins) -> list[Path]:
    """The three figures as PNG and SVG in ``out``; none for an unstable loop."""
    from posfb.analysis.common.plots import save_report_figure

    if not margins.stable:
        return []
    paths = []
    for stem, draw in zip(STEMS, (margins_bode, margins_nyquist, margins_sensitivity),
                          strict=True):  # fmt: skip
        paths += save_report_figure(draw(design, margins), out, stem)
    return paths
