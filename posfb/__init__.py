"""posfb: robust joint-position-feedback control of robot manipulators on Drake.

The code lives in three layers, imported one way only::

    posfb.models    physics, control laws, design (Eq. 5-26)   <- no posfb imports above it
    posfb.diagrams  Drake wiring and the closed-loop runner     <- imports posfb.models
    posfb.analysis  metrics, studies, reports, the CLI          <- imports both

The folders ``models/``, ``diagrams/`` and ``analysis/`` of the repository are
installed as these subpackages (``pyproject.toml``, ``[tool.setuptools]``). Docstrings
that cite "reading note N" refer to ``docs/reading-notes.md``.
"""

__version__ = "0.1.0"
