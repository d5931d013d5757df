"""Small studies and row comparisons shared by the Monte-Carlo tests."""

from __future__ import annotations

from pathlib import Path

from helpers.paths import REPO
from posfb.analysis.montecarlo.records import ControllerRun, SampleResult, metric_columns
from posfb.analysis.montecarlo.store import ResultStore
from posfb.analysis.uncertainty.coverage import BOUND_NAMES

#: A store an earlier posfb wrote (schema version 3, before the ``saturated`` and
#: ``lost`` statuses): the realism study's ideal arm, shipped with the docs.
EARLIER_STORE = REPO / "docs/realism/stores/ideal.sqlite"

#: A tiny study: two controllers, 1 s runs, parameters drawn the shipped study's way.
TINY_STUDY = """\
seed: 7
samples: 4
duration: 1.0
controllers: [proposed, pid]
encoder_counts: [20000, 4000]
parameters:
  link_mass: [!Uniform {min: -0.2, max: 0.2, relative: true}]
  link_com: [!Uniform {min: -0.1, max: 0.1, relative: true}]
  damping: [!Uniform {min: -0.2, max: 0.2, relative: true}]
  coulomb: [!Uniform {min: -0.2, max: 0.2, relative: true}, !Deterministic {}]
  motor_constant: [!Gaussian {mean: 0.0, stddev: 0.05, relative: true, min: -0.15, max: 0.15}]
  payload_mass: !Uniform {min: 0.0, max: 0.5}
"""


def write_study(folder: Path, text: str = TINY_STUDY, name: str = "study.yaml") -> Path:
    path = folder / name
    path.write_text(text)
    return path


def deterministic_rows(db: Path) -> tuple[list[dict], list[dict]]:
    """The store's rows without what legitimately differs between runs (wall time,
    when and by which code version a sample was written)."""
    with ResultStore.open_existing(db) as store:
        samples = [
            {k: v for k, v in row.items() if k not in ("finished_at", "code_version")}
            for row in store.sample_rows()
        ]
        runs = [{k: v for k, v in row.items() if k != "wall_time_s"} for row in store.run_rows()]
    return samples, runs


def all_rows(db: Path) -> tuple[list[dict], list[dict]]:
    """Every column of every row."""
    with ResultStore.open_existing(db) as store:
        return store.sample_rows(), store.run_rows()


def make_result(index: int, controllers=("proposed", "pid"), status="ok") -> SampleResult:
    """A finished sample with made-up numbers (no simulation)."""
    metrics = {column: 0.001 * (index + 1) * (k + 1) for k, column in enumerate(metric_columns(2))}
    return SampleResult(
        index=index,
        parameters={"link_mass": [5.0, 0.9], "payload_mass": 0.1 * index},
        encoder_counts=20000,
        theta={"theta1": 0.33, "l1": 0.25},
        bound_ratios={**dict.fromkeys(BOUND_NAMES, 0.2), "delta_M1": 1.5},
        inside_bounds=False,
        runs=tuple(
            ControllerRun(c, status, "" if status == "ok" else "stopped", metrics)
            for c in controllers
        ),
    )


def fake_evaluate(study_text: str, index: int) -> SampleResult:
    """A stand-in for ``worker.evaluate`` (no simulation) that fails on sample 2, as a
    bug in the worker code would."""
    if index == 2:
        raise RuntimeError("bug in the worker")
    return make_result(index)


def run_into_store(path: Path, study_text: str, workers: int = 1) -> Path:
    """Run the study ``study_text`` (the real closed loop) into a new store at ``path``."""
    from posfb.analysis.montecarlo.scheduler import run_study
    from posfb.analysis.uncertainty.study import study_from_text

    study = study_from_text(study_text)
    with ResultStore.create_or_resume(path, study, "test") as store:
        run_study(study, store, "test", workers=workers, progress=False)
    return path


def made_up_evaluate(study_text: str, index: int, controllers=None) -> SampleResult:
    """A stand-in for ``worker.evaluate`` (no simulation) that runs ``controllers``
    (default: the tiny study's)."""
    return make_result(index, controllers or ("proposed", "pid"))


#: A plug-in controller (P + gravity) whose worker process kills itself with SIGKILL,
#: as the out-of-memory killer does, on the samples that draw the voltage limit
#: ``kill_at``; each kill is logged (one line per try) to ``log``.
KILLER = '''\
import os
import signal
from pathlib import Path

import posfb


class Killer(posfb.Controller):
    def __init__(self, setup, kill_at=11.0, log="kills.log"):
        super().__init__(setup)
        self.kill = kill_at in tuple(setup.voltage_limit)
        self.log = Path(log)

    def step(self, q, desired, memory):
        if self.kill:
            with self.log.open("a") as file:
                file.write(f"{os.getpid()}\\n")
            os.kill(os.getpid(), signal.SIGKILL)
        gravity = self.setup.nominal.gravity(q)
        return 300.0 * (desired[: self.setup.joints] - q) + gravity, []
'''

#: A study of the killer and PID whose samples draw a voltage limit of 12 or 11 V.
KILLER_STUDY = """\
seed: 2
scenario: scenario.yaml
samples: 3
duration: 0.5
controllers: [Killer, pid]
draws:
  actuator.voltage_limit: !UniformDiscrete {values: [12.0, 11.0]}
"""


def write_killer_study(folder: Path) -> tuple[Path, Path]:
    """The killer plug-in, its scenario and ``KILLER_STUDY`` in ``folder``; returns the
    study's path and the kill log's."""
    log = folder / "kills.log"
    (folder / "killer.py").write_text(KILLER)
    (folder / "scenario.yaml").write_text(
        "controller: !Python {file: killer.py, class: Killer, settings: "
        f"{{kill_at: 11.0, log: {log}}}}}\n"
    )
    return write_study(folder, KILLER_STUDY), log


class SmallDisk:
    """A folder on a disk of its own that a test fills up and frees: a 4 MiB tmpfs
    mounted there where this process may mount one (root), or else a file-size limit
    (``RLIMIT_FSIZE``, SIGXFSZ ignored, so writes fail with EFBIG) on the commands
    ``run`` starts while the disk is "full". Either way the disk refuses real writes."""

    def __init__(self, folder: Path, size: int = 4 << 20) -> None:
        import subprocess

        self.folder = folder
        folder.mkdir()
        mount = ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(folder)]
        self.mounted = subprocess.run(mount, capture_output=True).returncode == 0
        self.full = False

    def fill(self) -> None:
        """Take every free byte (tmpfs), or limit the file size of later commands."""
        self.full = True
        if self.mounted:
            with (self.folder / "filler").open("wb", buffering=0) as filler:  # close: no flush
                try:
                    while True:
                        filler.write(b"\0" * (1 << 16))
                        filler.flush()
                except OSError:
                    pass

    def free(self) -> None:
        self.full = False
        (self.folder / "filler").unlink(missing_ok=True)

    def _limit(self) -> None:
        import resource
        import signal

        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (0, resource.RLIM_INFINITY))

    def run(self, args: list[str], cwd: Path):
        """``posfb ARGS`` in a subprocess (under the file-size limit while full)."""
        import subprocess
        import sys

        limit = self._limit if self.full and not self.mounted else None
        return subprocess.run(
            [sys.executable, "-m", "posfb.analysis.cli", *args],
            cwd=cwd, capture_output=True, text=True, timeout=300, preexec_fn=limit,
        )  # fmt: skip

    def close(self) -> None:
        import subprocess

        if self.mounted:
            subprocess.run(["umount", "-l", str(self.folder)], check=False)
