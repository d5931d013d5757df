"""A closed-loop run's time series as a table, written with pandas / pyarrow / numpy.

One row per control sample ``t_k = k T_s``, ``k = 0..N`` (the rows of
``ClosedLoopResult``; a diverged run has fewer). The leading columns are fixed
(``leading_columns(n)``), for two joints::

    time_s, q1_desired_rad, q2_desired_rad, q1_rad, q2_rad,
    q1_measured_rad, q2_measured_rad, u1_commanded_V, u2_commanded_V,
    u1_applied_V, u2_applied_V, q1_desired_velocity_rad_per_s,
    q2_desired_velocity_rad_per_s, q1_desired_acceleration_rad_per_s2,
    q2_desired_acceleration_rad_per_s2

and likewise ``q1 .. qn``, ``u1 .. un`` for ``n`` joints. The desired position,
velocity and acceleration are the ``desired`` input the controller held at ``t_k``
(what a replay of the controller on the log needs).

``q`` is the true joint position, ``q_measured`` the encoder's; the voltages at
row ``k`` are the ones computed at ``t_k`` and held on ``[t_k, t_k + T_s)``.
The paper's RMS (``analysis.common.metrics.rms``) recomputed from the file over rows
``1..N`` of ``q - q_desired`` and ``u_applied`` equals the run's metrics.

Then come the controller's internals, each name with its unit appended
(``ClosedLoopResult.internals_columns``: each built-in controller spec's
``internal_units``, a trailing ``_j`` in a name being the joint; a plug-in
controller names its columns with their units). For the paper's controllers: the
lumped model of Sec. 4.1 (``models.lumped``) is each joint's equation of motion
divided by its motor constant, so every "torque" of the controllers is an
armature voltage, in V:

* ``tau_lin_j``, ``tau_lc_j``, ``tau_nc_j`` (Eq. 3-4, 13, 19): V.
* ``alpha`` (Eq. 21-22): the nonlinear torque's gain, dimensionless (the paper
  gives ``alpha* = 4`` without a unit) -> ``alpha_dimensionless``.
* ``phi_j``, the SPR filter's output (Eq. 20): ``tau_NC = -alpha phi`` with a
  dimensionless ``alpha``, so V. (Its input ``z = E x~`` mixes rad, rad/s and
  V through the LQR's ``P``; the unit is fixed by the product, not derived
  from ``E``.)
* ``U1`` (Eq. 24), a bound on ``||q~'||``: rad/s -> ``U1_rad_per_s``.
* ``U2`` (Eq. 25), a bound on ``||q~''||``: rad/s^2 -> ``U2_rad_per_s2``.
* ``delta_bar`` (Eq. 18), a bound on the residual torque ``tau_Lin - h +
  Delta tau_d``: V.
* PID: ``qdot_est_j``, the backward-difference velocity, rad/s; and
  ``error_integral_j = T_s sum q~``, rad s -> ``error_integral_j_rad_s``.

Formats (``EXPORT_FORMATS``), chosen by the path's suffix: ``.csv``
(``DataFrame.to_csv``, shortest round-trip float text, so the values read back
exactly with ``read_run``), ``.parquet`` (pyarrow), ``.npz`` (``numpy.savez``,
one float array per column, keys = column names, in column order). Files are
written to a temporary name beside the target and moved over it with
``os.replace``: a failed export never leaves a partial file.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd

from posfb.analysis.common.outputs import EXPORT_FORMATS, atomic_file
from posfb.models.validation import require_regular_file

if TYPE_CHECKING:
    from posfb.diagrams.runner import ClosedLoopResult

#: pandas < 3 parses CSV floats with a fast, not always exact parser unless told;
#: pandas 3 parses them exactly by default and deprecates the option.
_CSV_READ_OPTIONS = (
    {"float_precision": "round_trip"} if int(pd.__version__.split(".")[0]) < 3 else {}
)


#: The per-joint name pattern of each leading column group (``j`` the joint, from 1).
Q_DESIRED, Q_TRUE, Q_MEASURED = "q{j}_desired_rad", "q{j}_rad", "q{j}_measured_rad"
U_COMMANDED, U_APPLIED = "u{j}_commanded_V", "u{j}_applied_V"
QD_DESIRED, QDD_DESIRED = "q{j}_desired_velocity_rad_per_s", "q{j}_desired_acceleration_rad_per_s2"

#: The first column groups of every exported run, in this order.
_LEADING = (Q_DESIRED, Q_TRUE, Q_MEASURED, U_COMMANDED, U_APPLIED, QD_DESIRED, QDD_DESIRED)


def leading_columns(joints: int) -> tuple[str, ...]:
    """``time_s``, then each group of ``_LEADING`` for joints ``1..joints``."""
    names = [pattern.format(j=j + 1) for pattern in _LEADING for j in range(joints)]
    return ("time_s", *names)


def _or_nan(values: np.ndarray | None, rows: int, width: int) -> np.ndarray:
    """``values``, or NaN where a result made by hand carries none."""
    return np.full((rows, width), np.nan) if values is None else values


def _columns(name: str, values: np.ndarray, rows: int, width: int) -> np.ndarray:
    array = np.asarray(values, dtype=float)
    if array.ndim == 1 and width == 1:
        array = array[:, None]
    if array.shape != (rows, width):
        raise ValueError(
            f"result.{name} has shape {array.shape}; ({rows}, {width}) is required "
            "(one row per sample of result.times)"
        )
    return array


def run_table(result: ClosedLoopResult) -> pd.DataFrame:
    """The run as a table: ``leading_columns(n)``, then the internals with their units."""
    times = np.asarray(result.times, dtype=float)
    if times.ndim != 1:
        raise ValueError(f"result.times has shape {times.shape}; a 1-D array is required")
    rows = len(times)
    n = result.config.joints
    names = tuple(result.internals_names)
    internal_names = list(result.internals_columns)
    blocks = [
        times[:, None],
        _columns("q_desired", result.q_desired, rows, n),
        _columns("q_true", result.q_true, rows, n),
        _columns("q_measured", result.q_measured, rows, n),
        _columns("u_commanded", result.u_commanded, rows, n),
        _columns("u_applied", result.u_applied, rows, n),
        _columns("qd_desired", _or_nan(result.qd_desired, rows, n), rows, n),
        _columns("qdd_desired", _or_nan(result.qdd_desired, rows, n), rows, n),
        _columns("internals", np.reshape(result.internals, (rows, -1)), rows, len(names)),
    ]
    columns = [*leading_columns(n), *internal_names]
    if len(set(columns)) != len(columns):
        raise ValueError(f"duplicate column names in {columns}")
    data = np.hstack(blocks)
    return pd.DataFrame({name: data[:, i].copy() for i, name in enumerate(columns)})


def _format(path: Path, option: str = "--out") -> str:
    suffix = path.suffix.lower()
    if suffix not in EXPORT_FORMATS:
        raise ValueError(
            f"{option} = {str(path)!r}: suffix {path.suffix or '(none)'!r} is not supported; "
            f"one of {', '.join(EXPORT_FORMATS)} is required"
        )
    return suffix


def write_table(table: pd.DataFrame, path: str | os.PathLike[str]) -> Path:
    """Write ``table`` in the format of ``path``'s suffix, atomically; returns the path."""
    target = Path(path)
    suffix = _format(target)
    with atomic_file(target) as temporary:
        if suffix == ".csv":
            table.to_csv(temporary, index=False, float_format=None)
        elif suffix == ".parquet":
            table.to_parquet(temporary, index=False, engine="pyarrow")
        else:
            arrays = {str(name): table[name].to_numpy() for name in table.columns}
            with open(temporary, "wb") as stream:  # a file object: savez adds no suffix
                np.savez(stream, **arrays)
    return target


def export_run(result: ClosedLoopResult, path: str | os.PathLike[str]) -> Path:
    """Write ``run_table(result)`` to ``path`` (``.csv``, ``.parquet`` or ``.npz``).

    The parent folder is created; ``ValueError`` (naming ``--out``) for another suffix."""
    target = Path(path)
    _format(target)  # refuse a bad suffix before building the table
    return write_table(run_table(result), target)


def read_run(path: str | os.PathLike[str]) -> pd.DataFrame:
    """Read a file written by ``export_run`` back into a DataFrame (same columns, order)."""
    source = require_regular_file("log", path)
    suffix = _format(source, "path")
    if suffix == ".csv":
        return pd.read_csv(source, **_CSV_READ_OPTIONS)
    if suffix == ".parquet":
        return pd.read_parquet(source, engine="pyarrow")
    with np.load(source, allow_pickle=False) as data:
        return pd.DataFrame({name: data[name] for name in data.files})
