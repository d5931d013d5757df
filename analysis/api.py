"""posfb's public Python API (re-exported by ``posfb``): load a scenario, simulate it,
build its Drake diagram to wire more, compare controllers.

The command line calls these functions (``posfb simulate`` is ``simulate``, ``posfb
compare`` is ``compare``), so a script and a command take one code path and give the
same numbers to the bit. Every setting of the scenario is applied: the true arm's
payload and parameter overrides travel inside the resolved ``ClosedLoopConfig``
(``diagrams.loop_config.TruePlant``), so no lower-level call can drop them.

Warnings about a scenario (a trajectory beyond the voltage limit, a failed design
check) are issued as ``ScenarioWarning`` with Python's ``warnings`` module; the
command line prints them on stderr.
"""

from __future__ import annotations

import json
import warnings
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING

from posfb.analysis.common import progress as progress_bars
from posfb.analysis.common.cases import CASE_FILES
from posfb.analysis.common.metrics import (
    RunMetrics,
    Verdict,
    run_metrics,
    run_verdict,
)
from posfb.analysis.common.shipped import shipped_files
from posfb.diagrams.resolve import (
    LoadedScenario,
    ResolvedScenario,
    resolve,
    scenario_from_file,
    scenario_from_mapping,
)
from posfb.diagrams.runner import ClosedLoopResult, ClosedLoopRunner
from posfb.diagrams.scenario import yaml_value
from posfb.diagrams.wiring import ClosedLoop, Extension
from posfb.models.controllers import PAPER_CONTROLLERS, failed_checks, require_design

if TYPE_CHECKING:
    import pandas as pd
    from matplotlib.figure import Figure
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import Context, Diagram

    from posfb.analysis.design.linear_loop import LinearDesign
    from posfb.analysis.design.settings import TuneSettings
    from posfb.analysis.design.tune import TuneResult
    from posfb.analysis.identification.identify import Identification
    from posfb.analysis.identification.plan import PlannedExcitation
    from posfb.analysis.uncertainty.study import Study

#: The paper's nominal experiment (Sec. 4.2): the scenario when none is given.
DEFAULT_SCENARIO = CASE_FILES["nominal"]

#: Controllers that ``compare`` runs when none are named (Sec. 4.2's three).
DEFAULT_COMPARISON = PAPER_CONTROLLERS

#: Figures that ``Run.plot`` and ``Comparison.figure`` draw (Figs. 4/6 and 5/7).
FIGURES = ("errors", "positions")

ScenarioSource = LoadedScenario | str | Path | Mapping[str, object] | None
Settings = Mapping[str, object] | Iterable[str]


class ScenarioWarning(UserWarning):
    """Something about a scenario that does not stop a run but may spoil it: a
    trajectory beyond the voltage limit, a design check the controller fails, or a run
    that is not ``ok``: ``diverged``, or finished ``saturated`` or ``lost``
    (``analysis.common.metrics.run_verdict``)."""


def shipped_scenarios() -> dict[str, Path]:
    """The scenario files shipped with posfb, by name (``paper_nominal``,
    ``paper_payload``, ``three_link_nominal``, ...).

    Examples
    --------
    >>> import posfb
    >>> sorted(posfb.shipped_scenarios())[:2]
    ['paper_nominal', 'paper_payload']
    """
    return shipped_files("scenario")


_SETTINGS_FORMS = "a mapping {key: value} or a list of 'KEY=VALUE' strings is required"


def settings_list(settings: Settings | None) -> list[str]:
    """``KEY=VALUE`` strings from a mapping ``{key: value}`` or an iterable of strings;
    anything else is a ``TypeError`` naming ``set``."""
    if settings is None:
        return []
    if isinstance(settings, Mapping):
        for key in settings:
            if not isinstance(key, str):
                raise TypeError(f"set key = {key!r}; {_SETTINGS_FORMS}")
        return [f"{key}={yaml_value(value, key)}" for key, value in settings.items()]
    if isinstance(settings, str) or not isinstance(settings, Iterable):
        raise TypeError(f"set = {settings!r}; {_SETTINGS_FORMS}")
    items = list(settings)
    for item in items:
        if not isinstance(item, str):
            raise TypeError(f"set item = {item!r}; {_SETTINGS_FORMS}")
    return items


