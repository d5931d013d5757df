"""Run the unfinished samples of a study on local worker processes or a Dask
cluster, writing each result as it arrives.

Only the parent process writes to the store (one transaction per sample, in
completion order). At most ``2 x workers`` samples are in flight at a time, so
a killed run loses at most those; the rest were never started. On Ctrl-C (the
workers ignore it) the queued samples are dropped and the running ones are
finished and stored before the run stops. A run killed outright (SIGTERM, SIGKILL)
loses its samples in flight, and its workers end themselves within a second
(``watchdog``).
A local worker that dies (killed, or by the out-of-memory killer) breaks the pool and
every sample in flight with it: a fresh pool runs those samples again, one at a time,
so the one that kills its worker again is known; it is recorded as that sample's error
(``WORKER_DIED``, every run ``error``, the draw kept) and the run goes on
(``RunSummary.worker_died``). A stored sample with runs missing
(``ResultStore.missing_runs``) is sent with the controllers to run on it.
Local workers come from a ``forkserver`` context (fresh processes, never a fork
of a parent with Drake threads) whose server preloads the worker module, so
each worker starts without importing Drake again. With a Dask scheduler
address, the same ``worker.evaluate(study_text, index)`` tasks go to an
existing ``dask.distributed`` cluster (its workers need posfb installed). There Dask
itself re-runs a task whose worker died, on another worker, up to its
``distributed.scheduler.allowed-failures`` (3 by default); a sample that still kills its
worker (``KilledWorker``) is recorded as ``WORKER_DIED`` as on a local pool.
"""

from __future__ import annotations

import itertools
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections import Counter, deque
from collections.abc import Callable, Generator, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass

from tqdm import tqdm

from posfb.analysis.common import termination
from posfb.analysis.common.errors import InterruptedRunError, UsageError, WorkerDiedError
from posfb.analysis.common.side_by_side import FORKSERVER_INIT
from posfb.analysis.montecarlo import worker
from posfb.analysis.montecarlo.records import SampleResult
from posfb.analysis.montecarlo.store import ResultStore
from posfb.analysis.montecarlo.watchdog import watch_run
from posfb.analysis.uncertainty.study import Study, canonical_text, identity

#: Samples in flight per worker (one running, one queued so no worker idles).
IN_FLIGHT_PER_WORKER = 2

#: Seconds to wait for a Dask scheduler to answer.
DASK_CONNECT_TIMEOUT = "10s"

#: ``evaluate(study_text, index)``, or ``evaluate(study_text, index, controllers)`` for
#: a sample stored with the runs of ``controllers`` missing.
Evaluate = Callable[..., SampleResult]

#: A unit of work: a sample's index and the controllers to run on it (``None``: every
#: controller of the study).
Task = tuple[int, tuple[str, ...] | None]

#: The message of the runs of a sample whose worker process died on it, and again on
#: its retry.
WORKER_DIED = (
    "the worker process died running this sample, and again on its retry (killed, "
    "e.g. by the out-of-memory killer or a signal)"
)


@dataclass(frozen=True)
class RunSummary:
    """What one ``run_study`` call did."""

    requested: int
    already_done: int
    written: int
    elapsed_s: float
    statuses: dict[str, int]
    #: The samples recorded as errors because their worker died (``WORKER_DIED``).
    worker_died: tuple[int, ...] = ()

    @property
    def samples_per_second(self) -> float:
        return self.written / self.elapsed_s if self.elapsed_s > 0 else 0.0


def _arguments(study_text: str, task: Task) -> tuple[object, ...]:
    """The arguments of ``evaluate`` for ``task``."""
    index, controllers = task
    return (study_text, index) if controllers is None else (study_text, index, controllers)


