"""Compiling generated C with the ``cc`` on the PATH, for ``posfb codegen --check`` and
software in the loop: the flags the code is written for (``CFLAGS``), and the
controller's object compiled once per source.

``compiled_object`` keeps each object it compiles in the posfb cache
(``models.disk_cache``: ``c_objects``, off with ``POSFB_CACHE_DIR=off``; private folders,
each entry's hash checked before use, so no one else can plant an object software in the
loop would load), by the SHA-256 of the generated source and header, the flags and the
compiler's identity (its path and ``--version``). A check and a ``--sil`` run of one
design, or a second ``--sil`` run, then compile the controller once: a large one (the
paper's controller on six joints) takes seconds at ``-O2``. The object is
position-independent, so it links into the check program and into the shared library
alike.

Every compiler call is bounded: it runs in a process group of its own, stopped (the
whole group: no compiler is left behind) after ``COMPILE_TIMEOUT_S`` seconds
(``$POSFB_COMPILE_TIMEOUT`` sets another limit) or when posfb is interrupted; on Linux
the compiler is also killed when posfb itself is killed outright (SIGKILL). A missing
compiler, a failure and a timeout are ``CompilerError`` (one line, ``EXIT_COMPILER``).
"""

from __future__ import annotations

import contextlib
import ctypes
import functools
import hashlib
import math
import os
import shutil
import signal
import subprocess
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path

from posfb.analysis.codegen.package import CFLAGS
from posfb.analysis.common.errors import CompilerError
from posfb.models.disk_cache import CACHE_VERSION, entry_path, load_entry, save_entry

#: The flags of the controller's object beside ``CFLAGS`` (it links into a shared library).
OBJECT_FLAGS = ("-c", "-fPIC")

#: How long one compiler call may run (s) before it is stopped (module docstring): far
#: above the largest controller's compile (the paper's on six joints: 5-7 s at -O2).
COMPILE_TIMEOUT_S = 300.0

#: The environment variable that sets another limit (seconds, > 0).
TIMEOUT_ENV = "POSFB_COMPILE_TIMEOUT"


def compiler() -> str:
    """The C compiler on the PATH (``cc``); ``CompilerError`` without one."""
    found = shutil.which("cc")
    if found is None:
        raise CompilerError("a C compiler is required to build the generated code: no 'cc' "
                            "on the PATH (install gcc or clang)")  # fmt: skip
    return found


def compile_timeout() -> float:
    """The limit of one compiler call (s): ``$POSFB_COMPILE_TIMEOUT`` or
    ``COMPILE_TIMEOUT_S``; ``ValueError`` naming the variable for one that is not a
    number > 0."""
    text = os.environ.get(TIMEOUT_ENV)
    if text is None:
        return COMPILE_TIMEOUT_S
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0.0):
        raise ValueError(f"{TIMEOUT_ENV} = {text!r}; a number of seconds > 0 is required")
    return value


def _die_with_parent() -> None:
    """In the compiler's process before it runs (Linux): SIGKILL it when posfb dies, even
    killed outright (``prctl(PR_SET_PDEATHSIG)``, kept across its ``exec``)."""
    with contextlib.suppress(OSError, AttributeError):
        ctypes.CDLL(None, use_errno=True).prctl(1, signal.SIGKILL)  # 1: PR_SET_PDEATHSIG


def run_compiler(command: Sequence[str], folder: Path | None = None) -> tuple[int, str, str]:
    """``command`` (a compiler call) run in ``folder`` in a process group of its own:
    ``(exit code, stdout, stderr)``. Past the limit (``compile_timeout``) or on an
    interrupt, the whole group is killed; a timeout is ``CompilerError``."""
    limit = compile_timeout()
    process = subprocess.Popen(
        list(command), cwd=folder, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
        stderr=subprocess.PIPE, text=True, start_new_session=True,
        preexec_fn=_die_with_parent if sys.platform == "linux" else None,
    )  # fmt: skip
    try:
        out, err = process.communicate(timeout=limit)
    except BaseException as stopped:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(process.pid, signal.SIGKILL)
        process.communicate()
        if isinstance(stopped, subprocess.TimeoutExpired):
            raise CompilerError(
                f"the C compiler {command[0]} did not finish within {limit:g} s "
                f"({TIMEOUT_ENV} sets another limit)"
            ) from None
        raise
    return process.returncode, out, err


@functools.cache
def _identity(path: str) -> str:
    """The compiler at ``path`` and its ``--version`` text."""
    try:
        version = run_compiler([path, "--version"])[1]
    except OSError:
        version = ""
    return f"{path}\n{version}"


def compile_c(folder: Path, output: Path, sources: list[str], *flags: str) -> Path:
    """``output`` built from ``sources`` in ``folder`` by the ``cc`` on the PATH with the
    flags the code is written for (``CFLAGS``) and ``flags`` (linked with ``-lm`` unless
    ``-c``); ``CompilerError`` with the compiler's first line if it fails."""
    libraries = [] if "-c" in flags else ["-lm"]
    command = [compiler(), *CFLAGS.split(), *flags, "-o", str(output), *sources, *libraries]
    try:
        code, _, err = run_compiler(command, folder)
    except OSError as error:
        raise CompilerError(f"the C compiler {command[0]} could not be run: "
                            f"{error.strerror or error}") from None  # fmt: skip
    if code != 0:
        first = (err.strip().splitlines() or ["(no message)"])[0]
        raise CompilerError(
            f"the C compiler {command[0]} failed (exit {code}) building {output.name}: {first}"
        )
    return output


def compiled_object(folder: Path, files: Mapping[str, str], name: str) -> Path:
    """``NAME.c`` of ``files`` (written in ``folder``) compiled into ``folder/NAME.o``,
    copied from the cache when the same source was compiled before (module
    docstring)."""
    target = folder / f"{name}.o"
    parts = (files[f"{name}.c"], files[f"{name}.h"], CFLAGS, *OBJECT_FLAGS,
             _identity(compiler()), str(CACHE_VERSION))  # fmt: skip
    cached = entry_path("c_objects", hashlib.sha256("\0".join(parts).encode()).hexdigest())
    stored = None if cached is None else load_entry(cached)
    if stored is not None:
        target.write_bytes(stored)
        return target
    compile_c(folder, target, [f"{name}.c"], *OBJECT_FLAGS)
    if cached is not None:
        save_entry(cached, target.read_bytes())
    return target
