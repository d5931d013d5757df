"""Generated C of a designed controller (``posfb codegen``): the law against an
independent evaluation of its equations, the C compiled with strict flags and free of
dynamic memory, the C step against a simulated log, and a software-in-the-loop run
against the simulated controller's."""

from __future__ import annotations

import hashlib
import json
import math
import re
import shutil
import subprocess
import sys

import numpy as np
import pytest

import posfb
from helpers.paths import REPO
from posfb.analysis.codegen.check import ROUND_OFF_FACTOR, TOLERANCE, check, log_inputs
from posfb.analysis.codegen.package import CFLAGS, generate
from posfb.analysis.common.shipped import shipped_files
from posfb.diagrams.resolve import resolve
from posfb.models.controllers.lin_lc import lin_lc_law
from posfb.models.controllers.pid import pid_law
from posfb.models.design import compute_design
from posfb.models.design.config import PidGains
from posfb.models.disk_cache import CACHE_ENV
from posfb.models.laws.law import Stepper
from posfb.models.laws.nominal import symbolic_model
from posfb.models.lumped import TABLE1, LumpedModel

CLI = [sys.executable, "-m", "posfb.analysis.cli"]

#: Every built-in controller: each has generated code.
KINDS = ["proposed", "lin_lc", "pid", "pd_gravity", "adrc"]

#: The functions the generated code must not call.
DYNAMIC_MEMORY = ("malloc", "calloc", "realloc", "free")


def test_lin_lc_law_is_eq_4_and_13():
    """The law's step against its equations evaluated with ``models.lumped``'s matrices
    and the design's filter: ``u = (M(q) - M0) qdd_d + C(q, qd_d) qd_d + G(q) + F(qd_d) +
    M0 qdd_d + B qd_d + C_f w + D_f q~`` and ``w' = A_f w + B_f q~``."""
    design = compute_design()
    stepper = Stepper(lin_lc_law(design, symbolic_model(TABLE1)))
    model, f = LumpedModel(TABLE1), design.lin_lc_filter
    rng = np.random.default_rng(1)
    for _ in range(20):
        q, desired, memory = rng.normal(size=2), rng.normal(size=6), rng.normal(size=len(f.A))
        q_d, velocity, acceleration = desired[:2], desired[2:4], desired[4:]
        error = q - q_d
        expected = (
            (model.M(q) - model.M0()) @ acceleration + model.C(q, velocity) @ velocity
            + model.G(q) + model.F(velocity) + model.M0() @ acceleration
            + model.B() @ velocity + f.C @ memory + f.D @ error
        )  # fmt: skip
        following = f.A @ memory + f.B @ error
        voltage, _ = stepper.step(q, desired, memory)
        np.testing.assert_allclose(voltage, expected, rtol=1e-12, atol=1e-12)
        np.testing.assert_allclose(memory, following, rtol=1e-12, atol=1e-12)


def test_pid_law_is_eq_26():
    """The PID law's step against Eq. 26 with ``models.lumped``'s inverse dynamics:
    ``u = M(q) a + C(q, qdot) qdot + G(q) + B qdot + F(qdot)`` with ``qdot = (q -
    q_(k-1)) / T``, ``a = qdd_d - K_v (qdot - qd_d) - K_p q~ - K_I I``."""
    gains, T = PidGains(), 0.01
    stepper, model = Stepper(pid_law(symbolic_model(TABLE1), gains, T)), LumpedModel(TABLE1)
    Kp, Kv, KI = (np.asarray(g, dtype=float) for g in (gains.Kp, gains.Kv, gains.KI))
    rng = np.random.default_rng(2)
    for _ in range(50):
        q, desired, memory = rng.normal(size=2), rng.normal(size=6), rng.normal(size=4)
        qdot, integral = (q - memory[:2]) / T, memory[2:].copy()
        command = desired[4:] - Kv * (qdot - desired[2:4]) - Kp * (q - desired[:2]) - KI * integral
        expected = model.inverse_dynamics(q, qdot, command, friction=True)
        voltage, _ = stepper.step(q, desired, memory)
        np.testing.assert_allclose(voltage, expected, rtol=1e-13, atol=1e-10)
        np.testing.assert_allclose(memory, np.concatenate([q, integral + T * (q - desired[:2])]),
                                   rtol=1e-15, atol=1e-15)  # fmt: skip


