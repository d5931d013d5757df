"""``posfb reproduce``: Sec. 4 of the paper in simulation, with every artefact.

Every file is written into ``--out`` atomically (a temporary file beside it, then a
rename), so an interrupted run leaves each file whole. Order of work (``results.json``
is rewritten after every run, so finished runs are never lost; figures are written as
soon as their runs exist):

1. **Paper settings** (the main result): 3 controllers x {nominal, payload},
   Figs. 4-7, Tables 3-4 side by side.
2. **Design evidence**: the design checks of ``models.design`` and the scan of the
   proposed controller's sampled-data loop over ``alpha*``
   (``analysis.paper.diagnostics``).
3. **Second study** (only if the paper's ``alpha*`` gives an unstable sampled-data
   loop on the true arm): the proposed controller with the largest ``alpha*`` of
   the scan that makes every loop stable, everything else unchanged.
4. **Evidence studies** that locate the causes of the differences: no Coulomb
   friction (plant and model), an ideal encoder, a 100x tighter integrator.
5. The closed-loop diagram graph, ``tables.md`` and ``report.md``.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import asdict, replace
from pathlib import Path

from posfb.analysis.common import plots
from posfb.analysis.common.metrics import run_metrics, run_verdict
from posfb.analysis.common.outputs import atomic_file, staged_folder
from posfb.analysis.common.progress import run_progress
from posfb.analysis.common.tables import PAPER_TABLES, side_by_side, theta_table
from posfb.analysis.paper import diagnostics
from posfb.analysis.paper.experiment import (
    CASES,
    PAPER_STUDY,
    ResultsFile,
    Study,
    case_parameters,
    case_scenario,
    case_title,
    require_case,
    result_entry,
)
from posfb.analysis.paper.paper_report import write_report
from posfb.diagrams.graph import graphviz_source, render
from posfb.diagrams.resolve import resolve
from posfb.diagrams.runner import ClosedLoopResult, ClosedLoopRunner
from posfb.models.controllers import cached_design, failed_checks
from posfb.models.design import ControllerConfig
from posfb.models.lumped import TABLE1
from posfb.models.plant import apply_parameters, build_arm_diagram
from posfb.models.theta_of_plant import identify

#: The ``alpha*`` values scanned for the second study (the paper's 4 down to 2).
ALPHA_STAR_GRID = (4.0, 3.75, 3.5, 3.25, 3.0, 2.75, 2.5, 2.25, 2.0)

#: Frequencies above this (Hz) are far above the trajectory's (0.48 and 0.64 Hz
#: fundamentals): used to locate oscillations in the error spectra.
OSCILLATION_FLOOR_HZ = 1.5

#: Seconds after a desired-velocity reversal attributed to the friction switch.
REVERSAL_WINDOW_S = 0.3

#: The error content above this (Hz) measures the proposed controller's
#: sampled-data oscillation (10-18 Hz), well above the PID limit cycle (~2 Hz).
FAST_BAND_HZ = 5.0


def _alpha_study(alpha_star: float) -> Study:
    return Study(
        key="alpha_star",
        title=f"Second study: alpha* = {alpha_star:g} (instead of the paper's 4)",
        description=(
            f"The paper's settings except alpha* = {alpha_star:g}: the largest alpha* of "
            f"{ALPHA_STAR_GRID} whose sampled-data loop (T_s = 0.01 s) is stable on the true "
            "arm with and without the payload. PID and Lin+LC are unaffected by alpha* and "
            "keep their paper-settings runs."
        ),
        controllers=("proposed",),
        settings=(f"controller.alpha_star={alpha_star!r}",),
    )


#: Evidence studies: each removes one suspected cause of a difference.
EVIDENCE_STUDIES = (
    Study(
        key="no_coulomb",
        title="Evidence: no Coulomb friction (plant f_c = 0 and model theta6 = theta11 = 0)",
        description=(
            "Paper settings, but neither the arm nor the controllers' model has Coulomb "
            "friction: shows which behaviour friction causes and which it hides."
        ),
        settings=(
            "plant.parameters.coulomb=[0.0, 0.0]",
            "nominal_model=!Theta {theta6: 0.0, theta11: 0.0}",
        ),
    ),
    Study(
        key="ideal_encoder",
        title="Evidence: ideal encoder (no quantisation)",
        description="Paper settings, nominal arm, encoder_counts = 0 (exact positions).",
        cases=("nominal",),
        settings=("sensor.encoder_counts=0",),
    ),
    Study(
        key="foh_filters",
        title="Evidence: first-order-hold filters (the default before issue 20)",
        description=(
            "Paper settings, but the controllers' filters discretised by a first-order hold "
            "instead of the default zero-order hold: how the discretisation moves the rows."
        ),
        controllers=("proposed", "lin_lc"),
        settings=("controller.discretisation=foh",),
    ),
    Study(
        key="fine_integrator",
        title="Numerics: integrator accuracy 1e-4 instead of 3e-3",
        description="Paper settings, nominal arm, RK3 accuracy 1e-4 (default 3e-3).",
        cases=("nominal",),
        settings=("timing.simulator.accuracy=1e-4",),
    ),
)


class Reproduction:
    """One ``posfb reproduce`` into ``out``; ``progress`` receives one line per step."""

    def __init__(
        self, out: Path, duration: float, progress: Callable[[str], None], bars: bool = False
    ) -> None:
        self.out = Path(out)
        self.duration = duration
        self.base = resolve(case_scenario("nominal", (f"timing.duration={duration}",))).config
        self.progress = progress
        self.bars = bars
        self.out.mkdir(parents=True, exist_ok=True)
        self.results = ResultsFile(
            self.out / "results.json",
            {
                "description": (
                    "posfb reproduce: Sec. 4 of the paper in simulation. 'nominal' and "
                    "'payload' hold the paper-settings runs (Tables 3-4); 'studies' the "
                    "second study and the evidence studies."
                ),
                "settings": {
                    "sample_time": self.base.sample_time,
                    "duration": self.base.timing.duration,
                    "encoder_counts": list(self.base.sensor_state.encoder_counts),
                    "voltage_limit": list(self.base.voltage_limit),
                    "divergence_bound": self.base.timing.divergence_bound,
                    "integration_scheme": self.base.timing.simulator.integration_scheme,
                    "integrator_accuracy": self.base.timing.simulator.accuracy,
                },
            },
        )
        self.artefacts: list[Path] = [self.out / "results.json"]
        self._count = 0

    def run(self) -> list[Path]:
        self._identification()
        paper = self._run_study(PAPER_STUDY, (), "paper settings")
        self._figures(paper, "", "paper settings")
        self._write_tables()
        alpha_star = self._design_evidence()
        if alpha_star is not None:
            study = _alpha_study(alpha_star)
            fixed = self._run_study(study, ("studies", study.key), study.title)
            self.results.set(("studies", study.key, "alpha_star"), alpha_star)
            merged = {case: {**paper[case], "proposed": fixed[case]["proposed"]} for case in CASES}
            self._figures(
                merged,
                "_alpha_star",
                f"alpha* = {alpha_star:g}",
                {"proposed": f", alpha* = {alpha_star:g}"},
            )
        for study in EVIDENCE_STUDIES:
            self._run_study(study, ("studies", study.key), study.title)
        self._evidence()
        self._graph()
        self._write_tables()
        self.artefacts.append(write_report(self.results.data, self.out))
        return self.artefacts

    def _identification(self) -> None:
        """theta_1..theta_11 of the true arm in each case (Sec. 4.1), beside Table 1:
        what the controllers' nominal model gets right and wrong."""
        _, arm, context = build_arm_diagram()
        identified = {}
        for case in CASES:
            apply_parameters(arm, context, case_parameters(arm, case))
            identified[case] = identify(arm, context)
        self.results.set(
            ("identification",), {case: theta.as_dict() for case, theta in identified.items()}
        )
        self.progress("the true arm, identified (Sec. 4.1):\n" + theta_table(identified))

    def _run_study(
        self, study: Study, keys: tuple[str, ...], label: str
    ) -> dict[str, dict[str, ClosedLoopResult]]:
        if keys:
            self.results.set((*keys, "title"), study.title)
            self.results.set((*keys, "description"), study.description)
        runs: dict[str, dict[str, ClosedLoopResult]] = {case: {} for case in study.cases}
        for kind in study.controllers:
            design = resolve(case_scenario(study.cases[0], study.settings)).config.design
            for detail in failed_checks(kind, design):
                self.progress(f"     warning: {label}: the {kind} design fails a check: {detail}")
        for case, kind, run in study.runs(self.duration):
            with run_progress(self.duration, f"{case} {kind}", self.bars) as bar:
                result = run(progress=bar)
            runs[case][kind] = result
            self.results.set((*keys, case, kind), self._entry(result))
            self._count += 1
            m = run_metrics(result)
            self.progress(
                f"[{self._count:2d}] {label} | {case} | {kind}: rms_q = "
                f"({m.rms_q[0]:.5f}, {m.rms_q[1]:.5f}) rad, rms_u = ({m.rms_u[0]:.3f}, "
                f"{m.rms_u[1]:.3f}) V, {run_verdict(result).status}, {m.wall_time_s:.2f} s"
            )
        return runs

    def _entry(self, result: ClosedLoopResult) -> dict[str, object]:
        """``result_entry`` plus the error spectrum's largest line above
        ``OSCILLATION_FLOOR_HZ`` and its RMS above ``FAST_BAND_HZ``, per joint."""
        T, error = self.base.sample_time, result.q_error[1:]
        return {
            **result_entry(result),
            "error_peak_hz": [
                diagnostics.peak_frequency(error[:, j], T, OSCILLATION_FLOOR_HZ) for j in range(2)
            ],
            "error_rms_fast_band": [
                diagnostics.band_rms(error[:, j], T, FAST_BAND_HZ) for j in range(2)
            ],
            "error_share_after_reversal": [
                diagnostics.reversal_share(
                    self.base.trajectory, result.times[1:], error[:, j], j, REVERSAL_WINDOW_S
                )
                for j in range(2)
            ],
        }

    def _figures(
        self,
        runs: dict[str, dict[str, ClosedLoopResult]],
        suffix: str,
        label: str,
        label_suffix: dict[str, str] | None = None,
    ) -> None:
        numbers = {"nominal": (4, 5), "payload": (6, 7)}
        for case in CASES:
            first, second = numbers[case]
            title = f"{case_title(case)}, {label}"
            figures = (
                (
                    f"fig{first}{suffix}",
                    plots.positions_and_voltages(runs[case], title, label_suffix),
                ),
                (
                    f"fig{second}{suffix}",
                    plots.tracking_errors(runs[case], title, label_suffix, scale="linear"),
                ),
            )
            for stem, figure in figures:
                self.artefacts += plots.save(figure, self.out, stem)
                self.progress(f"     wrote {stem}.png and {stem}.svg")

    def _design_evidence(self) -> float | None:
        design = cached_design(ControllerConfig())
        self.results.set(
            ("design", "checks"),
            [{"name": c.name, "passed": c.passed, "detail": c.detail} for c in design.checks],
        )
        rows = diagnostics.sampled_data_scan(ALPHA_STAR_GRID)
        self.results.set(
            ("design", "alpha_star_scan"),
            [
                {
                    "alpha_star": row.alpha_star,
                    "design_model": asdict(row.design),
                    **{case: asdict(loop) for case, loop in row.true_arm.items()},
                }
                for row in rows
            ],
        )
        paper_row = rows[0]
        chosen = None if paper_row.worst_radius < 1.0 else diagnostics.choose_alpha_star(rows)
        self.results.set(("design", "chosen_alpha_star"), chosen)
        self.progress(
            f"     design: sampled-data spectral radius at alpha* = 4: "
            f"{paper_row.design.radius:.4f} (design model), worst on the true arm "
            f"{paper_row.worst_radius:.4f}; second study alpha* = {chosen}"
        )
        return chosen

    def _evidence(self) -> None:
        T, duration = self.base.sample_time, self.base.timing.duration
        self.results.set(
            ("evidence", "pid_mismatch_prediction"),
            {
                case: diagnostics.pid_mismatch_prediction(case, self.base.trajectory, duration, T)
                for case in CASES
            },
        )
        self.results.set(
            ("evidence", "model_voltage_rms"),
            {
                "table1": diagnostics.model_voltage_rms(TABLE1, self.base.trajectory, duration, T),
                "payload_arm": diagnostics.model_voltage_rms(
                    diagnostics.true_lumped("payload"), self.base.trajectory, duration, T
                ),
            },
        )
        self.results.set(("evidence", "oscillation_floor_hz"), OSCILLATION_FLOOR_HZ)
        self.results.set(("evidence", "fast_band_hz"), FAST_BAND_HZ)
        self.results.set(("evidence", "reversal_window_s"), REVERSAL_WINDOW_S)

    def _graph(self) -> None:
        source = graphviz_source(ClosedLoopRunner(self.base).diagram)
        path, note = render(source, self.out / "closed_loop_proposed.svg")
        self.artefacts.append(path)
        self.results.set(("artefacts", "graph"), path.name)
        self.progress(f"     wrote {path.name}" + (f" ({note})" if note else ""))

    def _write_tables(self) -> None:
        data = self.results.data
        lines = ["# Simulated RMS values beside the paper's Tables 3 and 4", ""]
        for case, table in (("nominal", "Table 3"), ("payload", "Table 4")):
            if case in data:
                lines += [f"## {table}: {case_title(case)}, paper settings", ""]
                lines += [side_by_side(data[case], PAPER_TABLES[case]), ""]
        path = self.out / "tables.md"
        with atomic_file(path) as partial:
            partial.write_text("\n".join(lines))
        if path not in self.artefacts:
            self.artefacts.append(path)


