"""Files shipped inside posfb (the arms' URDFs, the scenarios and studies), as
filesystem paths.

They are read through ``importlib.resources``, so that they resolve the same in a
checkout (an editable install) and in an installed wheel, where they are package data
(``pyproject.toml``, ``[tool.setuptools.package-data]``). A wheel is always installed
unpacked, so a shipped file is a real file: Drake's URDF parser needs one."""

from __future__ import annotations

from importlib.resources import files
from pathlib import Path


def package_path(package: str, *parts: str) -> Path:
    """The file or folder ``parts`` of the posfb package ``package`` (e.g.
    ``package_path("posfb.urdf", "two_link_arm.urdf")``)."""
    return Path(str(files(package).joinpath(*parts)))
