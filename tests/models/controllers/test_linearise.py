"""The linear feedback derived from a controller's law (``models.controllers.linearise``)
against the feedbacks written out by hand from each controller's equations (the ones
posfb used before they were derived): Eq. 26 on the linear part for PID, the Sec. 3
design's filters for Lin+LC and the paper's controller (``designed_feedback``, alpha =
alpha*), the dirty derivative for PD + gravity and the clip-free ESO for ADRC. On the
paper's theta model and on a URDF arm."""

from __future__ import annotations

import sys

import casadi as ca
import numpy as np
import pytest

import posfb
from helpers.paths import REPO
from posfb.diagrams.resolve import resolve
from posfb.models.controllers import (
    ControllerBuild,
    controller_law,
    kinds,
    linear_feedback,
    spec,
)
from posfb.models.controllers.linearise import law_feedback
from posfb.models.controllers.plugin import plugin_instance
from posfb.models.design import cached_design, designed_feedback
from posfb.models.design.realisation import DiscreteFilter
from posfb.models.laws.law import law
from posfb.models.nominal import nominal_model

#: The scenarios: the paper's two-link theta model and a three-link URDF arm.
SCENARIOS = ("paper_nominal", "three_link_nominal")

#: The shipped scenarios' folder.
SHIPPED = REPO / "analysis" / "scenarios"


def _pid(build: ControllerBuild) -> DiscreteFilter:
    """Eq. 26 on the nominal linear part: ``u_k = M0* (-K_p q~_k - K_v d_k - K_I I_k) + B*
    d_k``, ``d_k = (q~_k - q~_(k-1)) / T_s``; state ``[q~_(k-1), I_k]``."""
    design = build.design
    model = nominal_model(design.nominal)
    M0, B, T = model.M0(), model.B(), design.sample_time
    Kp, Kv, KI = (np.diag(np.asarray(g, dtype=float))
                  for g in (design.pid.Kp, design.pid.Kv, design.pid.KI))  # fmt: skip
    n, zero, eye = len(M0), np.zeros_like(M0), np.eye(len(M0))
    rate = (M0 @ Kv - B) / T
    return DiscreteFilter(
        A=np.block([[zero, zero], [zero, eye]]), B=np.vstack([eye, T * eye]),
        C=np.hstack([rate, -M0 @ KI]), D=-M0 @ Kp - rate,
        initial=np.vstack([eye, np.zeros((n, n))]),
    )  # fmt: skip


def _instance(kind: str, build: ControllerBuild):
    module = sys.modules[spec(kind).settings.__module__]
    cls = {"pd_gravity": "PdGravityController", "adrc": "AdrcController"}[kind]
    return plugin_instance(getattr(module, cls), build)


def _pd_gravity(build: ControllerBuild) -> DiscreteFilter:
    """``u_k = -K_p q~_k - K_d v_k``, ``v_k = keep v_(k-1) + gain (q~_k - q~_(k-1))``."""
    law = _instance("pd_gravity", build)
    T = law.setup.sample_time
    keep, gain = law.tau_f / (law.tau_f + T), 1.0 / (law.tau_f + T)
    Kp, Kd = np.diag(law.Kp), np.diag(law.Kd)
    eye, zero = np.eye(len(Kp)), np.zeros_like(Kp)
    return DiscreteFilter(
        A=np.block([[zero, zero], [-gain * eye, keep * eye]]), B=np.vstack([eye, gain * eye]),
        C=np.hstack([gain * Kd, -keep * Kd]), D=-Kp - gain * Kd, initial=np.vstack([eye, zero]),
    )  # fmt: skip


