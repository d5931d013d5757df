"""Run the unfinished samples of a study on local worker processes or a Dask
cluster, writing each result as it arrives.

Only the parent process writes to the store (one transaction per sample, in
completion order). At most ``2 x workers`` samples are in flight at a time, so
a killed run loses at most those; the rest were never started. On Ctrl-C (the
workers ignore it) the queued samples are dropped and the running ones are
finished and stored before the run stops.
Local workers come from a ``forkserver`` context (fresh processes, never a fork
of a parent with Drake threads) whose server preloads the worker module, so
each worker starts without importing Drake again. With a Dask scheduler
address, the same ``worker.evaluate(study_text, index)`` tasks go to an
existing ``dask.distributed`` cluster (its workers need posfb installed).
"""

from __future__ import annotations

import itertools
import multiprocessing
import sys
import time
from collections import Counter
from collections.abc import Callable, Generator, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from dataclasses import dataclass

from tqdm import tqdm

from posfb.analysis.errors import UsageError
from posfb.analysis.montecarlo import worker
from posfb.analysis.montecarlo.config import Study, canonical_text, identity
from posfb.analysis.montecarlo.records import SampleResult
from posfb.analysis.montecarlo.store import ResultStore

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
    pool = ProcessPoolExecutor(max_workers=workers, mp_context=context)
    try:
        while True:
            for index in queue:
                in_flight.add(pool.submit(evaluate, study_text, index))
                if len(in_flight) >= IN_FLIGHT_PER_WORKER * workers:
                    break
            if not in_flight:
                return
            try:
                done, in_flight = wait(in_flight, return_when=FIRST_COMPLETED)
            except KeyboardInterrupt:
                yield from _drain(in_flight)
                raise
            for future in done:
                yield future.result()
    finally:
        pool.shutdown(wait=False, cancel_futures=True)


def _drain(in_flight: set[Future]) -> Generator[SampleResult, None, None]:
    """After Ctrl-C: drop the queued samples, finish (and so keep) the running ones; a
    second Ctrl-C drops those too. The workers ignore Ctrl-C themselves."""
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
