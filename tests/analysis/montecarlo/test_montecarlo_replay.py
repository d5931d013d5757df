"""``posfb montecarlo replay``: a stored sample rebuilt from the store alone."""

from __future__ import annotations

import math
import shutil
import sqlite3
from pathlib import Path

import pytest

from helpers.montecarlo_helpers import TINY_STUDY, run_into_store
from posfb.analysis.cli import main
from posfb.analysis.common.export import read_run
from posfb.analysis.common.metrics import rms
from posfb.analysis.montecarlo.records import ControllerRun, SampleResult
from posfb.analysis.montecarlo.replay import compare, index_ranges, same
from posfb.analysis.montecarlo.store import ResultStore

#: The tiny study, two short samples, with one scenario key (sensor noise) drawn as well.
STUDY = (
    TINY_STUDY.replace("duration: 1.0", "duration: 0.3").replace("samples: 4", "samples: 2")
    + "draws:\n  sensor.noise_std[1]: !Uniform {min: 0.0, max: 1e-5}\n"
)


@pytest.fixture(scope="module")
def db(tmp_path_factory) -> Path:
    return run_into_store(tmp_path_factory.mktemp("replay") / "study.sqlite", STUDY)


def stored_run(db: Path, sample: int, controller: str) -> dict:
    with ResultStore.open_existing(db) as store:
        return next(
            row
            for row in store.run_rows()
            if row["sample"] == sample and row["controller"] == controller
        )


def exit_code(argv: list[str]) -> int:
    """``main``'s exit code, also where argparse refuses (it raises ``SystemExit``)."""
    try:
        return main(argv)
    except SystemExit as stop:
        return int(stop.code)


def replay(capsys, *args: str) -> tuple[int, str, str]:
    code = main(["montecarlo", "replay", *args])
    out, err = capsys.readouterr()
    return code, out, err


def test_a_replay_matches_the_store_and_writes_the_runs(db, tmp_path, capsys):
    out = tmp_path / "out"
    code, text, err = replay(capsys, "--db", str(db), "--sample", "1", "--out", str(out))
    assert code == 0, err
    for subject in ("sample 1", "proposed", "pid"):
        assert f"{subject}: matches the stored row" in text
    names = {path.name for path in out.iterdir()}
    assert names == {
        "sample_1_proposed.csv",
        "sample_1_pid.csv",
        *(
            f"sample_1_{stem}.{suffix}"
            for stem in ("positions", "errors")
            for suffix in ("png", "svg")
        ),
    }
    for controller in ("proposed", "pid"):
        table = read_run(out / f"sample_1_{controller}.csv")
        q = table[["q1_rad", "q2_rad"]].to_numpy()
        q_desired = table[["q1_desired_rad", "q2_desired_rad"]].to_numpy()
        error = (q - q_desired)[1:]
        row = stored_run(db, 1, controller)
        assert row["status"] == "ok"
        for joint in range(2):
            # recomputed from the written columns: equal up to the round-off of the
            # subtraction's order (one ulp was seen), not a different run
            expected = row[f"rms_q{joint + 1}"]
            assert rms(error[:, joint]) == pytest.approx(expected, rel=1e-12), (controller, joint)


@pytest.mark.slow
def test_a_tampered_row_differs_and_is_named(db, tmp_path, capsys):
    tampered = tmp_path / "tampered.sqlite"
    shutil.copy(db, tampered)
    stored = stored_run(db, 0, "pid")["rms_q1"]
    connection = sqlite3.connect(tampered)
    with connection:
        connection.execute(
            "UPDATE runs SET rms_q1 = ? WHERE sample = 0 AND controller = 'pid'", (stored * 2,)
        )
    connection.close()
    out = tmp_path / "out"
    code, text, err = replay(capsys, "--db", str(tampered), "--sample", "0", "--out", str(out))
    assert code == 1, err
    lines = {line.strip().split(":")[0]: line.strip() for line in text.splitlines()}
    assert lines["proposed"] == "proposed: matches the stored row"
    assert lines["sample 0"] == "sample 0: matches the stored row"
    assert "differs" in lines["pid"] and "rms_q1" in lines["pid"]
    assert f"stored {stored * 2!r}, replayed {stored!r}" in lines["pid"]
    assert "rms_q2" not in lines["pid"]
    assert (out / "sample_0_pid.csv").is_file()  # the files are still written


def test_one_controller_and_its_animation(db, tmp_path, capsys):
    out = tmp_path / "out"
    code, text, err = replay(
        capsys,
        "--db", str(db), "--sample", "0", "--controller", "pid", "--out", str(out), "--animate",
    )  # fmt: skip
    assert code == 0, err
    assert "pid: matches the stored row" in text
    assert "proposed" not in text.split("\n", 1)[1]  # only the header may name the study's
    assert sorted(path.name for path in out.glob("*.csv")) == ["sample_0_pid.csv"]
    html = [path.name for path in out.glob("*.html")]
    assert html == ["sample_0_pid.html"]
    assert (out / html[0]).read_text()[:200].lstrip().lower().startswith("<!doctype html>")
    assert (out / "sample_0_errors.svg").is_file()


