"""The common-Lyapunov SDP on a real arm's loops: posfb's interior-point method
(``models.design.lyapunov_sdp``) against cvxpy with Clarabel on the same program (issue 45):

    .venv/bin/python bench/bench_lyapunov_sdp.py [--repeat 3] [--out sdp.json]

The loops are those ``scenario check`` certifies on the published Panda of
``example-robot-data`` with a user's drive data (``bench_route.py``'s scenario): the
proposed controller's sampled loop with ``M*(q)`` frozen at the path's configurations and
at ``M0*``, balanced, and the ``BATCH`` of largest spectral radius (the first SDP of
``common_lyapunov``'s search). Printed: each solver's seconds (the best of ``--repeat``),
the optimum of the margin program ``max s: tr P = 1, P >= s I, P - A_i^T P A_i >= s I``
and posfb's dual bound; then the whole ``common_lyapunov`` call as ``scenario check``
makes it.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))
import bench_route  # noqa: E402  (the published arm and its drive data)

from helpers.reference_sdp import clarabel_margin  # noqa: E402  (the independent solver)


def panda_loops(folder: Path) -> list[np.ndarray]:
    """The transition matrices ``scenario check`` hands to ``common_lyapunov`` on the
    Panda (the spy records them; the check runs without its simulation)."""
    urdf = bench_route.published(bench_route.PANDA)
    drives = bench_route.write_drives(urdf, folder / "drives.yaml")
    subprocess.run([*bench_route.posfb_command(), "scenario", "init", "--urdf", str(urdf),
                    "--drives", str(drives), "--out", "arm.yaml"], cwd=folder, check=True,
                   capture_output=True)  # fmt: skip
    import posfb.models.design.synthesis as synthesis
    from posfb.analysis.cli import main

    recorded: list[list[np.ndarray]] = []
    original = synthesis.common_lyapunov

    def spy(transitions):
        recorded.append([np.array(A) for A in transitions])
        return original(transitions)

    synthesis.common_lyapunov = spy
    os.environ["POSFB_CACHE_DIR"] = "off"
    cwd = Path.cwd()
    os.chdir(folder)
    try:
        with open(os.devnull, "w") as sink:
            stdout, sys.stdout = sys.stdout, sink
            try:
                main(["scenario", "check", "arm.yaml", "--no-sim"])
            except SystemExit:
                pass
            finally:
                sys.stdout = stdout
    finally:
        os.chdir(cwd)
        synthesis.common_lyapunov = original
    return recorded[0]


def best_of(repeat: int, function):
    times, result = [], None
    for _ in range(repeat):
        start = time.perf_counter()
        result = function()
        times.append(time.perf_counter() - start)
    return min(times), result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--out", type=Path)
    options = parser.parse_args()
    if options.repeat < 1:
        raise SystemExit(f"--repeat {options.repeat}: at least 1 is required")
    from posfb.models.design import common_lyapunov as search
    from posfb.models.design.lyapunov_sdp import maximise_margin

    loops = panda_loops(Path(tempfile.mkdtemp(prefix="bench-sdp-")))
    scale = search._balancing(loops)
    balanced = [A / scale[:, None] * scale[None, :] for A in loops]
    radii = [search.spectral_radius(A) for A in balanced]
    batch = [balanced[i] for i in np.argsort(radii)[::-1][: search.BATCH]]
    print(f"Panda: {len(loops)} loops of {len(loops[0])} states; the SDP on the {len(batch)} "
          f"of largest spectral radius ({max(radii):.6g})")  # fmt: skip
    seconds, answer = best_of(options.repeat, lambda: maximise_margin(batch))
    optimum_s, optimum = best_of(options.repeat, lambda: maximise_margin(batch, decide=False))
    print(f"posfb (decide):   {seconds:7.2f} s  margin {answer.margin:.3e}  bound "
          f"{answer.bound:.3e}  {answer.iterations} iterations, {answer.ended}")  # fmt: skip
    print(f"posfb (optimum):  {optimum_s:7.2f} s  margin {optimum.margin:.3e}  bound "
          f"{optimum.bound:.3e}  {optimum.iterations} iterations, {optimum.ended}")  # fmt: skip
    clarabel_s, clarabel = best_of(1, lambda: clarabel_margin(batch))
    print(f"cvxpy + Clarabel: {clarabel_s:7.2f} s  optimum {clarabel:.3e}")
    check_s, certificate = best_of(1, lambda: search.common_lyapunov(loops))
    print(f"common_lyapunov, all {len(loops)} loops: {check_s:.2f} s: {certificate.message}")
    if options.out:
        options.out.write_text(json.dumps({
            "loops": len(loops), "states": len(loops[0]), "batch": len(batch),
            "posfb": {"seconds": seconds, "margin": answer.margin, "bound": answer.bound,
                      "iterations": answer.iterations, "ended": answer.ended},
            "posfb_optimum": {"seconds": optimum_s, "margin": optimum.margin,
                              "bound": optimum.bound},
            "clarabel": {"seconds": clarabel_s, "optimum": clarabel},
            "common_lyapunov": {"seconds": check_s, "message": certificate.message},
        }, indent=2))  # fmt: skip


if __name__ == "__main__":
    main()
