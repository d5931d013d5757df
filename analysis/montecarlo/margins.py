"""The report's margins over the sampled plants: for every controller of the study with a
linear design, the disk margin and the delay margin of its loop on each sampled plant
(``analysis.uncertainty.loops``: the design as it is, closed around the plant's own
linear part with its linear effects, at the plant's worst configuration of the path with
its ``M*(q)`` frozen (``StudyLoops.sample(..., frozen=True)``: the loop whose radius the
worker stores); ``SampledFeedback.robustness``), summarised as the smallest, the 5th
percentile and the median.

The figures are recomputed from the study (its samples' draws are deterministic), not
read from the store: a store written before them reports them too. At most
``MARGIN_SAMPLES`` samples, the first by index, are used; the section says how many. A
plant whose loop is unstable (``rho >= 1``) has margin 0.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from posfb.analysis.montecarlo.results import StudyData
from posfb.analysis.uncertainty.loops import StudyLoops
from posfb.analysis.uncertainty.study import Study, canonical_text, study_from_text

#: The most samples whose margins a report computes (about 0.05-0.5 s each per
#: controller, by the arm's joints).
MARGIN_SAMPLES = 200


@dataclass(frozen=True)
class MarginSummary:
    """One controller's margins over ``plants`` sampled plants: ``unstable`` of them with
    ``rho >= 1``; ``disk`` and ``delay_s`` as (smallest, 5th percentile, median)."""

    controller: str
    plants: int
    unstable: int
    disk: tuple[float, float, float]
    delay_s: tuple[float, float, float]
    sample_time: float


def _summary(values: np.ndarray) -> tuple[float, float, float]:
    return float(np.min(values)), float(np.percentile(values, 5)), float(np.median(values))


def margin_summaries(data: StudyData) -> list[MarginSummary]:
    """The ``MarginSummary`` of each controller of ``data`` with a linear design."""
    return _summaries(data.study, data.controllers, data.samples)


def margin_inputs(data: StudyData) -> list[tuple[str, tuple[str, ...], tuple[int, ...]]]:
    """What ``summaries_in_process`` takes for each controller of ``data``: the study as
    canonical YAML (written once), the controller and the sample indices (the report
    computes its margins in processes of their own, one per controller, while it draws
    its figures: issue 45)."""
    text, samples = canonical_text(data.study), tuple(int(i) for i in data.samples)
    return [(text, (controller,), samples) for controller in data.controllers]


def summaries_in_process(
    study_text: str, controllers: tuple[str, ...], samples: tuple[int, ...], say: object
) -> list[MarginSummary]:
    """``margin_summaries`` in a worker process (``analysis.common.side_by_side``), from
    ``margin_inputs`` (one BLAS thread: the report draws on the other core)."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(1):
        return _summaries(study_from_text(study_text), controllers, np.asarray(samples))


def _summaries(
    study: Study, controllers: Sequence[str], samples: np.ndarray
) -> list[MarginSummary]:
    """The ``MarginSummary`` of each of ``controllers`` with a linear design, over the
    first ``MARGIN_SAMPLES`` of ``samples`` (indices of ``study``)."""
    indices = np.sort(samples)[:MARGIN_SAMPLES]
    found = []
    for controller in controllers:
        try:
            loops = StudyLoops(study, controller)
        except ValueError:  # a plug-in: no linear design
            continue
        figures = np.array([loops.sample(int(i), frozen=True).robustness() for i in indices])
        found.append(MarginSummary(
            controller, len(indices), int(np.sum(figures[:, 0] >= 1.0)),
            _summary(figures[:, 1]), _summary(figures[:, 2]), loops.config.sample_time,
        ))  # fmt: skip
    return found


def markdown(summaries: list[MarginSummary], samples: int) -> list[str]:
    """The report's section (empty without a controller with a linear design)."""
    if not summaries:
        return []
    used = summaries[0].plants
    which = "every sample" if used == samples else f"the first {used} of {samples} samples"
    lines = [
        "## Margins over the sampled plants",
        "",
        f"Each controller's loop as designed, closed around each plant's own linear part "
        f"with its linear effects (`posfb design --margins` on that plant; {which}). "
        "Disk margin at skew 0, the worse of the two breaks; delay margin: the extra loop "
        "delay, the same on every joint, at which the sampled loop turns unstable. An "
        "unstable plant counts as margin 0.",
        "",
        "| controller | plants | rho >= 1 | disk margin: min | 5th pct | median | "
        "delay margin (ms): min | 5th pct | median |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for s in summaries:
        disk = " | ".join(f"{v:.3f}" for v in s.disk)
        delay = " | ".join(f"{v * 1e3:.2f}" for v in s.delay_s)
        lines.append(f"| {s.controller} | {s.plants} | {s.unstable} | {disk} | {delay} |")
    return [*lines, ""]
