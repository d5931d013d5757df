"""Links to files inside the committed reports that the findings pages include.

The reports under ``docs/results``, ``docs/montecarlo`` and ``docs/realism`` are written
by posfb's commands for GitHub, with links relative to the report (``[SVG](fig4.svg)``).
MyST's ``{include}`` rewrites their images (``:relative-images:``) but reads a link to a
file that is not a page as a cross-reference relative to the *including* page, which
does not resolve. This transform, run while each page is read, turns every such link
whose target is an existing file next to the report it was written in into a download
link of that file, so that the report is included exactly as the command wrote it.
"""

from __future__ import annotations

from pathlib import Path

from sphinx import addnodes
from sphinx.application import Sphinx
from sphinx.transforms import SphinxTransform


class ReportFileLinks(SphinxTransform):
    """``[text](file)`` in an included report -> a download of ``file`` beside it."""

    default_priority = 400

    def apply(self, **kwargs) -> None:
        srcdir = Path(self.env.srcdir).resolve()
        for node in list(self.document.findall(addnodes.pending_xref)):
            if node.get("reftype") != "myst" or node.get("refdomain") == "doc":
                continue
            target = node.get("reftarget", "")
            source = node.source or ""
            if not target or "://" in target or "#" in target or not source:
                continue
            path = (Path(source).parent / target).resolve()
            if not path.is_file() or not path.is_relative_to(srcdir):
                continue
            link = addnodes.download_reference(
                refdoc=self.env.docname,
                reftarget="/" + path.relative_to(srcdir).as_posix(),
                refexplicit=True,
                refdomain=None,
                reftype="myst",
            )
            link += node.children
            node.replace_self(link)


def setup(app: Sphinx) -> dict:
    app.add_transform(ReportFileLinks)
    return {"version": "1", "parallel_read_safe": True, "parallel_write_safe": True}
