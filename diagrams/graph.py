"""Diagram graphs: the closed loop's wiring as data (for structural checks) and as
a picture (Graphviz ``dot``; without it the ``.dot`` text is written instead).

Install Graphviz with ``apt-get install graphviz`` (``bin/setup`` does this on a
fresh machine) or see https://graphviz.org/download/.
"""

from __future__ import annotations

import shutil
import subprocess
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from pydrake.systems.framework import Diagram

#: Rendering options: draw the MultibodyPlant (named ``arm``) as separate input and
#: output nodes so that the feedback loop reads left to right.
GRAPHVIZ_OPTIONS = {"arm/split": "I/O"}

#: How to install the renderer, for messages.
INSTALL_HINT = "install Graphviz (apt-get install graphviz, or https://graphviz.org/download/)"


@dataclass(frozen=True)
class Edge:
    """One connection: ``source.output -> target.input`` (system and port names)."""

    source: str
    output: str
    target: str
    input: str


def edges(diagram: Diagram) -> list[Edge]:
    """Every internal connection of ``diagram`` (its top level)."""
    result = []
    for (target, input_index), (source, output_index) in diagram.connection_map().items():
        result.append(
            Edge(
                source.get_name(),
                source.get_output_port(output_index).get_name(),
                target.get_name(),
                target.get_input_port(input_index).get_name(),
            )
        )
    return result


def reachable(graph: Iterable[Edge], start: str, blocked: frozenset[str] = frozenset()) -> set[str]:
    """Systems reachable from ``start`` along connections, not passing through ``blocked``."""
    successors: dict[str, set[str]] = {}
    for edge in graph:
        successors.setdefault(edge.source, set()).add(edge.target)
    seen, frontier = {start}, [start]
    while frontier:
        for following in successors.get(frontier.pop(), ()):
            if following not in seen and following not in blocked:
                seen.add(following)
                frontier.append(following)
    return seen


def graphviz_source(diagram: Diagram) -> str:
    """The Graphviz (``dot``) text of ``diagram`` with ``GRAPHVIZ_OPTIONS``, laid out top
    to bottom: Drake's left-to-right layout puts the loop's dozen systems side by side
    (3625 x 805 px for the paper's loop, unreadable at page width); top to bottom it is
    about 1040 px wide."""
    return diagram.GetGraphvizString(options=GRAPHVIZ_OPTIONS).replace(
        "rankdir=LR", "rankdir=TB", 1
    )


#: The file types ``render`` writes.
GRAPH_SUFFIXES = (".svg", ".png", ".pdf", ".dot")


def render(source: str, out: Path) -> tuple[Path, str]:
    """Render ``source`` to ``out`` (format from its suffix: ``.svg``, ``.png``, ``.pdf``).

    Without ``dot`` on the PATH, write ``out`` with suffix ``.dot`` instead. Returns the
    written path and a note ("" when rendered)."""
    out = Path(out)
    fmt = out.suffix.lstrip(".").lower()
    if out.suffix.lower() not in GRAPH_SUFFIXES:
        raise ValueError(f"out = {str(out)!r}; a .svg, .png, .pdf or .dot file name is required")
    out.parent.mkdir(parents=True, exist_ok=True)
    dot = shutil.which("dot")
    if fmt == "dot" or dot is None:
        written = out.with_suffix(".dot")
        written.write_text(source)
        note = "" if fmt == "dot" else f"Graphviz 'dot' not found: wrote {written}; {INSTALL_HINT}"
        return written, note
    completed = subprocess.run(
        [dot, f"-T{fmt}", "-o", str(out)], input=source, text=True, capture_output=True
    )
    if completed.returncode != 0:
        reason = (completed.stderr.strip().splitlines() or ["no message"])[0]
        raise RuntimeError(f"dot failed to render {out}: {reason}")
    return out, ""
