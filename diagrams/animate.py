"""A self-contained HTML animation of one closed-loop run (Meshcat recording).

The run is simulated without any visualizer; its logged joint positions are then
replayed, at Meshcat's 64 frames per second, through a small diagram that holds
only the arm's plant, its SceneGraph and a ``MeshcatVisualizer`` (all C++
systems), and ``Meshcat.StaticHtml()`` writes the recording.

What happens to network ports (Drake 1.51):

* Drake's ``Meshcat`` cannot be created without a server. Its constructor
  always starts a websocket thread and binds a listening TCP port (or throws);
  every scene update, the recording that ``StaticHtml()`` replays included, is
  handled on that thread. ``MeshcatParams`` has no "no server" option, and the
  ``DRAKE_ALLOW_NETWORK`` policy can only switch Meshcat off altogether.
* ``StartMeshcat()`` is ``Meshcat()`` with default parameters (plus Deepnote
  proxy set-up): it listens on *all* interfaces (``host="*"``), on the first
  free port from 7000.
* :func:`new_recording_meshcat` asks for ``host="localhost"`` and ``port=0``:
  the server listens on the loopback interface only, on a port the OS picks,
  while the ``Meshcat`` object lives. Meshcat's destructor closes the socket.
* A diagram that contains a Python ``LeafSystem`` (the closed loop does) is
  never freed in pydrake 1.51.1 (the leak of drake#22515 / drake#23161; seen
  here with a one-port LeafSystem), so a ``MeshcatVisualizer`` in the closed
  loop would keep its Meshcat, and the port, open until the process exits. Do
  not give the closed loop a Meshcat to record. The replay diagram has no
  Python systems: :func:`animation_html` frees it and the Meshcat before it
  returns. The port is open for the replay only (about 0.2 s for a 20 s run,
  not during the simulation); a local process could connect meanwhile and see
  the scene.
* ``StaticHtml()`` inlines the viewer's JavaScript (meshcat.js, msgpack, stats)
  and replays the scene tree (objects, transforms, properties, camera) and the
  animation as embedded data; the block that opens a websocket is removed. The
  file plays offline and opens no connection.

Framing: the arm moves in the x-z plane, so :func:`frame_arm` puts a
narrow-angle perspective camera on the -y axis looking at the base, at the
distance where the vertical field of view spans the arm's reach (from the
plant, :func:`arm_reach`) plus a margin, and hides the grid and axes. The
camera settings live in Meshcat's scene tree, so ``StaticHtml()`` keeps them. A
perspective camera rather than ``Set2dRenderMode``'s orthographic one: for an
orthographic camera meshcat.js fixes the vertical extent and widens the view to
the right only, so the base would be off centre in a wide window.
"""

from __future__ import annotations

import gc
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from pydrake.geometry import (
    Meshcat,
    MeshcatParams,
    MeshcatVisualizer,
    MeshcatVisualizerParams,
    SceneGraph,
)
from pydrake.multibody.plant import MultibodyPlant
from pydrake.systems.framework import DiagramBuilder

from posfb.diagrams.resolve import LoadedScenario, run_scenario
from posfb.diagrams.runner import ClosedLoopResult
from posfb.models.plant import PlantConfig, add_arm

#: Vertical field of view of the framing camera (degrees). Narrow, so that the
#: planar arm is seen with little perspective distortion.
CAMERA_FOV_DEG = 30.0
#: Extra room around the reach, as a fraction of it.
FRAME_MARGIN = 0.15


@dataclass(frozen=True)
class ArmView:
    """The camera :func:`frame_arm` set, in Drake's z-up world frame (m, degrees)."""

    camera_in_world: np.ndarray
    target_in_world: np.ndarray
    fov_deg: float
    half_height_m: float


def new_recording_meshcat() -> Meshcat:
    """A Meshcat for recording: loopback only, on an OS-chosen port.

    The port closes when the last reference to the returned object is dropped
    (see the module docstring). Raises ``RuntimeError`` (one line) if Meshcat
    cannot start."""
    params = MeshcatParams(host="localhost", port=0, show_stats_plot=False)
    try:
        return Meshcat(params)
    except RuntimeError as error:
        first = (str(error).strip().splitlines() or ["no reason given"])[0]
        raise RuntimeError(f"Meshcat could not start (localhost only): {first}") from None


def arm_reach(plant: MultibodyPlant) -> float:
    """An upper bound on how far any body origin gets from the world origin (m).

    The sum, over the plant's joints, of the distance from the parent body's
    origin to the joint (in a URDF chain the child body's origin is on the
    joint): rotating the links of a chain never takes a point farther than the
    sum of its segments. For the two-link arm it is l1 + l2 (elbow and tip offsets)."""
    return float(
        sum(
            np.linalg.norm(
                plant.get_joint(index).frame_on_parent().GetFixedPoseInBodyFrame().translation()
            )
            for index in plant.GetJointIndices()
        )
    )