def test_proposed_law_is_eq_19_to_25():
    """The paper's controller's law against its equations written out here with numpy
    (``models.controllers.proposed``'s docstring): the filter, the running maxima, Eq. 18
    with ``models.lumped``'s ``||M1*||``, ``alpha = alpha* - sqrt(y)`` and the clipped
    update of ``y``, ``u = tau_Lin + tau_d + eta~ - alpha phi``."""
    from posfb.models.controllers.proposed import proposed_law

    design = compute_design()
    f, n, S = design.proposed_filter, 2, len(design.proposed_filter.A)
    stepper, model = Stepper(proposed_law(design, symbolic_model(TABLE1))), LumpedModel(TABLE1)
    nonlinear, c = design.config.nonlinear, design.bound_filter.c
    decay = np.exp(-design.config.sample_time / nonlinear.K_alpha)
    rate = 2.0 * design.coupling_norm * (1.0 - decay)
    rng = np.random.default_rng(3)
    for _ in range(30):
        q, desired = rng.normal(size=2), rng.normal(size=6)
        memory = np.concatenate([rng.normal(size=S), rng.uniform(0, 1, 4), [rng.uniform(0, 16)]])
        q_d, v, a = desired[:2], desired[2:4], desired[4:]
        error, state = q - q_d, memory[:S]
        out = f.C @ state + f.D @ error
        eta, phi = out[:n], out[n : 2 * n]
        p_max = np.maximum(memory[S : S + n], np.abs(out[2 * n : 3 * n]))
        pbar_max = np.maximum(memory[S + n : S + 2 * n], np.abs(out[3 * n :]))
        U1, U2 = np.linalg.norm(p_max) / c, np.linalg.norm(pbar_max) / c**2
        delta_bar = design.bounds.delta_bar(np.linalg.norm(model.M1(q), 2), U1, U2,
                                            np.linalg.norm(v), np.linalg.norm(a))  # fmt: skip
        U_x = np.sqrt(error @ error + U1**2 + eta @ eta)
        y = memory[-1]
        alpha = nonlinear.alpha_star - np.sqrt(y)
        y_next = max(0.0, decay * y - rate * U_x * (delta_bar + np.linalg.norm(phi) * np.sqrt(y)))
        tau_lin = model.M1(q) @ a + model.C(q, v) @ v + model.G(q) + model.F(v)
        expected = tau_lin + model.M0() @ a + model.B() @ v + eta - alpha * phi
        following = np.concatenate([f.A @ state + f.B @ error, p_max, pbar_max, [y_next]])
        voltage, _ = stepper.step(q, desired, memory)
        np.testing.assert_allclose(voltage, expected, rtol=1e-11, atol=1e-11)
        np.testing.assert_allclose(memory, following, rtol=1e-11, atol=1e-11)


def _baseline(kind: str):
    """The registered plug-in baseline ``kind`` built for the paper's arm (its instance,
    holding its gains and its law)."""
    from posfb.models.controllers import ControllerBuild, spec
    from posfb.models.controllers.plugin import plugin_instance

    config = resolve(posfb.load_scenario(set={"controller.kind": kind})).config
    entry = spec(kind)
    cls = {"pd_gravity": "PdGravityController", "adrc": "AdrcController"}[kind]
    module = sys.modules[entry.settings.__module__]
    build = ControllerBuild(config.design, config.voltage_limit, config.controller_settings)
    return plugin_instance(getattr(module, cls), build)


