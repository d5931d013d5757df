"""An on-disk cache for per-arm numbers that take seconds to compute and never change
for an unchanged arm: the nominal norms of a URDF arm's workspace search
(``models.serial_bounds.model_norms``, the Assumption-1 defaults of the paper's
controller).

An entry is a JSON map of floats in ``<cache>/<kind>/<key>.json``, ``key`` the SHA-256
of the inputs that determine it (the URDF file's bytes and the search's settings) and
of ``CACHE_VERSION``. The folder is ``$POSFB_CACHE_DIR`` if set, else the user's cache
directory (``platformdirs``: ``~/.cache/posfb`` on Linux); ``POSFB_CACHE_DIR=off``
turns the cache off. The cache only saves time: an entry that cannot be read is
recomputed, one that cannot be written is skipped, and a run never fails because of it.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import tempfile
from collections.abc import Callable, Mapping
from pathlib import Path

#: Bump when a cached computation changes its result for the same inputs.
CACHE_VERSION = 1

#: The environment variable that moves (or, set to ``off``, disables) the cache.
CACHE_ENV = "POSFB_CACHE_DIR"


def cache_root() -> Path | None:
    """The cache folder, or ``None`` when ``POSFB_CACHE_DIR=off``."""
    configured = os.environ.get(CACHE_ENV)
    if configured is not None:
        return None if configured.strip().lower() in ("off", "") else Path(configured)
    import platformdirs  # on use: the CLI's start-up does not pay for it

    return Path(platformdirs.user_cache_dir("posfb", appauthor=False))


def file_digest(path: str | Path) -> str:
    """The SHA-256 of the bytes of the file at ``path``."""
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _entry(kind: str, key: Mapping[str, object]) -> Path | None:
    root = cache_root()
    if root is None:
        return None
    text = json.dumps({"version": CACHE_VERSION, **key}, sort_keys=True)
    return root / kind / f"{hashlib.sha256(text.encode()).hexdigest()}.json"


def _read(path: Path) -> dict[str, float] | None:
    try:
        stored = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(stored, dict) or not all(
        isinstance(v, float) and math.isfinite(v) for v in stored.values()
    ):
        return None
    return stored


def store_entry(path: Path, write: Callable[[Path], None]) -> None:
    """A cache entry at ``path`` written atomically: ``write`` fills a temporary file in
    the same folder, then a rename, so that a concurrent reader sees the old entry or the
    whole new one. A cache that cannot be written is skipped."""
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        handle, temporary = tempfile.mkstemp(dir=path.parent, suffix=".tmp")
        os.close(handle)
        try:
            write(Path(temporary))
            os.replace(temporary, path)
        except BaseException:
            Path(temporary).unlink(missing_ok=True)
            raise
    except OSError:
        return


def _write(path: Path, values: Mapping[str, float]) -> None:
    """``values`` as the JSON entry at ``path`` (``store_entry``)."""
    store_entry(path, lambda temporary: temporary.write_text(json.dumps(dict(values))))


def cached_floats(
    kind: str, key: Mapping[str, object], compute: Callable[[], Mapping[str, float]]
) -> dict[str, float]:
    """``compute()`` (a map of finite floats), read from the cache entry of ``kind`` and
    ``key`` (JSON-serialisable inputs that determine the result) when one exists,
    computed and stored otherwise."""
    path = _entry(kind, key)
    stored = None if path is None else _read(path)
    if stored is not None:
        return stored
    values = {name: float(value) for name, value in compute().items()}
    if path is not None:
        _write(path, values)
    return values
