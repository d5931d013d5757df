"""Scenario warnings (``posfb.ScenarioWarning``, issued by the API) printed the command
line's way: one line each on stderr, ``posfb COMMAND: warning: ...``, as they arrive."""

from __future__ import annotations

import sys
import warnings
from collections.abc import Iterator
from contextlib import contextmanager


@contextmanager
def printed_warnings(command: str) -> Iterator[None]:
    """Inside the block, every ``ScenarioWarning`` is printed once for ``command``
    instead of going through Python's warning machinery."""
    from posfb.analysis.api import ScenarioWarning

    def show(message, category, filename, lineno, file=None, line=None) -> None:  # noqa: ANN001
        if issubclass(category, ScenarioWarning):
            sys.stderr.write(f"posfb {command}: warning: {message}\n")
        else:
            previous(message, category, filename, lineno, file, line)

    with warnings.catch_warnings():
        warnings.simplefilter("always", ScenarioWarning)
        previous = warnings.showwarning
        warnings.showwarning = show
        yield
