"""``analysis.common.export``: a run's time series as CSV / Parquet / NPZ."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from posfb.analysis.common.export import (
    EXPORT_FORMATS,
    export_run,
    leading_columns,
    read_run,
    run_table,
)
from posfb.analysis.common.metrics import rms
from posfb.diagrams.loop_config import ClosedLoopConfig
from posfb.diagrams.runner import ClosedLoopRunner
from posfb.diagrams.sections import Timing
from posfb.models.controllers import PAPER_CONTROLLERS, spec
from posfb.models.controllers.base import unit_of

#: Short runs keep the module fast.
DURATION = 0.5

EXPECTED_LEADING = [
    "time_s",
    "q1_desired_rad",
    "q2_desired_rad",
    "q1_rad",
    "q2_rad",
    "q1_measured_rad",
    "q2_measured_rad",
    "u1_commanded_V",
    "u2_commanded_V",
    "u1_applied_V",
    "u2_applied_V",
    "q1_desired_velocity_rad_per_s",
    "q2_desired_velocity_rad_per_s",
    "q1_desired_acceleration_rad_per_s2",
    "q2_desired_acceleration_rad_per_s2",
]


@pytest.fixture(scope="module")
def runs():
    results = {}
    for kind in PAPER_CONTROLLERS:
        config = ClosedLoopConfig(controller=kind, timing=Timing(duration=DURATION))
        results[kind] = (config, ClosedLoopRunner(config).run())
    return results


def read_back(path) -> pd.DataFrame:
    """Read with the libraries themselves, not with ``read_run``."""
    if path.suffix == ".csv":
        return pd.read_csv(path)
    if path.suffix == ".parquet":
        return pd.read_parquet(path)
    with np.load(path) as data:
        return pd.DataFrame({name: data[name] for name in data.files})


def expected_rms(result) -> tuple[np.ndarray, np.ndarray]:
    metrics = getattr(result, "metrics", None)
    if metrics is not None:
        return np.asarray(metrics.rms_q), np.asarray(metrics.rms_u)
    return rms((result.q_true - result.q_desired)[1:]), rms(result.u_applied[1:])


@pytest.mark.parametrize("suffix", EXPORT_FORMATS)
@pytest.mark.parametrize("kind", PAPER_CONTROLLERS)
def test_export_round_trip_and_rms(runs, tmp_path, kind, suffix):
    config, result = runs[kind]
    assert result.status == "ok"
    path = export_run(result, tmp_path / "nested" / f"run{suffix}")
    assert path == tmp_path / "nested" / f"run{suffix}"
    assert [p.name for p in path.parent.iterdir()] == [path.name]  # no temporary left
    table = read_back(path)

    columns = list(table.columns)
    assert columns[: len(EXPECTED_LEADING)] == EXPECTED_LEADING
    assert list(leading_columns(2)) == EXPECTED_LEADING
    assert len(table) == config.samples + 1
    assert all(table[c].dtype == np.float64 for c in columns)

    times = table["time_s"].to_numpy()
    np.testing.assert_allclose(np.diff(times), config.sample_time, rtol=0, atol=1e-12)
    assert times[0] == 0.0

    q_err = (
        table[["q1_rad", "q2_rad"]].to_numpy()
        - table[["q1_desired_rad", "q2_desired_rad"]].to_numpy()
    )
    u = table[["u1_applied_V", "u2_applied_V"]].to_numpy()
    rms_q = np.sqrt(np.mean(q_err[1:] ** 2, axis=0))
    rms_u = np.sqrt(np.mean(u[1:] ** 2, axis=0))
    want_q, want_u = expected_rms(result)
    np.testing.assert_allclose(rms_q, want_q, rtol=1e-12, atol=0)
    np.testing.assert_allclose(rms_u, want_u, rtol=1e-12, atol=0)

    # every value read back equals what was written (CSV: shortest round-trip text;
    # pandas < 3's default CSV float parser may be off in the last bit, read_run is exact)
    written = run_table(result)
    assert list(written.columns) == columns
    np.testing.assert_allclose(table.to_numpy(), written.to_numpy(), rtol=1e-15, atol=0)
    pd.testing.assert_frame_equal(read_run(path), written, check_exact=True)


@pytest.mark.parametrize("kind", PAPER_CONTROLLERS)
def test_internals_have_unit_suffixes(runs, kind):
    _, result = runs[kind]
    table = run_table(result)
    internals = list(table.columns[len(leading_columns(2)) :])
    assert len(internals) == len(result.internals_names) > 0
    for name, column in zip(result.internals_names, internals, strict=True):
        units = spec(kind).internal_units
        assert column == f"{name}_{unit_of(name, units)}"
        np.testing.assert_array_equal(
            table[column].to_numpy(), result.internals[:, result.internals_names.index(name)]
        )
    np.testing.assert_array_equal(table["u1_commanded_V"], result.u_commanded[:, 0])
    np.testing.assert_array_equal(table["q2_measured_rad"], result.q_measured[:, 1])


def test_proposed_internals_names(runs):
    _, result = runs["proposed"]
    internals = list(run_table(result).columns[len(leading_columns(2)) :])
    assert internals == [
        "tau_lin_1_V", "tau_lin_2_V", "tau_lc_1_V", "tau_lc_2_V", "tau_nc_1_V", "tau_nc_2_V",
        "alpha_dimensionless", "phi_1_V", "phi_2_V", "U1_rad_per_s", "U2_rad_per_s2",
        "delta_bar_V",
    ]  # fmt: skip


def test_an_internal_without_a_unit_is_refused():
    with pytest.raises(KeyError, match="'mystery'.*internal_units"):
        unit_of("mystery", spec("lin_lc").internal_units)


@pytest.mark.parametrize("name", ["run.txt", "run", "run.csv.gz", "run.json"])
def test_bad_suffix_is_refused(runs, tmp_path, name):
    _, result = runs["pid"]
    suffix = name[name.rfind(".") :] if "." in name else "(none)"
    with pytest.raises(ValueError) as error:
        export_run(result, tmp_path / name)
    message = str(error.value)
    assert "--out" in message and repr(suffix) in message
    assert all(allowed in message for allowed in EXPORT_FORMATS)
    assert list(tmp_path.iterdir()) == []


def test_failed_write_leaves_no_file(runs, tmp_path, monkeypatch):
    _, result = runs["pid"]
    target = tmp_path / "run.parquet"
    target.write_bytes(b"previous")

    def fail(*args, **kwargs):
        raise OSError("disk full")

    monkeypatch.setattr(pd.DataFrame, "to_parquet", fail)
    with pytest.raises(OSError, match="disk full"):
        export_run(result, target)
    assert target.read_bytes() == b"previous"
    assert [p.name for p in tmp_path.iterdir()] == ["run.parquet"]


def test_the_log_holds_the_desired_input_the_controller_held(runs):
    """The desired velocity and acceleration columns are the trajectory's at each sample
    time (``models.trajectory``, evaluated independently of the diagram)."""
    _, result = next(iter(runs.values()))
    table = run_table(result)
    trajectory = result.config.trajectory
    for k in (0, 7, len(table) - 1):
        _, velocity, acceleration = trajectory.evaluate(float(table.time_s[k]))
        for j in range(2):
            assert table[f"q{j + 1}_desired_velocity_rad_per_s"][k] == pytest.approx(
                velocity[j], abs=1e-12)  # fmt: skip
            assert table[f"q{j + 1}_desired_acceleration_rad_per_s2"][k] == pytest.approx(
                acceleration[j], abs=1e-12)  # fmt: skip
