"""The code version stored with results: the package version and, when posfb runs from
a git checkout of its own (an editable install), the commit and whether the working
tree differs from it. An installed wheel reports its version only, even when its
site-packages lies inside somebody's git repository."""

from __future__ import annotations

import subprocess
from importlib import metadata
from pathlib import Path

#: The checkout's root when posfb runs from one (``analysis/common/`` is two below
#: it); in an installed wheel, the folder ``posfb/`` in site-packages.
_ROOT = Path(__file__).resolve().parents[2]


def _git(*args: str) -> str | None:
    """Output of a read-only git command in the source tree (``None`` without git)."""
    try:
        done = subprocess.run(
            ["git", "--no-optional-locks", *args],
            cwd=_ROOT,
            capture_output=True,
            text=True,
            timeout=10,
        )
    except (OSError, subprocess.TimeoutExpired):
        return None
    return done.stdout.strip() if done.returncode == 0 else None


def code_version() -> str:
    """E.g. ``posfb 0.1.0 git 3b23e65a1c2d+dirty`` (``+dirty``: tracked changes or new
    files not ignored; ``posfb 0.1.0`` outside git)."""
    try:
        version = f"posfb {metadata.version('posfb')}"
    except metadata.PackageNotFoundError:
        version = "posfb (not installed)"
    top = _git("rev-parse", "--show-toplevel")
    if top is None or Path(top).resolve() != _ROOT:
        return version  # not posfb's own checkout
    commit = _git("rev-parse", "--short=12", "HEAD")
    if commit is None:
        return version
    dirty = _git("status", "--porcelain")
    return f"{version} git {commit}{'+dirty' if dirty else ''}"
