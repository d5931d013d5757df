"""The model-error study (issue 29, item 5): its interpolation and its size measure
against closed forms, and ``posfb model-error`` end to end on a small study (runs,
resumes without redoing finished work, reports)."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

from posfb.analysis.model_error.model_error_report import crossing
from posfb.analysis.model_error.voltage_error import DesiredPath
from posfb.models.lumped import TABLE1
from posfb.models.trajectory import WaveTrajectory


def test_crossing_is_exact_for_a_power_law():
    # errors = a size^b is a straight line in log-log, which the interpolation follows
    # exactly: the crossing is (target / a)^(1 / b) (closed form).
    a, b, target = 0.02, 1.3, 0.0037
    sizes = [0.05, 0.1, 0.2, 0.4]
    errors = [a * s**b for s in sizes]
    assert crossing(sizes, errors, target) == pytest.approx((target / a) ** (1.0 / b), rel=1e-12)


def test_crossing_outside_the_scan_is_none():
    sizes, errors = [0.1, 0.2], [1.0, 2.0]
    assert math.isnan(crossing(sizes, errors, 3.0))  # never reached
    assert math.isnan(crossing(sizes, errors, 0.5))  # reached before the smallest size


def _paper_path() -> DesiredPath:
    return DesiredPath.of_trajectory(WaveTrajectory(), 0.01, 2000, TABLE1.l1, TABLE1.g)


def test_voltage_error_of_a_scaled_model_is_the_scale():
    # The voltage is linear in theta: a model (1 + eps) theta is off by eps of the
    # voltage at every sample, at each joint; an exact model by nothing.
    path, theta = _paper_path(), TABLE1.theta
    assert path.voltage_error(theta, theta) == pytest.approx(np.zeros((1, 2)), abs=1e-15)
    assert path.voltage_error(1.07 * theta, theta) == pytest.approx(np.full((1, 2), 0.07))


TINY_STUDY = """\
study:
  seed: 2013
  sampling: random
  scenario: {scenario}
  duration: 1.0
  controllers: [lin_lc, pid]
  encoder_counts: [20000]
identification:
  encoder_counts: [20000]
  plans: 1
  duration: 20.0
  controller: lin_lc
posterior_samples: 2
sizes: [0.1]
size_samples: 2
"""


@pytest.mark.slow
def test_model_error_runs_resumes_and_reports(tmp_path):
    from posfb.analysis.common.shipped import SCENARIO_DIR

    spec = tmp_path / "tiny.yaml"
    spec.write_text(TINY_STUDY.format(scenario=SCENARIO_DIR / "paper_nominal.yaml"))
    out = tmp_path / "out"
    command = [sys.executable, "-m", "posfb.analysis.cli", "model-error", str(spec),
               "--out", str(out), "--no-progress"]  # fmt: skip
    first = subprocess.run(command, capture_output=True, text=True)
    assert first.returncode == 0, first.stderr
    record = out / "identification" / "counts_20000_plan_0.json"
    stamp = record.stat().st_mtime_ns
    second = subprocess.run(command, capture_output=True, text=True)
    assert second.returncode == 0, second.stderr
    assert record.stat().st_mtime_ns == stamp  # a finished identification is not redone
    assert "0 new" in second.stderr  # nor a finished sample
    results = json.loads((out / "results.json").read_text())
    accuracy = results["accuracy"]["20000"]
    # the criterion on the identifiable theta: within 3 stated sigma
    assert accuracy["within_3_sigma"] >= 0.9 * accuracy["identifiable"]
    assert set(results["table3"]["medians"]) == {"ideal", "identified_20000"}
    assert set(results["size"]["medians"]) == {"ideal", "size_10"}
    # the drawn arms differ from the model (a model error), the ideal arm barely
    e_size = results["size"]["voltage_error"]["size_10"]
    assert all(e > 0.01 for e in e_size)
    report = (out / "report.md").read_text()
    assert "## (c) Model-error size" in report and "identified_20000" in report
    # Issue 43: damaged intermediate files (a kill or a full disk during an older write)
    # are named by --report-only and made again, with a line each, by the next run.
    plan = out / "identification" / "plan_0.csv"
    plan.write_text(plan.read_text()[:500])
    record.write_text('{"encoder_counts": 20000, "plan"')
    refused = subprocess.run([*command, "--report-only"], capture_output=True, text=True)
    assert refused.returncode == 2
    (line,) = refused.stderr.strip().splitlines()
    assert line.startswith(f"posfb model-error: error: {record} is damaged (Expecting ")
    assert line.endswith("; run posfb model-error without --report-only to make it again")
    third = subprocess.run(command, capture_output=True, text=True)
    assert third.returncode == 0, third.stderr
    assert f"{record} is damaged" in third.stderr and f"{plan} is damaged (" in third.stderr
    assert json.loads(record.read_text())["encoder_counts"] == 20000