def _names(argument: str, value: object) -> list[str]:
    """``value`` as a list of controller names; a single string (``"pid,lin_lc"``) or a
    non-string item is a ``TypeError`` naming ``argument``."""
    if isinstance(value, str) or not isinstance(value, Iterable):
        raise TypeError(
            f"{argument} = {value!r}; a list of controller names such as ['pid', 'lin_lc'] "
            "is required"
        )
    names = list(value)
    for name in names:
        if not isinstance(name, str):
            raise TypeError(f"{argument} item = {name!r}; a controller name (a string) is required")
    return names


def load_scenario(source: ScenarioSource = None, set: Settings | None = None) -> LoadedScenario:  # noqa: A002
    """A validated scenario: a YAML file, a mapping with the file's structure, or an
    already loaded scenario, with settings applied in order.

    Parameters
    ----------
    source
        A scenario file's path (relative paths inside it are read from its folder), a
        mapping of the same keys (relative paths from the working folder), a
        ``LoadedScenario``, or ``None`` for the paper's nominal experiment
        (``analysis/scenarios/paper_nominal.yaml``).
    set
        ``{dotted.key: value}`` (or ``"KEY=VALUE"`` strings, as the command line's
        ``--set``), applied in order. A single value for a per-joint key means every
        joint.

    Returns
    -------
    LoadedScenario
        The settings tree (``.scenario``) and the folder its paths are read from.

    Raises
    ------
    ValueError
        One line naming the key, the value and what is allowed.
    TypeError
        ``source`` or ``set`` (or one of its items) of another type than those above.

    Examples
    --------
    >>> import posfb
    >>> scenario = posfb.load_scenario(set={"controller.kind": "lin_lc", "timing.duration": 1})
    >>> scenario.get("timing.duration")
    1.0
    """
    if not isinstance(source, LoadedScenario | Mapping | str | Path | None):
        raise TypeError(
            f"source = {source!r}; a scenario file's path, a mapping, a LoadedScenario or "
            "None is required"
        )
    if isinstance(source, LoadedScenario):
        loaded = source.with_settings(settings_list(set))
    elif isinstance(source, Mapping):
        loaded = scenario_from_mapping(source, settings_list(set))
    else:
        path = DEFAULT_SCENARIO if source is None else Path(source)
        loaded = scenario_from_file(path, settings_list(set))
    return loaded


def _scenario(source: ScenarioSource, controller: str | None) -> LoadedScenario:
    """``source`` loaded (and validated once) with ``controller`` chosen, if given."""
    if controller is not None and not isinstance(controller, str):
        raise TypeError(f"controller = {controller!r}; a controller name (a string) is required")
    return load_scenario(source, None if controller is None else {"controller.kind": controller})


def scenario_warnings(resolved: ResolvedScenario) -> list[str]:
    """What may spoil a run of ``resolved`` without stopping it (``ScenarioWarning``)."""
    from posfb.analysis.common.feasibility import trajectory_warnings

    config = resolved.config
    return [
        *trajectory_warnings(resolved),
        *(
            f"the {config.controller} design fails a check: {detail}"
            for detail in failed_checks(config.controller, config.design)
        ),
    ]


def _resolve_for_run(loaded: LoadedScenario) -> ResolvedScenario:
    """Resolve ``loaded``, refuse a design its controller cannot use, warn about the rest."""
    resolved = resolve(loaded)
    config = resolved.config
    require_design(config.controller, config.design)
    for warning in scenario_warnings(resolved):
        warnings.warn(ScenarioWarning(warning), stacklevel=3)
    return resolved


