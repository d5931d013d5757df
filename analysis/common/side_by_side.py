"""Independent calls run side by side, one process each (issue 45: ``tune`` designs its
controllers at once, one per core).

``side_by_side(calls, workers, preload, say)`` runs each call ``function(*arguments,
say)`` in its own process of a ``forkserver`` context (fresh processes, never a fork of a
parent with Drake's threads, as the Monte-Carlo workers: ``analysis.montecarlo.
scheduler``), at most ``workers`` at once, and returns their results in the calls'
order. A call's ``say(text)`` reaches the parent's ``say`` (a progress line), in the
order the parent receives them.

Errors keep the order of a loop that makes the calls one after the other: the error
raised is the first call's, in the calls' order, that failed; it is raised once every
call before it has ended (one of them may fail first), and the calls after it are
stopped. A process that ends without a result (killed) raises ``RuntimeError`` naming
the call. On any exception in the parent (Ctrl-C included) every process still running
is stopped. The workers ignore Ctrl-C (``FORKSERVER_INIT``): the parent decides.

Arguments and results cross processes by ``pickle``: a call's arguments and its result
must pickle (an exception that does not is raised as a ``RuntimeError`` with its text).
"""

from __future__ import annotations

import multiprocessing
import os
import pickle
import queue
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass

#: The module every posfb forkserver imports first (its workers ignore Ctrl-C and have
#: ``scipy.stats``): this module's and the Monte-Carlo workers' (``analysis.montecarlo.
#: scheduler``), so that one forkserver serves both.
FORKSERVER_INIT = "posfb.analysis.common.forkserver_init"

#: Seconds the parent waits for a message before it looks at its processes.
POLL_SECONDS = 0.2


def available_cores() -> int:
    """The cores this process may run on (its CPU affinity, else the machine's count)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


@dataclass(frozen=True)
class Call:
    """``function(*arguments, say)`` run in a process; ``name`` says which in an error."""

    name: str
    function: Callable[..., object]
    arguments: tuple[object, ...]


def _picklable(error: BaseException) -> BaseException:
    """``error``, or a ``RuntimeError`` with its text when it does not pickle."""
    try:
        pickle.loads(pickle.dumps(error))
    except Exception:  # noqa: BLE001 - any pickling failure: send its text instead
        return RuntimeError(f"{type(error).__name__}: {error}")
    return error


def _child(index: int, call: Call, messages: multiprocessing.Queue) -> None:
    """A worker process: run ``call``, send its lines, then its result or its error."""

    def say(text: str) -> None:
        messages.put(("say", index, text))

    try:
        result = call.function(*call.arguments, say)
    except BaseException as error:  # noqa: BLE001 - every error goes to the parent
        messages.put(("error", index, _picklable(error)))
        return
    messages.put(("done", index, result))


def side_by_side(
    calls: Sequence[Call], workers: int, preload: Sequence[str] = (),
    say: Callable[[str], None] | None = None,
) -> list[object]:  # fmt: skip
    """The results of ``calls``, each run in its own process, at most ``workers`` at once
    (module docstring); ``preload``: modules the forkserver imports once, before it forks
    the workers (those the calls need, so that no worker imports them again)."""
    if not isinstance(workers, int) or workers < 1:
        raise ValueError(f"workers = {workers!r}; an integer >= 1 is required")
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload([FORKSERVER_INIT, *preload])
    messages = context.Queue()
    running: dict[int, multiprocessing.Process] = {}
    ended: dict[int, tuple[bool, object]] = {}  # index: (succeeded, result or error)
    pending = list(range(len(calls)))
    suspects: set[int] = set()
    try:
        while len(ended) < len(calls):
            failed = min((i for i, (ok, _) in ended.items() if not ok), default=None)
            if failed is not None and all(i in ended for i in range(failed)):
                raise ended[failed][1]
            while pending and len(running) < workers and (failed is None or pending[0] < failed):
                index = pending.pop(0)
                process = context.Process(target=_child, args=(index, calls[index], messages),
                                          name=f"posfb {calls[index].name}", daemon=True)
                process.start()
                running[index] = process
            try:
                kind, index, value = messages.get(timeout=POLL_SECONDS)
            except queue.Empty:
                _collect_dead(calls, running, ended, suspects)
                continue
            if kind == "say":
                if say is not None:
                    say(value)
                continue
            ended[index] = (kind == "done", value)  # a late result outranks "died"
            process = running.pop(index, None)
            if process is not None:
                process.join()
    finally:
        for process in running.values():
            process.terminate()
        for process in running.values():
            process.join()
    failed = min((i for i, (ok, _) in ended.items() if not ok), default=None)
    if failed is not None:
        raise ended[failed][1]
    return [ended[i][1] for i in range(len(calls))]


def _collect_dead(
    calls: Sequence[Call], running: dict[int, multiprocessing.Process],
    ended: dict[int, tuple[bool, object]], suspects: set[int],
) -> None:  # fmt: skip
    """Record as failed each running process that has ended without sending its result
    and was already seen ended at the last empty poll (a process sends its result before
    it ends, so one more wait on the queue reads a result that was still in the pipe)."""
    for index, process in list(running.items()):
        if process.is_alive():
            continue
        if index not in suspects:
            suspects.add(index)
            continue
        running.pop(index)
        ended[index] = (False, RuntimeError(
            f"the process of {calls[index].name} ended (exit code {process.exitcode}) before "
            "it sent its result"))  # fmt: skip


def beside(
    calls: Sequence[Call], workers: int, preload: Sequence[str] = ()
) -> Callable[[], list[object]]:
    """``side_by_side(calls, workers, preload)`` started in a thread, while the caller goes
    on with work of its own (a report draws figures meanwhile): a function that waits for
    the results and returns them, or raises the error ``side_by_side`` raised."""
    answer: dict[str, object] = {}

    def work() -> None:
        try:
            answer["results"] = side_by_side(calls, workers, preload)
        except BaseException as error:  # noqa: BLE001 - handed to the caller
            answer["error"] = error

    thread = threading.Thread(target=work, name="posfb side by side", daemon=True)
    thread.start()

    def results() -> list[object]:
        thread.join()
        if "error" in answer:
            raise answer["error"]
        return answer["results"]

    return results


def start_forkserver(preload: Sequence[str]) -> None:
    """Start the workers' forkserver now: it imports ``preload`` while the caller imports
    its own modules (a command that will run calls side by side), and the first
    ``side_by_side`` forks its workers at once. Only the server starts (no call, no
    queue), so a command that then stops on bad input leaves nothing behind."""
    from multiprocessing import forkserver

    multiprocessing.get_context("forkserver").set_forkserver_preload([FORKSERVER_INIT, *preload])
    forkserver.ensure_running()