def test_pd_gravity_law_is_its_equations():
    """``v = (tau_f v_(k-1) + q - q_(k-1)) / (tau_f + T_s)``, ``u = K_p q~ + K_d (qdot_d - v)
    + G(q)`` with ``models.lumped``'s gravity."""
    controller, model = _baseline("pd_gravity"), LumpedModel(TABLE1)
    stepper, T = Stepper(controller.law), controller.setup.sample_time
    rng = np.random.default_rng(6)
    for _ in range(30):
        q, desired, memory = rng.normal(size=2), rng.normal(size=6), rng.normal(size=4)
        v = (controller.tau_f * memory[2:] + q - memory[:2]) / (controller.tau_f + T)
        expected = (controller.Kp * (desired[:2] - q) + controller.Kd * (desired[2:4] - v)
                    + model.G(q))  # fmt: skip
        voltage, _ = stepper.step(q, desired, memory)
        np.testing.assert_allclose(voltage, expected, rtol=1e-13, atol=1e-12)
        np.testing.assert_allclose(memory, np.concatenate([q, v]), rtol=1e-13, atol=1e-13)


def test_adrc_law_is_its_equations():
    """The current ESO and the law of ``models.controllers.adrc`` per joint: ``z = zbar +
    L (q - zbar_1)``, ``u = (K_p (q_d - z_1) + K_d (qdot_d - z_2) + qddot_d - z_3) / b0``,
    ``zbar' = Phi z + Gamma b0 clip(u)``."""
    controller = _baseline("adrc")
    stepper = Stepper(controller.law)
    rng = np.random.default_rng(7)
    for _ in range(30):
        q, desired, memory = rng.normal(size=2), rng.normal(size=6), rng.normal(size=6) * 30
        predicted = memory.reshape(3, 2)
        z = predicted + np.outer(controller.L, q - predicted[0])
        u0 = (controller.Kp * (desired[:2] - z[0]) + controller.Kd * (desired[2:4] - z[1])
              + desired[4:])  # fmt: skip
        expected = (u0 - z[2]) / controller.b0
        applied = np.clip(expected, -controller.limit, controller.limit)
        following = controller.Phi @ z + np.outer(controller.Gamma, controller.b0 * applied)
        voltage, _ = stepper.step(q, desired, memory)
        np.testing.assert_allclose(voltage, expected, rtol=1e-12, atol=1e-10)
        np.testing.assert_allclose(memory, following.ravel(), rtol=1e-12, atol=1e-10)


#: The strict flags the issue names, at the compiler's default optimisation (the check
#: and the software-in-the-loop library compile with ``CFLAGS``, ``-O2`` included, so
#: both levels' warnings are errors somewhere in this file).
STRICT = ("-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic")


def _compile(folder, name: str) -> subprocess.CompletedProcess:
    return subprocess.run(["cc", *STRICT, "-c", f"{name}.c", "-o", f"{name}.o"],
                          cwd=folder, capture_output=True, text=True)  # fmt: skip


#: The arms every built-in controller is generated for: the paper's (its theta model) and
#: the shipped six-joint arm (its URDF model, by Newton-Euler expressions).
ARMS = {"paper": "paper_nominal", "six_joint": "six_joint_nominal"}


def _scenario(arm: str, kind: str):
    return posfb.load_scenario(shipped_files("scenario")[ARMS[arm]], set={"controller.kind": kind})


@pytest.mark.parametrize("arm", ARMS)
@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("precision", ["double", "float"])
def test_generated_code_compiles_strictly_without_dynamic_memory(tmp_path, arm, kind, precision):
    assert shutil.which("cc"), "a C compiler (cc) is required"
    assert set(STRICT) <= set(CFLAGS.split())  # the check and --sil are as strict
    package = generate(resolve(_scenario(arm, kind)), "ctrl", precision)
    for name, text in package.files.items():
        (tmp_path / name).write_text(text)
    result = _compile(tmp_path, "ctrl")
    assert result.returncode == 0, result.stderr
    symbols = subprocess.run(["nm", "ctrl.o"], cwd=tmp_path, capture_output=True, text=True,
                             check=True).stdout  # fmt: skip
    names = {line.split()[-1] for line in symbols.splitlines() if line.strip()}
    assert not names & set(DYNAMIC_MEMORY), names
    assert {"ctrl_start", "ctrl_step"} <= names
    includes = {line for line in package.files["ctrl.c"].splitlines() if "#include <" in line}
    assert includes == {"#include <math.h>", "#include <string.h>"}
    if arm == "paper":  # the example's Makefile (the same code on either arm)
        built = subprocess.run(["make", "-s"], cwd=tmp_path, capture_output=True, text=True)
        assert built.returncode == 0, built.stderr


