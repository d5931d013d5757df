"""Throughput and memory of ``posfb montecarlo run``.

    .venv/bin/python bench/bench_montecarlo.py [--samples 20] [--workers 1 2]

For the shipped study (``analysis/studies/paper_uncertainty.yaml``, 20 s runs
of the three controllers) it reports

* the serial compute rate: samples/s of one in-process evaluator, diagrams
  already built (what a warm worker sustains), and the share of a sample's time
  spent outside the simulations (sampling, identification, design checks, the
  spectral radii, metrics: everything but each run's ``wall_time_s``, which is
  Initialize + AdvanceTo);
* for each worker count, samples/s of the whole command path (store, pool
  start, diagram builds, SQLite commits) into a fresh store under ``--out``,
  and the share of the workers' time (workers x elapsed) not spent simulating;
* the peak memory of one worker process: RSS (shared pages of the forkserver
  counted) and USS (pages only that worker holds), sampled every 0.2 s.

``psutil`` comes with ``dask[distributed]``.
"""

from __future__ import annotations

import argparse
import threading
import time
from dataclasses import replace
from pathlib import Path

import psutil

from posfb.analysis.montecarlo.scheduler import run_study
from posfb.analysis.montecarlo.store import ResultStore
from posfb.analysis.montecarlo.worker import ClosedLoopEvaluator
from posfb.analysis.uncertainty.study import canonical_text, load_study

SHIPPED = Path(__file__).resolve().parent.parent / "analysis" / "studies" / "paper_uncertainty.yaml"


class WorkerMemory:
    """Peak RSS and USS (MiB) of the leaf descendants of this process (the workers)."""

    def __init__(self, period: float = 0.2) -> None:
        self.rss: dict[int, float] = {}
        self.uss: dict[int, float] = {}
        self._period = period
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._poll, daemon=True)

    def __enter__(self) -> WorkerMemory:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()

    def _poll(self) -> None:
        me = psutil.Process()
        while not self._stop.wait(self._period):
            for child in me.children(recursive=True):
                try:
                    if child.children():
                        continue  # the forkserver, not a worker
                    info = child.memory_full_info()
                except psutil.Error:
                    continue
                mib = 1 / 2**20
                self.rss[child.pid] = max(self.rss.get(child.pid, 0.0), info.rss * mib)
                self.uss[child.pid] = max(self.uss.get(child.pid, 0.0), info.uss * mib)


def serial_rate(study, samples: int) -> tuple[float, float]:
    """Samples/s of one warm in-process evaluator, and the share of its time spent
    outside the runs' simulations."""
    evaluator = ClosedLoopEvaluator(study)
    evaluator(0)  # warm-up: design caches, first-call costs
    simulating = 0.0
    start = time.perf_counter()
    for index in range(1, samples + 1):
        result = evaluator(index)
        simulating += sum(run.metrics["wall_time_s"] or 0.0 for run in result.runs)
    elapsed = time.perf_counter() - start
    return samples / elapsed, 1.0 - simulating / elapsed


def simulated_seconds(db: Path) -> float:
    """The stored runs' summed simulation wall time."""
    with ResultStore.open_existing(db) as store:
        return sum(row["wall_time_s"] or 0.0 for row in store.run_rows())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", default=str(SHIPPED))
    parser.add_argument("--samples", type=int, default=20)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--serial-samples", type=int, default=5)
    parser.add_argument("--out", default="/tmp/posfb-bench")
    args = parser.parse_args()
    study = replace(load_study(args.study), samples=args.samples)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    print(
        f"study {args.study}: {len(canonical_text(study))} B canonical, "
        f"{study.duration:g} s runs of {', '.join(study.controllers)}"
    )
    rate, outside = serial_rate(study, args.serial_samples)
    print(
        f"serial, warm, in-process: {rate:.3f} samples/s ({1 / rate:.2f} s per sample), "
        f"{100 * outside:.1f} % of it outside the simulations"
    )
    for workers in args.workers:
        db = out / f"bench_w{workers}.sqlite"
        for suffix in ("", "-wal", "-shm"):
            Path(f"{db}{suffix}").unlink(missing_ok=True)
        with ResultStore.create_or_resume(db, study, "bench") as store, WorkerMemory() as memory:
            summary = run_study(study, store, "bench", workers=workers, progress=False)
        busy = workers * summary.elapsed_s
        outside = 1.0 - simulated_seconds(db) / busy
        print(
            f"workers {workers}: {summary.written} samples in {summary.elapsed_s:.1f} s = "
            f"{summary.samples_per_second:.3f} samples/s ({100 * outside:.1f} % of "
            f"workers x elapsed outside the simulations); statuses {summary.statuses}; "
            f"worker peak RSS {max(memory.rss.values(), default=0):.0f} MiB, "
            f"USS {max(memory.uss.values(), default=0):.0f} MiB"
        )


if __name__ == "__main__":
    main()
