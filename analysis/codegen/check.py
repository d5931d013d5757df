"""``posfb codegen --check LOG``: compile a generated controller with the ``cc`` on the
PATH and replay a log through it: sample 0's measured position and desired signals go to
``NAME_start``, every sample's to ``NAME_step``, and each voltage is compared with the
log's commanded one (``u<j>_commanded_V``). The same check serves a log recorded on the
arm, with the columns of ``posfb simulate --out``.
"""

from __future__ import annotations

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


@dataclass(frozen=True)
class CheckResult:
    """The replay: ``samples`` compared, the largest absolute difference (V) and the
    largest relative to the log's largest voltage, and where it was."""

    samples: int
    largest_difference_V: float
    largest_relative: float
    at_sample: int


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


#: How far the median spacing of a log's rows may be from the sample time (relative).
SPACING_TOLERANCE = 0.01


def log_inputs(table: object, package: Package) -> tuple[np.ndarray, np.ndarray]:
    """The log's rows as ``(inputs, voltages)``: ``[q, q_d, qdot_d, qddot_d]`` and the
    commanded voltages; ``ValueError`` for a log of another joint count (its measured
    positions' columns), one whose rows are not the controller's samples (the median
    spacing of ``time_s`` off the sample time by more than ``SPACING_TOLERANCE``), or
    naming the missing columns."""
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
    if "time_s" in table.columns and len(table) > 1:
        spacing = float(np.median(np.diff(table["time_s"].to_numpy(dtype=float))))
        if not abs(spacing - sample_time) <= SPACING_TOLERANCE * sample_time:
            raise ValueError(
                f"the log's rows are {spacing:g} s apart and the controller samples every "
                f"{sample_time:g} s; a log of one row per sample is required (posfb simulate "
                "--out writes one)"
            )
    columns = [[p.format(j=j + 1) for j in range(joints)] for p in REPLAY_COLUMNS]
    missing = [c for group in columns for c in group if c not in table.columns]
    if missing:
        raise ValueError(
            f"the log lacks {', '.join(missing[:4])}{' ...' if len(missing) > 4 else ''}; a "
            "log written by posfb simulate --out (this version) has them"
        )
    inputs = np.hstack([table[group].to_numpy(dtype=float) for group in columns[:4]])
    return inputs, table[columns[4]].to_numpy(dtype=float)


def replay(program: Path, inputs: np.ndarray) -> np.ndarray:
    """The compiled controller's voltages over ``inputs``' rows."""
    text = "\n".join(" ".join(repr(float(v)) for v in row) for row in inputs) + "\n"
    result = subprocess.run([str(program)], input=text, capture_output=True, text=True,
                            check=True)  # fmt: skip
    return np.array([[float(v) for v in line.split()] for line in result.stdout.splitlines()])


def check(package: Package, table: object) -> CheckResult:
    """Replay the log ``table`` through the compiled ``package`` (module docstring), built
    in a temporary folder."""
    inputs, logged = log_inputs(table, package)
    if not np.all(np.isfinite(inputs)):
        kept = int(np.argmin(np.all(np.isfinite(inputs), axis=1)))
        inputs, logged = inputs[:kept], logged[:kept]
    if len(inputs) == 0:
        raise ValueError("the log has no complete row to replay")
    with tempfile.TemporaryDirectory(prefix="posfb-codegen-") as folder:
        for name, text in package.files.items():
            (Path(folder) / name).write_text(text)
        voltages = replay(build(package, Path(folder)), inputs)
    compared = np.all(np.isfinite(logged), axis=1)
    difference = np.abs(voltages - logged)[compared]
    worst = np.unravel_index(int(np.argmax(difference)), difference.shape)
    scale = float(np.max(np.abs(logged[compared])))
    largest = float(difference[worst])
    return CheckResult(
        samples=int(np.sum(compared)),
        largest_difference_V=largest,
        largest_relative=largest / scale if scale > 0.0 else largest,
        at_sample=int(np.flatnonzero(compared)[worst[0]]),
    )