def test_the_controller_object_is_compiled_once_per_source(tmp_path, monkeypatch):
    """``analysis.codegen.build.compiled_object``: the same generated source is compiled
    once (a check and a --sil run share it); another source is compiled anew."""
    from posfb.analysis.codegen import build

    monkeypatch.setenv(CACHE_ENV, str(tmp_path / "cache"))
    packages = [generate(resolve(posfb.load_scenario(set={"controller.kind": kind})), None,
                         "double") for kind in ("lin_lc", "pid")]  # fmt: skip
    compiled = []
    real_compile = build.compile_c
    monkeypatch.setattr(build, "compile_c", lambda *a: compiled.append(a) or real_compile(*a))
    for package, folder in zip([*packages, packages[0]], ("a", "b", "c"), strict=True):
        (tmp_path / folder).mkdir()
        for name, text in package.files.items():
            (tmp_path / folder / name).write_text(text)
        build.compiled_object(tmp_path / folder, package.files, package.name)
    assert [call[0].name for call in compiled] == ["a", "b"]  # "c" came from the cache
    assert len(list((tmp_path / "cache" / "c_objects").glob("*.entry"))) == 2
    first, third = ((tmp_path / f / f"{packages[0].name}.o").read_bytes() for f in "ac")
    assert first == third


def test_a_planted_or_damaged_object_is_compiled_again_never_loaded(tmp_path, monkeypatch):
    """Issue 43: an object in the cache that is not the one posfb wrote (raw bytes at the
    entry's path, a truncated entry) is compiled again; in a cache others may write to,
    even an entry with a consistent hash is not read."""
    from posfb.analysis.codegen import build

    cache = tmp_path / "cache"
    monkeypatch.setenv(CACHE_ENV, str(cache))
    package = generate(resolve(posfb.load_scenario(set={"controller.kind": "pid"})), None,
                       "double")  # fmt: skip
    for name, text in package.files.items():
        (tmp_path / name).write_text(text)
    compiled = []
    real_compile = build.compile_c
    monkeypatch.setattr(build, "compile_c", lambda *a: compiled.append(a) or real_compile(*a))
    fresh = build.compiled_object(tmp_path, package.files, package.name).read_bytes()
    (entry,) = (cache / "c_objects").glob("*.entry")
    planted = b"\x7fELF a planted object with a constructor"
    consistent = b"sha256:" + hashlib.sha256(planted).hexdigest().encode() + b"\n" + planted
    for damage, mode in ((planted, 0o700), (entry.read_bytes()[:100], 0o700),
                         (consistent, 0o777)):  # fmt: skip
        entry.write_bytes(damage)
        cache.chmod(mode)
        built = build.compiled_object(tmp_path, package.files, package.name).read_bytes()
        assert built == fresh
    cache.chmod(0o700)
    assert len(compiled) == 4  # the first build and one per damaged entry


def test_readme_names_the_limit_and_the_design():
    """The folder's README gives what the code alone does not: the limit to clip the
    voltage to, joint by joint, and the nominal model the controller was designed on."""
    paper = generate(resolve(posfb.load_scenario(set={"actuator.voltage_limit": [24, 12]})),
                     None, "double").files["README.md"]  # fmt: skip
    assert "±(24, 12) V, joint by joint" in paper
    assert "the theta model of Eq. 2" in paper
    six = generate(resolve(_scenario("six_joint", "pid")), None, "float").files["README.md"]
    assert "±24 V on every joint" in six  # the shipped scenario's limit
    assert "six_joint_arm.urdf" in six


@pytest.fixture(scope="module", params=[(arm, kind) for arm in ARMS for kind in KINDS],
                ids=lambda param: "-".join(param))  # fmt: skip
def closed_loop_log(request):
    """A 20 s run and its log, per arm and controller."""
    scenario = _scenario(*request.param)
    run = posfb.simulate(scenario)
    return scenario, run, run.frame()


