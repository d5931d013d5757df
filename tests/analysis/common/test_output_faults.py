"""Outputs on a real full disk (``helpers.montecarlo_helpers.SmallDisk``: a small tmpfs,
or a file-size limit): one line naming the path, exit code 7, and nothing partial left
where the output goes (issue 43)."""

from __future__ import annotations

import pytest

from helpers.montecarlo_helpers import SmallDisk
from posfb.analysis.common.errors import EXIT_DISK_FULL

pytestmark = pytest.mark.slow


@pytest.fixture()
def disk(tmp_path):
    disk = SmallDisk(tmp_path / "disk")
    yield disk
    disk.close()


@pytest.mark.parametrize(
    "args, written",
    [
        (("identify", "plan", "--out", "{disk}/plan.csv"), "plan.csv"),
        (("codegen", "--controller", "lin_lc", "--out", "{disk}/c"), "c"),
    ],
)
def test_a_full_disk_names_the_output_and_leaves_nothing(disk, tmp_path, args, written):
    disk.fill()
    result = disk.run([a.replace("{disk}", str(disk.folder)) for a in args], cwd=tmp_path)
    assert result.returncode == EXIT_DISK_FULL, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    assert str(disk.folder) in lines[0]
    left = sorted(p.name for p in disk.folder.iterdir() if p.name != "filler")
    assert left == [], left  # no partial output, no temporary beside it