@dataclass(frozen=True, eq=False)
class Run:
    """One closed-loop run of a scenario: its logs (``result``), the scenario, and the
    paper's metrics (Sec. 4.2: RMS over the samples ``k = 1..N0``, ``q~`` from the true
    position, ``u`` the applied voltage)."""

    result: ClosedLoopResult
    scenario: LoadedScenario

    @cached_property
    def metrics(self) -> RunMetrics:
        return run_metrics(self.result)

    @cached_property
    def verdict(self) -> Verdict:
        """The run's status and why (``analysis.common.metrics.run_verdict``)."""
        return run_verdict(self.result)

    @property
    def controller(self) -> str:
        """The controller's kind (``pid``, ``lin_lc``, ``proposed``)."""
        return self.result.controller

    @property
    def label(self) -> str:
        """The controller's name for legends and tables, for this run's settings
        (``ControllerSpec.label_for``: "(paper)" only with the paper's)."""
        config = self.result.config
        return config.spec.label_for(config.design)

    @property
    def rms_q(self) -> tuple[float, ...]:
        """RMS of the tracking error ``q~`` per joint (rad)."""
        return self.metrics.rms_q

    @property
    def rms_u(self) -> tuple[float, ...]:
        """RMS of the applied voltage per joint (V)."""
        return self.metrics.rms_u

    @property
    def rms_q_measured(self) -> tuple[float, ...]:
        """RMS of the error the encoder reads, ``q_m - q_d``, per joint (rad): what a
        hardware experiment reports (``analysis.common.metrics``)."""
        return self.metrics.rms_q_measured

    @property
    def status(self) -> str:
        """``ok``; ``saturated`` or ``lost`` (it finished, but at the voltage limit or far
        from its path most of its second half); or ``diverged`` (stopped early).
        ``message`` says why (``analysis.common.metrics.run_verdict``)."""
        return self.verdict.status

    @property
    def message(self) -> str:
        """Why the run is not ``ok`` (empty when it is)."""
        return self.verdict.message

    def summary(self) -> dict[str, object]:
        """The keys ``posfb simulate --json`` prints: the controller, the scenario's
        source, duration, sample time and encoder counts, the metrics, ``status`` and
        ``message`` (a metric that does not exist is ``None``). The RMS measured error
        per joint is ``rms_measured_q`` (the spelling of the store's and ``compare``'s
        ``rms_measured_q1 .. n`` columns) and, under its earlier name, ``rms_q_measured``,
        kept so that scripts that read it keep working."""
        from posfb.analysis.paper.experiment import result_entry

        config = self.result.config
        entry = result_entry(self.result)
        return {
            "controller": config.controller,
            "scenario": self.scenario.source,
            "duration": config.timing.duration,
            "sample_time": config.sample_time,
            "encoder_counts": list(config.sensor_state.encoder_counts),
            **entry,
            "rms_measured_q": entry["rms_q_measured"],
        }

    def frame(self) -> pd.DataFrame:
        """The time series, one row per control sample: the columns of ``posfb simulate
        --out`` (``analysis.common.export``)."""
        from posfb.analysis.common.export import run_table

        return run_table(self.result)

    def save(self, path: str | Path) -> Path:
        """Write ``frame()`` to ``path`` (``.csv``, ``.parquet`` or ``.npz``), atomically:
        an existing file is replaced, a failed write leaves it as it was; returns it."""
        from posfb.analysis.common.export import export_run

        return export_run(self.result, path)

    def plot(self, figure: str = "errors", title: str | None = None) -> Figure:
        """Fig. 5/7 (``"errors"``: ``|q~|`` per joint on a log axis and a close-up) or Fig. 4/6
        (``"positions"``: positions and applied voltages) of this run."""
        return _figure({self.controller: self.result}, figure, title or self.label)


def _figure(results: Mapping[str, ClosedLoopResult], figure: str, title: str) -> Figure:
    from posfb.analysis.common import plots

    draw = {"errors": plots.tracking_errors, "positions": plots.positions_and_voltages}
    if figure not in draw:
        raise ValueError(f"figure = {figure!r}; one of {', '.join(FIGURES)} is required")
    return draw[figure](results, title)


