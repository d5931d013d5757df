"""The margins of a design in words and in JSON (``posfb design --margins``, ``posfb
scenario check``): ``models.design.margins`` computes them, this module only writes them.

JSON (``margins_to_dict``): ``null`` where a margin is infinite (no crossover, a delay
beyond the scan) or undefined; with an unstable nominal loop (``stable: false``) the
margins do not apply and every one of them is ``null``.

Over the configurations the arm visits (``LinearDesign.frozen_margins``: ``M*(q)`` frozen
at the path's configurations that bound them), the worst of each loop-wide figure and
where it occurs (``frozen_worst``; an unstable frozen loop has no margin: 0): the
``configurations`` object of the JSON and a block of the text.
"""

from __future__ import annotations

import math

from posfb.analysis.design.linear_loop import LinearDesign
from posfb.models.design.configurations import Configuration
from posfb.models.design.margins import (
    MAX_DELAY_SAMPLES,
    BreakMargins,
    ChannelMargins,
    LoopMargins,
)


def _number(value: float) -> float | None:
    """JSON's number, or ``null`` for an infinite or undefined one."""
    return float(value) if math.isfinite(value) else None


def _channel(channel: ChannelMargins) -> dict[str, float | None]:
    return {
        "gain_margin": _number(channel.gain_margin),
        "phase_crossover_rad_per_s": _number(channel.phase_crossover_rad_per_s),
        "phase_margin_deg": _number(channel.phase_margin_deg),
        "crossover_rad_per_s": _number(channel.crossover_rad_per_s),
        "delay_margin_s": _number(channel.delay_margin_s),
    }


def _break(margins: BreakMargins) -> dict[str, object]:
    return {
        "disk_margin": _number(margins.disk_margin),
        "disk_gain_margin": _number(margins.disk_gain_margin),
        "disk_phase_margin_deg": _number(margins.disk_phase_margin_deg),
        "disk_frequency_rad_per_s": _number(margins.disk_frequency_rad_per_s),
        "peak_sensitivity": _number(margins.peak_sensitivity),
        "peak_complementary_sensitivity": _number(margins.peak_complementary_sensitivity),
        "channels": [_channel(c) for c in margins.channels],
    }


def loop_figures(margins: LoopMargins) -> dict[str, object]:
    """The loop-wide figures (the worse break's) with the spectral radius (module
    docstring), every margin ``null`` for an unstable loop: ``margins_to_dict``'s head,
    and ``posfb tune``'s ``margins_before``/``margins_after``."""
    result: dict[str, object] = {
        "spectral_radius": margins.radius,
        "stable": margins.stable,
        "delay_margin_s": _number(margins.delay_margin_s),
        "delay_margin_samples": _number(margins.delay_margin_samples),
        "disk_margin": _number(margins.disk_margin),
        "disk_gain_margin": _number(margins.disk_gain_margin),
        "disk_phase_margin_deg": _number(margins.disk_phase_margin_deg),
        "peak_sensitivity": _number(margins.peak_sensitivity),
        "peak_complementary_sensitivity": _number(margins.peak_complementary_sensitivity),
    }
    return result if margins.stable else _nulled(result)


#: The loop-wide margins judged over the frozen configurations, each with its worse end
#: (the spectral radius is judged over every configuration: ``LinearDesign.frozen_radii``).
FROZEN_FIGURES = (
    ("disk_margin", "min"),
    ("delay_margin_s", "min"),
    ("peak_sensitivity", "max"),
    ("peak_complementary_sensitivity", "max"),
)

Frozen = list[tuple[Configuration, LoopMargins]]


def _figure(margins: LoopMargins, name: str) -> float:
    """A loop-wide figure of ``margins``; a margin of an unstable loop is 0."""
    if not margins.stable:
        return 0.0 if name in ("disk_margin", "delay_margin_s") else math.inf
    return float(getattr(margins, name))


def frozen_worst(design: LinearDesign, frozen: Frozen) -> dict[str, tuple[float, Configuration]]:
    """Each ``FROZEN_FIGURES`` figure's worst over the ``frozen`` margins (the radius over
    every configuration of the design's set) and the configuration where it occurs."""
    worst: dict[str, tuple[float, Configuration]] = {}
    radii = design.frozen_radii()
    if radii is not None and design.configurations is not None:
        worst["spectral_radius"] = (
            radii.worst,
            design.configurations.configurations[radii.worst_index],
        )
    for name, end in FROZEN_FIGURES:
        values = [(_figure(m, name), c) for c, m in frozen]
        if values:
            pick = max if end == "max" else min
            worst[name] = pick(values, key=lambda item: item[0])
    return worst


def _frozen_dict(design: LinearDesign, frozen: Frozen) -> dict[str, object]:
    worst = frozen_worst(design, frozen)
    return {
        name: {"value": _number(value), "time": where.time, "q": list(where.q), "role": where.role}
        for name, (value, where) in worst.items()
    } | {"evaluated_at": [{"time": c.time, "q": list(c.q), "role": c.role} for c, _ in frozen]}


