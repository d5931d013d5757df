"""``posfb montecarlo replay``: rebuild one stored sample, check it, keep its time series.

A sample is a pure function of the study and its index (``uncertainty.sampling``), so the
store alone (its canonical study YAML, which holds the seed, and the sample
index) is enough to run the sample again. ``ClosedLoopEvaluator.evaluate``
(``worker``) is the one code path of a study's samples and of a replay: the
replay recomputes the ``SampleResult`` the store was written from, and also
keeps the closed-loop runs behind it.

"Bit for bit" means here: every stored value the replay recomputes equals the
replayed one exactly (floats compared with ``==``, no tolerance; a float read
back from SQLite or from the JSON columns is the same double that was written,
since SQLite ``REAL`` is an IEEE double and ``json`` writes floats as their
shortest round-trip text). Two NaNs are the same value. The store keeps
``None`` (SQL ``NULL``) where a metric was not finite and the replay is put
through the same conversion (``worker._metrics_dict``), so ``None`` meets
``None``; ``None`` against a number is a difference.

Compared: the sample's ``encoder_counts``, ``payload_mass``, ``inside_bounds``
and every entry of ``parameters``, ``theta`` and ``bound_ratios``; per
controller ``status``, ``message``, the metric columns but ``wall_time_s`` (a
timing, never reproducible) and ``sampled_data_spectral_radius``. Not compared:
``code_version``, ``finished_at`` (when and by what the row was written); what the
store never recorded for the sample (``ResultStore.unrecorded``: a version-1 store's
radius, a version-1 or 2 store's measured error).

Written (``write_outputs``): per controller the time series
``sample_<I>_<controller>.csv`` (``analysis.common.export.export_run``, the format of
``simulate --out``), the figures ``sample_<I>_positions`` and ``sample_<I>_errors``
(PNG and SVG, every replayed controller in one figure, as ``simulate --figure``
writes them) and, where asked, the HTML animation ``sample_<I>_<controller>.html``
(``diagrams.animate.animation_html``, as ``posfb animate`` writes it).
"""

from __future__ import annotations

import json
import math
from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path

from posfb.analysis.common import plots
from posfb.analysis.common.errors import UsageError
from posfb.analysis.common.export import export_run
from posfb.analysis.montecarlo.records import ControllerRun, SampleResult, metric_columns
from posfb.analysis.montecarlo.store import RADIUS_COLUMN
from posfb.analysis.uncertainty.study import Study
from posfb.diagrams.animate import animation_html
from posfb.diagrams.runner import ClosedLoopResult


def run_columns(joints: int) -> tuple[str, ...]:
    """The ``runs`` columns compared, in the order differences are reported: every
    metric a replay must reproduce (``wall_time_s`` is a timing)."""
    metrics = (column for column in metric_columns(joints) if column != "wall_time_s")
    return ("status", "message", *metrics, RADIUS_COLUMN)


def _joints(metrics: Mapping[str, object]) -> int:
    """The joint count of a run's metrics (its ``rms_q*`` entries)."""
    return sum(1 for key in metrics if key.startswith("rms_q"))


#: The scalar ``samples`` columns compared (then the JSON ones, ``SAMPLE_JSON_COLUMNS``).
SAMPLE_COLUMNS = ("encoder_counts", "payload_mass", "inside_bounds")

#: The JSON ``samples`` columns compared entry by entry.
SAMPLE_JSON_COLUMNS = ("parameters", "theta", "bound_ratios")

#: At most this many stretches of sample indices are named in a refusal.
_RANGES_SHOWN = 6


class _Absent:
    """A value one side does not have (a key or a row missing)."""

    def __repr__(self) -> str:
        return "absent"


ABSENT = _Absent()


@dataclass(frozen=True)
class Difference:
    """One column (``parameters.link_mass[1]`` for an entry of a JSON column) whose
    stored and replayed values are not the same."""

    column: str
    stored: object
    replayed: object

    def describe(self) -> str:
        """``rms_q1: stored 0.0012, replayed 0.0013 (replayed - stored = +1e-04)``."""
        text = f"{self.column}: stored {self.stored!r}, replayed {self.replayed!r}"
        if _is_number(self.stored) and _is_number(self.replayed):
            delta = float(self.replayed) - float(self.stored)  # type: ignore[arg-type]
            if math.isfinite(delta):
                text += f" (replayed - stored = {delta:+.3g})"
        return text