def _sil_precision(sil: object) -> str | None:
    """The precision of ``simulate``'s ``sil`` (``None``: no software in the loop);
    ``ValueError`` for another value."""
    if sil is False or sil is None:
        return None
    if sil is True:
        return "double"
    from posfb.models.laws.c_code import PRECISIONS

    if isinstance(sil, str) and sil in PRECISIONS:
        return sil
    raise ValueError(f"sil = {sil!r}; False, True (double), 'double' or 'float' is required")


def simulate(
    scenario: ScenarioSource = None,
    controller: str | None = None,
    *,
    progress: bool = False,
    sil: bool | str = False,
) -> Run:
    """Run a scenario's closed loop on its true arm, as ``posfb simulate`` does.

    Parameters
    ----------
    scenario
        Anything ``load_scenario`` takes (default: the paper's nominal experiment).
    controller
        A controller kind that replaces the scenario's ``controller.kind``.
    progress
        Show a progress bar on stderr.
    sil
        Software in the loop: the controller generated as C (``posfb codegen``),
        compiled by the ``cc`` on the PATH and run as the diagram's controller; ``True``
        or ``"double"`` in double precision, ``"float"`` in single.

    Returns
    -------
    Run
        ``.rms_q``, ``.rms_u``, ``.status``, ``.frame()``, ``.plot()``, ``.save(path)``.
        A run that diverges returns with ``status == "diverged"``; it does not raise.
        A run that is not ``ok`` (``diverged``, or finished ``saturated`` or ``lost``)
        also issues a ``ScenarioWarning`` saying why (``compare`` and the command line
        print it as one line per run).

    Raises
    ------
    ValueError
        A bad setting, or a design the controller refuses (one line).

    Examples
    --------
    >>> import posfb
    >>> run = posfb.simulate(posfb.load_scenario(set={"timing.duration": 0.5}), "lin_lc")
    >>> run.status, len(run.rms_q)
    ('ok', 2)
    """
    loaded = _scenario(scenario, controller)
    resolved = _resolve_for_run(loaded)
    config = resolved.config
    compiled, precision = None, _sil_precision(sil)
    if precision is not None:
        from posfb.analysis.codegen.sil import compiled_controller

        compiled = compiled_controller(resolved, precision)
    with progress_bars.run_progress(config.timing.duration, config.spec.label, progress) as update:
        result = ClosedLoopRunner(config, controller=compiled).run(progress=update)
    run = Run(result, loaded)
    if run.status != "ok":
        warnings.warn(ScenarioWarning(f"the {run.label} run {run.verdict.sentence()}"),
                      stacklevel=2)  # fmt: skip
    return run


@dataclass(eq=False)
class BuiltLoop:
    """A scenario's closed loop, built: the Drake ``Diagram`` with its named subsystems
    (``systems``: ``arm``, ``encoder``, ``encoder_hold``, ``desired_hold``,
    ``controller``, ``saturation``, ``logger``, ...), a fresh ``Simulator`` whose
    Context holds the scenario's true arm and sensor settings, ready to run."""

    runner: ClosedLoopRunner
    simulator: Simulator
    scenario: LoadedScenario

    @property
    def systems(self) -> ClosedLoop:
        return self.runner.loop

    @property
    def diagram(self) -> Diagram:
        return self.runner.diagram

    @property
    def context(self) -> Context:
        """The root Context the simulator advances."""
        return self.simulator.get_mutable_context()

    def run(self, progress: Callable[[float], None] | None = None) -> Run:
        """Simulate the scenario's duration from t = 0, stopping early on divergence,
        and return its ``Run`` (the metrics of ``simulate``)."""
        if self.context.get_time() != 0.0:
            raise ValueError(
                f"the simulator is at t = {self.context.get_time():g} s; run() starts at "
                "t = 0 (call collect() after advancing it yourself)"
            )
        return Run(self.runner.advance(self.simulator, progress), self.scenario)

    def collect(self) -> Run:
        """The logs up to the simulator's time as a ``Run``, for a script that advanced
        the simulator itself (``simulator.AdvanceTo(t)``)."""
        return Run(self.runner.collect(self.context), self.scenario)


