"""Checks applied where a parameter enters: each error names the parameter,
the value it got and what is allowed."""

from __future__ import annotations

import math
import os
import stat
from collections.abc import Sequence
from pathlib import Path

import numpy as np


def shown(value: object) -> str:
    """``value`` as a message shows it: numpy scalars and arrays as plain Python numbers
    and lists (``1.0``, not ``np.float64(1.0)``), everything else by its ``repr``."""
    if isinstance(value, np.generic | np.ndarray):
        value = value.tolist()
    elif isinstance(value, list | tuple):
        value = type(value)(v.tolist() if isinstance(v, np.generic) else v for v in value)
    return repr(value)


def require_finite(name: str, value: float) -> float:
    """Return ``value`` as float, refusing NaN and infinities."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        message = f"{name} = {shown(value)} is not a number; a finite real is required"
        raise ValueError(message) from None
    if not math.isfinite(number):
        raise ValueError(f"{name} = {shown(value)} is not finite; a finite real is required")
    return number


def require_nonnegative(name: str, value: float) -> float:
    """Return ``value`` if it is finite and >= 0."""
    number = require_finite(name, value)
    if number < 0.0:
        raise ValueError(f"{name} = {shown(value)} is negative; a finite value >= 0 is required")
    return number


def require_positive(name: str, value: float) -> float:
    """Return ``value`` if it is finite and > 0."""
    number = require_finite(name, value)
    if number <= 0.0:
        raise ValueError(f"{name} = {shown(value)} is not positive; a finite value > 0 is required")
    return number


def per_joint(name: str, value: object, size: int, kind: str = "number") -> list:
    """``value`` as ``size`` entries: one ``kind`` for all joints (a scalar or a list of
    one) or one per joint; the entries themselves are checked by the caller."""
    values = list(value) if isinstance(value, list | tuple | np.ndarray) else [value]
    if len(values) == 1:
        values = values * size
    if len(values) != size:
        raise ValueError(
            f"{name} = {shown(value)}; one {kind} for all joints or {size} (one per joint) "
            "is required"
        )
    return values


def require_vector(name: str, value: Sequence[float] | np.ndarray, size: int) -> np.ndarray:
    """Return ``value`` as a finite float vector of length ``size``."""
    array = np.asarray(value, dtype=float)
    if array.shape != (size,):
        raise ValueError(f"{name} has shape {array.shape}; a vector of length {size} is required")
    if not np.all(np.isfinite(array)):
        raise ValueError(
            f"{name} = {array.tolist()} has non-finite entries; finite values required"
        )
    return array


def require_matrix(name: str, value: Sequence | np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Return ``value`` as a finite float matrix of the given shape."""
    array = np.asarray(value, dtype=float)
    if array.shape != shape:
        raise ValueError(f"{name} has shape {array.shape}; shape {shape} is required")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} has non-finite entries; finite values are required")
    return array


def require_regular_file(
    what: str, path: str | os.PathLike[str], missing: type[Exception] = ValueError
) -> Path:
    """``path`` if it names a regular file (a ``what`` such as "log"): a folder, a FIFO,
    a device or a socket is refused in one line before anything reads it (a FIFO would
    block the read), a missing file with ``missing``."""
    path = Path(path)
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        raise missing(f"{what} {path} does not exist") from None
    except OSError as error:
        raise ValueError(f"{what} {path} cannot be read: {error.strerror}") from None
    if stat.S_ISDIR(mode):
        raise ValueError(f"{what} {path} is a directory; a file is required")
    if not stat.S_ISREG(mode):
        raise ValueError(
            f"{what} {path} is not a regular file (a FIFO, a device or a socket); a file is "
            "required"
        )
    return path