#: The float build's largest difference, relative to the log's largest voltage (measured
#: on the paper's arm / the six-joint arm). Each law sums gains times inputs that float
#: rounds to about 6e-8 relative: a position near 2 rad to 1.2e-7 rad.
#: * Lin+LC (measured 0.9e-5 / 1.3e-5): the LC filter's D gains reach 440 V/rad (400 V/rad
#:   on six joints, six of them summed per row); 1.2e-7 rad times those is 5e-5 V.
#: * PID (1.5e-5 / 2.2e-5): its velocity is the backward difference of float positions
#:   (1.2e-7 rad over T_s = 10 ms: 1e-5 rad/s), times K_v M*.
#: * The paper's controller (1.9e-5 / 2.3e-5, in the first 0.2 s): the gains of its filter
#:   (E of Eq. 20) reach hundreds of volts per radian, as Lin+LC's.
#: * PD + gravity (2.8e-5 / 2.9e-5): its dirty derivative, as PID's velocity.
#: * ADRC (2.7e-4 / 4.1e-4): the observer's disturbance state integrates the rounding (a
#:   marginally stable mode of the controller's own recursion).
FLOAT_TOLERANCE = {"lin_lc": 2e-5, "pid": 3e-5, "proposed": 3e-5, "pd_gravity": 5e-5,
                   "adrc": 5e-4}  # fmt: skip


def test_c_step_reproduces_the_simulated_voltages(closed_loop_log):
    """Over the 20 s log: double to 1e-12 V, float within ``FLOAT_TOLERANCE``; both pass
    ``check``'s default tolerance of their precision."""
    scenario, _, frame = closed_loop_log
    resolved = resolve(scenario)
    double = check(generate(resolved, None, "double"), frame)
    assert double.samples == len(frame)
    assert double.largest_difference_V <= 1e-12
    assert double.passed
    single = check(generate(resolved, None, "float"), frame)
    assert single.largest_relative <= FLOAT_TOLERANCE[resolved.config.controller]
    assert single.passed and single.largest_relative <= TOLERANCE["float"]


def test_software_in_the_loop_equals_the_simulated_controller(closed_loop_log):
    scenario, simulated, _ = closed_loop_log
    compiled = posfb.simulate(scenario, sil=True)
    for name in ("q_true", "q_measured"):
        np.testing.assert_allclose(getattr(compiled.result, name),
                                   getattr(simulated.result, name), rtol=0, atol=1e-9)  # fmt: skip
    for name in ("u_commanded", "u_applied"):
        np.testing.assert_allclose(getattr(compiled.result, name),
                                   getattr(simulated.result, name), rtol=0, atol=1e-9)  # fmt: skip
    assert list(compiled.frame().columns) == list(simulated.frame().columns)


def _frobenius(arm: str):
    return posfb.load_scenario(shipped_files("scenario")[ARMS[arm]],
                               set={"controller.kind": "proposed",
                                    "controller.bounds.M1_norm": "frobenius"})  # fmt: skip


def test_a_frobenius_m1_norm_raises_delta_bar_and_is_labelled_own_settings():
    """``bounds.M1_norm = frobenius`` (Eq. 18 with ``||M1*||_F >= ||M1*||_2``): at the same
    sample, ``delta_bar`` grows by ``(||M1*||_F - ||M1*||_2) U2`` and nothing else moves;
    the run is not the paper's controller."""
    from posfb.models.controllers.proposed import (
        OWN_SETTINGS_LABEL,
        PAPER_LABEL,
        proposed_internals,
    )
    from posfb.models.controllers.proposed import proposed_label as label

    for arm in ARMS:
        resolved = [resolve(_scenario(arm, "proposed")), resolve(_frobenius(arm))]
        laws = [generate(r, None, "double").law for r in resolved]
        steppers = [Stepper(law) for law in laws]
        names = proposed_internals(laws[0].joints)
        rng = np.random.default_rng(5)
        raised = 0
        for _ in range(20):
            n = laws[0].joints
            q, desired = rng.normal(size=n), rng.normal(size=3 * n)
            memory = rng.uniform(0.0, 1.0, laws[0].memory)
            out = [stepper.step(q, desired, memory.copy()) for stepper in steppers]
            spectral, frobenius = (dict(zip(names, internals, strict=True))
                                   for _, internals in out)  # fmt: skip
            assert frobenius["delta_bar"] >= spectral["delta_bar"]
            raised += frobenius["delta_bar"] > spectral["delta_bar"] * (1 + 1e-12)
            for name in names:
                if name != "delta_bar":
                    assert frobenius[name] == pytest.approx(spectral[name], rel=1e-12, abs=1e-12)
        assert raised == 20  # U2 > 0 here, and M1* has more than one singular value
    paper = resolve(posfb.load_scenario(set={"controller.bounds.M1_norm": "frobenius"}))
    assert label(resolve(posfb.load_scenario()).config.design) == PAPER_LABEL
    assert label(paper.config.design) == OWN_SETTINGS_LABEL