def build(
    scenario: ScenarioSource = None,
    controller: str | None = None,
    *,
    extend: Extension | None = None,
) -> BuiltLoop:
    """Build a scenario's closed loop as a Drake diagram, for scripts that wire more.

    Parameters
    ----------
    scenario, controller
        As for ``simulate``.
    extend
        ``extend(builder, systems)`` is called with the ``DiagramBuilder`` and the
        loop's systems (``diagrams.wiring.LoopSystems``) before the diagram is
        built: add a disturbance, a visualiser or another logger there. The
        controller's only input from the arm stays the quantised position.

    Returns
    -------
    BuiltLoop
        ``.diagram``, ``.systems``, ``.simulator``, ``.context``; ``.run()`` gives the
        same ``Run`` as ``simulate`` when nothing was added.

    Examples
    --------
    >>> import posfb
    >>> loop = posfb.build(posfb.load_scenario(set={"timing.duration": 0.1}))
    >>> loop.systems.saturation.get_name()
    'voltage_saturation'
    """
    loaded = _scenario(scenario, controller)
    resolved = _resolve_for_run(loaded)
    runner = ClosedLoopRunner(resolved.config, extend=extend)
    return BuiltLoop(runner, runner.new_simulator(), loaded)


@dataclass(eq=False)
class Comparison:
    """Several controllers on one scenario: ``runs`` by controller kind, in order."""

    scenario: LoadedScenario
    runs: dict[str, Run] = field(default_factory=dict)

    def table(self) -> pd.DataFrame:
        """One row per controller: label, status, RMS(q~) and RMS(u) per joint (rad, V),
        max |q~| (rad), the share of saturated samples and the RMS of the measured error
        per joint (rad, ``analysis.common.metrics``)."""
        import pandas as pd

        rows = []
        for kind, run in self.runs.items():
            metrics = run.metrics
            row: dict[str, object] = {"controller": kind, "label": run.label,
                                      "status": run.status}  # fmt: skip
            row |= {f"rms_q{j + 1}_rad": v for j, v in enumerate(metrics.rms_q)}
            row |= {f"rms_u{j + 1}_V": v for j, v in enumerate(metrics.rms_u)}
            row |= {"max_abs_q_err_rad": metrics.max_abs_q_err,
                    "saturated_fraction": metrics.saturated_fraction}  # fmt: skip
            row |= {f"rms_measured_q{j + 1}_rad": v for j, v in enumerate(metrics.rms_q_measured)}
            rows.append(row)
        return pd.DataFrame(rows)

    def figure(self, figure: str = "errors", title: str | None = None) -> Figure:
        """All runs overlaid: Fig. 5/7 (``"errors"``) or Fig. 4/6 (``"positions"``)."""
        results = {kind: run.result for kind, run in self.runs.items()}
        return _figure(results, figure, title or f"scenario {self.scenario.source}")

    def markdown(self) -> str:
        """``table()`` as a Markdown table (5 significant digits)."""
        table = self.table()
        header = "| " + " | ".join(table.columns) + " |"
        rule = "|" + "|".join("---" if c in ("controller", "label", "status") else "---:"
                              for c in table.columns) + "|"  # fmt: skip
        lines = [header, rule]
        for row in table.itertuples(index=False):
            cells = [f"{v:.5g}" if isinstance(v, float) else str(v) for v in row]
            lines.append("| " + " | ".join(cells) + " |")
        return "\n".join(lines) + "\n"

    def save(self, directory: str | Path) -> list[Path]:
        """Write ``comparison.csv``, ``comparison.md``, ``comparison.json`` (every run's
        ``summary()``) and both figures (PNG, SVG) into ``directory`` (created; its other
        files are kept). The files are written into a temporary folder beside it and
        moved in only once all are complete (``analysis.common.outputs.staged_folder``): a
        failed save leaves ``directory`` as it was. Returns the paths written."""
        from posfb.analysis.common import plots
        from posfb.analysis.common.export import write_table
        from posfb.analysis.common.outputs import staged_folder

        with staged_folder(directory) as staged:
            folder = staged.path
            written = [write_table(self.table(), folder / "comparison.csv")]
            markdown = folder / "comparison.md"
            markdown.write_text(self.markdown())
            summary = folder / "comparison.json"
            summaries = {kind: run.summary() for kind, run in self.runs.items()}
            summary.write_text(json.dumps(summaries, indent=2) + "\n")
            written += [markdown, summary]
            for name in FIGURES:
                written += plots.save(self.figure(name), folder, name)
        return staged.final(written)


