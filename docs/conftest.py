"""The guide's Python code blocks run in the test suite (Sybil).

Every ```` ```python ```` block of a page under ``docs/`` runs, in order, in one
namespace per page; a block preceded by ``% skip: next`` does not. Shell blocks
(``bash``, ``console``) are not run: the command line is covered by the generated CLI
reference and the suite's own tests. The committed reports that the findings pages
include are outputs, not pages, and are not collected. Each page runs in a scratch folder
of its own (a block may write ``run.parquet``) with a private posfb cache.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from sybil import Sybil
from sybil.parsers.myst import PythonCodeBlockParser, SkipParser

from posfb.models.disk_cache import CACHE_ENV

#: The committed artefacts (reports written by posfb's commands) and generated folders:
#: not collected at all.
collect_ignore_glob = ["_build", "_gallery_src", "gallery", "results", "montecarlo", "realism",
                       "stability_map", "nonidealities", "examples", "animate", "_ext"]  # fmt: skip

#: The same, for Sybil's own file filter (a path relative to ``docs/``).
ARTEFACTS = ("_build/*", "gallery/*", "results/*.md", "montecarlo/*/*.md", "realism/*.md",
             "realism/*/*.md")  # fmt: skip


def _enter(namespace: dict) -> None:
    """A scratch folder and cache of the page's own, as the working folder."""
    scratch = tempfile.TemporaryDirectory(prefix="posfb-docs-")
    namespace["_scratch"] = scratch, Path.cwd(), os.environ.get(CACHE_ENV)
    os.environ[CACHE_ENV] = str(Path(scratch.name) / "cache")
    os.chdir(scratch.name)


def _leave(namespace: dict) -> None:
    scratch, previous, cache = namespace.pop("_scratch")
    os.chdir(previous)
    if cache is None:
        os.environ.pop(CACHE_ENV, None)
    else:
        os.environ[CACHE_ENV] = cache
    scratch.cleanup()


pytest_collect_file = Sybil(
    parsers=[PythonCodeBlockParser(), SkipParser()],
    patterns=["*.md"],
    excludes=list(ARTEFACTS),
    setup=_enter,
    teardown=_leave,
).pytest()
