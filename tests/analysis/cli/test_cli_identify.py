"""``posfb identify`` end to end, as a user runs it."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from posfb.models.lumped import TABLE1

CLI = [sys.executable, "-m", "posfb.analysis.cli"]


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([*CLI, *args], capture_output=True, text=True, timeout=120)


@pytest.mark.slow
def test_json_has_exactly_the_documented_keys():
    result = _run("identify", "--json")
    assert result.returncode == 0, result.stderr
    data = json.loads(result.stdout)
    assert set(data) == {f"theta{i}" for i in range(1, 12)} | {"l1"}
    assert data["theta1"] == pytest.approx(TABLE1.theta1, rel=0.02)


@pytest.mark.slow
def test_table_lists_every_theta_beside_table1():
    result = _run("identify")
    assert result.returncode == 0, result.stderr
    for i in range(1, 12):
        assert f"| theta{i} |" in result.stdout


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["identify", "--payload", "-1"], "payload"),
        (["identify", "--payload", "nan"], "payload"),
        (["identify", "--urdf", "/no/such/arm.urdf"], "arm.urdf"),
        (["identify", "--payload", "heavy"], "payload"),
    ],
)
@pytest.mark.slow
def test_bad_input_gives_one_line_and_nonzero_exit(args, needle):
    result = _run(*args)
    assert result.returncode != 0
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert needle in lines[0]
    assert "Traceback" not in result.stderr