@pytest.mark.parametrize(
    ("args", "expected"),
    [
        (("--sample", "5"), "holds samples 0-1"),
        (("--sample", "0", "--controller", "lin_lc"), "its controllers: proposed, pid"),
        (("--sample", "-1"), "--sample"),
        (("--sample", "0", "--db", "{tmp}/none.sqlite"), "do not exist"),
        (("--sample", "0", "--out", "{tmp}/a_file"), "a folder is required"),
    ],
    ids=["sample not stored", "unknown controller", "negative sample", "no store", "out a file"],
)
def test_bad_input_gets_one_line_and_exit_2(db, tmp_path, capsys, args, expected):
    (tmp_path / "a_file").write_text("not a folder\n")
    given = [arg.replace("{tmp}", str(tmp_path)) for arg in args]
    defaults = {"--db": str(db), "--out": str(tmp_path / "out")}
    for option, value in defaults.items():
        if option not in given:
            given += [option, value]
    code = exit_code(["montecarlo", "replay", *given])
    out, err = capsys.readouterr()
    assert code == 2
    assert len(err.strip().splitlines()) == 1 and expected in err, err
    assert "Traceback" not in err and out == ""
    assert not (tmp_path / "out").exists()


def _sample(metrics: dict, radius: float | None = 0.5) -> SampleResult:
    return SampleResult(
        index=3,
        parameters={"link_mass": (5.0, 0.9), "payload_mass": 0.25},
        encoder_counts=20000,
        theta={"theta1": 0.33},
        bound_ratios={"delta_M0": 0.2},
        inside_bounds=True,
        runs=(ControllerRun("proposed", "diverged", "stopped", metrics, radius),),
    )


def test_compare_is_exact_and_treats_missing_metrics_as_the_store_does():
    sample_row = {
        "sample": 3,
        "encoder_counts": 20000,
        "payload_mass": 0.25,
        "parameters": {"link_mass": [5.0, 0.9], "payload_mass": 0.25},
        "theta": {"theta1": 0.33},
        "bound_ratios": {"delta_M0": 0.2},
        "inside_bounds": True,
    }
    metrics = {"rms_q1": 0.1, "rms_q2": None, "wall_time_s": 1.0}
    run_row = {
        "sample": 3, "controller": "proposed", "status": "diverged", "message": "stopped",
        "rms_q1": 0.1, "rms_q2": None, "rms_u1": None, "rms_u2": None, "max_abs_q_err": None,
        "saturated_fraction": None, "wall_time_s": 9.0, "sampled_data_spectral_radius": 0.5,
    }  # fmt: skip
    found = compare(sample_row, [run_row], _sample(metrics))
    assert [c.subject for c in found] == ["sample 3", "proposed"]
    assert all(c.matches for c in found)  # wall time is not compared; None meets None

    nudged = {**metrics, "rms_q1": math.nextafter(0.1, 1.0), "rms_q2": 0.2}
    sample_differs = {**sample_row, "theta": {"theta1": 0.34}}
    found = compare(sample_differs, [run_row], _sample(nudged, radius=None))
    assert [d.column for d in found[0].differences] == ["theta.theta1"]
    columns = [d.column for d in found[1].differences]
    assert columns == ["rms_q1", "rms_q2", "sampled_data_spectral_radius"]
    assert "replayed - stored = +1.39e-17" in found[1].line()

    assert [d.column for d in compare(sample_row, [], _sample(metrics))[1].differences] == ["row"]
    version_1 = {**run_row, "sampled_data_spectral_radius": None}  # no radius stored
    unrecorded = ("sampled_data_spectral_radius",)
    assert all(c.matches for c in compare(sample_row, [version_1], _sample(metrics), unrecorded))
    measured = {**metrics, "rms_measured_q1": 0.1}  # replayed; a version-2 row has none
    assert not all(c.matches for c in compare(sample_row, [run_row], _sample(measured)))
    unrecorded = ("rms_measured_q1", "rms_measured_q2")
    assert all(c.matches for c in compare(sample_row, [run_row], _sample(measured), unrecorded))


def test_same_and_index_ranges():
    assert same(math.nan, math.nan) and same(1, 1.0) and same(None, None)
    assert (
        not same(None, math.nan) and not same(0.1, math.nextafter(0.1, 1.0)) and not same(True, 1)
    )
    assert not same(0.0, None)
    assert index_ranges([0, 1, 2, 3, 5, 8, 9]) == "0-3, 5, 8-9"
    assert index_ranges(range(0, 40, 2)).endswith("and 14 more stretches")
