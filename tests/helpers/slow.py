"""``heavy``: a fixture that takes seconds to build says so where it is defined, and
every test that uses it (directly or through another fixture) is marked ``slow``
(``tests/conftest.py``), so that ``pytest -m "not slow"`` never builds it. Tests slow on
their own carry ``@pytest.mark.slow`` themselves."""

from __future__ import annotations

from collections.abc import Callable
from typing import TypeVar

F = TypeVar("F", bound=Callable)

#: The attribute ``heavy`` sets on a fixture's function.
HEAVY = "posfb_heavy_fixture"


def heavy(function: F) -> F:
    """Mark the fixture ``function`` heavy; apply it below ``@pytest.fixture``."""
    setattr(function, HEAVY, True)
    return function
