"""``posfb design``: in process through ``analysis.cli.main`` (fast), and once end to
end as a user runs it."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
import scipy.linalg

from helpers.scipy_loop import sampled_radius
from posfb.analysis.cli import main
from posfb.models.design import ControllerConfig
from posfb.models.design.augmented import augmented_system
from posfb.models.lumped import TABLE1, LumpedModel


def _run(capsys, *args: str) -> tuple[int, str, str]:
    code = main(list(args))
    captured = capsys.readouterr()
    return code, captured.out, captured.err


# The report's tests pass --no-sim (the exact arm's 20 s run is not what they read);
# test_the_design_is_confirmed_on_the_exact_arm_unless_no_sim checks that run.
def test_json_at_the_paper_settings(capsys):
    code, out, err = _run(capsys, "design", "--json", "--no-sim")
    assert code == 0, err
    data = json.loads(out)
    for key in ("K", "P", "E", "continuous_poles", "sampled_data_spectral_radius", "warnings"):
        assert key in data
    assert len(data["K"]) == 2 and all(len(row) == 6 for row in data["K"])
    assert len(data["P"]) == 6 and len(data["E"]) == 2
    assert len(data["continuous_poles"]) == 6
    assert all(re < 0.0 for re, _ in data["continuous_poles"])
    # K of Eq. 14 from scipy's Riccati solver on the augmented system of Eq. 11
    config, model = ControllerConfig(), LumpedModel(TABLE1)
    augmented = augmented_system(model.M0(), model.B(), np.asarray(config.lqr.lambdas))
    R = np.asarray(config.lqr.R)
    P = scipy.linalg.solve_continuous_are(augmented.A_a, augmented.B_a1, config.lqr.Q, R)
    K = np.linalg.solve(R, augmented.B_a1.T @ P)
    np.testing.assert_allclose(data["K"], K, rtol=1e-6, atol=1e-6 * np.max(np.abs(K)))
    # The loop rebuilt with scipy's ZOH of the continuous filter (the default sampling)
    assert data["sampled_data_spectral_radius_at_M0"] == pytest.approx(
        sampled_radius("zoh", alpha=config.nonlinear.alpha_star), rel=1e-9
    )
    # the verdict's radius is the worst over the path's configurations, M0* among them
    assert data["sampled_data_spectral_radius"] >= data["sampled_data_spectral_radius_at_M0"]
    assert data["warnings"] == [data["checks"]["sampled_data"]["detail"]]


def test_json_at_200_hz_flags_the_bound_filter(capsys):
    code, out, err = _run(capsys, "design", "--sample-time", "0.005", "--json", "--no-sim")
    assert code == 0, err
    data = json.loads(out)
    assert data["sampled_data_spectral_radius"] < 1.0
    assert len(data["warnings"]) == 1 and "filter_a" in data["warnings"][0]


def test_text_report_flags_failed_checks_in_words(capsys):
    code, out, _ = _run(capsys, "design", "--no-sim")
    assert code == 0
    assert "[FAILED] sampled-data closed loop" in out
    assert "UNSTABLE" in out
    assert "1 check(s) FAILED" in out
    _, smaller_gain, _ = _run(capsys, "design", "--alpha-star", "2", "--no-sim")
    assert "all checks passed" in smaller_gain


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["design", "--sample-time", "0"], "timing.sample_time"),
        (["design", "--sample-time", "-0.01"], "timing.sample_time"),
        (["design", "--sample-time", "nan"], "timing.sample_time"),
        (["design", "--alpha-star", "0"], "controller.alpha_star"),
        (["design", "--alpha-star", "inf"], "controller.alpha_star"),
    ],
)
def test_bad_value_gives_one_line_and_exit_2(capsys, args, needle):
    code, out, err = _run(capsys, *args)
    assert code == 2 and out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], err


def test_end_to_end_bad_input_is_one_line_and_nonzero():
    result = subprocess.run(
        [sys.executable, "-m", "posfb.analysis.cli", "design", "--alpha-star", "big"],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "alpha-star" in lines[0]
    assert "Traceback" not in result.stderr


def test_a_lin_lc_entry_reports_only_its_own_design(capsys):
    # Lin+LC's entry holds the linear torque's inputs only: its report shows no alpha*, no
    # E, no proposed loop, and its three checks.
    assert main(["design", "--no-sim"]) == 0
    proposed = capsys.readouterr().out
    assert main(["design", "--set", "controller.kind=lin_lc", "--no-sim"]) == 0
    text = capsys.readouterr().out
    assert "alpha*" not in text and "E = " not in text and "(proposed" not in text
    # The same LQR inputs carried over: the same Lin+LC loop as in the paper's entry.
    line = next(row for row in text.splitlines() if "spectral radius (Lin+LC)" in row)
    assert text.count("[ok]") == 3 and line in proposed
    assert main(["design", "--set", "controller.kind=lin_lc", "--json", "--no-sim"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert set(data["checks"]) == {"riccati", "lc_filter", "sampled_data_lin_lc"}
    assert data["sampled_data_spectral_radius"] is None and data["E"] is None


def test_the_design_is_confirmed_on_the_exact_arm_unless_no_sim(capsys):
    code, out, err = _run(capsys, "design", "--set", "timing.duration=1", "--json")
    assert code == 0, err
    exact = json.loads(out)["exact_arm"]
    assert exact["status"] == "ok" and exact["reached_s"] == pytest.approx(1.0)
    code, out, err = _run(capsys, "design", "--no-sim", "--json")
    assert code == 0, err
    assert "exact_arm" not in json.loads(out)
