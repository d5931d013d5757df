"""The run figures (``analysis.common.plots``): every controller's error readable beside one a
hundred times worse, the legend outside the data, one colour per line (a plug-in's
and a named entry's none of a built-in's), "(paper)" only for the paper's settings.
The runs are made up (no simulation): the figures only read a run's logs and config."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from matplotlib.colors import to_hex

from helpers.figure_checks import legend_labels, legends_over_axes, line_colours
from posfb.analysis.api import load_scenario, resolve
from posfb.analysis.common.plots import positions_and_voltages, tracking_errors
from posfb.analysis.common.shipped import SCENARIO_DIR
from posfb.diagrams.loop_config import ClosedLoopConfig
from posfb.diagrams.runner import ClosedLoopResult
from posfb.models.controllers.plugin import load_plugin
from posfb.models.controllers.registry import registered_colours
from posfb.models.design import ControllerConfig

#: A user's controller, as small as the contract allows.
MINE = """
import posfb

class Mine(posfb.Controller):
    def step(self, q, desired, memory):
        return 0.0 * q, []
"""


def made_up_run(
    config: ClosedLoopConfig, amplitude: float, seconds: float = 20.0
) -> ClosedLoopResult:
    """A finished two-joint run whose error is a sine of ``amplitude`` rad per joint."""
    times = np.arange(0.0, seconds + 1e-9, 0.01)
    desired = np.column_stack([np.sin(times), 0.5 * np.cos(times)])
    error = amplitude * np.column_stack([np.sin(3.0 * times), np.cos(2.0 * times)])
    voltages = np.column_stack([np.sin(times), np.cos(times)])
    return ClosedLoopResult(
        config=config, times=times, q_true=desired + error, q_measured=desired + error,
        q_desired=desired, u_commanded=voltages, u_applied=voltages,
        internals=np.zeros((times.size, 0)), internals_names=(), internals_columns=(),
        status="ok", message="", wall_time_s=0.0,
    )  # fmt: skip


def rms(result: ClosedLoopResult, joint: int) -> float:
    return float(np.sqrt(np.mean(result.q_error[:, joint] ** 2)))


@pytest.fixture(scope="module")
def runs() -> dict[str, ClosedLoopResult]:
    """PID at 35 mrad beside Lin+LC and the paper's controller at 0.2-0.3 mrad, a user's
    plug-in and a named entry of the paper's controller with its own alpha*."""
    plugin = load_plugin(MINE, "mine.py", "Mine", {}, "")
    tuned = ControllerConfig()
    tuned = replace(tuned, nonlinear=replace(tuned.nonlinear, alpha_star=2.75))
    return {
        "pid": made_up_run(ClosedLoopConfig(controller="pid"), 35e-3),
        "lin_lc": made_up_run(ClosedLoopConfig(controller="lin_lc"), 0.3e-3),
        "proposed": made_up_run(ClosedLoopConfig(controller="proposed"), 0.2e-3),
        "Mine": made_up_run(ClosedLoopConfig(controller="Mine", controller_settings=plugin), 5e-3),
        "proposed_275": made_up_run(ClosedLoopConfig(controller="proposed", design=tuned), 1e-3),
    }


def test_the_error_figure_shows_small_and_large_errors_on_log_axes(runs):
    figure = tracking_errors(runs, "made up")
    assert len(figure.axes) == 4  # two rows (run, close-up) of one panel per joint
    for k, axis in enumerate(figure.axes):
        joint = k % 2
        assert axis.get_yscale() == "log"
        low, high = axis.get_ylim()
        sizes = [rms(result, joint) for result in runs.values()]
        # Both the smallest error and the largest sit inside the axis, a decade or more
        # above its floor: neither is squashed onto the other.
        assert low <= 0.1 * min(sizes) and max(sizes) <= high
        assert all(np.all(line.get_ydata() >= 0.0) for line in axis.get_lines())


def test_the_papers_signed_linear_errors_remain_on_request(runs):
    figure = tracking_errors(runs, "made up", scale="linear")
    assert {axis.get_yscale() for axis in figure.axes} == {"linear"}
    assert any(np.any(line.get_ydata() < 0.0) for line in figure.axes[0].get_lines())
    with pytest.raises(ValueError, match="scale = 'loglog'; one of log, linear"):
        tracking_errors(runs, "made up", scale="loglog")  # type: ignore[arg-type]


@pytest.mark.slow
@pytest.mark.parametrize("draw", [tracking_errors, positions_and_voltages])
def test_the_legend_covers_no_panel(runs, draw):
    figure = draw(runs, "made up")
    assert legend_labels(figure)
    assert legends_over_axes(figure) == []


@pytest.mark.slow
@pytest.mark.parametrize("draw", [tracking_errors, positions_and_voltages])
def test_every_line_has_its_own_colour_and_a_plugin_none_of_a_builtins(runs, draw):
    figure = draw(runs, "made up")
    colours = line_colours(figure.axes[0])
    controllers = {label: colour for label, colour in colours.items() if label != "desired"}
    assert len(controllers) == len(runs)
    assert len(set(controllers.values())) == len(runs)
    builtins = {to_hex(colour) for colour in registered_colours()}
    assert controllers["Mine"] not in builtins
    assert controllers["proposed_275: Lin + LC + NC (own settings)"] not in builtins
    # A built-in kind keeps its spec's colour.
    assert controllers["Lin + LC"] == to_hex(runs["lin_lc"].config.spec.style["color"])


def test_only_the_papers_settings_are_labelled_paper(runs):
    labels = legend_labels(tracking_errors(runs, "made up"))
    assert labels == [
        "computed torque + PID", "Lin + LC", "Lin + LC + NC (paper)", "Mine",
        "proposed_275: Lin + LC + NC (own settings)",
    ]  # fmt: skip
    for name, paper in (("paper_nominal", True), ("paper_tuned", False)):
        config = resolve(load_scenario(SCENARIO_DIR / f"{name}.yaml")).config
        assert ("(paper)" in config.spec.label_for(config.design)) is paper