def _local_results(
    study_text: str, pending: Iterator[Task], workers: int, evaluate: Evaluate
) -> Generator[SampleResult, None, None]:
    context = multiprocessing.get_context("forkserver")
    # By name: importing it here would make this (the parent) process ignore Ctrl-C.
    context.set_forkserver_preload([FORKSERVER_INIT, worker.__name__])
    in_flight: dict[Future, Task] = {}
    retries: deque[Task] = deque()  # in flight when a worker died: run again one at a time
    retried: set[int] = set()
    ctrl_c = _DeferredCtrlC()
    previous = ctrl_c.install()
    started = False
    pool = _pool(context, workers)
    try:
        while True:
            if retries or any(index in retried for index, _ in in_flight.values()):
                if retries and not in_flight:
                    task = retries.popleft()
                    retried.add(task[0])
                    in_flight[_submit(pool, evaluate, study_text, task)] = task
            else:
                for task in pending:
                    in_flight[_submit(pool, evaluate, study_text, task)] = task
                    if len(in_flight) >= IN_FLIGHT_PER_WORKER * workers:
                        break
            if not in_flight:
                if ctrl_c.pending:  # it came while the last sample was stored: never dropped
                    raise KeyboardInterrupt
                return
            done: set[Future] = set()
            try:
                if started:
                    ctrl_c.allow()
                done, _ = wait(in_flight, return_when=FIRST_COMPLETED)
                ctrl_c.allowed = False
                started = True
            except KeyboardInterrupt:
                ctrl_c.allowed = True  # a second Ctrl-C drops the samples in flight
                yield from _drain(set(in_flight))
                raise
            lost = yield from _finished(done, in_flight)
            if not lost:
                continue
            if ctrl_c.pending:  # Ctrl-C reached the forkserver before it could ignore it
                raise KeyboardInterrupt
            # The pool is broken: every sample still in flight is lost with it.
            lost += yield from _finished(set(in_flight), in_flight)
            pool.shutdown(wait=False, cancel_futures=True)
            pool = _pool(context, workers)
            if len(lost) == 1 and lost[0][0] in retried:  # it killed its worker again
                yield _worker_died(pool, study_text, lost[0])
            else:
                retries.extend(sorted(lost))
    finally:
        ctrl_c.uninstall(previous)
        # Joined when nothing runs any more: its manager thread, left behind, can still be
        # closing its pipes while the interpreter exits (an "OSError: [Errno 9] Bad file
        # descriptor" traceback after the command's last line: CPython's shutdown(wait=
        # False) races, gh-132969). Left behind when a second Ctrl-C dropped samples.
        idle = all(future.done() for future in in_flight)
        pool.shutdown(wait=idle, cancel_futures=True)


def _submit(pool: ProcessPoolExecutor, evaluate: Evaluate, study_text: str, task: Task) -> Future:
    """``task`` submitted to ``pool``; a pool that broke meanwhile gives a future that
    failed as the samples in flight did (the task is lost with them)."""
    try:
        return pool.submit(evaluate, *_arguments(study_text, task))
    except BrokenProcessPool as error:
        future: Future = Future()
        future.set_exception(error)
        return future


def _pool(context: multiprocessing.context.BaseContext, workers: int) -> ProcessPoolExecutor:
    """A local pool whose workers end themselves when this process is gone (``watchdog``)."""
    return ProcessPoolExecutor(
        max_workers=workers, mp_context=context, initializer=watch_run, initargs=(os.getpid(),)
    )


def _finished(
    done: set[Future], in_flight: dict[Future, Task]
) -> Generator[SampleResult, None, list[Task]]:
    """Yield the results of the ``done`` futures (removed from ``in_flight``; waited for
    first) and return the tasks lost with a broken pool. An exception of the evaluation
    itself (a bug) propagates."""
    lost = []
    for future in wait(done).done:
        task = in_flight.pop(future)
        if isinstance(future.exception(), BrokenProcessPool):
            lost.append(task)
        else:
            yield future.result()
    return lost


def _worker_died(pool: ProcessPoolExecutor, study_text: str, task: Task) -> SampleResult:
    """Sample ``task``'s draw with each of its runs recorded as ``error`` (``WORKER_DIED``),
    drawn on a worker of ``pool`` without running a controller."""
    index, controllers = task
    future = pool.submit(worker.record_failure, study_text, index, controllers, WORKER_DIED)
    try:
        return future.result()
    except BrokenProcessPool:
        raise WorkerDiedError(
            f"sample {index}: the worker process died on it twice, and again when only "
            "drawing it; every sample stored before is kept (run the same command again "
            "to resume)"
        ) from None


class _DeferredCtrlC:
    """The local pool's SIGINT handler: Ctrl-C is raised as ``KeyboardInterrupt`` only
    inside ``wait`` once the first sample is back, and kept pending elsewhere. So a store
    write is never cut, and the pool is never shut down while the forkserver still starts
    its workers (they would unpickle semaphores that are gone: a traceback, and the exit
    can hang). A handler, not a blocked signal mask: the kernel may hand SIGINT to any
    thread (BLAS, Drake), and Python runs the handler in the main thread regardless."""

    def __init__(self) -> None:
        self.allowed = False
        self.pending = False

    def __call__(self, signum: int, frame: object) -> None:
        if signum == signal.SIGTERM and not termination.received():
            return  # a forked worker, ended as by default
        if self.allowed:
            raise termination.TerminatedError if signum == signal.SIGTERM else KeyboardInterrupt
        self.pending = True

    def allow(self) -> None:
        """From now on Ctrl-C raises; one that came meanwhile raises now."""
        self.allowed = True
        if self.pending:
            self.pending = False
            raise KeyboardInterrupt

    def install(self) -> object:
        """Install for Ctrl-C, and for SIGTERM in a command's process
        (``analysis.common.termination``), from the main thread only (elsewhere the
        signals are not ours to handle); the previous handlers."""
        if threading.current_thread() is not threading.main_thread():
            return None
        previous = {signal.SIGINT: signal.signal(signal.SIGINT, self)}
        if termination.in_command_process():
            previous[signal.SIGTERM] = signal.signal(signal.SIGTERM, self)
        return previous

    @staticmethod
    def uninstall(previous: object) -> None:
        for signum, handler in (previous or {}).items():
            signal.signal(signum, handler)


