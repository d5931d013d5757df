"""The import rule: imports point down only, as the contracts of ``[tool.importlinter]`` in
``pyproject.toml`` state (``posfb.analysis > posfb.diagrams > posfb.models``; inside
``posfb.analysis``: ``cli > api > studies > uncertainty > common``). import-linter
(grimp) reads every import, those inside functions and under ``TYPE_CHECKING`` too.

posfb's subpackages are installed from the repository's top-level folders (``setup.py``),
not from folders below ``posfb/``, and grimp finds a package's modules by walking its
folder. So the test lays posfb out as an installed package, links to the folders the
running ``posfb`` was imported from, and runs the contracts there in a fresh interpreter.
"""

from __future__ import annotations

import ast
import importlib.util
import os
import subprocess
import sys
import tomllib
from pathlib import Path

import posfb.analysis
import posfb.diagrams
import posfb.models

PYPROJECT = Path(__file__).resolve().parent.parent / "pyproject.toml"

#: ``python -c``: every contract of ``argv[1]`` (no cache); the exit code is 0 if all hold.
LINT = """
import sys
from importlinter.cli import lint_imports
sys.exit(lint_imports(config_filename=sys.argv[1], no_cache=True))
"""


def installed_layout(root: Path) -> Path:
    """``root/posfb`` as an installed posfb: links to ``posfb``'s own files and to the
    folders of its subpackages (the checkout's, in an editable install)."""
    package = root / "posfb"
    package.mkdir()
    for path in Path(posfb.__file__).parent.iterdir():
        if path.suffix == ".py":
            (package / path.name).symlink_to(path)
    for sub in (posfb.analysis, posfb.diagrams, posfb.models):
        (package / sub.__name__.rpartition(".")[2]).symlink_to(Path(sub.__file__).parent)
    return root


def test_imports_point_down_only(tmp_path):
    assert importlib.util.find_spec("importlinter"), "import-linter: pip install -e '.[dev]'"
    contracts = tomllib.loads(PYPROJECT.read_text())["tool"]["importlinter"]["contracts"]
    root = installed_layout(tmp_path)
    result = subprocess.run(
        [sys.executable, "-c", LINT, str(PYPROJECT)],
        cwd=root,  # import-linter puts its working folder first on sys.path
        env={**os.environ, "PYTHONPATH": str(root)},
        capture_output=True,
        text=True,
        timeout=300,
    )
    report = result.stdout + result.stderr
    assert result.returncode == 0, report
    assert f"{len(contracts)} kept, 0 broken" in report, report


#: Where a built-in controller's name may be written: the controllers themselves and the
#: paper's layer, which reproduces the paper's three by name.
NAMING_FOLDERS = ("models/controllers", "analysis/paper")


def _docstrings(tree: ast.AST) -> set[int]:
    """The ``id`` of every docstring's constant in ``tree``."""
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Module | ast.ClassDef | ast.FunctionDef | ast.AsyncFunctionDef):
            first = node.body[0] if node.body else None
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                found.add(id(first.value))
    return found


def test_no_package_file_spells_a_builtin_controllers_name():
    """Issue 44: outside ``NAMING_FOLDERS``, no code writes a built-in kind as a string
    (a comparison, a key, an argument, a row): what it needs of a controller it reads from
    the spec. Docstrings and help texts that show a command may name one (they are the
    user's examples, as ``examples/`` are); a name inside a longer string is not code."""
    from posfb.models.controllers import REGISTRY

    builtin = set(REGISTRY)
    assert {"pid", "lin_lc", "proposed", "pd_gravity", "adrc"} <= builtin  # the test's reach
    spelled = []
    for sub in (posfb.analysis, posfb.diagrams, posfb.models, posfb):
        folder = Path(sub.__file__).parent
        files = folder.rglob("*.py") if sub is not posfb else folder.glob("*.py")
        for path in files:
            where = f"{folder.name}/{path.relative_to(folder).as_posix()}"
            if where.startswith(NAMING_FOLDERS):
                continue
            tree = ast.parse(path.read_text(), str(path))
            docstrings = _docstrings(tree)
            spelled += [
                f"{where}:{node.lineno}: {node.value!r}"
                for node in ast.walk(tree)
                if isinstance(node, ast.Constant) and node.value in builtin
                and id(node) not in docstrings
            ]  # fmt: skip
    assert not spelled, "\n".join(spelled)
