"""The report of ``posfb tune``: each tuned value beside the one it replaced, the
objective and the constraints before and after, the cross-check runs, the margins of the
nominal loop before and after (``posfb design --margins``) and the guarantee with its
formula and source, or, for a tuned entry whose check run is not ``ok``, one line saying
why it gets none (``TunedController.not_certified``; text, and a JSON-ready dict)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from posfb.analysis.design.problem import VOLTAGE_SIGMAS, Evaluation

if TYPE_CHECKING:  # the result's writer: the result's module imports this one
    from posfb.analysis.design.tune import SimulatedCheck, TunedController, TuneResult
    from posfb.models.design.margins import LoopMargins

#: The violation the guarantee bounds.
UNSTABLE = "the sampled loop unstable (rho >= 1)"


def _value(entry: TunedController, which: str, name: str) -> object:
    """Setting ``name`` of the entry ``which`` (``before``, ``after``) as the report shows
    it (``Tuning.value``): a matrix by its diagonal."""
    value = entry.tuning.value(getattr(entry, which), name)
    if isinstance(value, list) and value and isinstance(value[0], list):
        return [float(v) for v in np.diag(np.asarray(value, dtype=float))]
    if isinstance(value, list):
        return [float(v) for v in value]
    return float(value)


def _text(value: object) -> str:
    if isinstance(value, list):
        return "[" + ", ".join(f"{v:.4g}" for v in value) + "]"
    return f"{value:.4g}"


def _radius(value: float) -> str:
    return "-" if not math.isfinite(value) else f"{value:.4f}"


def _objective(evaluation: Evaluation) -> str:
    if evaluation.refused:
        return "refused"
    if not math.isfinite(evaluation.predicted_rms):
        return "inf (nominal loop unstable)"
    return f"{evaluation.predicted_rms:.4g} rad"


def _run(check: SimulatedCheck) -> str:
    """A check run: its RMS errors, saturated share and verdict (with why it is not ok)."""
    if not check.rms_q:
        return check.sentence()
    rms = ", ".join(f"{v:.3g}" for v in check.rms_q)
    return f"({rms}) rad, {100 * check.saturated_fraction:.0f} % saturated, {check.sentence()}"


def _guarantee(entry: TunedController) -> str:
    """The guarantee in words, or, for an entry whose check run is not ``ok``, why it
    has none."""
    if entry.not_certified:
        return f"none stated: {entry.not_certified}"
    return entry.guarantee.sentence(UNSTABLE)


def _controller_lines(entry: TunedController, result: TuneResult) -> list[str]:
    settings = result.settings
    limit = 1.0 - settings.margin
    error = ", ".join(f"{v:.3g}" for v in entry.disturbance_std)
    lines = [
        f"{entry.controller}: {entry.generations} generations, {entry.evaluations} designs; "
        f"model error of the {entry.design_plants} design plants RMS ({error}) V, bandwidth "
        f"{entry.disturbance_bandwidth:.3g} rad/s"
    ]
    for name in entry.tuning.shown:
        shown = "diagonal of " if name in ("Q1", "R") else ""
        lines.append(
            f"  {shown}controller.{name}: {_text(_value(entry, 'before', name))} -> "
            f"{_text(_value(entry, 'after', name))}"
        )
    start, best = entry.start, entry.best
    lines += [
        f"  predicted RMS tracking error: {_objective(start)} -> {_objective(best)}",
        f"  nominal rho: {_radius(start.nominal_radius)} -> {_radius(best.nominal_radius)} "
        f"(required <= {limit:g})",
        f"  worst rho on the {entry.design_plants} design plants: "
        f"{_radius(start.worst_radius)} -> {_radius(best.worst_radius)}",
        f"  peak voltage / limit (feed-forward + {VOLTAGE_SIGMAS:g} sigma of the feedback): "
        f"{start.voltage_ratio:.3g} -> {best.voltage_ratio:.3g}",
        f"  simulated RMS error ({result.check_duration:g} s, scenario's arm): "
        f"{_run(entry.simulated_before)} -> {_run(entry.simulated_after)}",
        f"  round {entry.rounds} of at most {settings.rounds}: designed on "
        f"{entry.design_plants} plants, verified on {entry.guarantee.plants} fresh ones",
        f"  guarantee: {_guarantee(entry)}",
        f"  largest rho on the fresh plants: {max(entry.verified_radii, default=math.nan):.4f}",
        f"  (for reference, not claimed: the scenario approach for a convex design with "
        f"d = {entry.decisions} variables on N = {entry.design_plants} plants would give "
        f"beta = {entry.scenario_beta:.3g} for epsilon = {settings.epsilon:g}, Calafiore "
        "and Campi 2006; this search is not convex)",
    ]
    lines.append(f"  margins of the nominal loop: {_margins_change(entry)}")
    lines += [f"  warning: {edge.sentence()}" for edge in entry.at_edge]
    if entry.worse:
        lines.append(f"  worse than the scenario's own: {', '.join(entry.worse)}")
    return lines


def _margin_text(margins: LoopMargins | None, figure: str) -> str:
    if margins is None or not margins.stable:
        return "none"
    if figure == "disk":
        return f"{margins.disk_margin:.3f}"
    if figure == "delay":
        delay = margins.delay_margin_s
        return "inf" if math.isinf(delay) else f"{delay * 1e3:.3g} ms"
    return f"{margins.peak_sensitivity:.3g}"


def _margins_change(entry: TunedController) -> str:
    """The tuned entry's margins beside the scenario's own (``posfb design --margins``)."""
    return ", ".join(
        f"{name} {_margin_text(entry.margins_before, figure)} -> "
        f"{_margin_text(entry.margins_after, figure)}"
        for name, figure in (
            ("disk margin", "disk"),
            ("delay margin", "delay"),
            ("peak |S|", "peak"),
        )  # fmt: skip
    )


def text_report(result: TuneResult) -> str:
    """The readable report (also the tuned file's header)."""
    settings = result.settings
    lines = [
        f"posfb tune {result.source}: seed {settings.seed}, {settings.plants} design "
        f"plants drawn i.i.d. from {result.family}, margin {settings.margin:g}, "
        f"epsilon {settings.epsilon:g}, beta {settings.beta:g}",
        "objective: predicted RMS tracking error of the nominal sampled-data loop driven by "
        "the design plants' model error along the trajectory and the encoder's quantisation "
        "(analysis/design/problem.py)",
    ]
    for entry in result.controllers.values():
        lines += _controller_lines(entry, result)
    return "\n".join(lines)


def _evaluation_dict(evaluation: Evaluation) -> dict[str, object]:
    def finite(value: float) -> float | None:
        return value if math.isfinite(value) else None

    return {
        "predicted_rms": finite(evaluation.predicted_rms),
        "nominal_radius": finite(evaluation.nominal_radius),
        "worst_radius": finite(evaluation.worst_radius),
        "voltage": list(evaluation.voltage),
        "voltage_ratio": finite(evaluation.voltage_ratio),
        "feasible": evaluation.feasible,
    }


def _margins_dict(margins: LoopMargins | None) -> dict[str, object] | None:
    """The loop-wide margins (``margins_report.loop_figures``; ``null`` where none)."""
    from posfb.analysis.design.margins_report import loop_figures

    return None if margins is None else loop_figures(margins)


def result_dict(result: TuneResult) -> dict[str, object]:
    """``posfb tune --json``."""
    settings = result.settings
    controllers = {}
    for name, entry in result.controllers.items():
        guarantee = entry.guarantee
        controllers[name] = {
            "settings": {
                key: {"before": _value(entry, "before", key), "after": _value(entry, "after", key)}
                for key in entry.tuning.shown
            },
            "before": _evaluation_dict(entry.start),
            "after": _evaluation_dict(entry.best),
            "simulated_before": vars(entry.simulated_before) | {
                "rms_q": list(entry.simulated_before.rms_q)},
            "simulated_after": vars(entry.simulated_after) | {
                "rms_q": list(entry.simulated_after.rms_q)},
            "guarantee": {
                "epsilon": guarantee.epsilon,
                "beta": guarantee.beta,
                "plants": guarantee.plants,
                "failures": guarantee.failures,
                "epsilon_bound": guarantee.epsilon_bound,
                "holds": guarantee.holds,
                "rounds": entry.rounds,
                "certified": not entry.not_certified,
                "statement": _guarantee(entry),
            },
            "design_plants": entry.design_plants,
            "model_error_rms": list(entry.disturbance_std),
            "model_error_bandwidth": entry.disturbance_bandwidth,
            "largest_verified_radius": max(entry.verified_radii, default=None),
            "scenario_approach_beta": entry.scenario_beta,
            "generations": entry.generations,
            "evaluations": entry.evaluations,
            "margins_before": _margins_dict(entry.margins_before),
            "margins_after": _margins_dict(entry.margins_after),
            "worse": list(entry.worse),
            "at_edge": [vars(edge) for edge in entry.at_edge],
        }  # fmt: skip
    return {
        "scenario": result.source,
        "seed": settings.seed,
        "margin": settings.margin,
        "design_plants": settings.plants,
        "family": result.family,
        "controllers": controllers,
        "wall_time_s": result.wall_time_s,
    }