def _drain(in_flight: set[Future]) -> Generator[SampleResult, None, None]:
    """After Ctrl-C: drop the queued samples, finish (and so keep) the running and the
    finished ones; a second Ctrl-C drops those too. The workers ignore Ctrl-C themselves."""
    running = {future for future in in_flight if not future.cancel()}
    if running:
        sys.stderr.write(
            f"stopping: finishing {len(running)} sample(s) in flight (Ctrl-C again to drop them)\n"
        )
    for future in running:
        try:
            yield future.result()
        except Exception:  # a failed sample is simply not kept
            continue


def _dask_results(
    study_text: str, pending: Iterator[Task], address: str, evaluate: Evaluate, key: str
) -> Generator[SampleResult, None, None]:
    from dask.distributed import Client, KilledWorker, as_completed

    try:
        client = Client(address, timeout=DASK_CONNECT_TIMEOUT)
    except (OSError, TimeoutError) as error:
        raise UsageError(f"cannot reach the Dask scheduler at {address}: {error}") from None
    try:
        slots = max(1, sum(client.nthreads().values())) * IN_FLIGHT_PER_WORKER
        queue = pending
        tasks: dict[str, Task] = {}

        def submit(task: Task):
            arguments = _arguments(study_text, task)
            future = client.submit(evaluate, *arguments, key=f"{key}-{task[0]}", pure=False)
            tasks[future.key] = task
            return future

        running = as_completed([submit(task) for task in itertools.islice(queue, slots)])
        for future in running:
            try:
                result = future.result()
            except KilledWorker:  # Dask retried it on fresh workers; each one died
                index, controllers = tasks[future.key]
                result = client.submit(
                    worker.record_failure, study_text, index, controllers, WORKER_DIED,
                    key=f"{key}-{index}-died", pure=False,
                ).result()  # fmt: skip
            tasks.pop(future.key, None)
            future.release()
            next_task = next(queue, None)
            if next_task is not None:
                running.add(submit(next_task))
            yield result
    finally:
        client.close()


def run_study(
    study: Study,
    store: ResultStore,
    code_version: str,
    workers: int = 1,
    dask_scheduler: str | None = None,
    progress: bool = True,
    evaluate: Evaluate = worker.evaluate,
) -> RunSummary:
    """Evaluate every sample of ``study`` not yet in ``store`` (and the missing runs of
    those stored incomplete) and store it.

    ``evaluate(study_text, index)`` must be importable by the workers (a
    module-level function); the default runs the closed loops."""
    if workers < 1:
        raise UsageError(f"workers = {workers!r}; at least 1 worker is required")
    finished, partial = store.finished(), store.missing_runs()
    already = sum(1 for index in finished if index < study.samples)
    todo = study.samples - already
    # Lazy: the memory of a run does not grow with --samples.
    pending = (
        (index, partial.get(index)) for index in range(study.samples) if index not in finished
    )
    text = canonical_text(study)
    if todo == 0:
        results: Generator[SampleResult, None, None] = (result for result in ())
    elif dask_scheduler:
        key = f"posfb-montecarlo-{identity(study)[:12]}"
        results = _dask_results(text, pending, dask_scheduler, evaluate, key)
    else:
        results = _local_results(text, pending, max(1, min(workers, todo)), evaluate)
    statuses: Counter[str] = Counter()
    written, died = 0, []
    start = time.perf_counter()
    bar = tqdm(
        total=study.samples,
        initial=already,
        unit="sample",
        file=sys.stderr,
        disable=not progress,
        dynamic_ncols=True,
    )
    try:
        for result in results:
            store.write(result, code_version)
            written += 1
            statuses.update(run.status for run in result.runs)
            if any(run.message == WORKER_DIED for run in result.runs):
                died.append(result.index)
            bar.update(1)
    finally:
        results.close()  # stops the workers at once on an interrupt or a failure
        bar.close()
    return RunSummary(
        requested=study.samples,
        already_done=already,
        written=written,
        elapsed_s=time.perf_counter() - start,
        statuses=dict(statuses),
        worker_died=tuple(sorted(died)),
    )


def interrupted(store: ResultStore, study: Study, where: str) -> InterruptedRunError:
    """The one line of a run stopped by Ctrl-C: how many samples ``store`` (at
    ``where``) keeps and how to resume."""
    saved = sum(1 for index in store.finished() if index < study.samples)
    return InterruptedRunError(
        f"{saved} of {study.samples} samples are saved in {where}; run the same command "
        "again to resume"
    )