def reproduce(
    out: Path,
    duration: float = 20.0,
    progress: Callable[[str], None] = print,
    bars: bool = False,
) -> list[Path]:
    """Run everything into ``out`` (``bars``: a progress bar per run on stderr); returns
    the artefacts written. Each is written atomically as soon as it exists (module
    docstring): an interrupted reproduction keeps every run it finished in
    ``results.json``, and ``out``'s other files are kept."""
    started = time.perf_counter()
    Path(out).mkdir(parents=True, exist_ok=True)
    artefacts = Reproduction(Path(out), duration, progress, bars).run()
    progress(f"done in {time.perf_counter() - started:.1f} s: {Path(out) / 'report.md'}")
    return artefacts


def case_experiment(
    case: str, out: Path, duration: float = 20.0, progress: Callable[[str], None] = print
) -> dict[str, ClosedLoopResult]:
    """One experiment of Sec. 4 with the paper's settings (``analysis/paper/nominal_experiment.py``,
    ``analysis/paper/payload_experiment.py``): the three controllers on ``case``'s shipped
    scenario, its two figures (Figs. 4-5 or 6-7, PNG and SVG) and its table beside the
    paper's (``table3.md`` / ``table4.md``), written into ``out`` as ``reproduce`` writes
    (all of them, or on a failure none)."""
    out = Path(out)
    study = replace(PAPER_STUDY, cases=(require_case(case),))
    runs: dict[str, ClosedLoopResult] = {}
    for _, kind, run in study.runs(duration):
        runs[kind] = run()
        progress(f"{kind}: {run_verdict(runs[kind]).status}, {runs[kind].wall_time_s:.2f} s")
    first, table = {"nominal": (4, "Table 3"), "payload": (6, "Table 4")}[case]
    title = f"{case_title(case)}, paper settings"
    text = side_by_side({k: result_entry(r) for k, r in runs.items()}, PAPER_TABLES[case])
    with staged_folder(out) as staged:
        plots.save(plots.positions_and_voltages(runs, title), staged.path, f"fig{first}")
        plots.save(
            plots.tracking_errors(runs, title, scale="linear"), staged.path, f"fig{first + 1}"
        )
        (staged.path / f"table{3 if case == 'nominal' else 4}.md").write_text(
            f"# {table}: {case_title(case)}\n\n{text}\n"
        )
    progress(f"{table} (simulated | paper):\n{text}")
    progress(f"figures fig{first}, fig{first + 1} (.png, .svg) and the table are in {out}/")
    return runs