def margins_to_dict(
    design: LinearDesign, margins: LoopMargins, frozen: Frozen | None = None
) -> dict[str, object]:
    """The ``margins`` object of ``--json`` (module docstring): the loop-wide figures
    (``loop_figures``), ``channels`` loop at a time at the plant input, ``at`` both
    breaks in full, and with ``frozen`` (``LinearDesign.frozen_margins``) the worst over
    the configurations (``configurations``; ``null`` without)."""
    result: dict[str, object] = {
        "controller": design.controller,
        "sample_time": design.sample_time,
        **loop_figures(margins),
        "channels": [_channel(c) for c in margins.at_input.channels],
        "at": {b.where: _break(b) for b in margins.breaks},
        "left_out": list(design.left_out),
    }
    if not margins.stable:
        result = _nulled(result)
    result["configurations"] = None if frozen is None else _frozen_dict(design, frozen)
    return result


def _nulled(value: object) -> object:
    """``value`` with every margin ``null`` (the identity and the radius kept)."""
    kept = {"controller", "sample_time", "spectral_radius", "stable", "left_out"}
    if isinstance(value, dict):
        return {k: (v if k in kept else _nulled(v)) for k, v in value.items()}
    if isinstance(value, list):
        return [_nulled(v) for v in value]
    return None


def radius_text(radius: float) -> str:
    """A spectral radius to four decimals, or to as many as it takes (up to 12) to tell
    one just below 1 (a slow integral mode: ``0.99998``) from 1."""
    for decimals in range(4, 13):
        text = f"{radius:.{decimals}f}"
        if radius >= 1.0 or float(text) < 1.0:
            return text
    return text


def _value(value: float, form: str, unit: str = "") -> str:
    return "none" if not math.isfinite(value) else f"{value:{form}}{unit}"


def _delay(seconds: float, sample_time: float) -> str:
    if math.isinf(seconds):
        return f"more than {MAX_DELAY_SAMPLES} periods"
    return f"{seconds * 1e3:.3g} ms ({seconds / sample_time:.3g} T_s)"


def _frozen_lines(design: LinearDesign, frozen: Frozen) -> list[str]:
    """The worst figures over the configurations, one line each."""
    worst = frozen_worst(design, frozen)
    if not worst:
        return []
    T = design.sample_time
    shown = {
        "spectral_radius": lambda v: radius_text(v) + (" UNSTABLE" if v >= 1.0 else ""),
        "disk_margin": lambda v: f"{v:.3f}",
        "delay_margin_s": lambda v: _delay(v, T),
        "peak_sensitivity": lambda v: _value(v, ".3f"),
        "peak_complementary_sensitivity": lambda v: _value(v, ".3f"),
    }
    names = {"spectral_radius": "spectral radius", "disk_margin": "disk margin",
             "delay_margin_s": "delay margin", "peak_sensitivity": "peak |S|",
             "peak_complementary_sensitivity": "peak |T|"}  # fmt: skip
    lines = [
        "  over the path's configurations (M*(q) frozen; margins at "
        f"{len(frozen)} of them, the worst radius's and the path's lightest and heaviest):"
    ]
    lines += [f"    worst {names[n]} {shown[n](v)} at {c.describe()}"
              for n, (v, c) in worst.items()]  # fmt: skip
    if design.configurations is not None:
        lines.append(f"    {design.configurations.describe_range()}")
    return lines


def format_margins(design: LinearDesign, margins: LoopMargins, frozen: Frozen | None = None) -> str:
    """The margins in words: the loop-wide line, then per break the disk margin, the
    sensitivity peaks and one line per joint; with ``frozen``, first the worst over the
    configurations."""
    T = design.sample_time
    lines = [f"Margins of the sampled loop ({design.label}, T_s = {T:g} s, nominal linear "
             f"plant held over T_s): spectral radius {radius_text(margins.radius)} "
             "at M0*"]  # fmt: skip
    if design.left_out:
        lines.append(f"  left out (nonlinear): {', '.join(design.left_out)}")
    lines += _frozen_lines(design, frozen or [])
    if not margins.stable:
        lines.append("  the nominal loop is UNSTABLE (radius >= 1): no margin applies")
        return "\n".join(lines)
    lines += [
        "  delay margin (the same extra delay on every joint): "
        + _delay(margins.delay_margin_s, T),
        f"  disk margin {margins.disk_margin:.3f}: gain x{_value(margins.disk_gain_margin, '.3f')}"
        f" (or x{_value(1.0 / margins.disk_gain_margin, '.3f')}), phase "
        f"+-{margins.disk_phase_margin_deg:.1f} deg, in every channel at once",
        f"  peak |S| {margins.peak_sensitivity:.3f}, peak |T| "
        f"{margins.peak_complementary_sensitivity:.3f}",
    ]
    for where in margins.breaks:
        lines.append(
            f"  at the plant {where.where}: disk {where.disk_margin:.3f} at "
            f"{where.disk_frequency_rad_per_s:.3g} rad/s, peak |S| {where.peak_sensitivity:.3f}, "
            f"|T| {where.peak_complementary_sensitivity:.3f}; loop at a time:"
        )
        for j, c in enumerate(where.channels, start=1):
            lines.append(
                f"    joint {j}: gain margin x{_value(c.gain_margin, '.3g')}, phase margin "
                f"{_value(c.phase_margin_deg, '.1f', ' deg')} at "
                f"{_value(c.crossover_rad_per_s, '.3g', ' rad/s')}, delay margin "
                f"{_delay(c.delay_margin_s, T)}"
            )
    return "\n".join(lines)
