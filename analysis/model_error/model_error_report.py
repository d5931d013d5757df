"""The model-error report: ``report.md`` and ``results.json`` from the identification
records (part a) and the studies' stores (parts b and c).

The crossing of part (c): the size at which a controller's median joint-1 error reaches
the paper's Table 3 value, interpolated linearly in ``log(size)`` and ``log(error)``
between the two scanned sizes around it (``crossing``); none where the scan does not
reach it. Its model error is given as the voltage error of ``voltage_error`` at that
size, interpolated alike.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from posfb.analysis.model_error.accuracy import POSTERIOR_PLAN, AccuracyRecord, load_records
from posfb.analysis.model_error.experiments import (
    SIZES,
    TABLE3,
    TABLE4,
    identified_name,
    model_error_studies,
    size_name,
)
from posfb.analysis.model_error.spec import ModelErrorSpec
from posfb.analysis.model_error.voltage_error import DesiredPath
from posfb.analysis.montecarlo.store import ResultStore
from posfb.analysis.realism.findings import Findings, findings
from posfb.analysis.realism.run import store_path
from posfb.diagrams.resolve import resolve, scenario_from_file
from posfb.models.identification.theta_regressor import THETA_NAMES

#: A theta whose stated relative standard error is below this is "well identified" in
#: the accuracy table (the issue's criterion: within 5 % of the truth).
WELL_IDENTIFIED = 0.02


def crossing(sizes: list[float], errors: list[float], target: float) -> float:
    """The size where ``errors`` (one per increasing size) first reaches ``target``,
    interpolated in log-log between the scanned sizes around it; NaN if it never does
    (or already does at the smallest size)."""
    for i in range(1, len(sizes)):
        low, high = errors[i - 1], errors[i]
        if low < target <= high and low > 0.0:
            share = math.log(target / low) / math.log(high / low)
            return math.exp(math.log(sizes[i - 1]) + share * math.log(sizes[i] / sizes[i - 1]))
    return math.nan


def _at(sizes: list[float], values: list[float], size: float) -> float:
    """``values`` at ``size`` interpolated in log-log (NaN for a NaN size)."""
    if not math.isfinite(size):
        return math.nan
    return float(np.exp(np.interp(np.log(size), np.log(sizes), np.log(values))))


def _desired_path(spec: ModelErrorSpec) -> tuple[DesiredPath, np.ndarray]:
    """The Table 3 experiment's path, and the scenario model's theta (Table 1)."""
    config = resolve(scenario_from_file(spec.study.scenario, spec.study.settings)).config
    nominal = config.design.nominal
    samples = round((spec.study.duration or config.timing.duration) / config.sample_time)
    path = DesiredPath.of_trajectory(
        config.trajectory, config.sample_time, samples, nominal.l1, nominal.g
    )
    return path, nominal.theta


def _sample_thetas(store: Path) -> np.ndarray:
    with ResultStore.open_existing(store) as opened:
        rows = opened.sample_rows()
    return np.array([[row["theta"][name] for name in THETA_NAMES] for row in rows])


def _median_voltage_error(path: DesiredPath, store: Path, model: np.ndarray) -> list[float]:
    if not store.is_file():
        return [math.nan, math.nan]
    return np.median(path.voltage_error(model, _sample_thetas(store)), axis=0).tolist()


def _accuracy(records: dict[int, list[AccuracyRecord]], path: DesiredPath) -> dict:
    out = {}
    for counts, found in records.items():
        identifiable = np.array([r.identifiable() for r in found])
        well = np.array([r.relative_std() < WELL_IDENTIFIED for r in found])
        errors = np.abs(np.array([r.relative_error() for r in found]))
        z = np.abs(np.array([r.z() for r in found]))
        stated = np.array([r.relative_std() for r in found])
        voltage = path.voltage_error(
            np.array([r.model for r in found]), np.array([r.truth for r in found])
        )
        out[counts] = {
            "identifications": len(found),
            "identifiable": int(identifiable.sum()),
            "within_3_sigma": int((z[identifiable] <= 3.0).sum()),
            "rms_z": float(np.sqrt(np.mean(z[identifiable] ** 2))),
            "well_identified": int(well.sum()),
            "well_within_5_percent": int((errors[well] <= 0.05).sum()),
            "largest_well_error": float(errors[well].max()) if well.any() else math.nan,
            "coarse_warnings": sum(any("too coarse" in w for w in r.warnings) for r in found),
            "voltage_error": np.median(voltage, axis=0).tolist(),
            "truth": found[0].truth,
            "stated_relative_std": np.median(stated, axis=0).tolist(),
            "actual_relative_error": np.median(errors, axis=0).tolist(),
            "largest_relative_error": errors.max(axis=0).tolist(),
        }
    return out


def _medians(found: Findings) -> dict:
    return {
        name: {
            c: [study.errors[c].median(j) for j in range(found.joints)] for c in found.controllers
        }
        for name, study in found.found.items()
    }


def results(spec: ModelErrorSpec, out: Path) -> dict:
    """Every number the report states (module docstring)."""
    records = load_records(spec, out / "identification")
    path, table1 = _desired_path(spec)
    studies = model_error_studies(spec, out / "identification")
    result: dict[str, object] = {"accuracy": _accuracy(records, path)}
    identified = {
        identified_name(c): np.array(found[POSTERIOR_PLAN].model) for c, found in records.items()
    }
    for part, realism in studies.items():
        found = findings(realism, out / "stores" / part)
        entry = {"medians": _medians(found), "paper": found.paper, "voltage_error": {}}
        for name in realism.studies:
            model = table1 if part == SIZES else identified.get(name, table1)  # ideal: Table 1
            store = store_path(out / "stores" / part, name)
            entry["voltage_error"][name] = _median_voltage_error(path, store, model)
        result[part] = entry
    sizes = result[SIZES]
    scanned = [s for s in spec.sizes if size_name(s) in sizes["medians"]]
    result["crossings"] = {}
    for controller, paper in sizes["paper"].items():
        if controller not in spec.study.controllers or not scanned:
            continue
        joint1 = [sizes["medians"][size_name(s)][controller][0] for s in scanned]
        size = crossing(scanned, joint1, paper[0])
        e1 = [sizes["voltage_error"][size_name(s)][0] for s in scanned]
        result["crossings"][controller] = {
            "size": size, "voltage_error": _at(scanned, e1, size), "paper": paper[0],
        }  # fmt: skip
    return result


def _mrad(value: float) -> str:
    return "-" if not math.isfinite(value) else f"{1000.0 * value:.3g}"


def _pct(value: float) -> str:
    return "-" if not math.isfinite(value) else f"{100.0 * value:.3g} %"


def _accuracy_section(spec: ModelErrorSpec, accuracy: dict) -> list[str]:
    runs = spec.identification
    lines = [
        "## (a) How accurate is the identification?",
        "",
        f"{runs.plans} planned excitations of {runs.duration:g} s (`posfb identify plan`, "
        f"seeds 0-{runs.plans - 1}) played by {runs.controller} on the arm, each identified "
        "at each resolution; truth: the arm's own theta. *Identifiable*: stated relative "
        "standard error at most 10 %; *well identified*: below 2 %. The voltage error is "
        "the model file's along Table 3's path (`voltage_error.py`), median over the plans.",
        "",
        "| counts | identifiable theta | within +-3 sigma | RMS of error / sigma | well "
        "identified within 5 % | largest error, well identified | 'too coarse' warnings | "
        "voltage error joint 1 | joint 2 |",
        "|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for counts, a in accuracy.items():
        lines.append(
            f"| {counts} | {a['identifiable']} | {a['within_3_sigma']} | {a['rms_z']:.2f} | "
            f"{a['well_within_5_percent']} of {a['well_identified']} | "
            f"{_pct(a['largest_well_error'])} | {a['coarse_warnings']} of "
            f"{a['identifications']} | {_pct(a['voltage_error'][0])} | "
            f"{_pct(a['voltage_error'][1])} |"
        )
    header = " | ".join(f"{c}: stated | actual | largest" for c in accuracy)
    lines += [
        "",
        "Per theta: the stated relative standard error and the actual relative error "
        "(medians over the plans), and the largest actual error:",
        "",
        f"| theta | truth | {header} |",
        "|---|---:|" + "---:|---:|---:|" * len(accuracy),
    ]
    first = next(iter(accuracy.values()))
    for i, name in enumerate(THETA_NAMES):
        cells = " | ".join(
            f"{_pct(a['stated_relative_std'][i])} | {_pct(a['actual_relative_error'][i])} | "
            f"{_pct(a['largest_relative_error'][i])}"
            for a in accuracy.values()
        )
        lines.append(f"| {name} | {first['truth'][i]:.4g} | {cells} |")
    return lines


def _experiment_section(title: str, part: dict, controllers: list[str]) -> list[str]:
    paper = part["paper"]
    shown = [c for c in controllers if c in paper]
    head = " | ".join(f"{c}, joint 1 | joint 2" for c in shown)
    lines = [
        title,
        "",
        "Median RMS(q~) in mrad (true link error); voltage error of the drawn arms against "
        "the controllers' model, median:",
        "",
        f"| arm | voltage error joint 1 | joint 2 | {head} |",
        "|---|---:|---:|" + "---:|---:|" * len(shown),
        "| paper (hardware) | | | "
        + " | ".join(f"{_mrad(paper[c][0])} | {_mrad(paper[c][1])}" for c in shown) + " |",
    ]  # fmt: skip
    for name, medians in part["medians"].items():
        e = part["voltage_error"].get(name, [math.nan, math.nan])
        cells = " | ".join(f"{_mrad(medians[c][0])} | {_mrad(medians[c][1])}" for c in shown)
        lines.append(f"| {name} | {_pct(e[0])} | {_pct(e[1])} | {cells} |")
    return lines


def markdown(spec: ModelErrorSpec, result: dict, command: str) -> str:
    """The report (``results`` as text)."""
    controllers = list(spec.study.controllers)
    lines = [
        "# Model error: the identified theta's own error",
        "",
        f"Written by `{command}` (`analysis/model_error/`). A labelled study: no default "
        "of posfb changes, nothing is fitted to the paper.",
        "",
        *_accuracy_section(spec, result["accuracy"]),
        "",
        *_experiment_section(
            "## (b) Table 3 on arms drawn from the identification's uncertainty",
            result[TABLE3],
            controllers,
        ),  # fmt: skip
        "",
        "`identified_<counts>`: the controllers designed on plan 0's model at that "
        "resolution, the arm drawn from its posterior (`posfb identify --study-out`).",
    ]
    if TABLE4 in result:
        lines += ["", *_experiment_section("## (b) Table 4, the payload arm", result[TABLE4],
                                           controllers)]  # fmt: skip
    lines += [
        "",
        *_experiment_section(
            "## (c) Model-error size: every physical parameter +-size",
            result[SIZES],
            controllers,
        ),  # fmt: skip
        "",
        "The size at which each controller's median joint-1 error reaches Table 3's "
        "(log-log interpolation between the scanned sizes; '-': not within the scan):",
        "",
        "| controller | Table 3, joint 1 (mrad) | size | voltage error joint 1 there |",
        "|---|---:|---:|---:|",
    ]
    for controller, c in result["crossings"].items():
        lines.append(
            f"| {controller} | {_mrad(c['paper'])} | {_pct(c['size'])} | "
            f"{_pct(c['voltage_error'])} |"
        )
    return "\n".join(lines) + "\n"


def _plain(value: object) -> object:
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def write_report(spec: ModelErrorSpec, out: Path, staged: Path, command: str) -> list[Path]:
    """``report.md`` and ``results.json`` into ``staged`` from ``out``'s records and
    stores."""
    result = results(spec, out)
    report, numbers = staged / "report.md", staged / "results.json"
    report.write_text(markdown(spec, result, command))
    numbers.write_text(json.dumps(_plain(result), indent=1) + "\n")
    return [report, numbers]
