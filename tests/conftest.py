"""Shared fixtures."""

from __future__ import annotations

import os

import pytest

from helpers.slow import HEAVY
from posfb.models.disk_cache import CACHE_ENV
from posfb.models.plant import build_arm_diagram


def pytest_collection_modifyitems(items: list[pytest.Item]) -> None:
    """Mark ``slow`` every test that uses a fixture defined ``heavy`` (``helpers.slow``),
    directly or through another fixture."""
    for item in items:
        info = getattr(item, "_fixtureinfo", None)
        definitions = info.name2fixturedefs.values() if info is not None else ()
        if any(getattr(d.func, HEAVY, False) for defs in definitions for d in defs):
            item.add_marker(pytest.mark.slow)


@pytest.fixture(autouse=True, scope="session")
def _private_cache(tmp_path_factory: pytest.TempPathFactory):
    """The suite (and every command it starts) caches in a folder of its own, never the
    user's cache directory, so a run neither reads nor leaves entries there. The workers
    of one ``pytest -n`` run share it (beside their own temporary folders; the cache
    writes atomically), so a design one worker computed is not computed again."""
    previous = os.environ.get(CACHE_ENV)
    if os.environ.get("PYTEST_XDIST_WORKER"):
        shared = tmp_path_factory.getbasetemp().parent / "posfb_cache"
        shared.mkdir(exist_ok=True)
        os.environ[CACHE_ENV] = str(shared)
    else:
        os.environ[CACHE_ENV] = str(tmp_path_factory.mktemp("posfb_cache"))
    yield
    if previous is None:
        os.environ.pop(CACHE_ENV, None)
    else:
        os.environ[CACHE_ENV] = previous


#: The share of its torque per volt the paper arm's shoulder motor keeps in
#: ``weak_shoulder``.
WEAK_SHOULDER_SHARE = 0.1


@pytest.fixture(scope="session")
def weak_shoulder() -> str:
    """A ``--set`` that leaves the paper arm's shoulder (joint 1) motor a tenth of the
    URDF's torque per volt, joint 2's as the URDF has it: the controllers cannot hold
    the shoulder on its path, yet its error stays under the 1 rad divergence bound
    (issue 27, item 5: a collapsed arm reported ``ok``)."""
    _, arm, _ = build_arm_diagram()
    kappa = list(arm.default_parameters.motor_constant)
    kappa[0] *= WEAK_SHOULDER_SHARE
    return f"plant.parameters.motor_constant={kappa}"


@pytest.fixture()
def arm_diagram():
    """The URDF arm alone with its default parameters: (diagram, arm, context)."""
    return build_arm_diagram()
