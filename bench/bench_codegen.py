"""Per-step cost of each controller's generated C (``posfb codegen``), double and float.

    .venv/bin/python bench/bench_codegen.py [--steps 10000000]

For each controller with generated code, on the paper's arm (its theta model) and on the
shipped six-joint arm (its URDF model): the C (``cc -O2`` with the flags the code is
written for) called ``--steps`` times in a loop on a changing position, wall nanoseconds
per ``NAME_step`` (best of 3), beside the simulated controller's Python step (the
``Stepper`` the diagram calls, best of 3 x 10000 calls). The paper's controller is also
timed, as its own labelled row, with ``bounds.M1_norm = frobenius`` (Eq. 18's
``||M1*(q)||`` by the Frobenius norm, an upper bound of the paper's spectral norm).
"""

from __future__ import annotations

import argparse
import subprocess
import tempfile
import time
from pathlib import Path

import numpy as np

import posfb
from posfb.analysis.codegen.package import CFLAGS, Package, generate
from posfb.analysis.common.shipped import shipped_files
from posfb.diagrams.resolve import resolve
from posfb.models.controllers import REGISTRY
from posfb.models.laws.law import Stepper

HARNESS = """#define _POSIX_C_SOURCE 199309L
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "{name}.h"
int main(int argc, char **argv) {{
  {name}_state s;
  {real} q[{upper}_JOINTS] = {{0}}, d[3 * {upper}_JOINTS] = {{0}}, u[{upper}_JOINTS];
  struct timespec a, b;
  long k, n = atol(argv[argc - 1]);
  double sink = 0;
  {name}_start(&s, q, d);
  clock_gettime(CLOCK_MONOTONIC, &a);
  for (k = 0; k < n; ++k) {{
    q[0] = ({real})(1e-9 * (double)(k & 1023));
    {name}_step(&s, q, d, u);
    sink += (double)u[0];
  }}
  clock_gettime(CLOCK_MONOTONIC, &b);
  printf("%.3f %g\\n", ((double)(b.tv_sec - a.tv_sec) * 1e9 + (double)(b.tv_nsec - a.tv_nsec))
         / (double)n, sink);
  return 0;
}}
"""


#: The arms, by the shipped scenario of each.
ARMS = {"paper": "paper_nominal", "six-joint": "six_joint_nominal"}


#: The labelled variants timed beside the controllers' own settings: name, kind, settings.
VARIANTS = (("proposed, M1_norm = frobenius", "proposed", {"controller.bounds.M1_norm":
                                                          "frobenius"}),)  # fmt: skip


def package_of(arm: str, kind: str, precision: str, extra: dict | None = None) -> Package:
    scenario = posfb.load_scenario(shipped_files("scenario")[ARMS[arm]],
                                   set={"controller.kind": kind, **(extra or {})})  # fmt: skip
    return generate(resolve(scenario), None, precision)


def c_nanoseconds(arm: str, kind: str, precision: str, steps: int,
                  extra: dict | None = None) -> float:  # fmt: skip
    package = package_of(arm, kind, precision, extra)
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder)
        for name, text in package.files.items():
            (path / name).write_text(text)
        harness = HARNESS.format(name=package.name, upper=package.name.upper(), real=precision)
        (path / "bench.c").write_text(harness)
        subprocess.run(["cc", *CFLAGS.split(), "-o", "bench", "bench.c", f"{package.name}.c",
                        "-lm"], cwd=path, check=True)  # fmt: skip
        command = [str(path / "bench"), str(steps)]
        runs = [subprocess.run(command, capture_output=True, text=True, check=True).stdout
                for _ in range(3)]  # fmt: skip
    return min(float(r.split()[0]) for r in runs)


def python_nanoseconds(arm: str, kind: str, extra: dict | None = None) -> float:
    package = package_of(arm, kind, "double", extra)
    stepper = Stepper(package.law)
    q, desired = np.zeros(package.law.joints), np.zeros(3 * package.law.joints)
    memory = stepper.start(q, desired)
    best = np.inf
    for _ in range(3):
        start = time.perf_counter()
        for _ in range(10000):
            stepper.step(q, desired, memory)
        best = min(best, (time.perf_counter() - start) / 10000 * 1e9)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=10_000_000)
    args = parser.parse_args()
    print("| arm | controller | C double, ns/step | C float, ns/step | Python Stepper, ns/step |")
    print("|---|---|---:|---:|---:|")
    for arm in ARMS:
        rows = [(kind, kind, None) for kind, spec in REGISTRY.items() if spec.law is not None]
        for name, kind, extra in [*rows, *VARIANTS]:
            double, single = (c_nanoseconds(arm, kind, p, args.steps, extra)
                              for p in ("double", "float"))  # fmt: skip
            python = python_nanoseconds(arm, kind, extra)
            print(f"| {arm} | {name} | {double:.1f} | {single:.1f} | {python:.0f} |", flush=True)


if __name__ == "__main__":
    main()
