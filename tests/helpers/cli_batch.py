"""Many ``posfb`` commands, each in a process of its own, without paying each one's
start-up: a fresh interpreter spends 3-5 s importing Drake, SciPy and posfb before a
command reads its first argument, which made ``tests/analysis/cli/test_misuse.py``'s 200-odd cases
the suite's slowest fixture. ``run_commands`` starts one server process that imports
those once, then forks a child per command; the child runs ``python -m
posfb.analysis.cli`` (``runpy``, as ``-m`` does) in the command's folder and environment,
with its own stdout and stderr (file descriptors, so that a C library's output is
caught too), and exits as the interpreter would: ``SystemExit``'s code, or a traceback
on stderr and 1 for an uncaught exception. A child is a fresh process in every way a
command can see but one: its modules were imported before its arguments were read (a
failure at import time would show in every command and in the suite's subprocess tests).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

#: The server: imports, then one forked child per job, ``workers`` at a time.
_SERVER = r"""
import json, os, runpy, signal, sys, traceback

import posfb.analysis.cli  # the parser
import posfb.diagrams.resolve  # the scenario loader with Drake and SciPy: most commands'

jobs, workers = json.loads(sys.stdin.read()), int(sys.argv[1])
running, codes = {}, {}


def run_child(job):
    os.chdir(job["cwd"])
    os.environ.clear()
    os.environ.update(job["env"])
    for fd, name in ((1, "stdout"), (2, "stderr")):
        os.dup2(os.open(job[name], os.O_WRONLY | os.O_CREAT | os.O_TRUNC), fd)
    os.dup2(os.open(os.devnull, os.O_RDONLY), 0)
    signal.alarm(job["timeout"])
    sys.argv = ["posfb", *job["args"]]
    try:
        runpy.run_module("posfb.analysis.cli", run_name="__main__", alter_sys=True)
        code = 0
    except SystemExit as exit:
        code = exit.code
    except BaseException:
        traceback.print_exc()
        code = 1
    sys.stdout.flush()
    sys.stderr.flush()
    return code


for index, job in enumerate(jobs):
    while len(running) >= workers:
        pid, status = os.wait()
        codes[running.pop(pid)] = os.waitstatus_to_exitcode(status)
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid == 0:  # the child ends as the interpreter does, through SystemExit
        raise SystemExit(run_child(job))
    running[pid] = index
while running:
    pid, status = os.wait()
    codes[running.pop(pid)] = os.waitstatus_to_exitcode(status)
print(json.dumps([codes[i] for i in range(len(jobs))]))
"""


@dataclass(frozen=True)
class Command:
    """``posfb ARGS`` run in ``cwd``, with ``env`` (``None``: the suite's environment)."""

    args: Sequence[str]
    cwd: Path
    env: Mapping[str, str] | None = None


def run_commands(
    commands: Sequence[Command], workers: int = 2, timeout: int = 300
) -> list[subprocess.CompletedProcess]:
    """Each command's exit code, stdout and stderr, in order (``workers`` at a time, each
    killed by ``SIGALRM`` after ``timeout`` seconds)."""
    with tempfile.TemporaryDirectory(prefix="posfb-cli-batch-") as scratch:
        jobs = [
            {"args": list(c.args), "cwd": str(c.cwd), "env": dict(os.environ if c.env is None
                                                                 else c.env),
             "stdout": f"{scratch}/{i}.out", "stderr": f"{scratch}/{i}.err", "timeout": timeout}
            for i, c in enumerate(commands)
        ]  # fmt: skip
        server = subprocess.run(
            [sys.executable, "-c", _SERVER, str(workers)], input=json.dumps(jobs),
            capture_output=True, text=True, timeout=timeout * len(jobs),
        )  # fmt: skip
        assert server.returncode == 0, server.stderr
        codes = json.loads(server.stdout.strip().splitlines()[-1])
        return [
            subprocess.CompletedProcess(
                ["posfb", *c.args], code, Path(job["stdout"]).read_text(),
                Path(job["stderr"]).read_text(),
            )  # fmt: skip
            for c, job, code in zip(commands, jobs, codes, strict=True)
        ]
