"""The workspace search of Assumption 1's norms (``models.serial_bounds``): the pieces
it rests on, each against an independent computation."""

from __future__ import annotations

import numpy as np
import pytest

from helpers.paths import REPO
from posfb.models import serial_bounds
from posfb.models.serial_model import SerialArmModel

SIX_JOINT = REPO / "urdf" / "six_joint_arm.urdf"


@pytest.fixture(scope="module")
def six_joint():
    return SerialArmModel(SIX_JOINT)


def test_inertia_does_not_depend_on_the_first_joint_angle(six_joint):
    # LEADING_INVARIANT: turning the whole arm about its base joint changes no inertia,
    # so M(q) and the Christoffel symbols are the same at q and at q + s e_1 (the
    # search of delta_M1 and delta_C drops q_1).
    rng = np.random.default_rng(3)
    for _ in range(10):
        q = rng.uniform(-np.pi, np.pi, six_joint.size)
        turned = q + np.eye(six_joint.size)[0] * rng.uniform(-np.pi, np.pi)
        np.testing.assert_allclose(six_joint.M(turned), six_joint.M(q), atol=1e-12)
        np.testing.assert_allclose(
            six_joint.christoffel(turned), six_joint.christoffel(q), atol=1e-12
        )


def test_tensor_norms_attain_their_value_and_bound_every_direction(six_joint):
    rng = np.random.default_rng(4)
    tensors = np.concatenate([
        rng.normal(size=(4, 5, 5, 5)),
        np.array([six_joint.christoffel(rng.uniform(-3, 3, 6)) for _ in range(3)])[:, :5, :5, :5],
    ])  # fmt: skip
    values, x, u, v = serial_bounds.tensor_norms(tensors)
    directions = rng.normal(size=(2000, 5))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    for p, tensor in enumerate(tensors):
        # attained: u^T (T x) v with unit x, u, v is the value
        np.testing.assert_allclose(np.linalg.norm([x[p], u[p], v[p]], axis=1), 1.0)
        assert u[p] @ (tensor @ x[p]) @ v[p] == pytest.approx(values[p], rel=1e-12)
        # a maximum: no random direction's gain (numpy's spectral norm) is larger
        gains = np.linalg.norm(np.einsum("ijk,dk->dij", tensor, directions), 2, axis=(1, 2))
        assert gains.max() <= values[p] * (1 + 1e-12)
        assert serial_bounds.tensor_norm(tensor) == pytest.approx(values[p], rel=1e-12)


@pytest.mark.parametrize("name", ["spectral", "coriolis", "euclidean"])
def test_each_maximum_climbs_its_own_gradient(six_joint, name):
    # Danskin: the gradient of a maximum is the maximiser's; compared with central
    # differences of the value itself, at random configurations (where it is smooth).
    M0 = six_joint.M0()
    objective = {
        "spectral": lambda: serial_bounds._spectral(
            lambda q: six_joint.M(q) - M0, six_joint.mass_matrix_derivatives
        ),
        "coriolis": lambda: serial_bounds._coriolis(six_joint.christoffel),
        "euclidean": lambda: serial_bounds._euclidean(six_joint.G),
    }[name]()
    rng = np.random.default_rng(5)
    step = 1e-5
    for _ in range(3):
        q = rng.uniform(-np.pi, np.pi, six_joint.size)
        value, gradient = objective.value_and_gradient(q)
        assert value == pytest.approx(objective.values(q[None])[0], rel=1e-12)
        central = np.array([
            (objective.values((q + step * e)[None])[0]
             - objective.values((q - step * e)[None])[0]) / (2 * step)
            for e in np.eye(six_joint.size)
        ])  # fmt: skip
        np.testing.assert_allclose(gradient, central, rtol=1e-4, atol=1e-6 * abs(value))


def test_the_nominal_norms_are_not_below_any_sampled_configuration(six_joint):
    # A lower bound of the true maxima that no configuration of a dense random sample
    # (numpy's norms, brute force over directions for C) exceeds.
    norms = serial_bounds.model_norms(six_joint)
    rng = np.random.default_rng(6)
    M0 = six_joint.M0()
    configurations = rng.uniform(-np.pi, np.pi, (400, six_joint.size))
    m1 = max(np.linalg.norm(six_joint.M(q) - M0, 2) for q in configurations)
    g = max(np.linalg.norm(six_joint.G(q)) for q in configurations)
    directions = rng.normal(size=(200, six_joint.size))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    c = max(
        np.linalg.norm(np.einsum("ijk,dk->dij", six_joint.christoffel(q), directions), 2,
                       axis=(1, 2)).max()
        for q in configurations[:100]
    )  # fmt: skip
    assert m1 <= norms["delta_M1"] * (1 + 1e-12)
    assert g <= norms["delta_G"] * (1 + 1e-12)
    assert c <= norms["delta_C"] * (1 + 1e-12)
