"""Faults of the C compiler, with real fake compilers on the ``PATH`` (issue 43): one
that hangs is stopped at the limit with its whole process group, one that fails without
a word and a missing one are one line each with ``EXIT_COMPILER``; the limit itself is
validated where it enters (``POSFB_COMPILE_TIMEOUT``). A real SIGTERM during a compile
is one line and ``EXIT_TERMINATED``, and leaves neither the compiler nor the software in
the loop's temporary folder behind."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from posfb.analysis.codegen.build import TIMEOUT_ENV
from posfb.analysis.common.errors import EXIT_COMPILER
from posfb.analysis.common.termination import EXIT_TERMINATED

pytestmark = pytest.mark.slow

#: A sleep no other process on the machine runs, to find the fake compiler's leftovers.
MARK = "4242.25"

FAKES = {
    "hangs": f"#!/bin/sh\nexec sleep {MARK}\n",
    "fails": "#!/bin/sh\nexit 1\n",
}


def sil_command(tmp_path: Path, fake: str | None, limit: str) -> tuple[list[str], dict]:
    """``posfb simulate --sil double`` (a short run) and its environment: the fake
    compiler ``fake`` as ``cc`` first on the PATH (``None``: no ``cc`` at all), the
    compile limit ``limit`` and a temporary folder of the test's own."""
    folder = tmp_path / "bin"
    folder.mkdir()
    path = str(folder)
    if fake is not None:
        script = folder / "cc"
        script.write_text(FAKES[fake])
        script.chmod(0o755)
        path += ":/usr/bin:/bin"
    (tmp_path / "tmp").mkdir()
    environment = {**os.environ, "PATH": path, TIMEOUT_ENV: limit,
                   "TMPDIR": str(tmp_path / "tmp")}  # fmt: skip
    command = [sys.executable, "-m", "posfb.analysis.cli", "simulate", "--controller",
               "lin_lc", "--sil", "double", "--set", "timing.duration=0.05"]  # fmt: skip
    return command, environment


def sil_run(tmp_path: Path, fake: str | None, limit: str = "2") -> subprocess.CompletedProcess:
    command, environment = sil_command(tmp_path, fake, limit)
    return subprocess.run(command, capture_output=True, text=True, env=environment,
                          cwd=tmp_path, timeout=240)  # fmt: skip


def fake_compilers() -> str:
    """The fake compiler's processes still running (``pgrep`` lines)."""
    return subprocess.run(["pgrep", "-f", f"sleep {MARK}"], capture_output=True,
                          text=True).stdout.strip()  # fmt: skip


def one_line(result: subprocess.CompletedProcess) -> str:
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr, result.stderr
    return lines[0]


def test_a_hanging_compiler_is_stopped_at_the_limit_with_its_children(tmp_path):
    began = time.monotonic()
    result = sil_run(tmp_path, "hangs")
    assert result.returncode == EXIT_COMPILER
    line = one_line(result)
    assert "did not finish within 2 s" in line and TIMEOUT_ENV in line and "cc" in line
    assert time.monotonic() - began < 120  # the start-up and one 2 s limit, not 4242 s
    assert fake_compilers() == "", "the fake compiler's process was left running"


def test_a_compiler_that_fails_silently_is_named(tmp_path):
    result = sil_run(tmp_path, "fails")
    assert result.returncode == EXIT_COMPILER
    line = one_line(result)
    assert "the C compiler" in line and "failed (exit 1)" in line and "(no message)" in line


def test_no_compiler_is_one_line(tmp_path):
    result = sil_run(tmp_path, None)
    assert result.returncode == EXIT_COMPILER
    assert "no 'cc' on the PATH" in one_line(result)


@pytest.mark.parametrize("limit", ["abc", "0", "-1", "nan"])
def test_a_bad_limit_names_the_variable(tmp_path, limit):
    result = sil_run(tmp_path, "fails", limit)
    assert result.returncode == 2
    assert f"{TIMEOUT_ENV} = {limit!r}; a number of seconds > 0 is required" in one_line(result)


def test_sigterm_during_a_compile_is_one_line_and_leaves_nothing(tmp_path):
    """... and a folder a run killed outright (SIGKILL) left is removed by this one."""
    command, environment = sil_command(tmp_path, "hangs", "600")
    killed = tmp_path / "tmp" / "posfb-sil-2147483647-left"  # no process has this id
    killed.mkdir()
    process = subprocess.Popen(command, stderr=subprocess.PIPE, stdout=subprocess.PIPE,
                               text=True, env=environment, cwd=tmp_path)  # fmt: skip
    began = time.monotonic()
    while fake_compilers() == "" and time.monotonic() - began < 120:  # the compile began
        time.sleep(0.2)
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == EXIT_TERMINATED, stderr
    lines = stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0] == "posfb simulate: terminated", stderr
    assert fake_compilers() == ""
    assert list((tmp_path / "tmp").glob("posfb-sil-*")) == []


def test_a_compiler_dies_with_a_posfb_killed_outright(tmp_path):
    """SIGKILL runs no cleanup in posfb; the compiler (here: the fake's ``sleep``, after
    its ``exec``) is killed with it all the same (Linux: ``PR_SET_PDEATHSIG``)."""
    command, environment = sil_command(tmp_path, "hangs", "600")
    process = subprocess.Popen(command, stderr=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                               env=environment, cwd=tmp_path)  # fmt: skip
    began = time.monotonic()
    while fake_compilers() == "" and time.monotonic() - began < 120:
        time.sleep(0.2)
    assert fake_compilers() != ""
    process.kill()
    process.wait(timeout=30)
    deadline = time.monotonic() + 10
    while fake_compilers() != "" and time.monotonic() < deadline:
        time.sleep(0.2)
    assert fake_compilers() == ""