def compare(
    scenario: ScenarioSource = None,
    controllers: Sequence[str] = DEFAULT_COMPARISON,
    *,
    progress: bool = False,
    sil: bool | str = False,
) -> Comparison:
    """Run several controllers on one scenario (each as ``simulate`` runs it).

    Parameters
    ----------
    scenario
        Anything ``load_scenario`` takes (default: the paper's nominal experiment).
    controllers
        Controller kinds, in the order of the table and the legends.
    progress
        Show a progress bar per run on stderr.
    sil
        Software in the loop for every controller (``simulate``'s ``sil``).

    Returns
    -------
    Comparison
        ``.runs``, ``.table()`` (pandas), ``.figure()``, ``.save(directory)``.

    Raises
    ------
    ValueError
        No controller, one named twice, or a bad setting.
    TypeError
        ``controllers`` as one string (``"pid,lin_lc"``) or with an item that is not a
        name.

    Examples
    --------
    >>> import posfb
    >>> short = posfb.load_scenario(set={"timing.duration": 0.5})
    >>> posfb.compare(short, ["pid", "lin_lc"]).table()["controller"].tolist()
    ['pid', 'lin_lc']
    """
    kinds = _names("controllers", controllers)
    if not kinds:
        raise ValueError("controllers = []; at least one controller is required")
    duplicates = sorted({kind for kind in kinds if kinds.count(kind) > 1})
    if duplicates:
        raise ValueError(f"controllers = {kinds}: {', '.join(duplicates)} named twice")
    _sil_precision(sil)
    loaded = load_scenario(scenario)
    comparison = Comparison(loaded)
    for kind in kinds:
        comparison.runs[kind] = simulate(loaded, kind, progress=progress, sil=sil)
    return comparison


def design(scenario: ScenarioSource = None, controller: str | None = None) -> LinearDesign:
    """A scenario's controller as a linear sampled loop, for its margins and for a
    control toolbox (what ``posfb design --margins`` reports).

    The loop is the one ``posfb design`` and ``posfb tune`` judge by its spectral
    radius: the nominal linear part of Eq. 2 held over ``T_s`` with every linear effect
    the scenario sets (sensor and compute delay, armature lag, compliant gear), closed
    by the controller's feedback linearised there (the paper's controller at ``alpha =
    alpha*``).

    Parameters
    ----------
    scenario, controller
        As for ``simulate``; the controller must be written as a law (every built-in
        one is; a ``!Python`` plug-in that sets ``self.law`` is too).

    Returns
    -------
    LinearDesign
        ``.radius()``, ``.margins()`` (``models.design.margins.LoopMargins``: gain,
        phase, delay and disk margins, sensitivity peaks), ``.controller_ss()`` and
        ``.plant_ss()`` (python-control ``StateSpace``, ``dt = T_s``; the loop is
        ``control.feedback(plant, controller, sign=+1)``), ``.controller_system()`` and
        ``.plant_system()`` (Drake ``LinearSystem``), ``.closed_loop_eigenvalues()``.

    Raises
    ------
    ValueError
        A bad setting, or a controller written as a step (one line).

    Examples
    --------
    >>> import posfb
    >>> loop = posfb.design(controller="lin_lc")
    >>> bool(loop.radius() < 1.0)
    True
    """
    from posfb.analysis.design.linear_loop import linear_design

    return linear_design(resolve(_scenario(scenario, controller)))