def test_the_c_step_of_a_frobenius_m1_norm_reproduces_its_simulated_voltages():
    scenario = _frobenius("six_joint").with_settings(["timing.duration=2"])
    frame = posfb.simulate(scenario).frame()
    result = check(generate(resolve(scenario), None, "double"), frame)
    assert result.samples == len(frame) and result.largest_difference_V <= 1e-12


#: The spread of a 20 s run's RMS error under perturbations of round-off size (the
#: integrator study, docs/guide/performance.md: PID's 7.7 %, the largest).
ROUND_OFF_SPREAD = 0.08


def test_float_software_in_the_loop_tracks_as_the_double_one(closed_loop_log):
    """The float build perturbs the voltage by about 1e-5 of its size: a perturbation of
    the round-off kind, so each joint's RMS error stays within the round-off spread of
    the double run's, plus half an encoder count (the errors are near one count)."""
    scenario, simulated, _ = closed_loop_log
    single = posfb.simulate(scenario, sil="float")
    assert single.status == "ok"
    counts = np.asarray(resolve(scenario).config.sensor.encoder_counts, dtype=float)
    half_count = np.pi / counts
    double = np.asarray(simulated.rms_q)
    assert np.all(np.abs(np.asarray(single.rms_q) - double)
                  <= ROUND_OFF_SPREAD * double + half_count)  # fmt: skip


def test_compare_runs_float_software_in_the_loop_from_the_command_line():
    """``posfb compare --sil float``: every run's controller is the float C; its RMS
    errors equal the API's float run's (``posfb.simulate(..., sil="float")``)."""
    result = subprocess.run(
        [*CLI, "compare", "--controllers", "lin_lc,pid", "--duration", "1", "--sil", "float",
         "--json", "--no-progress"], capture_output=True, text=True, check=True,
    )  # fmt: skip
    runs = json.loads(result.stdout)
    short = posfb.load_scenario(set={"timing.duration": 1})
    for kind in ("lin_lc", "pid"):
        expected = posfb.simulate(short, kind, sil="float").rms_q
        np.testing.assert_allclose(runs[kind]["rms_q"], expected, rtol=1e-12)


def test_sil_precision_is_validated():
    with pytest.raises(ValueError, match="sil = 'quad'; False, True \\(double\\), 'double' or "
                                         "'float' is required"):  # fmt: skip
        posfb.simulate(sil="quad")


#: Settings unlike the shipped scenario's: sample time, encoder, payload, and for the
#: paper's controller the second study's alpha* (Sec. 4.3) and a filter pole above
#: ln 2 / T_s (which the shorter sample time requires).
OTHER_SETTINGS = ["timing.sample_time=0.005", "sensor.encoder_counts=4096",
                  "plant.payload_mass=0.2"]  # fmt: skip


@pytest.mark.parametrize(("kind", "extra"), [("lin_lc", []),
                                             ("proposed", ["controller.alpha_star=2.75",
                                                           "controller.filter_a=160"])])
