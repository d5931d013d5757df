"""Compiling generated C with the ``cc`` on the PATH, for ``posfb codegen --check`` and
software in the loop: the flags the code is written for (``CFLAGS``), and the
controller's object compiled once per source.

``compiled_object`` keeps each object it compiles in the posfb cache
(``models.disk_cache.cache_root()/c_objects``, off with ``POSFB_CACHE_DIR=off``), by the
SHA-256 of the generated source and header, the flags and the compiler's identity (its
path and ``--version``). A check and a ``--sil`` run of one design, or a second ``--sil``
run, then compile the controller once: a large one (the paper's controller on six joints)
takes seconds at ``-O2``. The object is position-independent, so it links into the check
program and into the shared library alike.
"""

from __future__ import annotations

import functools
import hashlib
import shutil
import subprocess
from collections.abc import Mapping
from pathlib import Path

from posfb.analysis.codegen.package import CFLAGS
from posfb.models.disk_cache import cache_root, store_entry

#: The flags of the controller's object beside ``CFLAGS`` (it links into a shared library).
OBJECT_FLAGS = ("-c", "-fPIC")


def compiler() -> str:
    """The C compiler on the PATH (``cc``); ``ValueError`` without one."""
    found = shutil.which("cc")
    if found is None:
        raise ValueError("a C compiler is required to build the generated code: no 'cc' on "
                         "the PATH (install gcc or clang)")  # fmt: skip
    return found


@functools.cache
def _identity(path: str) -> str:
    """The compiler at ``path`` and its ``--version`` text."""
    try:
        version = subprocess.run([path, "--version"], capture_output=True, text=True).stdout
    except OSError:
        version = ""
    return f"{path}\n{version}"


def compile_c(folder: Path, output: Path, sources: list[str], *flags: str) -> Path:
    """``output`` built from ``sources`` in ``folder`` by the ``cc`` on the PATH with the
    flags the code is written for (``CFLAGS``) and ``flags`` (linked with ``-lm`` unless
    ``-c``); ``RuntimeError`` with the compiler's first line if it fails."""
    libraries = [] if "-c" in flags else ["-lm"]
    command = [compiler(), *CFLAGS.split(), *flags, "-o", str(output), *sources, *libraries]
    result = subprocess.run(command, cwd=folder, capture_output=True, text=True)
    if result.returncode != 0:
        first = (result.stderr.strip().splitlines() or ["(no message)"])[0]
        raise RuntimeError(f"the generated code did not compile: {first}")
    return output


def compiled_object(folder: Path, files: Mapping[str, str], name: str) -> Path:
    """``NAME.c`` of ``files`` (written in ``folder``) compiled into ``folder/NAME.o``,
    copied from the cache when the same source was compiled before (module
    docstring)."""
    target = folder / f"{name}.o"
    root = cache_root()
    parts = (files[f"{name}.c"], files[f"{name}.h"], CFLAGS, *OBJECT_FLAGS,
             _identity(compiler()))  # fmt: skip
    key = hashlib.sha256("\0".join(parts).encode()).hexdigest()
    cached = None if root is None else root / "c_objects" / f"{key}.o"
    if cached is not None and cached.is_file():
        shutil.copyfile(cached, target)
        return target
    compile_c(folder, target, [f"{name}.c"], *OBJECT_FLAGS)
    if cached is not None:
        store_entry(cached, lambda temporary: shutil.copyfile(target, temporary))
    return target
