"""A cost model for a study, from a short calibration on this machine
(``posfb montecarlo run --dry-run``).

The calibration evaluates ``CALIBRATION_SAMPLES`` samples of the study in a fresh
worker process, started as ``montecarlo run`` starts its workers (the scheduler's
forkserver, with its preloaded modules), so the first sample pays what a worker's first
does: it builds the diagrams and designs, which this process may already hold from
validating the study (measured in this process, the warm-up read 0.00 s). It reports
the time per sample after the first and the worker's peak memory.
The prediction assumes the samples cost alike and that ``W`` local workers on ``W``
free cores run ``PARALLEL_EFFICIENCY x W`` times as fast as one (measured with
``bench/bench_montecarlo.py`` on this project's 2-core machine: 1.28 samples/s with
2 workers against 0.68 with 1), each worker holding about the calibration's memory.
A study whose draws change the diagram's structure from sample to sample (sample
time, delay, voltage limit) also pays a diagram build per new structure, which the
calibration sees only if its samples differ.
"""

from __future__ import annotations

import multiprocessing
import resource
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass

from posfb.analysis.common.side_by_side import FORKSERVER_INIT
from posfb.analysis.montecarlo import worker
from posfb.analysis.uncertainty.study import Study, canonical_text

#: Samples the calibration evaluates (the first is the warm-up).
CALIBRATION_SAMPLES = 3

#: Speed-up per worker beyond the first (module docstring).
PARALLEL_EFFICIENCY = 0.94


@dataclass(frozen=True)
class CostEstimate:
    """Seconds per sample (warm), the warm-up's extra seconds, peak memory (MiB) of one
    process, and the samples still to run."""

    seconds_per_sample: float
    warm_up_s: float
    memory_mib: float
    samples: int

    def wall_time_s(self, workers: int) -> float:
        """Predicted wall time with ``workers`` local workers (one warm-up each)."""
        speed_up = 1.0 if workers <= 1 else PARALLEL_EFFICIENCY * workers
        return self.warm_up_s + self.samples * self.seconds_per_sample / speed_up

    def memory_total_mib(self, workers: int) -> float:
        """Predicted memory of ``workers`` worker processes."""
        return self.memory_mib * max(1, workers)


def calibration_samples(study_text: str, count: int) -> tuple[list[float], float]:
    """In a worker process: the wall seconds of each of the first ``count`` samples of
    the study ``study_text`` and the process's peak memory (MiB) after them."""
    times = []
    for index in range(count):
        start = time.perf_counter()
        worker.evaluate(study_text, index)
        times.append(time.perf_counter() - start)
    return times, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def calibrate(study: Study, todo: int) -> CostEstimate:
    """Time ``CALIBRATION_SAMPLES`` samples of ``study`` in a fresh worker process
    (module docstring)."""
    count = min(CALIBRATION_SAMPLES, study.samples)
    context = multiprocessing.get_context("forkserver")
    context.set_forkserver_preload([FORKSERVER_INIT, worker.__name__])
    with ProcessPoolExecutor(max_workers=1, mp_context=context) as pool:
        times, memory_mib = pool.submit(calibration_samples, canonical_text(study), count).result()
    warm = times[1:] or times
    per_sample = sum(warm) / len(warm)
    return CostEstimate(
        seconds_per_sample=per_sample,
        warm_up_s=max(0.0, times[0] - per_sample),
        memory_mib=memory_mib,
        samples=todo,
    )


def _duration(seconds: float) -> str:
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.0f} min"
    if seconds < 3 * 86400:
        return f"{seconds / 3600:.1f} h"
    return f"{seconds / 86400:.1f} days"


def advice(estimate: CostEstimate, workers: int, cores: int) -> list[str]:
    """The lines ``--dry-run`` prints."""
    lines = [
        f"calibration: {estimate.seconds_per_sample:.2f} s per sample after a "
        f"{estimate.warm_up_s:.2f} s warm-up; {estimate.memory_mib:.0f} MiB per process",
        f"{estimate.samples} samples to run: about "
        f"{_duration(estimate.wall_time_s(workers))} with --workers {workers}, "
        f"{estimate.memory_total_mib(workers):.0f} MiB of workers",
    ]
    if workers < cores:
        lines.append(
            f"with --workers {cores} (every core here): about "
            f"{_duration(estimate.wall_time_s(cores))}, "
            f"{estimate.memory_total_mib(cores):.0f} MiB"
        )
    hour = 3600.0
    if estimate.wall_time_s(cores) > hour:
        needed = estimate.samples * estimate.seconds_per_sample / hour
        lines.append(
            f"to finish in about an hour: {needed:.0f} cores (a Dask cluster, "
            "--dask-scheduler tcp://host:port)"
        )
    return lines
