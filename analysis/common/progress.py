"""A progress bar for one long closed-loop run: simulated seconds done, their rate
and the time left (tqdm on stderr). Shown only when stderr is a terminal and the
user did not ask for ``--no-progress``."""

from __future__ import annotations

import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager

from tqdm import tqdm


def wanted(no_progress: bool) -> bool:
    """Whether to show progress: not switched off, and someone is watching stderr."""
    return not no_progress and sys.stderr.isatty()


@contextmanager
def run_progress(duration: float, label: str, show: bool) -> Iterator[Callable[[float], None]]:
    """A callback ``(simulated time) -> None`` that moves a bar to ``duration`` seconds."""
    bar = tqdm(
        total=duration, desc=label, unit="sim s", file=sys.stderr, disable=not show,
        bar_format="{desc}: {percentage:3.0f}%|{bar}| {n:.1f}/{total:g} sim s "
        "[{elapsed}<{remaining}, {rate_fmt}]",
    )  # fmt: skip

    def update(time: float) -> None:
        bar.update(min(time, duration) - bar.n)

    try:
        yield update
    finally:
        bar.close()
