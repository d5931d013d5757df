"""Do identification's stated intervals hold (issue 42, item 3)? The full form of
``tests/models/identification/test_identification_honest.py``'s coverage test:

    .venv/bin/python bench/bench_identification_coverage.py [--arms 10] [--joints 4]
        [--duration 20] [--counts 4096 131072] [--out DIR]

For each encoder resolution and arm seed, a random spatial arm (``tests/helpers/
spatial_arm.py``) with every link and drive parameter perturbed up to 15 % is run by the
independent generator (``tests/helpers/independent_logs.py``: Pinocchio, its own RK4, a
quantised encoder, held voltages, a computed-torque controller) along a Fourier
reference, and identified with its reference (instrumental variables, the cutoff rule).
Printed per arm: the identifiable values (relative standard error at most 10 %), how
many lie within 3 stated standard errors, the RMS of their errors in standard errors,
the worst ones and the identification's seconds; then the totals per resolution. Needs
the dev extra (Pinocchio) and the checkout's ``tests`` folder.
"""

from __future__ import annotations

import argparse
import platform
import sys
import tempfile
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--arms", type=int, default=10)
    parser.add_argument("--joints", type=int, default=4)
    parser.add_argument("--duration", type=float, default=20.0, help="seconds per log")
    parser.add_argument("--counts", type=int, nargs="+", default=[4096, 2**17])
    parser.add_argument("--out", type=Path, default=None, help="keep the logs here")
    args = parser.parse_args()

    from helpers.identification_coverage import SIGMAS, arm_coverage

    print(f"{platform.node()}: {args.arms} arms of {args.joints} joints, {args.duration:g} s")
    folder = args.out or Path(tempfile.mkdtemp(prefix="posfb-coverage-"))
    for counts in args.counts:
        covered = total = 0
        for seed in range(args.arms):
            judged = arm_coverage(folder / f"{counts}", seed, joints=args.joints,
                                  counts=counts, duration=args.duration)  # fmt: skip
            covered, total = covered + judged.covered, total + judged.z.size
            rms = float(np.sqrt(np.mean(judged.z**2))) if judged.z.size else float("nan")
            worst = [f"{n} {z:+.1f}" for n, z in zip(judged.names, judged.z, strict=True)
                     if abs(z) > SIGMAS]  # fmt: skip
            print(f"counts {counts} arm {seed}: {judged.covered} of {judged.z.size} within "
                  f"{SIGMAS:g} sigma, RMS z {rms:.2f}, {judged.seconds:.1f} s; "
                  f"outside: {', '.join(worst) or 'none'}", flush=True)  # fmt: skip
        share = 100.0 * covered / total if total else float("nan")
        print(f"counts {counts}: {covered} of {total} identifiable values within "
              f"{SIGMAS:g} sigma ({share:.1f} %)", flush=True)  # fmt: skip


if __name__ == "__main__":
    main()
