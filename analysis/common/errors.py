"""Errors the command line reports as one line, and the exit codes of runs."""

from __future__ import annotations

import errno
from collections.abc import Iterable
from typing import ClassVar


class UsageError(Exception):
    """Bad input detected after parsing; reported as one line and a non-zero exit."""


class InterruptedRunError(Exception):
    """The user stopped a command (Ctrl-C); the message says what was kept and how to go
    on. Reported as one line with exit code 130."""


#: Exit code of ``posfb codegen --check`` when a replayed voltage differs from the log's
#: by more than the tolerance (``analysis.codegen.check``): the code of a failed verdict,
#: as ``design --strict``'s.
EXIT_CHECK_FAILED = 1

#: Exit code of ``posfb simulate`` and ``posfb compare`` when a run diverged
#: (``status == "diverged"``; its metrics and files are still written), so that scripts
#: and sweeps catch it without parsing the output.
EXIT_DIVERGED = 4

#: Exit code of ``posfb simulate`` and ``posfb compare`` when a run finished but did not
#: track its path (``status`` ``saturated`` or ``lost``, ``analysis.common.metrics.run_verdict``;
#: a warning line says why, its metrics and files are still written) and none diverged.
EXIT_NOT_TRACKED = 5


def run_exit_code(statuses: Iterable[str]) -> int:
    """The exit code of ``simulate`` or ``compare`` for runs of these statuses: the
    worst wins (``EXIT_DIVERGED``, then ``EXIT_NOT_TRACKED``, else 0)."""
    from posfb.analysis.common.metrics import NOT_TRACKED_STATUSES

    seen = set(statuses)
    if "diverged" in seen:
        return EXIT_DIVERGED
    return EXIT_NOT_TRACKED if seen & set(NOT_TRACKED_STATUSES) else 0


#: Exit code when a results store is damaged (a table, its meta or a row posfb needs is
#: missing, or SQLite finds the file malformed): one line naming the store and what is
#: wrong; nothing is written to it.
EXIT_DAMAGED_STORE = 6

#: Exit code when the disk refuses a write (no space left, a quota or a file-size limit,
#: an I/O error): one line naming the path; every sample stored before is kept and the
#: same command resumes once there is room.
EXIT_DISK_FULL = 7

#: The ``OSError.errno`` values of a write the disk refused for want of room: no space
#: left, a quota, the process's file-size limit (``ulimit -f``).
DISK_FULL_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})

#: Exit code of ``posfb montecarlo run`` and ``posfb realism`` when a worker process
#: died (killed, or out of memory) on a sample and on its one retry: that sample is
#: recorded as ``error`` (its message says the worker died), the run goes on, and a
#: warning line names the samples.
EXIT_WORKER_DIED = 8


#: Exit code when the C compiler is missing, fails or does not finish within its time
#: (``posfb codegen --check``, ``simulate --sil``; ``analysis.codegen.build``): one line
#: naming the compiler and its first line of output, or the limit.
EXIT_COMPILER = 9


class EnvironmentFaultError(Exception):
    """A fault outside posfb (the disk, the store file, a killed process), not in the
    input nor a bug: reported as one line with the subclass's ``exit_code``."""

    exit_code: ClassVar[int]


class DamagedStoreError(EnvironmentFaultError):
    """A results store that posfb cannot read or resume (``EXIT_DAMAGED_STORE``)."""

    exit_code = EXIT_DAMAGED_STORE


class DiskFullError(EnvironmentFaultError):
    """The disk refused a write (``EXIT_DISK_FULL``)."""

    exit_code = EXIT_DISK_FULL


class CompilerError(EnvironmentFaultError):
    """The C compiler is missing, failed or ran past its time (``EXIT_COMPILER``)."""

    exit_code = EXIT_COMPILER


class WorkerDiedError(EnvironmentFaultError):
    """A worker process died even where nothing but the sample's draw ran
    (``EXIT_WORKER_DIED``)."""

    exit_code = EXIT_WORKER_DIED