def tune(
    scenario: ScenarioSource,
    study: str | Path | Study | None = None,
    settings: TuneSettings | None = None,
    *,
    set: Settings | None = None,  # noqa: A002
    out: str | Path | None = None,
    accept_worse: bool = False,
    progress: bool = False,
) -> TuneResult:
    """A robust design of the paper's controller and Lin+LC for the scenario's arm, with
    a stated probabilistic guarantee (``analysis.design``; what ``posfb tune`` runs).

    Parameters
    ----------
    scenario
        Anything ``load_scenario`` takes.
    study
        A Monte-Carlo study (file or ``Study``) whose ``parameters`` give the plants;
        ``None``: the default spread (``analysis.uncertainty.plants.DEFAULT_SPREAD``).
    settings
        ``TuneSettings`` (margin, plants, seed, epsilon, beta, budget, ...); default:
        its defaults.
    set
        Scenario settings applied before tuning, as in ``load_scenario``.
    out
        Where the tuned scenario will be written (its relative paths are kept when it is
        the scenario's folder, made absolute otherwise); ``TuneResult.save`` writes it,
        replacing an existing file (the API overwrites, as ``open(path, "w")`` does;
        ``posfb tune`` refuses an existing file without ``--force``).
    accept_worse
        Return a tuned design that is worse than the scenario's own (its predicted error
        or its check run; ``TuneResult.worse`` says why) instead of raising ``WorseError``.
    progress
        Rewrite one status line on stderr at each step and generation (the step, the best
        design so far, the budget left), when stderr is a terminal.

    Returns
    -------
    TuneResult
        ``.scenario`` (the tuned settings tree), ``.controllers`` (per controller: the
        settings before and after, the objective, the radii, the guarantee, the
        cross-check runs), ``.at_edge`` (the tuned values within 2 % of their search
        box's edge), ``.worse``, ``.dump()``, ``.save(path)``.

    Raises
    ------
    TuneError
        No design meets the constraints, or the budget ran out (``BudgetError``: checked
        inside the work, and up front from the first plants' cost), or
        (``WorseError``, holding the result) the design is worse than the scenario's own.
    ValueError
        Bad input: the scenario, the study (e.g. of another arm: refused before the
        study's own checks), a setting, an ``out`` that cannot be written (checked
        before the search).
    TypeError
        ``study``, ``settings`` or ``out`` of another type than those above.
    """
    from posfb.analysis.design.settings import TuneSettings
    from posfb.analysis.design.tune import tune as tune_loaded
    from posfb.analysis.uncertainty.study import Study, load_study
    from posfb.diagrams.arm import arm_identity

    if not isinstance(study, str | Path | Study | None):
        raise TypeError(f"study = {study!r}; a study file's path, a Study or None is required")
    if not isinstance(settings, TuneSettings | None):
        raise TypeError(
            f"settings = {settings!r}; a posfb.analysis.design.settings.TuneSettings or None "
            "is required (the scenario's own keys go in set=)"
        )
    if out is not None:
        if not isinstance(out, str | Path):
            raise TypeError(f"out = {out!r}; a file path or None is required")
        from posfb.analysis.common.errors import UsageError
        from posfb.analysis.common.outputs import output_file

        try:  # before the search, not after it
            output_file("out", str(out), (".yaml", ".yml"), force=True)
        except UsageError as error:
            raise ValueError(str(error)) from None
    loaded = load_scenario(scenario, set)
    name = str(study) if isinstance(study, str | Path) else None
    if name is not None:
        study = load_study(name, arm=arm_identity(loaded.scenario, loaded.base_dir))
    target = None if out is None else Path(out)
    from posfb.analysis.common import progress as progress_line

    shown = progress_line.wanted(not progress)
    with progress_line.status_line("posfb tune", shown) as show:
        return tune_loaded(loaded, study, settings, target, name, accept_worse=accept_worse,
                           progress=show if shown else None)  # fmt: skip


