"""An on-disk cache for per-arm numbers that take seconds to compute and never change
for an unchanged arm: the nominal norms of a URDF arm's workspace search
(``models.serial_bounds.model_norms``, the Assumption-1 defaults of the paper's
controller).

An entry is ``<cache>/<kind>/<key>.entry``, ``key`` the SHA-256 of the inputs that
determine it (the URDF file's bytes and the search's settings; a C source, its flags and
the compiler) and of ``CACHE_VERSION``. The folder is ``$POSFB_CACHE_DIR`` if set, else
the user's cache directory (``platformdirs``: ``~/.cache/posfb`` on Linux);
``POSFB_CACHE_DIR=off`` turns the cache off. The cache only saves time: an entry that
cannot be read is recomputed, one that cannot be written is skipped, and a run never
fails because of it.

**No one else can plant an entry** (issue 43). The cache holds compiled objects that
software in the loop loads into the process, and numbers a design trusts:

* the cache folder, and each kind's folder in it, is created private (0700); a folder
  that is not the user's own, or that others may write to, is not used (one warning
  line names it and why, once per process), ``POSFB_CACHE_DIR``'s included;
* an entry is ``sha256:<hex of the payload>`` on its first line, then the payload; it is
  written whole (a temporary file and a rename) and read only if it is a regular file
  whose payload has that hash. A damaged entry (truncated, edited, replaced) is deleted
  and recomputed, never used.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import math
import os
import stat
import tempfile
from collections.abc import Callable, Mapping
from pathlib import Path

#: Bump when a cached computation changes its result for the same inputs (2: entries
#: carry their hash).
CACHE_VERSION = 2

#: The environment variable that moves (or, set to ``off``, disables) the cache.
CACHE_ENV = "POSFB_CACHE_DIR"

#: The start of an entry's first line; the payload's SHA-256 (hex) follows.
HASH_PREFIX = b"sha256:"

_LOG = logging.getLogger("posfb")
_REFUSED: set[str] = set()


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


def _refusal(folder: Path) -> str | None:
    """Why ``folder`` (which exists) must not hold cache entries, or ``None``."""
    info = folder.stat()
    if not stat.S_ISDIR(info.st_mode):
        return "is not a folder"
    if hasattr(os, "geteuid") and info.st_uid != os.geteuid():
        return f"belongs to another user (uid {info.st_uid})"
    if info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        return f"may be written by others (mode {stat.S_IMODE(info.st_mode):o})"
    return None


def _private(folder: Path) -> bool:
    """Whether ``folder`` is the user's own and written by no one else, created private
    (0700) if missing (module docstring); a refusal is logged once per folder."""
    try:
        folder.mkdir(mode=0o700, parents=True, exist_ok=True)
        why = _refusal(folder)
    except OSError:
        return False  # a cache that cannot be made is skipped, as one that cannot be written
    if why is not None and str(folder) not in _REFUSED:
        _REFUSED.add(str(folder))
        _LOG.warning(
            "note: the cache folder %s %s; posfb does not use it (chmod 700 it, or set %s "
            "to a folder of your own or to off)", folder, why, CACHE_ENV
        )
    return why is None


def entry_path(kind: str, key: str) -> Path | None:
    """The entry of ``kind`` and ``key`` (a hex digest), or ``None`` when the cache is off
    or its folders are not private (module docstring)."""
    root = cache_root()
    if root is None or not _private(root) or not _private(root / kind):
        return None
    return root / kind / f"{key}.entry"


def load_entry(path: Path) -> bytes | None:
    """The payload of the entry at ``path`` if it is a regular file whose payload has the
    hash on its first line; a damaged one is deleted (module docstring)."""
    try:
        if not stat.S_ISREG(path.lstat().st_mode):
            return None
        header, _, payload = path.read_bytes().partition(b"\n")
    except OSError:
        return None
    if header == HASH_PREFIX + hashlib.sha256(payload).hexdigest().encode():
        return payload
    with contextlib.suppress(OSError):  # recomputed and replaced either way
        path.unlink(missing_ok=True)
    return None


def save_entry(path: Path, payload: bytes) -> None:
    """``payload`` as the entry at ``path``, its hash first (``store_entry``)."""
    header = HASH_PREFIX + hashlib.sha256(payload).hexdigest().encode() + b"\n"
    store_entry(path, lambda temporary: temporary.write_bytes(header + payload))


def _read(path: Path) -> dict[str, float] | None:
    payload = load_entry(path)
    try:
        stored = None if payload is None else json.loads(payload)
    except ValueError:
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


def cached_floats(
    kind: str, key: Mapping[str, object], compute: Callable[[], Mapping[str, float]]
) -> dict[str, float]:
    """``compute()`` (a map of finite floats), read from the cache entry of ``kind`` and
    ``key`` (JSON-serialisable inputs that determine the result) when one exists,
    computed and stored otherwise."""
    text = json.dumps({"version": CACHE_VERSION, **key}, sort_keys=True)
    path = entry_path(kind, hashlib.sha256(text.encode()).hexdigest())
    stored = None if path is None else _read(path)
    if stored is not None:
        return stored
    values = {name: float(value) for name, value in compute().items()}
    if path is not None:
        save_entry(path, json.dumps(values).encode())
    return values
