"""Software in the loop (``posfb simulate --sil``): the scenario's controller generated as
C (``analysis.codegen.package``), compiled into a shared library by the ``cc`` on the
PATH and loaded as the diagram's controller (``models.controllers.compiled``); everything else
in the loop is unchanged. The library lives in a temporary folder removed at exit.
"""

from __future__ import annotations

import atexit
import os
import shutil
import tempfile
from pathlib import Path

from posfb.analysis.codegen.build import compile_c, compiled_object
from posfb.analysis.codegen.package import generate
from posfb.diagrams.resolve import ResolvedScenario
from posfb.models.controllers import make_controller
from posfb.models.controllers.compiled import CompiledController

#: The temporary folders' prefix; the creating process's id follows it.
FOLDER_PREFIX = "posfb-sil-"


def _remove_stale_folders() -> None:
    """Remove the temporary folders of software-in-the-loop runs that were killed outright
    (SIGKILL: nothing of theirs ran at exit): the user's own, whose process is gone."""
    for folder in Path(tempfile.gettempdir()).glob(f"{FOLDER_PREFIX}*-*"):
        pid = folder.name.removeprefix(FOLDER_PREFIX).split("-", 1)[0]
        try:
            if not pid.isdigit() or folder.stat().st_uid != os.geteuid():
                continue
            os.kill(int(pid), 0)
        except ProcessLookupError:
            shutil.rmtree(folder, ignore_errors=True)
        except (OSError, OverflowError):
            continue


def shared_library(files: dict[str, str], name: str) -> Path:
    """``files`` written to a new temporary folder and ``NAME.c`` compiled into a shared
    library there; ``CompilerError`` without a C compiler, if it fails or runs past its
    limit (``analysis.codegen.build``). The folder is removed at exit; one a killed run
    left is removed by the next run (``_remove_stale_folders``)."""
    _remove_stale_folders()
    folder = Path(tempfile.mkdtemp(prefix=f"{FOLDER_PREFIX}{os.getpid()}-"))
    atexit.register(shutil.rmtree, folder, ignore_errors=True)
    for file, text in files.items():
        (folder / file).write_text(text)
    controller = compiled_object(folder, files, name)
    return compile_c(folder, folder / f"lib{name}.so", [controller.name], "-shared")


def compiled_controller(
    resolved: ResolvedScenario, precision: str = "double"
) -> CompiledController:
    """The scenario's controller as compiled C (module docstring); ``ValueError`` (one
    line) for a controller without generated code, ``CompilerError`` for a compiler
    that is missing, fails or runs past its limit."""
    package = generate(resolved, None, precision)
    config = resolved.config
    simulated = make_controller(
        config.controller, config.design, voltage_limit=config.voltage_limit,
        settings=config.controller_settings,
    )  # fmt: skip
    return CompiledController(
        shared_library(package.files, package.name), package.name, precision,
        config.sample_time, package.law.joints, package.law.memory,
        tuple(simulated.internals_names), tuple(simulated.internals_columns),
    )  # fmt: skip
