"""The numbers the realism report states, from the studies' stores.

For every study (the ideal arm, each effect, the combination), controller and joint:
the RMS tracking errors of its samples, their median, and the share of the gap to the
paper's hardware value that the median closes, on a log scale (``gap_share``). For
every study and joint: how often the paper's ranking of the controllers holds
(``ranking_agreement``), counting only the pairs the paper separates clearly
(``CLEAR_RATIO``), with a run that diverged or failed ranked last.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from itertools import combinations
from pathlib import Path

import numpy as np

from posfb.analysis.common.tables import PAPER_TABLES
from posfb.analysis.montecarlo.records import FINISHED
from posfb.analysis.montecarlo.results import StudyData, load
from posfb.analysis.montecarlo.store import ResultStore
from posfb.analysis.realism.run import store_path
from posfb.analysis.realism.spec import IDEAL, RealismStudies
from posfb.analysis.uncertainty.study import identity

#: Two controllers are ranked by the paper when its values differ by more than this
#: factor (Table 3's joint 2 has Lin+LC 0.0059 and PID 0.0060 rad: a tie within the
#: measurement's repeatability, so not a ranking).
CLEAR_RATIO = 1.1

#: ``gap_share`` bands the report names: at least ``EXPLAINS`` of the log gap closed
#: explains it (beyond ``OVERSHOOTS`` it overshoots the hardware), at most ``NEGLIGIBLE``
#: (or a move away) does not.
EXPLAINS, OVERSHOOTS, NEGLIGIBLE = 0.5, 1.5, 0.1


def gap_share(simulated: float, ideal: float, paper: float) -> float:
    """The share of the gap from the ideal simulation to the paper's hardware value that
    ``simulated`` closes, on a log scale: ``log(simulated / ideal) / log(paper / ideal)``
    (0: no change, 1: the paper's value, < 0: away from it, > 1: past it). NaN where
    the ideal already equals the paper's value or a value is not positive."""
    if not (simulated > 0.0 and ideal > 0.0 and paper > 0.0) or paper == ideal:
        return math.nan
    return math.log(simulated / ideal) / math.log(paper / ideal)


def paper_pairs(values: dict[str, float]) -> list[tuple[str, str]]:
    """The ordered pairs ``(better, worse)`` the paper separates by more than
    ``CLEAR_RATIO``, from ``{controller: value}``."""
    pairs = []
    for a, b in combinations(sorted(values), 2):
        low, high = sorted((a, b), key=lambda c: values[c])
        if values[high] > CLEAR_RATIO * values[low]:
            pairs.append((low, high))
    return pairs


def ranking_agreement(errors: dict[str, np.ndarray], pairs: list[tuple[str, str]]) -> np.ndarray:
    """Per sample, whether every pair ``(better, worse)`` holds for ``errors``
    (``{controller: RMS per sample}``, NaN for a run that did not finish: ranked last,
    so a pair holds only if ``better`` finished)."""
    ranked = {c: np.where(np.isfinite(v), v, np.inf) for c, v in errors.items()}
    agree = np.ones(len(next(iter(errors.values()))), dtype=bool)
    for better, worse in pairs:
        agree &= np.isfinite(ranked[better]) & (ranked[better] < ranked[worse])
    return agree


def _finite_median(values: np.ndarray) -> float:
    values = values[np.isfinite(values)]
    return float(np.median(values)) if values.size else math.nan


@dataclass(frozen=True)
class ControllerErrors:
    """One controller in one study: its true RMS errors (rad) per sample and joint (NaN
    where the run did not finish), the measured ones (``analysis.common.metrics``; NaN also
    where the store did not record them), and the count of runs that did not finish."""

    rms: np.ndarray
    measured: np.ndarray
    unfinished: int

    def median(self, joint: int) -> float:
        return _finite_median(self.rms[:, joint])

    def measured_median(self, joint: int) -> float:
        return _finite_median(self.measured[:, joint])

    def measured_count(self, joint: int) -> int:
        """The samples with a measured error at ``joint``."""
        return int(np.sum(np.isfinite(self.measured[:, joint])))


@dataclass(frozen=True)
class StudyFindings:
    """One study: its samples and the errors of each controller."""

    name: str
    label: str
    samples: int
    expected: int
    errors: dict[str, ControllerErrors]
    data: StudyData
    resumable: bool = True


@dataclass(frozen=True)
class Findings:
    """Every study's findings, the paper's values and ranking."""

    studies: RealismStudies
    found: dict[str, StudyFindings]
    paper: dict[str, tuple[float, ...]]

    @property
    def controllers(self) -> tuple[str, ...]:
        return tuple(self.studies.spec.study.controllers)

    @property
    def joints(self) -> int:
        return self.found[IDEAL].data.joints

    def paper_name(self, controller: str) -> str | None:
        """The paper's controller whose measurement ``controller`` is compared with
        (itself, its stand-in's, or none)."""
        name = self.studies.spec.stand_ins.get(controller, controller)
        return name if name in self.paper else None

    def paper_value(self, controller: str, joint: int) -> float:
        name = self.paper_name(controller)
        return math.nan if name is None else self.paper[name][joint]

    def lineups(self) -> list[dict[str, str]]:
        """The studied controllers ranked against the paper's, as ``{paper's name:
        studied controller}``: the paper's own, then one per stand-in in its place."""
        own = {c: c for c in self.controllers if c in self.paper}
        return [own] + [
            {**own, paper: stand_in} for stand_in, paper in self.studies.spec.stand_ins.items()
        ]

    def ideal(self, controller: str, joint: int) -> float:
        return self.found[IDEAL].errors[controller].median(joint)

    def share(self, name: str, controller: str, joint: int) -> float:
        """``gap_share`` of study ``name``'s median error."""
        return gap_share(
            self.found[name].errors[controller].median(joint),
            self.ideal(controller, joint),
            self.paper_value(controller, joint),
        )

    def pairs(self, joint: int) -> list[tuple[str, str]]:
        """The paper's clear pairs at ``joint`` among the studied controllers it has."""
        values = {c: self.paper[c][joint] for c in self.controllers if c in self.paper}
        return paper_pairs(values)

    def agreement(self, name: str, joint: int, lineup: dict[str, str]) -> tuple[int, int]:
        """``(samples where the paper's ranking at joint holds, samples)`` of study
        ``name``, with the studied controllers of ``lineup`` (``lineups``)."""
        study = self.found[name]
        errors = {paper: study.errors[c].rms[:, joint] for paper, c in lineup.items()}
        agree = ranking_agreement(errors, self.pairs(joint))
        return int(np.sum(agree)), len(agree)


def _study_findings(name: str, label: str, data: StudyData) -> StudyFindings:
    errors = {
        c: ControllerErrors(
            data.rms_q[c], data.rms_q_measured[c], int(np.sum(~np.isin(data.status[c], FINISHED)))
        )
        for c in data.controllers
    }
    return StudyFindings(name, label, len(data.samples), data.study.samples, errors, data)


def findings(studies: RealismStudies, stores: Path) -> Findings:
    """The findings of every study whose store exists in ``stores`` (the ideal arm's is
    required: every comparison is against it)."""
    found = {}
    for name in studies.studies:
        path = store_path(stores, name)
        if not path.is_file() or path.stat().st_size == 0:  # not run (or not begun)
            if name == IDEAL:
                raise ValueError(
                    f"{path} does not exist; run posfb realism without --report-only first"
                )
            continue
        with ResultStore.open_existing(path) as store:
            study = _study_findings(name, studies.label(name), load(store))
            same = store.meta()["identity"] == identity(studies.studies[name])
        found[name] = replace(study, resumable=same)
    return Findings(studies, found, PAPER_TABLES[studies.spec.paper_table])
