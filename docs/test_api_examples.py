"""The ``Examples`` sections of the public API's docstrings run as doctests.

One test per name of ``posfb.__all__``, collected from the names alone (nothing is
imported until a test runs). Each test finds the doctests of that object (a function's
docstring; a class's and its members') wherever the object is defined today, so a
module that moves takes its examples along and a new public name is tested by itself.
"""

from __future__ import annotations

import doctest
import inspect

import pytest

import posfb

#: Public names that are not documented objects (a version string).
PLAIN = {"__version__"}


@pytest.mark.parametrize("name", sorted(set(posfb.__all__) - PLAIN))
def test_the_examples_of_a_public_name_run(name: str) -> None:
    obj = getattr(posfb, name)
    finder = doctest.DocTestFinder(recurse=inspect.isclass(obj), exclude_empty=True)
    tests = finder.find(obj, f"posfb.{name}", module=inspect.getmodule(obj), globs={})
    runner = doctest.DocTestRunner(optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    for test in tests:
        runner.run(test)
    results = runner.summarize(verbose=False)
    assert results.failed == 0, f"{results.failed} of {results.attempted} examples of {name} failed"


def test_the_public_api_has_examples() -> None:
    """The API's docstrings do carry examples (the finder above finds some)."""
    doc = posfb.shipped_scenarios.__doc__
    assert ">>>" in doc and "Examples" in doc
