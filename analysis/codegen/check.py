"""``posfb codegen --check LOG``: compile a generated controller with the ``cc`` on the
PATH and replay a log through it: sample 0's measured position and desired signals go to
``NAME_start``, every sample's to ``NAME_step``, and each voltage is compared with the
log's commanded one (``u<j>_commanded_V``). The same check serves a log recorded on the
arm, with the columns of ``posfb simulate --out``.

The verdict: the check passes when every sample's voltage is within a tolerance of the
log's on every joint (``CheckResult.passed``), by default the C type's round-off bound
(``TOLERANCE``) times the log's largest commanded voltage. A log the replay cannot
stand for is refused with ``ValueError`` before anything is compiled (``log_inputs``):
rows that are not one per sample, or a replayed value that is not finite. Samples (rows)
are counted from 0, as ``posfb simulate`` writes them (``t_k = k T_s``); joints from 1, as
the columns name them.
"""

from __future__ import annotations

import math
import numbers
import re
import subprocess
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from posfb.analysis.codegen.build import compile_c, compiled_object
from posfb.analysis.codegen.package import Package
from posfb.analysis.common.export import (
    Q_DESIRED,
    Q_MEASURED,
    QD_DESIRED,
    QDD_DESIRED,
    U_COMMANDED,
)  # fmt: skip

#: The columns a replay reads, per joint (``analysis.common.export``).
REPLAY_COLUMNS = (Q_MEASURED, Q_DESIRED, QD_DESIRED, QDD_DESIRED, U_COMMANDED)


#: How many of the C type's epsilons (its relative rounding) a replayed voltage may be off
#: the log's, relative to the log's largest commanded voltage (``TOLERANCE``). The
#: float-vs-double spread over 20 s runs (2001 samples) of every built-in controller on
#: the shipped arms (``paper_nominal``, ``paper_payload``, ``three_link_nominal``,
#: ``six_joint_nominal``) was at most 246 float epsilons, except ADRC's: 2,005 to 3,514
#: (4.2e-4 of the largest voltage, on the six-joint arm), because its observer's
#: disturbance state integrates the rounding (a marginally stable mode; a replay is open
#: loop), so it grows with the log: 4,862 over 60 s and 8,248 over 120 s on the six-joint
#: arm. 2**14 = 16,384 covers a 120 s log of every built-in controller with a factor of 2;
#: a longer float log of ADRC may need ``--tolerance``. Measured with (each run's
#: ``largest_relative`` divided by float's epsilon ``2**-23``; ``--set
#: timing.duration=120`` for the long logs)::
#:
#:     for s in paper_nominal paper_payload three_link_nominal six_joint_nominal; do
#:       for k in proposed lin_lc pid pd_gravity adrc; do
#:         posfb simulate --scenario $s --controller $k --out $s-$k.csv --no-progress
#:         posfb codegen --scenario $s --controller $k --precision float --out c-$s-$k \\
#:           --check $s-$k.csv --tolerance 1e9 --json | jq .check.largest_relative
#:       done
#:     done
ROUND_OFF_FACTOR = 2**14

#: The default tolerance of a ``double`` build, relative to the log's largest commanded
#: voltage: ``ROUND_OFF_FACTOR`` double epsilons (3.6e-12; 8.7e-11 V on a 24 V log). The
#: round-off of the law's arithmetic is the same recursion's as in float
#: (``ROUND_OFF_FACTOR``), in double's epsilon ``2**-52``; a log written by ``posfb
#: simulate --out`` prints the shortest text that reads back exactly
#: (``analysis.common.export``), so its printed precision adds at most half an epsilon.
#: Measured: 0 V on every run of ``ROUND_OFF_FACTOR`` (the C and the simulated controller
#: evaluate one law in one order). A log printed with fewer digits (a logger's ``%.6g``)
#: needs ``--tolerance``: its last digit times the law's gains (up to hundreds of volts
#: per radian).
DOUBLE_TOLERANCE = ROUND_OFF_FACTOR * 2.0**-52

#: The default tolerance of a ``float`` build, relative to the log's largest commanded
#: voltage: float's epsilon ``2**-23`` times ``ROUND_OFF_FACTOR`` (2.0e-3; 0.047 V on a
#: 24 V log), twice the largest float-vs-double spread measured there.
FLOAT_TOLERANCE = ROUND_OFF_FACTOR * 2.0**-23

#: The default tolerance by the generated code's C type (``Package.precision``).
TOLERANCE = {"double": DOUBLE_TOLERANCE, "float": FLOAT_TOLERANCE}


