"""The repository's root, for tests that read its files (shipped scenarios and studies,
URDFs, the guide, the examples, ``pyproject.toml``). Computed here once, so that a test's
own folder under ``tests/`` (which mirrors the package folder it checks) never enters a
path."""

from __future__ import annotations

from pathlib import Path

#: The repository's root: this file is ``tests/helpers/paths.py``.
REPO = Path(__file__).resolve().parents[2]
