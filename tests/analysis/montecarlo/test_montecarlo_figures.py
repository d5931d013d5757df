"""The Monte-Carlo report's figures (``analysis.montecarlo.study_report``, ``stability``,
``convergence``) on a made-up 2000-sample study: titles, legends outside the data,
thinned dots that keep the statistics of every sample, a median line visible against
its box."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from matplotlib.colors import to_rgba

from helpers.figure_checks import legend_labels, legends_over_axes, suptitle
from helpers.montecarlo_helpers import TINY_STUDY
from posfb.analysis.common.plots import MAX_DOTS
from posfb.analysis.montecarlo import convergence, stability
from posfb.analysis.montecarlo.results import StudyData
from posfb.analysis.montecarlo.study_report import (
    plot_against_payload,
    plot_distributions,
    plot_inside_outside,
)
from posfb.analysis.uncertainty.coverage import BOUND_NAMES
from posfb.analysis.uncertainty.study import study_from_text

SAMPLES = 2000
CONTROLLERS = ("proposed", "lin_lc", "pid")


@pytest.fixture(scope="module")
def data() -> StudyData:
    """2000 samples of two joints: errors of 0.2 mrad, 0.3 mrad and 35 mrad around a
    payload trend, half the plants inside the bounds."""
    rng = np.random.default_rng(1)
    payload = rng.uniform(0.0, 0.5, SAMPLES)
    scales = dict(zip(CONTROLLERS, (0.2e-3, 0.3e-3, 35e-3), strict=True))
    rms_q = {
        c: scale * (1.0 + payload)[:, None] * rng.lognormal(0.0, 0.3, (SAMPLES, 2))
        for c, scale in scales.items()
    }
    return StudyData(
        study=study_from_text(TINY_STUDY), meta={}, samples=np.arange(SAMPLES),
        payload=payload, inside=np.arange(SAMPLES) % 2 == 0,
        exceeded=dict.fromkeys(BOUND_NAMES, 0), code_versions=("test",),
        controllers=CONTROLLERS, rms_q=rms_q,
        rms_q_measured={c: v.copy() for c, v in rms_q.items()},
        saturated={c: np.zeros(SAMPLES) for c in CONTROLLERS},
        status={c: np.full(SAMPLES, "ok", dtype=object) for c in CONTROLLERS},
        messages={c: [] for c in CONTROLLERS}, inputs={}, radius={}, joints=2,
    )  # fmt: skip


DRAW = {
    "rms_distributions": plot_distributions,
    "rms_vs_payload": plot_against_payload,
    "rms_inside_outside": plot_inside_outside,
}


@pytest.mark.slow
@pytest.mark.parametrize("name", DRAW)
def test_every_figure_has_a_title_and_no_legend_over_a_panel(data, tmp_path, name):
    figure = DRAW[name](data, tmp_path)
    assert (tmp_path / f"{name}.png").is_file() and (tmp_path / f"{name}.svg").is_file()
    assert len(suptitle(figure)) > 10
    assert legends_over_axes(figure) == []
    assert {axis.get_yscale() for axis in figure.axes} == {"log"}


def _dots(axis) -> list:
    return [line for line in axis.get_lines() if line.get_marker() == "."]


@pytest.mark.slow
def test_the_distributions_thin_the_dots_and_keep_every_samples_median(data, tmp_path):
    figure = plot_distributions(data, tmp_path)
    for joint, axis in enumerate(figure.axes):
        dots = _dots(axis)
        assert len(dots) == len(CONTROLLERS)
        assert all(len(line.get_ydata()) <= MAX_DOTS for line in dots)
        assert all(line.get_alpha() <= 0.3 for line in dots)
        # The boxes' medians are every sample's, not the thinned dots'.
        drawn = sorted(float(np.mean(line.get_ydata())) for line in _median_lines(axis))
        expected = sorted(float(np.median(data.rms_q[c][:, joint])) for c in CONTROLLERS)
        np.testing.assert_allclose(drawn, expected, rtol=1e-12)


def _median_lines(axis) -> list:
    """The box plots' median lines: horizontal two-point lines in black."""
    return [
        line
        for line in axis.get_lines()
        if len(line.get_ydata()) == 2
        and line.get_ydata()[0] == line.get_ydata()[1]
        and to_rgba(line.get_color()) == to_rgba("black")
        and line.get_zorder() > 3
    ]


@pytest.mark.slow
def test_rms_against_payload_draws_a_median_line_per_controller(data, tmp_path):
    figure = plot_against_payload(data, tmp_path)
    assert legend_labels(figure) == [f"{c} (median)" for c in CONTROLLERS]
    for joint, axis in enumerate(figure.axes):
        assert all(len(line.get_ydata()) <= MAX_DOTS for line in _dots(axis))
        trends = [line for line in axis.get_lines() if line.get_linestyle() == "-"]
        assert len(trends) == len(CONTROLLERS)
        for controller, line in zip(CONTROLLERS, trends, strict=True):
            # The made-up error grows with the payload: so does its median line.
            assert np.all(np.diff(line.get_xdata()) > 0.0)
            ys = line.get_ydata()
            assert ys[-1] > ys[0]
            values = data.rms_q[controller][:, joint]
            assert values.min() <= ys.min() and ys.max() <= values.max()


@pytest.mark.slow
def test_the_inside_outside_medians_contrast_with_their_boxes_and_lie_above_them(data, tmp_path):
    figure = plot_inside_outside(data, tmp_path)
    for axis in figure.axes:
        boxes = list(axis.patches)
        assert len(boxes) == 2 * len(CONTROLLERS)
        medians = _median_lines(axis)
        assert len(medians) == len(boxes)
        faces = {to_rgba(patch.get_facecolor())[:3] for patch in boxes}
        assert all(to_rgba(m.get_color())[:3] not in faces for m in medians)
        assert min(m.get_zorder() for m in medians) > max(p.get_zorder() for p in boxes)


@pytest.mark.slow  # over 10 s on 2 cores (issue 45, item 4)
def test_the_radius_convergence_and_ecdf_figures_keep_their_legends_off_the_data(data, tmp_path):
    radius = {c: 0.5 + 0.6 * np.linspace(0.0, 1.0, SAMPLES) for c in CONTROLLERS}
    with_radius = replace(data, radius=radius)
    figures = [stability.plot(with_radius, stability.loop_stability(with_radius), tmp_path)]
    figures += convergence.plot(data, tmp_path)
    for figure in figures:
        assert len(legend_labels(figure)) >= len(CONTROLLERS)
        assert legends_over_axes(figure) == []
    assert all(
        len(line.get_ydata()) <= MAX_DOTS for axis in figures[0].axes for line in _dots(axis)
    )