def test_check_passes_on_a_log_of_other_settings(tmp_path, kind, extra):
    """The command's check replays a log of other settings."""
    log = tmp_path / "log.csv"
    settings = [item for setting in OTHER_SETTINGS + extra for item in ("--set", setting)]
    subprocess.run(
        [*CLI, "simulate", "--controller", kind, "--duration", "5", *settings, "--out",
         str(log), "--no-progress"], check=True, capture_output=True,
    )  # fmt: skip
    result = subprocess.run(
        [*CLI, "codegen", "--controller", kind, *settings, "--out", str(tmp_path / "c"),
         "--check", str(log), "--json"], capture_output=True, text=True, check=True,
    )  # fmt: skip
    found = json.loads(result.stdout)["check"]
    assert found["samples"] >= 1000
    assert found["largest_difference_V"] <= 1e-12
    assert found["passed"] and found["largest_difference_V"] <= found["tolerance_V"]


@pytest.fixture(scope="module")
def short_log():
    """A 1 s Lin+LC run of the paper's arm (101 samples), its log and its double and
    float packages."""
    scenario = posfb.load_scenario(set={"timing.duration": 1, "controller.kind": "lin_lc"})
    resolved = resolve(scenario)
    packages = {p: generate(resolved, None, p) for p in ("double", "float")}
    return posfb.simulate(scenario).frame(), packages


#: A 3 V error in the log's commanded voltage: (sample, joint counted from 1).
SHIFTED = [(30, 2), (60, 1)]


def _shifted(frame):
    """``frame`` with 3 V added to the commanded voltage at ``SHIFTED``'s samples."""
    shifted = frame.copy()
    for sample, joint in SHIFTED:
        shifted.loc[sample, f"u{joint}_commanded_V"] += 3.0
    return shifted


@pytest.mark.parametrize("precision", ["double", "float"])
def test_check_passes_a_clean_log_and_fails_a_shifted_one(short_log, precision):
    """The default tolerance is the precision's ``TOLERANCE`` times the log's largest
    commanded voltage; a clean log is within it, a log with 3 V added at two samples is
    not, and the first of them is named (its row, time and joint) with the 3 V."""
    frame, packages = short_log
    clean = check(packages[precision], frame)
    volts = frame[[f"u{j}_commanded_V" for j in (1, 2)]].to_numpy()
    assert clean.tolerance_V == TOLERANCE[precision] * np.max(np.abs(volts))
    assert clean.passed and clean.largest_difference_V <= clean.tolerance_V
    assert clean.failing_sample is None and clean.failing_joint is None
    failed = check(packages[precision], _shifted(frame))
    assert not failed.passed
    sample, joint = SHIFTED[0]
    assert (failed.failing_sample, failed.failing_joint) == (sample, joint)
    assert failed.failing_time_s == frame["time_s"][sample]
    # 3 V off the clean difference there, which is within the clean log's largest
    assert abs(failed.failing_difference_V - 3.0) <= clean.largest_difference_V + 1e-12
    assert failed.at_sample in {s for s, _ in SHIFTED}
    # a tolerance above the shift passes it
    assert check(packages[precision], _shifted(frame), tolerance_V=3.5).passed


def _corrupted(frame, fault: str):
    """``frame`` in one of the mistakes a check must fail: positions offset by 0.5 rad,
    positions in degrees, voltages in mV, joint 1's measured position in joint 2's
    column."""
    corrupted = frame.copy()
    measured = ["q1_measured_rad", "q2_measured_rad"]
    if fault == "offset":
        corrupted[measured] += 0.5
    elif fault == "degrees":
        corrupted[measured] = np.degrees(corrupted[measured])
    elif fault == "millivolts":
        corrupted[["u1_commanded_V", "u2_commanded_V"]] *= 1000.0
    else:
        corrupted["q2_measured_rad"] = corrupted["q1_measured_rad"]
    return corrupted


@pytest.mark.parametrize("fault", ["offset", "degrees", "millivolts", "duplicated"])
def test_check_fails_a_log_of_wrong_units_or_columns(short_log, fault):
    frame, packages = short_log
    result = check(packages["double"], _corrupted(frame, fault))
    assert not result.passed
    assert result.failing_difference_V > result.tolerance_V
    assert result.largest_difference_V >= result.failing_difference_V


