"""Where a command writes: checked before any work is done, so that a mistyped or
unwritable ``--out`` costs one line, not a finished simulation.

``output_file`` accepts a file path whose folder exists or can be created;
``output_folder`` a folder that exists or can be created. Either refuses, in one
``UsageError`` line naming the option and the path: a parent that is a file, a
folder that is not writable, a file where a folder is wanted and the reverse."""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

from posfb.analysis.errors import UsageError

#: Suffixes of a run's time series that ``analysis.export`` writes and reads.
EXPORT_FORMATS = (".csv", ".parquet", ".npz")


def _first_existing(path: Path) -> Path:
    """``path`` or its nearest ancestor that exists."""
    for candidate in (path, *path.parents):
        if candidate.exists():
            return candidate
    return Path.cwd()


def _require_creatable_folder(option: str, folder: Path) -> None:
    existing = _first_existing(folder)
    if not existing.is_dir():
        raise UsageError(f"{option} {folder}: {existing} is a file, not a folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise UsageError(f"{option} {folder}: {existing} is not writable")


def output_file(option: str, value: str, suffixes: Iterable[str] | None = None) -> Path:
    """``value`` as a file to write (one of ``suffixes`` where given)."""
    path = Path(value)
    if suffixes is not None:
        allowed = tuple(suffixes)
        if path.suffix.lower() not in allowed:
            raise UsageError(f"{option} {value!r}; a file ending in one of {', '.join(allowed)}")
    if path.is_dir():
        raise UsageError(f"{option} {value}: is a folder; a file name is required")
    if path.exists() and not os.access(path, os.W_OK):
        raise UsageError(f"{option} {value}: the file is not writable")
    _require_creatable_folder(option, path.parent)
    return path


def output_folder(option: str, value: str) -> Path:
    """``value`` as a folder to write into (created if missing)."""
    path = Path(value)
    if path.exists() and not path.is_dir():
        raise UsageError(f"{option} {value}: is a file; a folder is required")
    _require_creatable_folder(option, path)
    return path
