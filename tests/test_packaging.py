"""What the wheel carries and how an installed posfb names itself (the wheel itself is
built, installed and run outside the checkout by ``bin/test_wheel``)."""

from __future__ import annotations

import fnmatch
import subprocess
import sys
import tomllib
from importlib import metadata
from pathlib import Path

import pytest

import posfb
from helpers.paths import REPO
from posfb.analysis.common import provenance, shipped

ROOT = REPO

#: The repository folders installed as posfb's packages (setup.py's LAYERS).
PACKAGE_FOLDERS = ("posfb", "models", "diagrams", "analysis", "urdf")


def _package_data_patterns() -> dict[str, list[str]]:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    return config["tool"]["setuptools"]["package-data"]


def _package_of(path: Path) -> str:
    """The installed package of a repository file (``analysis/studies/x.yaml`` ->
    ``posfb.analysis.studies``)."""
    folder = path.parent.parts
    return ".".join(["posfb", *folder] if folder[0] != "posfb" else folder)


def test_every_tracked_data_file_under_a_package_folder_is_package_data():
    """A file a command may read (a URDF, a scenario, a study) ships in the wheel: each
    tracked non-Python file under the package folders matches a package-data pattern of
    its package or of every package ("*")."""
    listed = subprocess.run(
        ["git", "ls-files", *PACKAGE_FOLDERS], cwd=ROOT, capture_output=True, text=True
    )
    if listed.returncode != 0:
        pytest.skip("not a git checkout")
    patterns = _package_data_patterns()
    data = [Path(name) for name in listed.stdout.split() if not name.endswith(".py")]
    assert data, "no data files found: the folders moved?"
    unshipped = [
        str(path)
        for path in data
        if not any(
            fnmatch.fnmatch(path.name, pattern)
            for pattern in [*patterns.get("*", []), *patterns.get(_package_of(path), [])]
        )
    ]
    assert not unshipped, f"not package data (pyproject.toml): {unshipped}"


def test_the_version_is_written_once_and_reported_by_the_command_line():
    done = subprocess.run(
        [sys.executable, "-m", "posfb.analysis.cli", "--version"], capture_output=True, text=True
    )
    assert done.returncode == 0
    assert done.stdout.strip() == f"posfb {posfb.__version__}"
    assert metadata.version("posfb") == posfb.__version__


def test_a_shipped_file_is_named_by_its_stem_and_a_file_is_kept_as_given(tmp_path):
    for kind in shipped.SHIPPED_DIRS:
        files = shipped.shipped_files(kind)
        assert files, kind
        for name, path in files.items():
            assert Path(shipped.shipped_or_path(kind, name)) == path and path.is_file()
    own = tmp_path / "paper_nominal.yaml"
    assert shipped.shipped_or_path("scenario", str(own)) == str(own)
    with pytest.raises(ValueError, match="one of: paper_sobol, paper_uncertainty"):
        shipped.shipped_or_path("study", "paper_uncertanty")


def test_code_version_names_a_commit_only_for_posfbs_own_checkout(tmp_path, monkeypatch):
    """Installed in a venv inside somebody else's git repository, posfb must not report
    that repository's commit as its own."""
    other = tmp_path / "their_project"
    (other / "venv" / "posfb").mkdir(parents=True)
    subprocess.run(["git", "init", "-q", str(other)], check=True)
    monkeypatch.setattr(provenance, "_ROOT", other / "venv" / "posfb")
    assert provenance.code_version() == f"posfb {posfb.__version__}"
