"""Sphinx configuration of posfb's API reference (``docs/api``), generated from the
public API's docstrings. ``bin/test`` builds it with warnings as errors, so a broken
docstring fails CI::

    .venv/bin/python -m sphinx -W -q -b html docs/api docs/api/_build
"""

import posfb

project = "posfb"
release = posfb.__version__
extensions = ["sphinx.ext.autodoc", "numpydoc"]
# The API's names are imported lazily; autodoc reads them through ``posfb.__getattr__``.
autodoc_default_options = {"members": False}
autodoc_typehints = "none"
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
html_theme = "alabaster"
exclude_patterns = ["_build"]