@dataclass(frozen=True)
class CheckResult:
    """The replay: ``samples`` compared, the largest absolute difference (V) and the
    largest relative to the log's largest voltage, and where it was; the verdict against
    ``tolerance_V``: ``passed`` when no difference exceeds it, else the first sample over
    it (its row, its ``time_s``, the joint counted from 1 and the difference)."""

    samples: int
    largest_difference_V: float
    largest_relative: float
    at_sample: int
    tolerance_V: float
    passed: bool
    failing_sample: int | None = None
    failing_time_s: float | None = None
    failing_joint: int | None = None
    failing_difference_V: float | None = None


def _harness(name: str, real: str) -> str:
    upper = name.upper()
    return f"""/* posfb codegen --check: rows of q (n) and desired (3n) on stdin, voltages out. */
#include <stdio.h>

#include "{name}.h"

int main(void) {{
  {name}_state state;
  {real} q[{upper}_JOINTS], desired[3 * {upper}_JOINTS], voltage[{upper}_JOINTS];
  double value;
  int j, k;
  for (k = 0;; ++k) {{
    for (j = 0; j < {upper}_JOINTS; ++j) {{
      if (scanf("%lf", &value) != 1) return 0;
      q[j] = ({real})value;
    }}
    for (j = 0; j < 3 * {upper}_JOINTS; ++j) {{
      if (scanf("%lf", &value) != 1) return 1;
      desired[j] = ({real})value;
    }}
    if (k == 0) {name}_start(&state, q, desired);
    {name}_step(&state, q, desired, voltage);
    for (j = 0; j < {upper}_JOINTS; ++j) printf("%s%.17g", j ? " " : "", (double)voltage[j]);
    printf("\\n");
  }}
}}
"""


def build(package: Package, folder: Path) -> Path:
    """Compile the check harness against ``package``'s files in ``folder`` (the
    controller's object from ``compiled_object``); the program."""
    folder = folder.resolve()
    (folder / "check_main.c").write_text(_harness(package.name, package.precision))
    controller = compiled_object(folder, package.files, package.name)
    return compile_c(folder, folder / f"{package.name}_check", ["check_main.c", controller.name])


#: How far each row's ``time_s`` may be from the previous row's plus the sample time
#: (relative to the sample time): a missing or repeated row is a whole sample off, and a
#: log of another sample time is off on every row. A log whose ``time_s`` is a clock that
#: jitters more can leave the column out: its rows are then taken as one per sample.
SPACING_TOLERANCE = 0.01


def _check_times(times: np.ndarray, sample_time: float) -> None:
    """``ValueError`` unless ``times`` are one row per sample: finite, increasing by the
    sample time within ``SPACING_TOLERANCE`` on every row; the first bad row named."""
    bad = np.flatnonzero(~np.isfinite(times))
    if bad.size:
        raise ValueError(f"time_s is {times[bad[0]]:g} at row {bad[0]}; a finite time on "
                         "every row is required")  # fmt: skip
    steps = np.diff(times)
    if steps.size == 0:
        return
    spacing = float(np.median(steps))
    if not abs(spacing - sample_time) <= SPACING_TOLERANCE * sample_time:
        raise ValueError(
            f"the log's rows are {spacing:g} s apart and the controller samples every "
            f"{sample_time:g} s; a log of one row per sample is required (posfb simulate "
            "--out writes one)"
        )
    off = np.flatnonzero(~(np.abs(steps - sample_time) <= SPACING_TOLERANCE * sample_time))
    if off.size == 0:
        return
    row, step = int(off[0]) + 1, float(steps[off[0]])
    if step == 0.0:
        found = f"row {row} repeats row {row - 1}'s time_s = {times[row]:g}"
    elif step < 0.0:
        found = (
            f"row {row}'s time_s = {times[row]:g} is before row {row - 1}'s ({times[row - 1]:g})"
        )
    else:
        found = f"row {row} (time_s = {times[row]:g}) is {step:g} s after row {row - 1}"
    raise ValueError(
        f"{found}; one row per sample, each {sample_time:g} s after the previous within "
        f"{SPACING_TOLERANCE:.0%}, is required"
    )


