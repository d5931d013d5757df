"""Where a command writes: checked before any work is done, so that a mistyped or
unwritable ``--out`` costs one line, not a finished simulation; and written so that a
failure half-way (a full disk, Ctrl-C, a bug) never leaves a partial file or folder.

``output_file`` accepts a file path whose folder exists or can be created, and refuses an
existing file, or the command's own input, unless ``force``; ``output_folder`` a folder
that exists or can be created (an existing folder is written into: a folder holds
several files, and rerunning a command into it is the normal use). Either refuses, in
one ``UsageError`` line naming the option and the path: a parent that is a file, a
folder that is not writable, a file where a folder is wanted and the reverse.

``atomic_file`` and ``staged_folder`` do the writing: a file is written to a temporary
file in its own folder and renamed over the target only once complete; a folder's files
are written into a temporary sibling folder and each moved into the target (by rename)
only once all of them are complete. On any failure the temporary is removed and the
target is as it was."""

from __future__ import annotations

import errno
import os
import secrets
import shutil
import stat
import tempfile
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from posfb.analysis.common.errors import UsageError

#: Suffixes of a run's time series that ``analysis.common.export`` writes and reads.
EXPORT_FORMATS = (".csv", ".parquet", ".npz")


def _first_existing(path: Path) -> Path:
    """``path`` or its nearest ancestor that exists."""
    for candidate in (path, *path.parents):
        if candidate.exists():
            return candidate
    return Path.cwd()


def _require_creatable_folder(option: str, value: str, folder: Path) -> None:
    """Refuse ``folder`` (where ``option value`` writes) unless it exists or can be made."""
    existing = _first_existing(folder)
    if not existing.is_dir():
        raise UsageError(f"{option} {value}: {existing} is a file, not a folder")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise UsageError(f"{option} {value}: folder {existing} is not writable")


def _same_file(path: Path, other: Path) -> bool:
    """Whether ``path`` and ``other`` name one file (a link, a relative path)."""
    try:
        return os.path.samefile(path, other)
    except OSError:  # one of them does not exist
        return path.resolve() == other.resolve()


def output_file(
    option: str,
    value: str,
    suffixes: Iterable[str] | None = None,
    force: bool = False,
    inputs: Iterable[str | os.PathLike[str]] = (),
) -> Path:
    """``value`` as a file to write (one of ``suffixes`` where given). Unless ``force``,
    a file that exists, or that is one of ``inputs`` (the command's own input files),
    is refused: ``--force`` replaces it."""
    if not str(value).strip():
        raise UsageError(f"{option} {value!r}; a file name is required")
    path = Path(value)
    if suffixes is not None:
        allowed = tuple(suffixes)
        if path.suffix.lower() not in allowed:
            raise UsageError(f"{option} {value!r}; a file ending in one of {', '.join(allowed)}")
    if path.is_dir():
        raise UsageError(f"{option} {value}: is a folder; a file name is required")
    if not force:
        for source in inputs:
            if _same_file(path, Path(source)):
                raise UsageError(
                    f"{option} {value} is this command's own input; another file name is "
                    "required (or --force to overwrite the input)"
                )
        if path.exists():
            raise UsageError(
                f"{option} {value} exists; another file name is required (or --force to "
                "overwrite it)"
            )
    if path.exists() and not os.access(path, os.W_OK):
        raise UsageError(f"{option} {value}: the file is not writable")
    _require_creatable_folder(option, value, path.parent)
    return path


def output_folder(option: str, value: str) -> Path:
    """``value`` as a folder to write into (created if missing; an existing one keeps the
    files the command does not write)."""
    if not str(value).strip():
        raise UsageError(f"{option} {value!r}; a folder name is required")
    path = Path(value)
    if path.exists() and not path.is_dir():
        raise UsageError(f"{option} {value}: is a file; a folder is required")
    _require_creatable_folder(option, value, path)
    return path


@contextmanager
def atomic_file(path: str | os.PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path`` (same folder, same suffix, so that writers
    that go by the suffix write the right format); once the block has written it, it
    replaces ``path`` in one rename, keeping an existing file's permissions. On any
    failure, ``KeyboardInterrupt`` included, the temporary is removed and ``path`` is
    left as it was; an ``OSError`` of the temporary names ``path`` instead."""
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    temporary = target.with_name(f".{target.stem}.{secrets.token_hex(4)}.tmp{target.suffix}")
    try:
        yield temporary
        with open(temporary, "rb") as written:  # on the disk before the rename
            os.fsync(written.fileno())
        if target.exists():
            os.chmod(temporary, stat.S_IMODE(target.stat().st_mode))
        os.replace(temporary, target)
    except OSError as error:
        temporary.unlink(missing_ok=True)
        if error.errno is not None and (
            error.filename is None or os.fspath(error.filename) == str(temporary)
        ):
            raise OSError(error.errno, error.strerror, str(target)) from error
        raise
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise


@dataclass(frozen=True)
class StagedFolder:
    """The temporary folder a command writes into (``path``) and the folder its files
    move to (``target``)."""

    path: Path
    target: Path

    def final(self, paths: Iterable[Path]) -> list[Path]:
        """Where ``paths``, written under ``path``, are once moved into ``target``."""
        return [self.target / Path(p).relative_to(self.path) for p in paths]


@contextmanager
def staged_folder(path: str | os.PathLike[str]) -> Iterator[StagedFolder]:
    """Yield a ``StagedFolder`` whose ``path`` is a new temporary folder beside ``path``
    (on the same file system, so that a move is a rename). Once the block is done, every
    file under it is moved into ``path`` (created if missing) by ``os.replace``, in the
    same relative place: a file of the same name is replaced, the folder's other files are
    kept; a folder where a file goes (or the reverse) is refused (``OSError`` naming it)
    before anything moves. On any failure, ``KeyboardInterrupt`` included, the temporary
    folder is removed and nothing of the run reaches ``path``; an ``OSError`` of a write
    into the temporary folder names ``path`` instead."""
    target = Path(path)
    anchor = _first_existing(target.parent)  # no folder is created before the work is done
    try:
        staging = Path(tempfile.mkdtemp(prefix=f".{target.name}.", suffix=".staging", dir=anchor))
    except OSError as error:
        raise OSError(error.errno, error.strerror, str(target)) from error
    try:
        try:
            yield StagedFolder(staging, target)
        except OSError as error:  # a write into the staging folder: name the target
            if error.errno is None or (
                error.filename is not None and not str(error.filename).startswith(str(staging))
            ):
                raise
            raise OSError(error.errno, error.strerror, str(target)) from error
        sources = sorted(staging.rglob("*"))
        for source in sources:  # every move checked before the first: nothing half-moved
            destination = target / source.relative_to(staging)
            if destination.is_dir() != source.is_dir() and destination.exists():
                kind = "a folder" if destination.is_dir() else "a file"
                raise OSError(errno.EEXIST, f"{kind} is in the way of the output", str(destination))
        target.mkdir(parents=True, exist_ok=True)
        for source in sources:
            destination = target / source.relative_to(staging)
            if source.is_dir():
                destination.mkdir(exist_ok=True)
            else:
                os.replace(source, destination)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
