"""A log is a table (issue 29): the columns ``posfb simulate --out`` writes, so a
simulated run is a valid log. Identification reads only

* ``time_s``: the sample instants (s), increasing and evenly spaced;
* ``q{j}_measured_rad`` per joint ``j = 1..n`` (the encoder's reading, rad), or
  ``q{j}_counts`` (whole encoder counts; ``counts_per_revolution`` converts them:
  ``q = 2 pi counts / N``);
* ``u{j}_applied_V`` per joint: the voltage the drive applied from that instant to the
  next (held, as a sampled controller's is).

and, where the log has them (``posfb simulate --out`` writes them; a controller knows
its reference), the controller's reference:

* ``q{j}_desired_rad`` per joint, with ``q{j}_desired_velocity_rad_per_s`` and
  ``q{j}_desired_acceleration_rad_per_s2`` (differentiated from the positions where
  absent). With it the fit uses instrumental variables (``models.identification.
  estimate``), which the encoder's quantisation does not bias.

CSV (``.csv``) or Parquet (``.parquet``); any other column (a simulated log's true
positions included) is ignored. ``TEMPLATE`` is a two-joint example a user fills from
a drive's record.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from posfb.models.identification.estimate import Reference
from posfb.models.validation import require_regular_file

#: Relative spread of the sample intervals a log may have (clock jitter, round-off).
EVEN_TOLERANCE = 1e-3

#: The fewest samples a log must hold.
MIN_SAMPLES = 100

#: The largest magnitude a log's position (rad, after counts are converted) or voltage
#: (V) may have: far beyond any arm's (1 600 turns, 10 kV), far below where the fit's
#: arithmetic overflows.
MAX_VALUE = 1e4

#: The widest sample spacing (s) a log may have: a control loop's log is sampled far
#: faster (the paper's: 10 ms); a wider one is a log in other time units (ms).
MAX_SAMPLE_TIME = 1.0

TEMPLATE = """\
time_s,q1_measured_rad,q2_measured_rad,u1_applied_V,u2_applied_V
0.00,0.000000,0.000000,0.512,-0.210
0.01,0.000314,0.000000,0.530,-0.198
0.02,0.000942,0.000314,0.561,-0.170
"""


@dataclass(frozen=True)
class EncoderLog:
    """What identification reads from a log: ``time`` (N,), the measured positions
    ``q`` and applied voltages ``u`` (N, n), the encoder's step per joint where the log
    gave counts (else ``None``), the file it came from and the controller's
    ``reference`` where the log gives it."""

    time: np.ndarray
    q: np.ndarray
    u: np.ndarray
    source: str
    quantisation_step: np.ndarray | None = None
    reference: Reference | None = None

    @property
    def joints(self) -> int:
        return self.q.shape[1]

    @property
    def sample_time(self) -> float:
        return float(self.time[1] - self.time[0])


def _table(path: Path):
    import pandas as pd

    require_regular_file("log", path)
    suffix = path.suffix.lower()
    try:
        if suffix == ".csv":
            return pd.read_csv(path)
        if suffix == ".parquet":
            return pd.read_parquet(path)
    except Exception as error:  # pandas raises many kinds; the file is the user's
        first = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise ValueError(f"log {path} cannot be read as {suffix[1:]}: {first}") from None
    raise ValueError(f"log {path}: suffix {suffix!r}; .csv or .parquet is required")


def _joint_count(columns: list[str], source: str) -> int:
    joints = 0
    while f"u{joints + 1}_applied_V" in columns:
        joints += 1
    if joints == 0:
        raise ValueError(
            f"log {source} has no column u1_applied_V; time_s, q<j>_measured_rad (or "
            "q<j>_counts) and u<j>_applied_V per joint are required"
        )
    return joints


def read_log(
    path: str | Path, *, joints: int | None = None, counts_per_revolution=None
) -> EncoderLog:
    """The log in ``path``, checked: the columns the module docstring lists, finite,
    at least ``MIN_SAMPLES`` rows, ``time_s`` increasing and evenly spaced (within
    ``EVEN_TOLERANCE`` of its median step). ``joints`` (the arm's) must match the log's;
    ``counts_per_revolution`` (one per joint, or one for all) converts ``q<j>_counts``."""
    path = Path(path)
    table = _table(path)
    columns = [str(c) for c in table.columns]
    n = _joint_count(columns, str(path))
    if joints is not None and n != joints:
        raise ValueError(
            f"log {path} has voltages for {n} joints and the arm has {joints}; a log of "
            "the same arm is required"
        )
    measured = [f"q{j}_measured_rad" for j in range(1, n + 1)]
    counted = [f"q{j}_counts" for j in range(1, n + 1)]
    voltages = [f"u{j}_applied_V" for j in range(1, n + 1)]
    if all(c in columns for c in measured):
        position_columns, step = measured, None
    elif all(c in columns for c in counted):
        if counts_per_revolution is None:
            raise ValueError(
                f"log {path} gives q<j>_counts; the encoder's counts per revolution "
                "(sensor.encoder_counts) are required to read them"
            )
        per_joint = np.broadcast_to(np.asarray(counts_per_revolution, dtype=float), (n,))
        if np.any(per_joint <= 0):
            raise ValueError(
                f"sensor.encoder_counts = {list(per_joint)}; counts per revolution > 0 are "
                "required to read q<j>_counts"
            )
        position_columns, step = counted, 2.0 * np.pi / per_joint
    else:
        missing = [c for c in ["time_s", *measured] if c not in columns]
        raise ValueError(
            f"log {path} lacks {', '.join(missing)}; time_s, q<j>_measured_rad (or q<j>_counts) "
            "and u<j>_applied_V per joint are required"
        )
    if "time_s" not in columns:
        raise ValueError(f"log {path} lacks time_s; the sample instants in s are required")
    try:
        data = table[["time_s", *position_columns, *voltages]].to_numpy(dtype=float)
    except ValueError:
        raise ValueError(f"log {path}: every column read must hold numbers") from None
    found = _first_cell(~np.isfinite(data), ["time_s", *position_columns, *voltages], data)
    if found is not None:
        name, row, value = found
        raise ValueError(
            f"log {path}: {name} is not finite at row {row} ({value!r}); finite numbers are "
            "required"
        )
    if data.shape[0] < MIN_SAMPLES:
        raise ValueError(
            f"log {path} has {data.shape[0]} samples; at least {MIN_SAMPLES} are required"
        )
    time = data[:, 0]
    steps = np.diff(time)
    if np.any(steps <= 0.0):
        row = int(np.flatnonzero(steps <= 0.0)[0])
        raise ValueError(
            f"log {path}: time_s does not increase at row {row + 2} ({time[row]!r} then "
            f"{time[row + 1]!r}); increasing sample instants are required"
        )
    median = float(np.median(steps))
    if median > MAX_SAMPLE_TIME:
        raise ValueError(
            f"log {path}: time_s is spaced {median:g} s; samples at most "
            f"{MAX_SAMPLE_TIME:g} s apart (a control loop's) are required: time in ms rather "
            "than s?"
        )
    spread = float(np.max(np.abs(steps - median)) / median)
    if spread > EVEN_TOLERANCE:
        raise ValueError(
            f"log {path}: time_s is unevenly spaced (steps from {steps.min():g} to "
            f"{steps.max():g} s); evenly spaced samples (within {EVEN_TOLERANCE:g} of the "
            "median step) are required"
        )
    q = data[:, 1 : n + 1]
    if step is not None:
        q = q * step
    for names, values, unit in ((position_columns, q, "rad"), (voltages, data[:, n + 1 :], "V")):
        found = _first_cell(np.abs(values) > MAX_VALUE, names, values)
        if found is not None:
            name, row, value = found
            raise ValueError(
                f"log {path}: {name} is {value:g} {unit} at row {row}; at most "
                f"{MAX_VALUE:g} {unit} in magnitude is required (another unit, or a corrupted "
                "file?)"
            )
    even_time = time[0] + median * np.arange(time.size)
    reference = _reference(table, columns, n, median, str(path))
    return EncoderLog(even_time, q, data[:, n + 1 :], str(path), step, reference)


def _first_cell(
    bad: np.ndarray, names: list[str], values: np.ndarray
) -> tuple[str, int, float] | None:
    """The first cell (row by row) where ``bad`` holds: its column's name, its data row
    (1-based) and its value; ``None`` if none."""
    if not bad.any():
        return None
    row, column = np.argwhere(bad)[0]
    return names[column], int(row) + 1, float(values[row, column])


def _reference(
    table, columns: list[str], n: int, sample_time: float, source: str
) -> Reference | None:
    """The controller's reference (module docstring), ``None`` where the log lacks it;
    a column of it that is not finite numbers is refused naming the column and row."""
    parts: list[list[str] | None] = [[f"q{j}_desired_rad" for j in range(1, n + 1)]]
    if not all(c in columns for c in parts[0]):
        return None
    for kind in ("velocity_rad_per_s", "acceleration_rad_per_s2"):
        wanted = [f"q{j}_desired_{kind}" for j in range(1, n + 1)]
        parts.append(wanted if all(c in columns for c in wanted) else None)
    derived: list[np.ndarray] = []
    for wanted in parts:
        if wanted is None:
            derived.append(np.gradient(derived[-1], sample_time, axis=0))
            continue
        try:
            values = table[wanted].to_numpy(dtype=float)
        except ValueError:
            raise ValueError(f"log {source}: every column read must hold numbers") from None
        found = _first_cell(~np.isfinite(values), wanted, values)
        if found is not None:
            name, row, value = found
            raise ValueError(
                f"log {source}: {name} is not finite at row {row} ({value!r}); finite numbers "
                "are required (or no reference columns: the fit is then least squares)"
            )
        derived.append(values)
    return Reference(*derived)
