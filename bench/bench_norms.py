"""The nominal norms of Eq. 18's bound (``models.serial_bounds.model_norms``) on a URDF
arm: their time cold, and their values against the earlier search (issue 45).

Usage::

    .venv/bin/python bench/bench_norms.py [--arms six_joint,panda] [--out FILE]

For each arm, ``max_q ||M1*(q)||``, ``k_C1`` and ``max_q ||G*(q)||`` by posfb's search
(a Sobol' sample, then BFGS on each maximum's exact gradient from the best points, the
first joint angle dropped where the maximum does not depend on it) and by the search it
replaced (issue 13: 64 Sobol' points, 4000 Nelder-Mead iterations from the 3 best, over
every joint angle, the tensor norm from each start in turn), written out below as the
reference. Both are lower bounds of the true maxima (a norm at a configuration the
search reached), so the larger is the better: the comparison says by how much each
value differs (``relative``: posfb's minus the reference, over the reference) and how
long each took. ``six_joint`` is the shipped arm; ``panda`` the published Panda of
example-robot-data, described by ``scenario init`` with the drive data of
``bench_route.py``. JSON on stdout (or ``--out``).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import scipy.optimize

sys.path.insert(0, str(Path(__file__).resolve().parent))
import bench_route  # noqa: E402  (its published arm and drive data)

from posfb.diagrams.resolve import load_scenario, resolve  # noqa: E402
from posfb.models import serial_bounds  # noqa: E402
from posfb.models.nominal import nominal_model  # noqa: E402

REPO = Path(__file__).resolve().parent.parent

#: The earlier search's settings (issue 13).
REFERENCE = {"samples": 64, "starts": 3, "steps": 4000}


def reference_tensor_norm(tensor: np.ndarray, iterations: int = 100) -> float:
    """The earlier tensor norm: the alternating maximisation from each start in turn."""
    n = tensor.shape[2]
    best = 0.0
    for x in [*np.eye(n), np.ones(n) / np.sqrt(n)]:
        value = 0.0
        for _ in range(iterations):
            left, singular, right = np.linalg.svd(tensor @ x)
            gradient = np.einsum("i,ijk,j->k", left[:, 0], tensor, right[0])
            length = float(np.linalg.norm(gradient))
            if length == 0.0 or singular[0] - value <= 1e-15 * max(singular[0], 1.0):
                value = max(value, float(singular[0]))
                break
            value, x = float(singular[0]), gradient / length
        best = max(best, value, float(np.linalg.norm(tensor @ x, 2)))
    return best


def reference_maximum(function, points: np.ndarray) -> float:
    """The earlier local search: Nelder-Mead from the best samples, every joint angle."""
    values = np.array([function(point) for point in points])
    best = float(values.max())
    for start in points[np.argsort(values)[::-1][: REFERENCE["starts"]]]:
        result = scipy.optimize.minimize(
            lambda point: -function(point), start, method="Nelder-Mead",
            options={"xatol": 1e-10, "fatol": 1e-15, "maxiter": REFERENCE["steps"]},
        )  # fmt: skip
        best = max(best, -float(result.fun))
    return best


def reference_norms(model) -> dict[str, float]:
    """The earlier ``model_norms``."""
    angles = serial_bounds._sobol_angles(model.size, REFERENCE["samples"], 0)
    M0 = model.M0()
    return {
        "delta_M1": reference_maximum(lambda q: float(np.linalg.norm(model.M(q) - M0, 2)),
                                      angles),  # fmt: skip
        "delta_C": reference_maximum(lambda q: reference_tensor_norm(model.christoffel(q)),
                                     angles),  # fmt: skip
        "delta_G": reference_maximum(lambda q: float(np.linalg.norm(model.G(q))), angles),
    }


def arm_scenario(arm: str, folder: Path) -> Path:
    """The arm's scenario file (panda: written by ``scenario init``)."""
    if arm == "six_joint":
        return REPO / "analysis/scenarios/six_joint_tuned.yaml"
    if arm != "panda":
        raise SystemExit(f"--arms: {arm!r}; six_joint or panda is required")
    urdf = bench_route.published(bench_route.PANDA)
    drives = bench_route.write_drives(urdf, folder / "drives.yaml")
    _, code, tail = bench_route.run(["scenario", "init", "--urdf", str(urdf), "--drives",
                                     str(drives), "--out", "arm.yaml"], folder, dict(os.environ))
    if code != 0:
        raise SystemExit(f"scenario init on the Panda failed: {tail}")
    return folder / "arm.yaml"


def measure(arm: str, folder: Path) -> dict:
    """Both searches' values and seconds on ``arm``."""
    model = nominal_model(resolve(load_scenario(arm_scenario(arm, folder))).config.design.nominal)
    start = time.perf_counter()
    found = serial_bounds.model_norms(model)
    seconds = time.perf_counter() - start
    start = time.perf_counter()
    reference = reference_norms(model)
    reference_seconds = time.perf_counter() - start
    return {
        "joints": model.size,
        "seconds": round(seconds, 3),
        "reference_seconds": round(reference_seconds, 3),
        "norms": {
            name: {
                "posfb": found[name],
                "reference": reference[name],
                "relative": (found[name] - reference[name]) / reference[name],
            }
            for name in found
        },
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--arms", default="six_joint,panda")
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        result = {arm: measure(arm, Path(folder)) for arm in args.arms.split(",")}
    text = json.dumps(result, indent=2)
    if args.out:
        args.out.write_text(text + "\n")
    print(text)


if __name__ == "__main__":
    main()
