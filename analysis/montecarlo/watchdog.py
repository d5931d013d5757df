"""A local worker ends itself when the run that started it is gone.

A ``posfb montecarlo run`` (or ``posfb realism``) killed by SIGTERM or SIGKILL cannot
stop its workers: they are children of the forkserver, not of the run, and a worker
blocked on the pool's queue or inside a sample never notices that nobody will read its
result. The forkserver itself stays up while any worker holds its pipe. So each worker
starts, as the pool's initializer, a daemon thread that looks every ``PERIOD_S`` seconds
whether the run's process still exists and ends the worker (``os._exit``) when it does
not; the forkserver and the resource tracker then see their pipes close and exit too.
The thread gets its turn whenever the worker runs Python (the controllers' blocks, every
sample period) or waits on a pipe or lock.
"""

from __future__ import annotations

import os
import threading
import time

#: How often a worker looks for the run that started it (s).
PERIOD_S = 1.0

#: The exit status of a worker that found its run gone.
ORPHANED = 3


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # a process of another user took the number: not ours
        return False
    return True


def _watch(run: int) -> None:
    while _alive(run):
        time.sleep(PERIOD_S)
    os._exit(ORPHANED)


def watch_run(run: int) -> None:
    """The pool's initializer: end this worker once process ``run`` is gone."""
    threading.Thread(target=_watch, args=(run,), name="posfb-watchdog", daemon=True).start()
