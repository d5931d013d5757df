"""``posfb animate``'s page in a real browser: Debian's ``chromium``, headless and
offline, renders the recording (``bin/setup`` installs it). The screenshot must show
the arm, and the page must ask nothing of the network.

The browser runs with its own background traffic switched off, every host name resolved
to nothing and every request sent to a closed local port, so nothing leaves the machine
whatever the page or the browser tries; Chromium's net log (``--log-net-log``) records
what was asked. A request the page made has the page's origin as its initiator; the
browser's own (update checks, which these switches do not all stop) have none."""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from posfb.analysis.cli import main

CHROMIUM = shutil.which("chromium")

pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="needs Debian's chromium (bin/setup)")

#: Headless, software WebGL (``docs/drake-notes.md``), and no way out of the machine.
OFFLINE = (
    "--headless=new", "--no-sandbox", "--disable-gpu", "--use-gl=swiftshader",
    "--enable-unsafe-swiftshader", "--window-size=1000,700", "--virtual-time-budget=8000",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    "--disable-default-apps", "--disable-domain-reliability", "--no-first-run",
    "--disable-client-side-phishing-detection", "--disable-breakpad",
    "--host-resolver-rules=MAP * ~NOTFOUND", "--proxy-server=127.0.0.1:9",
)  # fmt: skip

#: Schemes that leave the page (``file:``, ``data:``, ``blob:`` do not).
NETWORK_SCHEMES = ("http:", "https:", "ws:", "wss:", "ftp:")


def render(page: Path, folder: Path) -> tuple[np.ndarray, list[str]]:
    """The screenshot of ``page`` (RGB array) and the network URLs the page requested."""
    shot, log = folder / f"{page.stem}.png", folder / f"{page.stem}.json"
    subprocess.run(
        [CHROMIUM, *OFFLINE, f"--user-data-dir={folder / 'profile'}", f"--log-net-log={log}",
         f"--screenshot={shot}", page.resolve().as_uri()],
        capture_output=True, timeout=180, check=True,
    )  # fmt: skip
    events = json.loads(log.read_text())
    names = {value: key for key, value in events["constants"]["logEventTypes"].items()}
    requested = [
        event["params"]["url"]
        for event in events["events"]
        if names.get(event["type"]) == "URL_REQUEST_START_JOB"
        and "url" in event.get("params", {})
        and event["params"].get("initiator") != "not an origin"  # the browser's own
        and event["params"]["url"].startswith(NETWORK_SCHEMES)
    ]
    return np.asarray(Image.open(shot).convert("RGB")), requested


def coloured_pixels(image: np.ndarray) -> int:
    """Pixels of a saturated colour (the links are blue and orange; the background is a
    grey gradient and the controls black and white)."""
    rgb = image.astype(float) / 255.0
    saturation = np.ptp(rgb, axis=2) / np.maximum(rgb.max(axis=2), 1e-9)
    return int(np.count_nonzero(saturation > 0.5))


@pytest.mark.slow
def test_the_animation_draws_the_arm_and_requests_nothing(tmp_path, capsys):
    page = tmp_path / "arm.html"
    assert main(["animate", "--controller", "lin_lc", "--duration", "0.5", "--out", str(page),
                 "--no-progress"]) == 0  # fmt: skip
    image, requested = render(page, tmp_path)
    assert requested == []
    # Two links a few hundred pixels long and 20 wide: thousands of coloured pixels.
    assert coloured_pixels(image) > 2000


def test_the_checks_see_a_request_and_a_blank_page(tmp_path):
    # The controls for the two checks above: a page that asks for an image from the
    # network is caught (the request goes nowhere: no host resolves), and a page that
    # draws nothing has no coloured pixels.
    page = tmp_path / "asks.html"
    page.write_text('<html><body><img src="http://example.invalid/x.png"></body></html>')
    image, requested = render(page, tmp_path)
    assert requested == ["http://example.invalid/x.png"]
    assert coloured_pixels(image) < 50
