"""A store's results as arrays aligned by sample, and the plain counts the report uses.

Conventions (the report states them too):

* The RMS statistics use the runs that finished (``records.FINISHED``: ``ok``,
  ``saturated``, ``lost``, whose metrics cover the whole duration): a diverged run
  stops early, so its RMS covers a different time span; it counts as a failure
  (``diverged`` or ``error``) instead. A ``saturated`` or ``lost`` run is counted as
  such and keeps its RMS in the statistics (leaving it out would flatter the
  controller that failed).
* "The paper's controller beats PID" on a sample when ``proposed`` finished and
  either PID did not, or the proposed controller's tracking error
  ``||(rms_q1, .., rms_qn)||`` is smaller. The share is over the samples where
  neither run is an ``error``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from posfb.analysis.montecarlo.records import FINISHED, STATUSES, measured_columns
from posfb.analysis.montecarlo.store import RADIUS_COLUMN, ResultStore
from posfb.analysis.uncertainty.coverage import BOUND_NAMES
from posfb.analysis.uncertainty.statistics import Interval, median_interval, quantile_interval
from posfb.analysis.uncertainty.study import Study, VariedScalar, study_joints, varied_scalars
from posfb.models.controllers import PAPER_BASELINE, PAPER_CONTROLLER


@dataclass(frozen=True)
class StudyData:
    """A store's results as arrays aligned by sample (row ``i`` is ``samples[i]``).

    ``rms_q[controller]`` has shape ``(samples, joints)`` and ``saturated[controller]`` (the share
    of control samples with a commanded voltage beyond the limit) shape ``(n,)``, NaN
    where the run did not finish (``FINISHED``); ``rms_q_measured[controller]``, the RMS
    of the error the encoder reads, is shaped as ``rms_q`` and NaN also where the store
    did not record it
    (a version-2 store's samples); ``status[controller]`` holds the status strings.
    ``inputs`` maps the export column of every varied scalar (``varied_scalars``) to its
    drawn values; ``radius[controller]`` is the sampled-data spectral radius of the
    controller's designed loop on each plant (NaN where it has none)."""

    study: Study
    meta: dict[str, str]
    samples: np.ndarray
    payload: np.ndarray
    inside: np.ndarray
    exceeded: dict[str, int]
    code_versions: tuple[str, ...]
    controllers: tuple[str, ...]
    rms_q: dict[str, np.ndarray]
    rms_q_measured: dict[str, np.ndarray]
    saturated: dict[str, np.ndarray]
    status: dict[str, np.ndarray]
    messages: dict[str, list[str]]
    inputs: dict[str, np.ndarray]
    radius: dict[str, np.ndarray]
    joints: int


@dataclass(frozen=True)
class JointStats:
    """RMS tracking error (rad) of one controller at one joint over its finished runs."""

    controller: str
    joint: int
    count: int
    mean: float
    median: float
    p95: float
    max: float
    median_interval: Interval
    p95_interval: Interval


def load(store: ResultStore) -> StudyData:
    """Read every finished sample of ``store``."""
    study = store.study()
    samples = store.sample_rows()
    index = {row["sample"]: i for i, row in enumerate(samples)}
    n, joints = len(samples), study_joints(study)
    rms_columns = [f"rms_q{j + 1}" for j in range(joints)]
    measured_names = measured_columns(joints)
    rms_q = {c: np.full((n, joints), np.nan) for c in study.controllers}
    measured = {c: np.full((n, joints), np.nan) for c in study.controllers}
    saturated = {c: np.full(n, np.nan) for c in study.controllers}
    status = {c: np.full(n, "error", dtype=object) for c in study.controllers}
    messages: dict[str, list[str]] = {c: [] for c in study.controllers}
    radius = {c: np.full(n, np.nan) for c in study.controllers}
    for run in store.run_rows():
        i, controller = index[run["sample"]], run["controller"]
        status[controller][i] = run["status"]
        if run[RADIUS_COLUMN] is not None:
            radius[controller][i] = run[RADIUS_COLUMN]
        if run["status"] in FINISHED:
            rms_q[controller][i] = [run[column] for column in rms_columns]
            measured[controller][i] = [
                math.nan if run[column] is None else run[column] for column in measured_names
            ]
            saturated[controller][i] = run["saturated_fraction"]
        if run["status"] != "ok" and run["message"]:
            messages[controller].append(f"sample {run['sample']}: {run['message']}")
    return StudyData(
        study=study,
        meta=store.meta(),
        samples=np.array([row["sample"] for row in samples], dtype=int),
        payload=np.array([row["payload_mass"] for row in samples], dtype=float),
        inside=np.array([row["inside_bounds"] for row in samples], dtype=bool),
        exceeded={
            name: sum(row["bound_ratios"][name] > 1.0 for row in samples) for name in BOUND_NAMES
        },
        code_versions=tuple(sorted({row["code_version"] for row in samples})),
        controllers=tuple(study.controllers),
        rms_q=rms_q,
        rms_q_measured=measured,
        saturated=saturated,
        status=status,
        messages=messages,
        inputs={
            scalar.column: np.array([_drawn(row, scalar) for row in samples], dtype=float)
            for scalar in varied_scalars(study)
        },
        radius=radius,
        joints=joints,
    )


def _drawn(sample: dict[str, object], scalar: VariedScalar) -> float:
    """The value ``scalar`` took in a ``samples`` row (NaN where the row lacks it)."""
    if scalar.key == "encoder_counts":
        return float(sample["encoder_counts"])
    value = sample["parameters"].get(scalar.key)
    if value is None:
        return float("nan")
    return float(value[scalar.joint] if scalar.joint is not None else value)


def joint_stats(data: StudyData) -> list[JointStats]:
    """Mean, median, 95th percentile and max of the RMS error per controller and joint,
    with percentile-bootstrap 95 % intervals of the median and the 95th percentile
    (``analysis.uncertainty.statistics``, seeded: the same store gives the same report)."""
    stats = []
    for controller in data.controllers:
        for joint in range(data.joints):
            values = data.rms_q[controller][:, joint]
            values = values[np.isfinite(values)]
            median, p95 = median_interval(values), quantile_interval(values, 0.95)
            if values.size == 0:
                nan = float("nan")
                stats.append(JointStats(controller, joint + 1, 0, nan, nan, nan, nan, median, p95))
                continue
            stats.append(
                JointStats(
                    controller=controller,
                    joint=joint + 1,
                    count=int(values.size),
                    mean=float(np.mean(values)),
                    median=float(np.median(values)),
                    p95=float(np.percentile(values, 95)),
                    max=float(np.max(values)),
                    median_interval=median,
                    p95_interval=p95,
                )
            )
    return stats


def status_counts(data: StudyData) -> dict[str, dict[str, int]]:
    """``{controller: {status: count}}``."""
    return {c: {s: int(np.sum(data.status[c] == s)) for s in STATUSES} for c in data.controllers}


def beats(
    data: StudyData, challenger: str = PAPER_CONTROLLER, baseline: str = PAPER_BASELINE
) -> tuple[int, int]:
    """``(wins, comparable)``: samples where ``challenger`` beats ``baseline`` (module
    docstring) and samples where neither run is an error."""
    ours, theirs = data.status[challenger], data.status[baseline]
    comparable = (ours != "error") & (theirs != "error")
    ours_error = np.linalg.norm(data.rms_q[challenger], axis=1)
    theirs_error = np.linalg.norm(data.rms_q[baseline], axis=1)
    ours_finished, theirs_finished = np.isin(ours, FINISHED), np.isin(theirs, FINISHED)
    better = ours_finished & (~theirs_finished | (ours_error < theirs_error))
    return int(np.sum(better & comparable)), int(np.sum(comparable))


def ok_values(data: StudyData, controller: str, joint: int, mask: np.ndarray) -> np.ndarray:
    values = data.rms_q[controller][mask, joint]
    return values[np.isfinite(values)]
