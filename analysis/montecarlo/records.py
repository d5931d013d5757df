"""What one finished sample produces: plain, picklable values that cross process
boundaries (worker -> parent) and are what the store writes."""

from __future__ import annotations

from dataclasses import dataclass

from posfb.analysis.common.metrics import FINISHED_STATUSES, RUN_STATUSES

#: Outcomes of one controller on one sample: a run's verdict
#: (``analysis.common.metrics.run_verdict``: ``ok``, ``saturated``, ``lost``, ``diverged``), or
#: ``error`` where it raised. The store keeps them as text; ``saturated`` and ``lost``
#: are absent from a store written before posfb judged them (its runs that reached
#: their end all read ``ok``).
STATUSES = (*RUN_STATUSES, "error")

#: The runs whose metrics cover the whole duration (``ok``, ``saturated``, ``lost``):
#: the ones the RMS statistics use (``analysis.montecarlo.results``).
FINISHED = FINISHED_STATUSES


def measured_columns(joints: int) -> tuple[str, ...]:
    """``rms_measured_q1 .. rms_measured_qn``: the RMS of the measured error per joint
    (``RunMetrics.rms_q_measured``; store schema version 3)."""
    return tuple(f"rms_measured_q{j + 1}" for j in range(joints))


def metric_columns(joints: int) -> tuple[str, ...]:
    """The per-controller numbers the store keeps for an arm of ``joints`` joints (from
    ``analysis.common.metrics.RunMetrics``): ``rms_q1 .. rms_qn``, ``rms_u1 .. rms_un``, the
    scalars, then ``measured_columns``."""
    per_joint = tuple(f"rms_{x}{j + 1}" for x in ("q", "u") for j in range(joints))
    scalars = ("max_abs_q_err", "saturated_fraction", "wall_time_s")
    return (*per_joint, *scalars, *measured_columns(joints))


@dataclass(frozen=True)
class ControllerRun:
    """One controller on one sampled plant. ``metrics`` maps ``metric_columns(n)`` to
    values (``None`` where the run produced none, e.g. an error before the first step).
    ``spectral_radius``: the sampled-data loop of this plant's linear part with the
    controller as designed (``models.design.plant_spectral_radii``); ``None`` for a
    controller without one (PID)."""

    controller: str
    status: str
    message: str
    metrics: dict[str, float | None]
    spectral_radius: float | None = None

    def __post_init__(self) -> None:
        if self.status not in STATUSES:
            raise ValueError(f"status = {self.status!r}; one of {STATUSES} is required")


@dataclass(frozen=True)
class SampleResult:
    """Sample ``index``: its plant (``ArmParameters`` as a dict of lists), encoder
    resolution, identified theta (Table 1's, for a study whose nominal model is the
    theta model; empty otherwise), Assumption-1 ratios and one run per controller."""

    index: int
    parameters: dict[str, list[float] | float]
    encoder_counts: int
    theta: dict[str, float]
    bound_ratios: dict[str, float]
    inside_bounds: bool
    runs: tuple[ControllerRun, ...]
