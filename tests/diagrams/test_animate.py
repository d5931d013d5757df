"""``diagrams.animate``: the HTML is self-contained, framed on the arm, and no
Meshcat port is left open (no browser needed)."""

from __future__ import annotations

import base64
import math
import re
import socket
from pathlib import Path

# msgpack comes with dask[distributed] (a declared dependency); Meshcat's
# commands embedded in the page are msgpack messages.
import msgpack
import numpy as np
import pytest

import posfb.diagrams.animate as animate
from posfb.diagrams.resolve import load_scenario
from posfb.models.plant import PlantConfig, build_arm_diagram

COMMAND = re.compile(r"data:application/octet-binary;base64,([A-Za-z0-9+/=]+)")
LISTEN = "0A"  # TCP state in /proc/net/tcp*


def commands(html: str) -> list[dict]:
    """The Meshcat commands that the static page replays, decoded."""
    return [
        msgpack.unpackb(base64.b64decode(data), strict_map_key=False)
        for data in COMMAND.findall(html)
    ]


def find(cmds: list[dict], kind: str, path: str, prop: str | None = None) -> dict:
    hits = [
        c
        for c in cmds
        if c.get("type") == kind and c.get("path") == path and c.get("property") == prop
    ]
    assert len(hits) == 1, f"{kind} {path} {prop}: {len(hits)} commands"
    return hits[0]


def listening_addresses(port: int) -> list[str] | None:
    """Local addresses of sockets listening on ``port`` (hex, as in /proc/net/tcp*),
    or None where /proc/net/tcp is absent."""
    tables = [Path("/proc/net/tcp"), Path("/proc/net/tcp6")]
    if not tables[0].exists():
        return None
    found = []
    for table in tables:
        if not table.exists():
            continue
        for line in table.read_text().splitlines()[1:]:
            fields = line.split()
            address, port_hex = fields[1].split(":")
            if int(port_hex, 16) == port and fields[3] == LISTEN:
                found.append(address)
    return found


@pytest.fixture()
def opened(monkeypatch):
    """Records the port (and listening addresses) of every Meshcat animate opens,
    without keeping a reference to it."""
    seen: list[tuple[int, list[str] | None]] = []
    original = animate.new_recording_meshcat

    def spy():
        meshcat = original()
        seen.append((meshcat.port(), listening_addresses(meshcat.port())))
        return meshcat

    monkeypatch.setattr(animate, "new_recording_meshcat", spy)
    return seen


def test_arm_reach_is_both_link_lengths():
    _, arm, _ = build_arm_diagram()
    assert animate.arm_reach(arm.plant) == pytest.approx(0.25 + 0.30, abs=1e-12)


def test_record_animation_is_self_contained_framed_and_closes_its_port(tmp_path, opened):
    out, result = animate.record_animation(
        load_scenario(None, ["timing.duration=0.2"]), tmp_path / "sub" / "arm.html"
    )
    assert result.status == "ok"
    html = out.read_text()

    # Self-contained: every script inline, no stylesheet or other fetched
    # resource, and the websocket connection block of meshcat.html removed.
    assert re.findall(r"<script\b[^>]*>", html)
    assert not re.findall(r"<script\b[^>]*\bsrc\s*=", html)
    assert not re.findall(r"<(?:link|img|iframe)\b", html)
    assert "CONNECTION BLOCK" not in html
    assert "make_connection" not in html

    # The framing is in the page: a perspective camera on -y, looking at the base,
    # whose vertical field of view spans the reach plus the margin; no grid, no axes.
    cmds = commands(html)
    camera = find(cmds, "set_object", "/Cameras/default/rotated")["object"]["object"]
    assert camera["type"] == "PerspectiveCamera"
    assert camera["fov"] == pytest.approx(animate.CAMERA_FOV_DEG)
    half_height = 0.55 * (1.0 + animate.FRAME_MARGIN)
    distance = half_height / math.tan(math.radians(animate.CAMERA_FOV_DEG) / 2.0)
    position = find(cmds, "set_property", "/Cameras/default/rotated/<object>", "position")
    # three.js is y-up: Drake's (0, -d, 0) is (0, 0, d) there.
    np.testing.assert_allclose(position["value"], [0.0, 0.0, distance], atol=1e-9)
    targets = [c for c in cmds if c.get("type") == "set_target"]
    assert len(targets) == 1
    np.testing.assert_allclose(targets[0]["value"], [0.0, 0.0, 0.0], atol=1e-12)
    assert find(cmds, "set_property", "/Grid", "visible")["value"] is False
    assert find(cmds, "set_property", "/Axes", "visible")["value"] is False

    # The recording is in the page too.
    animations = [c for c in cmds if c.get("type") == "set_animation"]
    assert len(animations) == 1
    paths = {track["path"] for track in animations[0]["animations"]}
    assert any(path.endswith("/link1") for path in paths)
    assert any(path.endswith("/link2") for path in paths)

    # One Meshcat, on the loopback interface only, and closed again on return.
    assert len(opened) == 1
    port, addresses = opened[0]
    if addresses is not None:
        assert addresses, f"nothing was listening on port {port}"
        assert not [a for a in addresses if set(a) == {"0"}], "listening on all interfaces"
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as probe:
        probe.settimeout(2.0)
        with pytest.raises(ConnectionRefusedError):
            probe.connect(("127.0.0.1", port))


def test_animation_html_stops_at_the_first_non_finite_row(opened):
    times = np.linspace(0.0, 1.0, 101)
    q = np.zeros((101, 2))
    q[51:] = np.nan  # finite up to t = 0.5 s
    html = animate.animation_html(PlantConfig(), times, q)
    (animation,) = [c for c in commands(html) if c.get("type") == "set_animation"]
    track = animation["animations"][0]["clip"]
    last_frame = max(key["time"] for key in track["tracks"][0]["keys"])
    assert last_frame == math.floor(0.5 * track["fps"] + 1e-9)
    assert len(opened) == 1


def test_animation_html_rejects_bad_input():
    with pytest.raises(ValueError, match="one row of q per time"):
        animate.animation_html(PlantConfig(), np.zeros(3), np.zeros((2, 2)))
    with pytest.raises(ValueError, match="no finite first row"):
        animate.animation_html(PlantConfig(), np.zeros(1), np.full((1, 2), np.nan))


def test_frame_arm_rejects_a_non_positive_reach():
    with pytest.raises(ValueError, match="positive reach"):
        animate.frame_arm(None, 0.0)