def log_inputs(table: object, package: Package) -> tuple[np.ndarray, np.ndarray]:
    """The log's rows as ``(inputs, voltages)``: ``[q, q_d, qdot_d, qddot_d]`` and the
    commanded voltages; ``ValueError`` (the first fault found, in one line) for a log of
    another joint count (its measured positions' columns), a replayed column named twice,
    rows that are not the controller's samples (``_check_times``; a log without
    ``time_s`` is taken as one row per sample), missing columns (named), no rows, or a
    replayed value that is not finite (its column and row named)."""
    joints, sample_time = package.law.joints, package.sample_time
    measured = re.compile(re.escape(Q_MEASURED).replace(r"\{j\}", r"([0-9]+)"))
    logged = [int(found[1]) for found in map(measured.fullmatch, map(str, table.columns))
              if found]  # fmt: skip
    if logged and max(logged) != joints:
        raise ValueError(
            f"the log is of a {max(logged)}-joint arm (up to "
            f"{Q_MEASURED.format(j=max(logged))}) and the controller has {joints} joints; a "
            "log of the scenario's arm is required"
        )
    columns = [[p.format(j=j + 1) for j in range(joints)] for p in REPLAY_COLUMNS]
    named = list(map(str, table.columns))
    twice = [c for group in columns for c in group if named.count(c) > 1]
    if twice:
        raise ValueError(f"the log has {named.count(twice[0])} columns named {twice[0]}; one "
                         "of each is required")  # fmt: skip
    if "time_s" in named:
        _check_times(table["time_s"].to_numpy(dtype=float), sample_time)
    missing = [c for group in columns for c in group if c not in named]
    if missing:
        raise ValueError(
            f"the log lacks {', '.join(missing[:4])}{' ...' if len(missing) > 4 else ''}; a "
            "log written by posfb simulate --out (this version) has them"
        )
    if len(table) == 0:
        raise ValueError("the log has no rows to replay")
    replayed = [c for group in columns for c in group]
    values = table[replayed].to_numpy(dtype=float)
    bad = np.argwhere(~np.isfinite(values))
    if bad.size:
        row, column = (int(i) for i in bad[0])
        when = f" (time_s = {table['time_s'].iloc[row]:g})" if "time_s" in named else ""
        raise ValueError(
            f"{replayed[column]} is {values[row, column]:g} at row {row}{when}; a finite "
            "value in every replayed column is required"
        )
    return values[:, : 4 * joints], values[:, 4 * joints :]


def replay(program: Path, inputs: np.ndarray) -> np.ndarray:
    """The compiled controller's voltages over ``inputs``' rows."""
    text = "\n".join(" ".join(repr(float(v)) for v in row) for row in inputs) + "\n"
    result = subprocess.run([str(program)], input=text, capture_output=True, text=True,
                            check=True)  # fmt: skip
    return np.array([[float(v) for v in line.split()] for line in result.stdout.splitlines()])


def check(package: Package, table: object, tolerance_V: float | None = None) -> CheckResult:
    """Replay the log ``table`` through the compiled ``package`` (module docstring), built
    in a temporary folder, and judge it against ``tolerance_V`` (V; default: the
    precision's ``TOLERANCE`` times the log's largest commanded voltage). ``ValueError``
    for a log ``log_inputs`` refuses, or a tolerance that is not a finite number > 0."""
    if tolerance_V is not None and (
        isinstance(tolerance_V, bool) or not isinstance(tolerance_V, numbers.Real)
        or not (math.isfinite(tolerance_V) and tolerance_V > 0)
    ):  # fmt: skip
        raise ValueError(f"tolerance_V = {tolerance_V!r}; a finite number of volts > 0 (or "
                         "None: the precision's default) is required")  # fmt: skip
    inputs, logged = log_inputs(table, package)
    with tempfile.TemporaryDirectory(prefix="posfb-codegen-") as folder:
        for name, text in package.files.items():
            (Path(folder) / name).write_text(text)
        voltages = replay(build(package, Path(folder)), inputs)
    # a non-finite C voltage (the law overflowed) is infinitely far from a finite log
    difference = np.abs(voltages - logged)
    difference[np.isnan(difference)] = np.inf
    worst = np.unravel_index(int(np.argmax(difference)), difference.shape)
    scale = float(np.max(np.abs(logged)))
    largest = float(difference[worst])
    tolerance = TOLERANCE[package.precision] * scale if tolerance_V is None else tolerance_V
    over = np.argwhere(difference > tolerance)
    failing = {}
    if over.size:
        sample, joint = (int(i) for i in over[0])
        times = table["time_s"] if "time_s" in table.columns else None
        failing = {
            "failing_sample": sample, "failing_joint": joint + 1,
            "failing_time_s": float(sample * package.sample_time if times is None
                                    else times.iloc[sample]),
            "failing_difference_V": float(difference[sample, joint]),
        }  # fmt: skip
    return CheckResult(
        samples=len(logged),
        largest_difference_V=largest,
        largest_relative=largest / scale if scale > 0.0 else largest,
        at_sample=int(worst[0]),
        tolerance_V=float(tolerance),
        passed=not failing,
        **failing,
    )
