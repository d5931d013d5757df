"""The Assumption-1 check: closed-form constants against brute force over q."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from posfb.analysis.uncertainty.coverage import BOUND_NAMES, coverage, uncertainty_norms
from posfb.models.design import UncertaintyBounds
from posfb.models.design.bounds import resolve_bounds
from posfb.models.lumped import TABLE1, LumpedModel

PERTURBED = replace(
    TABLE1,
    theta1=0.36,
    theta3=0.0062,
    theta4=2.4,
    theta5=3.0,
    theta6=1.4,
    theta8=0.025,
    theta10=1.3,
    theta11=1.7,
)


def test_the_nominal_model_is_inside_with_zero_ratios():
    result = coverage(TABLE1, TABLE1, resolve_bounds(UncertaintyBounds(), TABLE1))
    assert result.inside
    assert all(result.ratios[name] == 0.0 for name in BOUND_NAMES)


def test_closed_form_constants_match_a_search_over_states():
    norms = uncertainty_norms(PERTURBED, TABLE1)
    nominal, true = LumpedModel(TABLE1), LumpedModel(PERTURBED)
    grid = np.linspace(-np.pi, np.pi, 121)
    m1 = g = c = 0.0
    for q1 in grid:
        for q2 in grid[::4]:
            q = np.array([q1, q2])
            m1 = max(m1, np.linalg.norm(nominal.M1(q) - true.M1(q), 2))
            g = max(g, np.linalg.norm(nominal.G(q) - true.G(q)))
    for q2 in grid:
        q = np.array([0.0, q2])
        for angle in np.linspace(0, np.pi, 91):
            x = np.array([np.cos(angle), np.sin(angle)])
            c = max(c, np.linalg.norm(nominal.C(q, x) - true.C(q, x), 2))
    f = max(
        np.linalg.norm(nominal.F(v) - true.F(v))
        for v in (np.array([1.0, 1.0]), np.array([1.0, -1.0]), np.array([0.0, 1.0]))
    )
    assert norms["delta_M1"] == pytest.approx(m1, rel=1e-9)
    assert norms["delta_G"] == pytest.approx(g, rel=1e-3) and norms["delta_G"] >= g - 1e-12
    assert norms["delta_C"] == pytest.approx(c, rel=1e-3) and norms["delta_C"] >= c - 1e-12
    assert norms["delta_F"] == pytest.approx(f, rel=1e-12)
    assert norms["delta_M0"] == pytest.approx(np.linalg.norm(nominal.M0() - true.M0(), 2))
    assert norms["delta_B"] == pytest.approx(np.linalg.norm(nominal.B() - true.B(), 2))


def test_a_bound_decides_inside_or_outside():
    norms = uncertainty_norms(PERTURBED, TABLE1)
    loose = resolve_bounds(UncertaintyBounds(**{n: 2 * norms[n] for n in BOUND_NAMES}), TABLE1)
    assert coverage(PERTURBED, TABLE1, loose).inside
    tight = replace(loose, delta_G=0.5 * norms["delta_G"])
    result = coverage(PERTURBED, TABLE1, tight)
    assert not result.inside and result.ratios["delta_G"] == pytest.approx(2.0)