def frame_arm(
    meshcat: Meshcat,
    reach_m: float,
    *,
    margin: float = FRAME_MARGIN,
    fov_deg: float = CAMERA_FOV_DEG,
) -> ArmView:
    """Point Meshcat's default camera at an arm that moves in the x-z plane about
    the origin.

    The camera sits on the -y axis looking at the origin (+x to the right, +z
    up), where its vertical field of view spans ±``reach_m``·(1 + ``margin``), so
    the arm is in view in any pose (in a window at least as wide as tall). Grid
    and axes are hidden."""
    if not reach_m > 0.0:
        raise ValueError(f"reach_m = {reach_m!r}; a positive reach is required")
    if not 0.0 < fov_deg < 180.0:
        raise ValueError(f"fov_deg = {fov_deg!r}; a value in (0, 180) is required")
    half_height = reach_m * (1.0 + margin)
    distance = half_height / math.tan(math.radians(fov_deg) / 2.0)
    meshcat.SetCamera(Meshcat.PerspectiveCamera(fov=fov_deg, near=0.01, far=100.0 * distance))
    target = np.zeros(3)
    camera = np.array([0.0, -distance, 0.0])
    meshcat.SetCameraPose(camera, target)
    meshcat.SetProperty("/Grid", "visible", False)
    meshcat.SetProperty("/Axes", "visible", False)
    return ArmView(camera, target, fov_deg, half_height)


def animation_html(plant_config: PlantConfig, times: np.ndarray, q: np.ndarray) -> str:
    """The arm of ``plant_config`` moving through joint positions ``q`` (one row
    per entry of ``times``, s), as one self-contained HTML page.

    Positions are interpolated linearly at the visualizer's frame instants; rows
    from the first non-finite one on are dropped. Meshcat's port is closed when
    this returns."""
    times = np.asarray(times, dtype=float)
    q = np.asarray(q, dtype=float)
    if times.ndim != 1 or q.ndim != 2 or len(q) != len(times) or len(times) == 0:
        raise ValueError(f"times {times.shape} and q {q.shape}: one row of q per time is required")
    finite = np.all(np.isfinite(q), axis=1) & np.isfinite(times)
    keep = len(times) if finite.all() else int(np.argmin(finite))
    if keep == 0:
        raise ValueError("q has no finite first row to show")
    html = _replay(plant_config, times[:keep], q[:keep])
    # _replay's diagram, visualizer and Meshcat are unreferenced now; collect any
    # cycle among them too, so that Meshcat's destructor has closed its port.
    gc.collect()
    return html


def _replay(plant_config: PlantConfig, times: np.ndarray, q: np.ndarray) -> str:
    meshcat = new_recording_meshcat()
    builder = DiagramBuilder()
    arm = add_arm(builder, plant_config)
    scene_graph = next(s for s in builder.GetSystems() if isinstance(s, SceneGraph))
    params = MeshcatVisualizerParams()
    visualizer = MeshcatVisualizer.AddToBuilder(builder, scene_graph, meshcat, params)
    diagram = builder.Build()
    frame_arm(meshcat, arm_reach(arm.plant))

    context = diagram.CreateDefaultContext()
    plant_context = arm.plant.GetMyMutableContextFromRoot(context)
    visualizer_context = visualizer.GetMyContextFromRoot(context)
    period = params.publish_period
    frames = np.arange(times[0], times[-1] + 0.5 * period, period)
    visualizer.StartRecording(set_transforms_while_recording=False)
    for t in frames:
        context.SetTime(t)
        position = [np.interp(t, times, q[:, joint]) for joint in range(q.shape[1])]
        arm.plant.SetPositions(plant_context, position)
        visualizer.ForcedPublish(visualizer_context)
    visualizer.PublishRecording()
    return meshcat.StaticHtml()


def record_animation(
    loaded: LoadedScenario, out: Path, progress: Callable[[float], None] | None = None
) -> tuple[Path, ClosedLoopResult]:
    """Run the scenario and write the animation of the true joint positions to ``out``
    (see :func:`animation_html`; ``progress`` as in ``ClosedLoopRunner.run``). Raises
    ``RuntimeError`` (one line) if Meshcat cannot start."""
    result = run_scenario(loaded, progress)
    html = animation_html(result.config.plant, result.times, result.q_true)
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(html)
    return out, result
