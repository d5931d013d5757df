"""The scenarios and studies shipped with posfb, by name.

A command that takes a scenario or a study file also takes the name of a shipped one
(``posfb montecarlo run paper_uncertainty``), so that they can be run from an installed
wheel, whose files sit in site-packages. A name is a file's stem: no folder, no
suffix. Names and paths only (no Drake, no numpy): the parser converts an argument
with these before any model loads."""

from __future__ import annotations

import argparse
from pathlib import Path

from posfb.models.package_data import package_path

#: The folder of the shipped scenario files.
SCENARIO_DIR = package_path("posfb.analysis", "scenarios")

#: The folder of the shipped Monte-Carlo studies.
STUDY_DIR = package_path("posfb.analysis", "studies")

#: The folder of the shipped realism studies.
REALISM_DIR = STUDY_DIR / "realism"

#: What each kind of shipped file is called in a message -> its folder.
SHIPPED_DIRS = {"scenario": SCENARIO_DIR, "study": STUDY_DIR, "realism study": REALISM_DIR}


def shipped_files(kind: str) -> dict[str, Path]:
    """The shipped files of ``kind`` (a key of ``SHIPPED_DIRS``), by name."""
    return {path.stem: path for path in sorted(SHIPPED_DIRS[kind].glob("*.yaml"))}


def shipped_or_path(kind: str, text: str) -> str:
    """``text`` as a path: the shipped file of ``kind`` it names, or ``text`` as given.

    A bare name (no folder, no suffix) that is not a file here must name a shipped
    file; otherwise the ``ValueError`` lists the shipped names."""
    path = Path(text)
    if path.suffix or len(path.parts) != 1 or path.exists():
        return text
    shipped = shipped_files(kind)
    if text in shipped:
        return str(shipped[text])
    names = ", ".join(shipped)
    raise ValueError(
        f"{kind} {text!r} is neither a file nor a shipped {kind}; give a YAML file or "
        f"one of: {names}"
    )


def _argument(kind: str, text: str) -> str:
    """``shipped_or_path`` for argparse, whose error shows the message as it is."""
    try:
        return shipped_or_path(kind, text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def scenario_argument(text: str) -> str:
    """argparse ``type`` of a scenario argument (a file or a shipped scenario's name)."""
    return _argument("scenario", text)


def study_argument(text: str) -> str:
    """argparse ``type`` of a study argument (a file or a shipped study's name)."""
    return _argument("study", text)


def realism_argument(text: str) -> str:
    """argparse ``type`` of a realism study argument (a file or a shipped one's name)."""
    return _argument("realism study", text)