@dataclass(frozen=True)
class Comparison:
    """What a replay found for one stored row: ``subject`` is a controller, or
    ``sample <I>`` for the sample's own row (plant, theta, bound ratios)."""

    subject: str
    differences: tuple[Difference, ...]

    @property
    def matches(self) -> bool:
        return not self.differences

    def line(self) -> str:
        """One line: ``pid: matches the stored row``, or what differs and by how much."""
        if self.matches:
            return f"{self.subject}: matches the stored row"
        details = "; ".join(difference.describe() for difference in self.differences)
        return f"{self.subject}: differs from the stored row in {details}"


def _is_number(value: object) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


def same(stored: object, replayed: object) -> bool:
    """Whether a stored and a replayed value are the same: numbers by ``==`` (an int
    and a float of the same value too; NaN is NaN), anything else (``None``,
    booleans, text) only a value of the same type that is ``==``."""
    if _is_number(stored) and _is_number(replayed):
        both_nan = math.isnan(stored) and math.isnan(replayed)  # type: ignore[arg-type]
        return stored == replayed or both_nan
    return type(stored) is type(replayed) and stored == replayed


def flatten(prefix: str, value: object) -> dict[str, object]:
    """A JSON value as ``{column: scalar}``: ``parameters.link_mass[0]`` and so on."""
    if isinstance(value, Mapping):
        entries: dict[str, object] = {}
        for key, item in value.items():
            entries.update(flatten(f"{prefix}.{key}", item))
        return entries
    if isinstance(value, list | tuple):
        entries = {}
        for position, item in enumerate(value):
            entries.update(flatten(f"{prefix}[{position}]", item))
        return entries
    return {prefix: value}


def _as_stored(value: object) -> object:
    """``value`` as the store's JSON columns read it back (tuples become lists)."""
    return json.loads(json.dumps(value))


def _differences(stored: Mapping[str, object], replayed: Mapping[str, object]) -> list[Difference]:
    """The columns of ``stored`` and ``replayed`` whose values are not ``same``, in the
    order of ``stored`` then the columns only ``replayed`` has."""
    columns = [*stored, *(column for column in replayed if column not in stored)]
    return [
        Difference(column, stored.get(column, ABSENT), replayed.get(column, ABSENT))
        for column in columns
        if not same(stored.get(column, ABSENT), replayed.get(column, ABSENT))
    ]


def sample_values(row: Mapping[str, object]) -> dict[str, object]:
    """The compared values of a ``samples`` row (``ResultStore.sample_rows``), flat."""
    values = {column: row[column] for column in SAMPLE_COLUMNS}
    for column in SAMPLE_JSON_COLUMNS:
        values.update(flatten(column, row[column]))
    return values


def replayed_sample_values(result: SampleResult) -> dict[str, object]:
    """The compared values of a recomputed sample, as the store would have written them."""
    row = {
        "encoder_counts": int(result.encoder_counts),
        "payload_mass": float(result.parameters["payload_mass"]),  # type: ignore[arg-type]
        "inside_bounds": bool(result.inside_bounds),
        "parameters": _as_stored(result.parameters),
        "theta": _as_stored(result.theta),
        "bound_ratios": _as_stored(result.bound_ratios),
    }
    return sample_values(row)


def run_values(row: Mapping[str, object]) -> dict[str, object]:
    """The compared values of a ``runs`` row (``ResultStore.run_rows``)."""
    return {column: row.get(column) for column in run_columns(_joints(row))}


def replayed_run_values(run: ControllerRun) -> dict[str, object]:
    """The compared values of a recomputed run, as the store would have written them."""
    stored = {
        "status": run.status,
        "message": run.message,
        **run.metrics,
        RADIUS_COLUMN: run.spectral_radius,
    }
    return {column: stored.get(column) for column in run_columns(_joints(run.metrics))}


