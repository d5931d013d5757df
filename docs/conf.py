"""Sphinx configuration of posfb's user guide and reference manual (``docs/``).

Markdown pages (MyST) for the guide, reST for the generated reference; ``bin/test``
builds it with warnings as errors::

    .venv/bin/python -m sphinx -W -q -b html docs docs/_build

Generated, so that they cannot drift from the code:

* the scenario reference (``docs/_ext/scenario_reference.py``, from the settings
  dataclasses and the registries);
* the command-line reference (sphinx-argparse over ``posfb.analysis.cli.full_parser``);
* the Python API reference (autodoc + numpydoc over ``posfb``'s public names);
* the examples gallery (sphinx-gallery runs ``examples/*.py`` with short options,
  ``docs/_ext/gallery_hooks.py``);
* the findings pages, which include the committed reports under ``docs/results``,
  ``docs/montecarlo``, ``docs/realism``, ``docs/model_error`` (MyST ``{include}``).
"""

from __future__ import annotations

import shutil
import sys
from pathlib import Path

import posfb

DOCS = Path(__file__).resolve().parent
ROOT = DOCS.parent
sys.path.insert(0, str(DOCS / "_ext"))

project = "posfb"
release = version = posfb.__version__
author = "posfb"
copyright = "posfb contributors"

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "numpydoc",
    "sphinxarg.ext",
    "sphinx_gallery.gen_gallery",
    "scenario_reference",
    "report_links",
    "layer_diagram",
]
source_suffix = {".rst": "restructuredtext", ".md": "markdown"}
root_doc = "index"

# The committed artefacts (reports, figures, stores, JSON) are outputs, not pages: the
# findings pages include them. The gallery's staging folder and the build are neither.
exclude_patterns = [
    "_build",
    "_ext",
    "_gallery_src",
    "api/_build",
    "animate",
    "examples",
    "montecarlo",
    "nonidealities",
    "realism",
    "model_error",
    "results",
    "stability_map",
    "sg_execution_times.rst",
    "gallery/sg_execution_times.rst",
]

# --- MyST ------------------------------------------------------------------------------
myst_enable_extensions = ["colon_fence", "dollarmath"]
myst_heading_anchors = 3

# --- the API reference -----------------------------------------------------------------
# The API's names are imported lazily; autodoc reads them through ``posfb.__getattr__``.
autodoc_default_options = {"members": False}
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False

# --- the examples gallery --------------------------------------------------------------
# sphinx-gallery needs a header file beside the scripts; examples/ holds only the
# scripts, so they are staged (copied unchanged: an unchanged script is not run again)
# into _gallery_src with the header below.
GALLERY_HEADER = """\
Examples gallery
================

Each script in ``examples/`` is a program against posfb's public API (``import posfb``),
run by the test suite (``tests/test_examples.py``) and here, at build time, with short
options (a 1 s run where the script's default is 5 s; ``robust_tuning`` with 20 design
plants). Run one yourself with its defaults, e.g.
``.venv/bin/python examples/sample_time_sweep.py --out sweep.png``.
"""


def _stage_examples() -> None:
    source, staged = ROOT / "examples", DOCS / "_gallery_src"
    staged.mkdir(exist_ok=True)
    scripts = {path.name for path in source.glob("*.py")}
    for path in staged.iterdir():
        if path.suffix == ".py" and path.name not in scripts:
            path.unlink()
    for name in scripts:
        target = staged / name
        text = (source / name).read_bytes()
        if not target.exists() or target.read_bytes() != text:
            shutil.copyfile(source / name, target)
    header = staged / "GALLERY_HEADER.rst"
    if not header.exists() or header.read_text() != GALLERY_HEADER:
        header.write_text(GALLERY_HEADER)


_stage_examples()

sphinx_gallery_conf = {
    "examples_dirs": "_gallery_src",
    "gallery_dirs": "gallery",
    "filename_pattern": r"\.py$",  # run every script
    "reset_argv": "gallery_hooks.reset_argv",
    "image_scrapers": ("gallery_hooks.saved_figures",),
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "write_computation_times": False,
    "show_memory": False,
    "remove_config_comments": True,
    "abort_on_example_error": True,
    "capture_repr": (),
}

# --- HTML ------------------------------------------------------------------------------
html_theme = "furo"
html_title = f"posfb {release}"
html_static_path: list[str] = []
