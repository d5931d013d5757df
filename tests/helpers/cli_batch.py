"""Many ``posfb`` commands, each in a process of its own, without paying each one's
start-up: a fresh interpreter spends 3-5 s importing Drake, SciPy and posfb before a
command reads its first argument, which made ``tests/analysis/cli/test_misuse.py``'s 200-odd cases
the suite's slowest fixture. ``run_commands`` starts one server process that imports
those once, then forks a child per command; the child runs ``python -m
posfb.analysis.cli`` (``runpy``, as ``-m`` does) in the command's folder and environment,
with its own stdout and stderr (file descriptors, so that a C library's output is
caught too), and exits as the interpreter would: ``SystemExit``'s code, or a traceback
on stderr and 1 for an uncaught exception, after the command's threads and ``atexit``
functions, but without the interpreter's teardown (``os._exit``: freeing every object
the server imported made the kernel copy its pages, most of a refused command's time).
The server imports what the commands import when they run, then freezes its objects out
of the garbage collector's reach (``gc.freeze``). A child is a fresh process in every way
a command can see but one: its modules were imported before its arguments were read (a
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
import atexit, gc, json, os, runpy, signal, sys, threading, traceback

import posfb.analysis.cli  # the parser
import posfb.diagrams.resolve  # the scenario loader with Drake and SciPy: most commands'
# what the commands import when they run (each child would import them again)
import posfb.analysis.api, posfb.analysis.codegen.package
import posfb.analysis.design.design_report, posfb.analysis.design.margins_report
import posfb.analysis.design.stability_map, posfb.analysis.design.tune
import posfb.analysis.design.worst_case
import posfb.analysis.identification.identify, posfb.analysis.identification.plan
import posfb.analysis.model_error.run, posfb.analysis.model_error.spec
import posfb.analysis.montecarlo.replay, posfb.analysis.montecarlo.scheduler
import posfb.analysis.montecarlo.store, posfb.analysis.montecarlo.study_report
import posfb.analysis.montecarlo.worker
import posfb.analysis.realism.run, posfb.analysis.realism.spec

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
    return code


def exit_as_the_interpreter(code):
    # End the child as the interpreter ends, without its teardown: the status of
    # SystemExit(code) (a text printed on stderr, then 1), after the non-daemon threads
    # and the atexit functions the command left (as Py_FinalizeEx runs them). The
    # teardown (every module and object freed) is what a child would spend most on: it
    # touches every page the server imported and makes the kernel copy it.
    if code is None:
        status = 0
    elif isinstance(code, int):
        status = code
    else:
        print(code, file=sys.stderr)
        status = 1
    threading._shutdown()
    atexit._run_exitfuncs()
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(status & 0xFF)


gc.freeze()  # the server's objects: no child's collection walks (and copies) them
for index, job in enumerate(jobs):
    while len(running) >= workers:
        pid, status = os.wait()
        codes[running.pop(pid)] = os.waitstatus_to_exitcode(status)
    sys.stdout.flush()
    sys.stderr.flush()
    pid = os.fork()
    if pid == 0:
        exit_as_the_interpreter(run_child(job))
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
