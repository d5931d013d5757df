"""Progress on stderr: a bar for one long closed-loop run (simulated seconds done, their
rate and the time left; tqdm), and a status line rewritten in place for work with no
total (``status_line``: tune's steps and generations). Shown only when stderr is a
terminal and the user did not ask for ``--no-progress``."""

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


@contextmanager
def status_line(label: str, show: bool) -> Iterator[Callable[[str], None]]:
    """A callback ``(text) -> None`` that rewrites one line on stderr, ``label: text``
    (for steps with no total, such as a search's generations); the line is ended when the
    block is left. Nothing is written when ``show`` is false."""
    written = [False]

    def update(text: str) -> None:
        if show:
            sys.stderr.write(f"\r{label}: {text}\x1b[K")
            sys.stderr.flush()
            written[0] = True

    try:
        yield update
    finally:
        if written[0]:
            sys.stderr.write("\n")
            sys.stderr.flush()