def identify(
    log: str | Path,
    scenario: ScenarioSource = None,
    *,
    validate: str | Path | None = None,
    cutoff_hz: float | None = None,
    stiction_velocity: float | None = None,
    window: float | None = None,
    set: Settings | None = None,  # noqa: A002
    progress: bool = False,
) -> Identification:
    """Identify the scenario's arm from an encoder log, as ``posfb identify --log`` does
    (``analysis.identification``; the estimator is ``models.identification``).

    Parameters
    ----------
    log
        CSV or Parquet with ``time_s``, ``q<j>_measured_rad`` (or ``q<j>_counts``) and
        ``u<j>_applied_V`` per joint (``posfb simulate --out`` writes one).
    scenario
        Anything ``load_scenario`` takes: its arm's nominal model says what is
        identified (theta of Sec. 4.1 for the paper's arm), its ``sensor.encoder_counts``
        the encoder's step.
    validate
        A second log of the same arm: the model's voltage and windowed output error
        against it (NRMSE per joint).
    cutoff_hz, stiction_velocity, window
        The filters' cutoff (default: the stated rule of the motion's band, the
        Nyquist frequency and the encoder, ``Estimate.cutoff_rule``), the
        velocity below which rows stay out of the fit (rad/s, default 0.3), the output
        error's window (s, default 1).
    set
        Scenario settings applied first, as in ``load_scenario``.
    progress
        Show each step (reading, fitting, checking, validating) on one line of stderr.

    Returns
    -------
    Identification
        ``.theta`` (the estimate, its covariance, the model values), ``.validation``,
        ``.warnings``, ``.as_dict()``, ``.report()``, ``.save(path)`` (the file
        ``nominal_model: !Identified {file: ...}`` reads), ``.figure(path)``.

    Raises
    ------
    ValueError
        A log that cannot be identified from (missing columns, uneven or non-monotonic
        time, NaN, too short, another arm's), or a bad setting (one line).
    """
    from posfb.analysis.identification.identify import identify_log
    from posfb.models.identification.estimate import FilterSettings
    from posfb.models.identification.validation import DEFAULT_WINDOW

    defaults = FilterSettings()
    settings = FilterSettings(
        cutoff_hz=cutoff_hz,
        stiction_velocity=defaults.stiction_velocity
        if stiction_velocity is None
        else stiction_velocity,
    )
    from posfb.analysis.common.progress import status_line

    with status_line("identify", progress) as say:
        return identify_log(
            load_scenario(scenario, set),
            log,
            validation_log=validate,
            settings=settings,
            window=DEFAULT_WINDOW if window is None else window,
            progress=say,
        )


def plan_excitation(
    scenario: ScenarioSource = None,
    *,
    duration: float = 60.0,
    harmonics: int = 5,
    period: float | None = 10.0,
    seed: int = 0,
    excursion: float | None = None,
    velocity_limit: float | None = None,
    set: Settings | None = None,  # noqa: A002
    progress: bool = False,
) -> PlannedExcitation:
    """An exciting trajectory for the scenario's arm, as ``posfb identify plan`` writes
    (finite Fourier series, Swevers et al. 1997; ``analysis.identification.plan``).

    Parameters
    ----------
    scenario
        Anything ``load_scenario`` takes: the arm, its rest position (the trajectory's
        start), sample time and voltage limit.
    duration, harmonics, period, seed
        The plan's length (s), harmonics per joint, the series' period (s, dividing
        ``duration``; ``None``: the duration) and the optimiser's random start.
    excursion, velocity_limit
        The largest excursion from rest (rad, default pi/2) and ``|q'|`` limit (rad/s,
        default: the URDF's, else 2).
    progress
        Show the search's start and iteration on one line of stderr (a terminal only).

    Returns
    -------
    PlannedExcitation
        ``.plan`` (coefficients, condition numbers before and after, peaks),
        ``.save(path)`` (a ``!CsvFile`` trajectory), ``.as_dict()``, ``.report()``.

    Raises
    ------
    ValueError
        Limits the plan cannot meet, or a bad argument (one line).
    """
    from posfb.analysis.common.progress import status_line
    from posfb.analysis.identification.plan import plan_for_scenario

    with status_line("identify plan", progress) as say:
        return plan_for_scenario(
            load_scenario(scenario, set),
            duration=duration,
            harmonics=harmonics,
            period=period,
            seed=seed,
            excursion=excursion,
            velocity_limit=velocity_limit,
            progress=say,
        )
