"""Run the unfinished samples of a study on local worker processes or a Dask
cluster, writing each result as it arrives.

Only the parent process writes to the store (one transaction per sample, in
completion order). At most ``2 x workers`` samples are in flight at a time, so
a killed run loses at most those; the rest were never started. On Ctrl-C (the
workers ignore it) the queued samples are dropped and the running ones are
finished and stored before the run stops. A run killed outright (SIGTERM, SIGKILL)
loses its samples in flight, and its workers end themselves within a second
(``watchdog``).
Local workers come from a ``forkserver`` context (fresh processes, never a fork
of a parent with Drake threads) whose server preloads the worker module, so
each worker starts without importing Drake again. With a Dask scheduler
address, the same ``worker.evaluate(study_text, index)`` tasks go to an
existing ``dask.distributed`` cluster (its workers need posfb installed).
"""

from __future__ import annotations

import itertools
import multiprocessing
import os
import signal
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable, Generator, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass

from tqdm import tqdm

from posfb.analysis.errors import InterruptedRunError, UsageError
from posfb.analysis.montecarlo import worker
from posfb.analysis.montecarlo.config import Study, canonical_text, identity
from posfb.analysis.montecarlo.records import SampleResult
from posfb.analysis.montecarlo.store import ResultStore
from posfb.analysis.montecarlo.watchdog import watch_run

#: Samples in flight per worker (one running, one queued so no worker idles).
IN_FLIGHT_PER_WORKER = 2

#: The module the workers' forkserver imports first (workers ignore Ctrl-C).
FORKSERVER_INIT = "posfb.analysis.montecarlo.forkserver_init"

#: Seconds to wait for a Dask scheduler to answer.
DASK_CONNECT_TIMEOUT = "10s"

Evaluate = Callable[[str, int], SampleResult]


@dataclass(frozen=True)
class RunSummary:
    """What one ``run_study`` call did."""

    requested: int
    already_done: int
    written: int
    elapsed_s: float
    statuses: dict[str, int]

    @property
    def samples_per_second(self) -> float:
        return self.written / self.elapsed_s if self.elapsed_s > 0 else 0.0


def _local_results(
    study_text: str, pending: Iterator[int], workers: int, evaluate: Evaluate
) -> Generator[SampleResult, None, None]:
    context = multiprocessing.get_context("forkserver")
    # By name: importing it here would make this (the parent) process ignore Ctrl-C.
    context.set_forkserver_preload([FORKSERVER_INIT, worker.__name__])
    queue = pending
    in_flight: set[Future] = set()
    ctrl_c = _DeferredCtrlC()
    previous = ctrl_c.install()
    started = False
    pool = ProcessPoolExecutor(
        max_workers=workers, mp_context=context, initializer=watch_run, initargs=(os.getpid(),)
    )
    try:
        while True:
            for index in queue:
                in_flight.add(pool.submit(evaluate, study_text, index))
                if len(in_flight) >= IN_FLIGHT_PER_WORKER * workers:
                    break
            if not in_flight:
                return
            done: set[Future] = set()
            try:
                if started:
                    ctrl_c.allow()
                done, in_flight = wait(in_flight, return_when=FIRST_COMPLETED)
                ctrl_c.allowed = False
                started = True
            except KeyboardInterrupt:
                ctrl_c.allowed = True  # a second Ctrl-C drops the samples in flight
                yield from _drain(done | in_flight)
                raise
            for future in done:
                yield future.result()
    except BrokenProcessPool:
        if ctrl_c.pending:  # Ctrl-C reached the forkserver before it could ignore it
            raise KeyboardInterrupt from None
        raise
    finally:
        ctrl_c.uninstall(previous)
        pool.shutdown(wait=False, cancel_futures=True)


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
        if self.allowed:
            raise KeyboardInterrupt
        self.pending = True

    def allow(self) -> None:
        """From now on Ctrl-C raises; one that came meanwhile raises now."""
        self.allowed = True
        if self.pending:
            self.pending = False
            raise KeyboardInterrupt

    def install(self) -> object:
        """Install (from the main thread only; elsewhere Ctrl-C is not ours to handle)."""
        if threading.current_thread() is not threading.main_thread():
            return None
        return signal.signal(signal.SIGINT, self)

    @staticmethod
    def uninstall(previous: object) -> None:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)


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
    study_text: str, pending: Iterator[int], address: str, evaluate: Evaluate, key: str
) -> Generator[SampleResult, None, None]:
    from dask.distributed import Client, as_completed

    try:
        client = Client(address, timeout=DASK_CONNECT_TIMEOUT)
    except (OSError, TimeoutError) as error:
        raise UsageError(f"cannot reach the Dask scheduler at {address}: {error}") from None
    try:
        slots = max(1, sum(client.nthreads().values())) * IN_FLIGHT_PER_WORKER
        queue = pending

        def submit(index: int):
            return client.submit(evaluate, study_text, index, key=f"{key}-{index}", pure=False)

        running = as_completed([submit(index) for index in itertools.islice(queue, slots)])
        for future in running:
            result = future.result()
            future.release()
            next_index = next(queue, None)
            if next_index is not None:
                running.add(submit(next_index))
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
    """Evaluate every sample of ``study`` not yet in ``store`` and store it.

    ``evaluate(study_text, index)`` must be importable by the workers (a
    module-level function); the default runs the closed loops."""
    if workers < 1:
        raise UsageError(f"workers = {workers!r}; at least 1 worker is required")
    finished = store.finished()
    already = sum(1 for index in finished if index < study.samples)
    todo = study.samples - already
    # Lazy: the memory of a run does not grow with --samples.
    pending = (index for index in range(study.samples) if index not in finished)
    text = canonical_text(study)
    if todo == 0:
        results: Generator[SampleResult, None, None] = (result for result in ())
    elif dask_scheduler:
        key = f"posfb-montecarlo-{identity(study)[:12]}"
        results = _dask_results(text, pending, dask_scheduler, evaluate, key)
    else:
        results = _local_results(text, pending, max(1, min(workers, todo)), evaluate)
    statuses: Counter[str] = Counter()
    written = 0
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
    )


def interrupted(store: ResultStore, study: Study, where: str) -> InterruptedRunError:
    """The one line of a run stopped by Ctrl-C: how many samples ``store`` (at
    ``where``) keeps and how to resume."""
    saved = sum(1 for index in store.finished() if index < study.samples)
    return InterruptedRunError(
        f"{saved} of {study.samples} samples are saved in {where}; run the same command "
        "again to resume"
    )