def compare(
    stored_sample: Mapping[str, object],
    stored_runs: Iterable[Mapping[str, object]],
    replayed: SampleResult,
    unrecorded: Collection[str] = (),
) -> list[Comparison]:
    """The sample's own row, then one ``Comparison`` per replayed controller (in the
    replay's order), of the stored rows of sample ``replayed.index`` against the
    recomputed ``replayed``. A controller without a stored row differs in ``row``.
    ``unrecorded``: columns the store never recorded for this sample, left out
    (``ResultStore.unrecorded``: an older store's radius or measured error)."""
    runs = {row["controller"]: row for row in stored_runs if row["sample"] == replayed.index}
    comparisons = [
        Comparison(
            f"sample {replayed.index}",
            tuple(_differences(sample_values(stored_sample), replayed_sample_values(replayed))),
        )
    ]
    for run in replayed.runs:
        stored = runs.get(run.controller)
        if stored is None:
            missing = (Difference("row", ABSENT, "present"),)
            comparisons.append(Comparison(run.controller, missing))
            continue
        stored_values, replayed_values = run_values(stored), replayed_run_values(run)
        for column in unrecorded:
            stored_values.pop(column, None)
            replayed_values.pop(column, None)
        found = _differences(stored_values, replayed_values)
        comparisons.append(Comparison(run.controller, tuple(found)))
    return comparisons


def index_ranges(indices: Iterable[int]) -> str:
    """``0-3, 5, 8-9``: the stretches of consecutive indices (the first few, then how
    many more)."""
    ordered = sorted(set(indices))
    stretches: list[tuple[int, int]] = []
    for index in ordered:
        if stretches and index == stretches[-1][1] + 1:
            stretches[-1] = (stretches[-1][0], index)
        else:
            stretches.append((index, index))
    shown = [f"{a}" if a == b else f"{a}-{b}" for a, b in stretches[:_RANGES_SHOWN]]
    if len(stretches) > _RANGES_SHOWN:
        shown.append(f"and {len(stretches) - _RANGES_SHOWN} more stretches")
    return ", ".join(shown)


def require_stored(index: int, stored: Iterable[int], db: object) -> None:
    """``UsageError`` naming the stored samples unless ``index`` is one of them."""
    indices = set(stored)
    if index in indices:
        return
    if not indices:
        raise UsageError(f"--sample {index}: --db {db} holds no finished samples")
    raise UsageError(
        f"--sample {index} is not in --db {db}; it holds samples {index_ranges(indices)}"
    )


def chosen_controllers(study: Study, controller: str | None, db: object) -> tuple[str, ...]:
    """The study's controllers, or just ``controller`` (``UsageError`` naming the study's
    controllers if it has no such one)."""
    if controller is None:
        return tuple(study.controllers)
    if controller not in study.controllers:
        raise UsageError(
            f"--controller {controller!r} is not in the study of --db {db}; its controllers: "
            f"{', '.join(study.controllers)}"
        )
    return (controller,)


def output_stem(index: int, name: str) -> str:
    """``sample_<index>_<name>``: the stem of every file a replay writes."""
    return f"sample_{index}_{name}"


def write_time_series(index: int, results: Mapping[str, ClosedLoopResult], out: Path) -> list[Path]:
    """``sample_<index>_<controller>.csv`` per run (``analysis.common.export.export_run``)."""
    return [
        export_run(result, out / f"{output_stem(index, controller)}.csv")
        for controller, result in results.items()
    ]


def write_figures(index: int, results: Mapping[str, ClosedLoopResult], out: Path) -> list[Path]:
    """Positions/voltages and tracking errors of every run together (PNG and SVG), as
    ``simulate --figure`` writes them; nothing without a run."""
    if not results:
        return []
    title = f"Monte-Carlo sample {index}"
    out.mkdir(parents=True, exist_ok=True)
    paths = plots.save(
        plots.positions_and_voltages(results, title), out, output_stem(index, "positions")
    )
    paths += plots.save(plots.tracking_errors(results, title), out, output_stem(index, "errors"))
    return paths


def write_animations(index: int, results: Mapping[str, ClosedLoopResult], out: Path) -> list[Path]:
    """``sample_<index>_<controller>.html`` per run: the arm moving through the run's true
    joint positions (``animation_html``, as ``posfb animate``). Raises ``RuntimeError``
    (one line) if Meshcat cannot start."""
    paths = []
    for controller, result in results.items():
        html = animation_html(result.config.plant, result.times, result.q_true)
        path = out / f"{output_stem(index, controller)}.html"
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(html)
        paths.append(path)
    return paths


def write_outputs(
    index: int, results: Mapping[str, ClosedLoopResult], out: Path, animate: bool = False
) -> list[Path]:
    """Every file of a replay into ``out`` (created): time series, figures and, with
    ``animate``, the animations; the paths written."""
    out.mkdir(parents=True, exist_ok=True)
    paths = write_time_series(index, results, out) + write_figures(index, results, out)
    if animate:
        paths += write_animations(index, results, out)
    return paths
