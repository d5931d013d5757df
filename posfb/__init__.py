"""posfb: robust joint-position-feedback control of robot manipulators on Drake.

The public API (``__all__``; its reference is generated into the user guide,
``docs/reference/api.rst``, and ``docs/guide/python.md`` is the tour)::

    scenario = posfb.load_scenario("my_arm.yaml", set={"timing.duration": 5})
    run = posfb.simulate(scenario, controller="lin_lc")     # what `posfb simulate` runs
    run.rms_q, run.status, run.frame(), run.plot(), run.save("run.parquet")
    loop = posfb.build(scenario, extend=add_disturbance)    # the Drake Diagram, to wire more
    posfb.compare(scenario, ["pid", "lin_lc", "proposed"]).save("out/")
    posfb.design(scenario, "lin_lc").margins()              # gain, phase, delay, disk margins
    class MyController(posfb.Controller): ...              # your own, position only

The code lives in three layers, imported one way only::

    posfb.models    physics, control laws, design (Eq. 5-26)   <- no posfb imports above it
    posfb.diagrams  Drake wiring and the closed-loop runner     <- imports posfb.models
    posfb.analysis  metrics, studies, reports, the CLI, the API <- imports both

The folders ``models/``, ``diagrams/`` and ``analysis/`` of the repository are
installed as these subpackages (``pyproject.toml``, ``[tool.setuptools]``). Docstrings
that cite "reading note N" refer to ``docs/reading-notes.md``.

``import posfb`` loads nothing heavy: each public name is imported on first use
(PEP 562), so the command line and scripts start fast.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING

__version__ = "0.1.0"

#: Public name -> the module that defines it.
_EXPORTS = {
    "load_scenario": "posfb.analysis.api",
    "simulate": "posfb.analysis.api",
    "build": "posfb.analysis.api",
    "compare": "posfb.analysis.api",
    "design": "posfb.analysis.api",
    "tune": "posfb.analysis.api",
    "identify": "posfb.analysis.api",
    "plan_excitation": "posfb.analysis.api",
    "Identification": "posfb.analysis.identification.identify",
    "PlannedExcitation": "posfb.analysis.identification.plan",
    "TuneSettings": "posfb.analysis.design.settings",
    "TuneResult": "posfb.analysis.design.tune",
    "TuneError": "posfb.analysis.design.search",
    "shipped_scenarios": "posfb.analysis.api",
    "Run": "posfb.analysis.api",
    "BuiltLoop": "posfb.analysis.api",
    "Comparison": "posfb.analysis.api",
    "ScenarioWarning": "posfb.analysis.api",
    "LinearDesign": "posfb.analysis.design.linear_loop",
    "LoadedScenario": "posfb.diagrams.resolve",
    "Controller": "posfb.models.controllers.plugin",
    "ControllerSetup": "posfb.models.controllers.plugin",
    "NominalDynamics": "posfb.models.controllers.plugin",
    "PluginError": "posfb.models.controllers.plugin",
    "Law": "posfb.models.laws.law",
    "law": "posfb.models.laws.law",
}

__all__ = [
    "BuiltLoop",
    "Comparison",
    "Controller",
    "ControllerSetup",
    "Identification",
    "Law",
    "LinearDesign",
    "LoadedScenario",
    "NominalDynamics",
    "PlannedExcitation",
    "PluginError",
    "Run",
    "ScenarioWarning",
    "TuneError",
    "TuneResult",
    "TuneSettings",
    "__version__",
    "build",
    "compare",
    "design",
    "identify",
    "law",
    "load_scenario",
    "plan_excitation",
    "shipped_scenarios",
    "simulate",
    "tune",
]

if TYPE_CHECKING:
    from posfb.analysis.api import (
        BuiltLoop,
        Comparison,
        Run,
        ScenarioWarning,
        build,
        compare,
        design,
        identify,
        load_scenario,
        plan_excitation,
        shipped_scenarios,
        simulate,
        tune,
    )
    from posfb.analysis.design.linear_loop import LinearDesign
    from posfb.analysis.design.search import TuneError
    from posfb.analysis.design.settings import TuneSettings
    from posfb.analysis.design.tune import TuneResult
    from posfb.analysis.identification.identify import Identification
    from posfb.analysis.identification.plan import PlannedExcitation
    from posfb.diagrams.resolve import LoadedScenario
    from posfb.models.controllers.plugin import (
        Controller,
        ControllerSetup,
        NominalDynamics,
        PluginError,
    )
    from posfb.models.laws.law import Law, law


def __getattr__(name: str) -> object:
    """Import a public name on first use (PEP 562)."""
    if name not in _EXPORTS:
        raise AttributeError(f"module 'posfb' has no attribute {name!r}")
    value = getattr(importlib.import_module(_EXPORTS[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