def _adrc(build: ControllerBuild) -> DiscreteFilter:
    """Per joint ``z = (I - L h) zbar + L y``, ``b0 u = -k z`` (``k = [K_p, K_d, 1]``),
    ``zbar' = (Phi - Gamma k) z``; state ``[zbar_1 (n), zbar_2 (n), zbar_3 (n)]``."""
    law = _instance("adrc", build)
    n = law.setup.joints
    k = np.array([law.Kp, law.Kd, 1.0])
    correct = np.eye(3) - np.outer(law.L, [1.0, 0.0, 0.0])
    closed = law.Phi - np.outer(law.Gamma, k)
    per_volt, eye = np.diag(1.0 / law.b0), np.eye(n)
    return DiscreteFilter(
        A=np.kron(closed @ correct, eye), B=np.kron((closed @ law.L)[:, None], eye),
        C=-per_volt @ np.kron((k @ correct)[None, :], eye), D=-(k @ law.L) * per_volt,
        initial=np.kron(np.array([[1.0], [0.0], [0.0]]), eye),
    )  # fmt: skip


#: The hand-written feedback of each built-in controller.
BY_HAND = {
    "pid": _pid,
    "lin_lc": lambda build: designed_feedback(cached_design(build.design), "sampled_data_lin_lc"),
    "proposed": lambda build: designed_feedback(cached_design(build.design), "sampled_data"),
    "pd_gravity": _pd_gravity,
    "adrc": _adrc,
}


@pytest.mark.parametrize("scenario", SCENARIOS)
@pytest.mark.parametrize("kind", list(BY_HAND))
def test_the_derived_feedback_is_the_hand_written_one(scenario, kind):
    loaded = posfb.load_scenario(SHIPPED / f"{scenario}.yaml", set={"controller.kind": kind})
    config = resolve(loaded).config
    settings = config.controller_settings
    derived = law_feedback(controller_law(kind, config.design, settings=settings,
                                          linear_part=True))  # fmt: skip
    expected = BY_HAND[kind](ControllerBuild(config.design, (), settings))
    # The feedback posfb uses (the Sec. 3 design's filter where the spec reads it) too.
    used = linear_feedback(kind, config.design, settings=settings)
    for name in ("A", "B", "C", "D", "initial"):
        theirs = getattr(expected, name)
        scale = max(1.0, float(np.max(np.abs(theirs))))
        for ours in (getattr(derived, name), getattr(used, name)):
            assert ours.shape == theirs.shape, name
            np.testing.assert_allclose(ours, theirs, rtol=0, atol=1e-12 * scale, err_msg=name)


def test_every_built_in_controller_has_a_derived_feedback():
    assert set(kinds()) == set(BY_HAND)


def _adaptive(held: dict[int, float] | None = None):
    """A one-joint law with an adapting gain in its memory: ``u = -(1 + sqrt(g)) (q +
    w)``, ``w' = 0.5 w + q``, ``g' = g + q^2``."""

    def step(memory, q, q_d, qd_dot, qd_ddot):
        gain = 1.0 + ca.sqrt(memory[1])
        voltage = -gain * (q - q_d + memory[0])
        return voltage, gain, ca.vertcat(0.5 * memory[0] + q - q_d, memory[1] + (q - q_d) ** 2)

    return law("adaptive", 1, 2, lambda q, q_d: ca.vertcat(q - q_d, 0.0), step, held)


def test_held_memory_is_fixed_and_an_unheld_adaptation_is_named():
    """Holding the adapting entry at ``g = 4`` gives the filter ``A = 0.5, B = 1, C = D =
    -3``; left free, its derivative at ``g = 0`` is not finite and the error says what to
    do. A held index outside the memory is refused."""
    feedback = law_feedback(_adaptive({1: 4.0}))
    for name, value in (("A", 0.5), ("B", 1.0), ("C", -3.0), ("D", -3.0), ("initial", 1.0)):
        np.testing.assert_allclose(getattr(feedback, name), [[value]], err_msg=name)
    with pytest.raises(ValueError, match="not finite at rest; hold the memory entries"):
        law_feedback(_adaptive())
    with pytest.raises(ValueError, match="held index 2; 0 <= index < 2"):
        _adaptive({2: 0.0})
