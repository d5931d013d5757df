"""Shared fixtures."""

from __future__ import annotations

import pytest

from posfb.models.plant import build_arm_diagram


@pytest.fixture()
def arm_diagram():
    """The URDF arm alone with its default parameters: (diagram, arm, context)."""
    return build_arm_diagram()
