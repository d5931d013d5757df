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
from helpers.paths import REPO

PYPROJECT = REPO / "pyproject.toml"

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


#: ``python -c``: every import inside a function (``argv[1]``: the laid-out ``posfb``) whose
#: target imports its importer back at run time (imports under ``TYPE_CHECKING`` left out:
#: they never run), one per line.
FUNCTION_CYCLES = """
import ast, sys
from pathlib import Path
import grimp

graph = grimp.build_graph("posfb", exclude_type_checking_imports=True, cache_dir=None)
root = Path(sys.argv[1])


def function_imports(module):
    parts = module.split(".")
    path = root.joinpath(*parts)
    path = path / "__init__.py" if path.is_dir() else path.with_suffix(".py")
    found = []
    def visit(node, inside):
        for child in ast.iter_child_nodes(node):
            if inside and isinstance(child, ast.ImportFrom):
                found.append((child.module or "", child.lineno))
            if inside and isinstance(child, ast.Import):
                found.extend((alias.name, child.lineno) for alias in child.names)
            visit(child, inside or isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef))
    visit(ast.parse(path.read_text()), False)
    return found


for module in sorted(graph.modules):
    for target, line in function_imports(module):
        if target not in graph.modules or not target.startswith("posfb"):
            continue
        back = graph.find_shortest_chain(importer=target, imported=module)
        if back:
            print(f"{module}:{line} imports {target}, which imports it back: {' -> '.join(back)}")
"""


def test_no_cycle_runs_through_a_function_level_import(tmp_path):
    """Issue 44: a lazy import (inside a function, for start-up time) never closes a cycle:
    what it imports does not import its importer back at run time."""
    root = installed_layout(tmp_path)
    result = subprocess.run(
        [sys.executable, "-c", FUNCTION_CYCLES, str(root)],
        cwd=root,
        env={**os.environ, "PYTHONPATH": str(root)},
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert result.returncode == 0, result.stderr
    assert not result.stdout, result.stdout

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
