"""Run (or resume) every study of a realism file, one SQLite store each."""

from __future__ import annotations

import sys
from pathlib import Path

from posfb.analysis.common.errors import UsageError
from posfb.analysis.common.provenance import code_version
from posfb.analysis.montecarlo.scheduler import interrupted, run_study
from posfb.analysis.montecarlo.store import ResultStore
from posfb.analysis.realism.spec import RealismStudies


def store_path(stores: Path, name: str) -> Path:
    """The store of the study ``name``."""
    return stores / f"{name}.sqlite"


def run_realism(
    studies: RealismStudies,
    stores: Path,
    workers: int = 1,
    progress: bool = True,
    only: list[str] | None = None,
) -> dict[str, tuple[int, ...]]:
    """Every study of ``studies`` (those named in ``only``, where given) into
    ``stores/NAME.sqlite``, in order; finished samples are kept (a store resumes), so an
    interrupted run loses only samples in flight. Returns, by study, the samples
    recorded as errors because their worker process died (``scheduler.WORKER_DIED``;
    studies without such samples are left out)."""
    names = list(studies.studies)
    for name in only or ():
        if name not in names:
            raise UsageError(f"--only {name!r}; one of {', '.join(names)} is required")
    stores.mkdir(parents=True, exist_ok=True)
    version, died = code_version(), {}
    for name, study in studies.studies.items():
        if only is not None and name not in only:
            continue
        path = store_path(stores, name)
        with ResultStore.create_or_resume(path, study, version) as store:
            try:
                summary = run_study(study, store, version, workers=workers, progress=progress)
            except KeyboardInterrupt:
                raise interrupted(store, study, f"{path} ({name})") from None
        sys.stderr.write(
            f"posfb realism: {name}: {summary.already_done + summary.written} of "
            f"{summary.requested} samples ({summary.written} new in {summary.elapsed_s:.0f} s)\n"
        )
        if summary.worker_died:
            died[name] = summary.worker_died
    return died
