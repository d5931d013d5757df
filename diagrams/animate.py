"""A self-contained HTML animation of one closed-loop run (Meshcat recording).

``StartMeshcat()`` serves on localhost only (no network needed); the
``MeshcatVisualizer`` records the arm's poses while the run is simulated, and
``Meshcat.StaticHtml()`` bundles the recording with the viewer's JavaScript into
one HTML file that plays offline in any browser.
"""

from __future__ import annotations

from pathlib import Path

from posfb.analysis.experiment import case_parameters
from posfb.diagrams.closed_loop import ClosedLoopConfig, ClosedLoopResult, ClosedLoopRunner
from pydrake.geometry import StartMeshcat


def record_animation(
    config: ClosedLoopConfig, case: str, out: Path
) -> tuple[Path, ClosedLoopResult]:
    """Simulate ``config`` on ``case`` ("nominal" or "payload") and write the
    recording to ``out``. Raises ``RuntimeError`` (one line) if Meshcat cannot start."""
    try:
        meshcat = StartMeshcat()
    except RuntimeError as error:
        first = (str(error).strip().splitlines() or ["no reason given"])[0]
        raise RuntimeError(f"Meshcat could not start (it serves on localhost): {first}") from None
    runner = ClosedLoopRunner(config, meshcat=meshcat)
    visualizer = runner.loop.visualizer
    visualizer.StartRecording(set_transforms_while_recording=False)
    result = runner.run(case_parameters(runner.arm, case))
    visualizer.PublishRecording()
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(meshcat.StaticHtml())
    return out, result