@pytest.mark.parametrize(("fault", "message"), [
    ("nan", "q1_desired_velocity_rad_per_s is nan at row 10 (time_s = 0.1)"),
    ("inf", "u2_commanded_V is inf at row 40 (time_s = 0.4)"),
    ("repeated", "row 21 repeats row 20's time_s = 0.2"),
    ("backwards", "row 21's time_s = 0.19 is before row 20's (0.2)"),
    ("gap", "row 20 (time_s = 0.21) is 0.02 s after row 19"),
    ("twice", "the log has 2 columns named q1_measured_rad"),
])  # fmt: skip
def test_a_log_the_replay_cannot_stand_for_is_refused(short_log, fault, message):
    """A non-finite replayed value (its column and row), rows that are not one per sample
    (the first bad row) and a replayed column named twice are refused before anything
    is compiled (``log_inputs``)."""
    frame, packages = short_log
    log = frame.copy()
    if fault == "nan":
        log.loc[10, "q1_desired_velocity_rad_per_s"] = np.nan
    elif fault == "inf":
        log.loc[40, "u2_commanded_V"] = np.inf
    elif fault == "repeated":
        log = log.iloc[[*range(21), 20, *range(21, len(log))]].reset_index(drop=True)
    elif fault == "backwards":
        log = log.iloc[[*range(20), 20, 19, *range(22, len(log))]].reset_index(drop=True)
    elif fault == "gap":
        log = log.drop(index=20).reset_index(drop=True)
    else:
        log.insert(len(log.columns), "q1_measured_rad", log["q1_measured_rad"],
                   allow_duplicates=True)  # fmt: skip
    with pytest.raises(ValueError, match=re.escape(message)):
        log_inputs(log, packages["double"])


@pytest.mark.parametrize("tolerance", [0.0, -1.0, math.inf, math.nan, True, "1"])
def test_check_tolerance_is_validated(short_log, tolerance):
    frame, packages = short_log
    with pytest.raises(ValueError, match=re.escape(f"tolerance_V = {tolerance!r}; a finite "
                                                   "number of volts > 0")):  # fmt: skip
        check(packages["double"], frame, tolerance_V=tolerance)


def test_the_guide_quotes_the_default_tolerances():
    """docs/guide/codegen.md's table reads ``TOLERANCE``: its factor and each precision's
    value, as the module defines them."""
    guide = (REPO / "docs" / "guide" / "codegen.md").read_text()
    superscript = str.maketrans("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹")
    factor = "2" + str(round(math.log2(ROUND_OFF_FACTOR))).translate(superscript)
    for precision, relative in TOLERANCE.items():
        mantissa, exponent = f"{relative:.1e}".split("e")
        row = f"| `{precision}` | {factor} {precision} epsilons = {mantissa}e{int(exponent)} |"
        assert row in guide, row


@pytest.mark.parametrize("shifted", [False, True])
def test_check_command_exits_1_naming_the_first_sample_over_the_tolerance(tmp_path, short_log,
                                                                          shifted):
    """``posfb codegen --check``: exit 0 and the tolerance on a clean log; exit 1 and one
    line on stderr naming the first sample, its time and joint over the tolerance on a
    log with 3 V added."""
    frame, _ = short_log
    log = tmp_path / "log.csv"
    (_shifted(frame) if shifted else frame).to_csv(log, index=False)
    result = subprocess.run(
        [*CLI, "codegen", "--controller", "lin_lc", "--set", "timing.duration=1", "--out",
         str(tmp_path / "c"), "--check", str(log)], capture_output=True, text=True,
    )  # fmt: skip
    if not shifted:
        assert result.returncode == 0, result.stderr
        assert " passed: 101 samples" in result.stdout and "double's default" in result.stdout
        return
    assert result.returncode == 1, result.stderr
    (line,) = result.stderr.strip().splitlines()
    sample, joint = SHIFTED[0]
    assert f"failed: sample {sample} (time_s = {frame['time_s'][sample]:g}), joint {joint}:" in line
    assert f"u{joint}_commanded_V by 3 V, over the tolerance" in line
