"""The ``layers`` directive: the package's shape as one diagram, generated from the
import-linter contracts in ``pyproject.toml`` (which ``tests/test_architecture.py``
checks against the code), so the picture cannot drift from what the code does.

Each ``layers`` contract is drawn as a column, its top layer first, an arrow from each
layer to the one it may import; ``|`` separates layers that import none of each other,
``:`` modules that import each other in one layer.
"""

from __future__ import annotations

import textwrap
import tomllib
from pathlib import Path

from docutils import nodes
from docutils.parsers.rst import Directive

#: The repository's ``pyproject.toml``.
PYPROJECT = Path(__file__).resolve().parents[2] / "pyproject.toml"

#: Width of a package's column.
COLUMN = 30


def _column(contract: dict) -> list[str]:
    """One contract's layers, top first, an arrow between each and the next."""
    lines = [contract["containers"][0], "=" * len(contract["containers"][0])]
    for index, layer in enumerate(contract["layers"]):
        if index:
            lines.append("   v")
        lines += textwrap.wrap(layer, COLUMN - 2, subsequent_indent="  ")
    return lines


def layer_diagram(pyproject: Path = PYPROJECT) -> str:
    """The text diagram of the ``layers`` contracts of ``pyproject``: the packages' order
    on the first line, then one column per package, in that order."""
    contracts = tomllib.loads(pyproject.read_text())["tool"]["importlinter"]["contracts"]
    layered = [c for c in contracts if c.get("type") == "layers"]
    packages = next(c["layers"] for c in layered if "containers" not in c)
    columns = {c["containers"][0]: _column(c) for c in layered if "containers" in c}
    shown = [columns[name] for name in packages if name in columns]
    rows = max(len(column) for column in shown)
    header = "  -->  ".join(packages) + "   (each imports only the ones to its right)"
    body = [
        "".join(column[row].ljust(COLUMN) if row < len(column) else " " * COLUMN
                for column in shown).rstrip()
        for row in range(rows)
    ]  # fmt: skip
    return "\n".join([header, "", *body])


class LayersDirective(Directive):
    """``.. layers::``: ``layer_diagram()`` as a literal block."""

    has_content = False

    def run(self) -> list[nodes.Node]:
        text = layer_diagram()
        return [nodes.literal_block(text, text)]


def setup(app: object) -> dict[str, object]:
    app.add_directive("layers", LayersDirective)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
