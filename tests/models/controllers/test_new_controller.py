"""A new controller is one module: a lead-lag position controller written as a law, with
its settings, its spec and what tune may vary, registered from a module of its own
(``sitecustomize`` imports it before posfb reads a scenario), gets ``simulate``,
``compare``, ``design --margins``, ``tune``, a Monte-Carlo study, ``codegen`` and
``--sil`` with no posfb file touched; the same law as a ``!Python`` plug-in gets the same,
its class saying what tune may vary (``tunable``)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import posfb
from helpers.cli_batch import Command, run_commands

#: The law, shared by the registered module and the plug-in: per joint a lead-lag from
#: the position error to the voltage, ``u = -K (e + T_d v) + G(q) + M0 qdd_d + B qd_d``
#: with ``v`` the error's derivative filtered by a lag ``tau`` (backward Euler), ``K = m
#: w^2``, ``T_d = 2 / w``, ``tau = 1 / (lag_ratio w)`` on the joint's inertia ``m``.
LAW = '''
import casadi as ca
import numpy as np

import posfb


def lead_lag_law(model, sample_time, bandwidth, lag_ratio):
    n, T = model.joints, sample_time
    for name, value in (("bandwidth", bandwidth), ("lag_ratio", lag_ratio)):
        if not value > 0:
            raise ValueError(f"controller.{name} = {value!r}; a number > 0 is required")
    inertia = np.diag(model.M0)
    K, T_d, tau = inertia * bandwidth**2, 2.0 / bandwidth, 1.0 / (lag_ratio * bandwidth)

    def step(memory, q, q_d, qd_dot, qd_ddot):
        error = q - q_d
        rate = (tau * memory[n:] + error - memory[:n]) / (tau + T)
        feedforward = ca.mtimes(ca.DM(model.M0), qd_ddot) + ca.mtimes(ca.DM(model.B), qd_dot)
        voltage = -ca.DM(K) * (error + T_d * rate) + model.gravity(q) + feedforward
        return voltage, rate, ca.vertcat(error, rate)

    start = lambda q, q_d: ca.vertcat(q - q_d, ca.DM.zeros(n))  # noqa: E731
    return posfb.law("lead_lag", n, 2 * n, start, step)
'''

#: The registered controller: settings, spec, tuning and the registration, one module.
MODULE = LAW + '''
from dataclasses import dataclass, replace

from posfb.models.controllers.registry import ControllerSpec, register
from posfb.models.controllers.tunable import Knob, Tuning


@dataclass
class LeadLag:
    bandwidth: float = 30.0
    lag_ratio: float = 5.0


def _law(build):
    settings = build.settings or LeadLag()
    return lead_lag_law(build.symbolic_model(), build.design.sample_time, settings.bandwidth,
                        settings.lag_ratio)


register(ControllerSpec(
    kind="lead_lag",
    label="lead-lag",
    law=_law,
    settings=LeadLag,
    internals=lambda n: tuple(f"rate_{j + 1}" for j in range(n)),
    internal_units={"rate": "rad_per_s"},
    tuning=Tuning(
        knobs=lambda entry: (Knob("bandwidth", 3.0, 300.0, entry.bandwidth),
                             Knob("lag_ratio", 2.0, 20.0, entry.lag_ratio)),
        apply=lambda entry, values, sample_time: replace(
            entry, bandwidth=float(values[0]), lag_ratio=float(values[1])),
        shown=("bandwidth", "lag_ratio"),
    ),
))
'''

#: The same law as a plug-in class.
PLUGIN = LAW + '''

class LeadLagPlugin(posfb.Controller):
    tunable = {"bandwidth": (3.0, 300.0), "lag_ratio": (2.0, 20.0)}

    def __init__(self, setup, bandwidth=30.0, lag_ratio=5.0):
        super().__init__(setup)
        self.internals = tuple(f"rate_{j + 1}_rad_per_s" for j in range(setup.joints))
        self.law = lead_lag_law(setup.nominal.symbolic(), setup.sample_time, bandwidth,
                                lag_ratio)
'''

#: A two-sample study of the controller against PID.
STUDY = """\
seed: 3
scenario: {scenario}
samples: 2
duration: 1.0
controllers: [{kind}, pid]
parameters:
  link_mass: [!Uniform {{min: -0.2, max: 0.2, relative: true}}]
"""

#: A small tuning (``tests/analysis/design/test_tuning.py``'s).
SMALL = ["--plants", "2", "--generations", "2", "--epsilon", "0.5", "--beta", "0.5",
         "--rounds", "1", "--accept-worse"]  # fmt: skip


def _commands(folder: Path, scenario: str, kind: str) -> dict[str, list[str]]:
    (folder / "study.yaml").write_text(STUDY.format(scenario=scenario, kind=kind))
    commands = {
        "simulate": ["simulate", "--scenario", scenario, "--json"],
        "compare": ["compare", "--scenario", scenario, "--controllers", f"{kind},pid", "--json"],
        "margins": ["design", "--scenario", scenario, "--margins", "--json"],
        "study": ["montecarlo", "run", "study.yaml", "--db", "study.sqlite", "--workers", "1",
                  "--no-progress"],
        "codegen": ["codegen", "--scenario", scenario, "--out", "generated"],
        "sil": ["simulate", "--scenario", scenario, "--sil", "--json"],
        "tune": ["tune", scenario, "--out", "tuned.yaml", *SMALL, "--json"],
    }  # fmt: skip
    return commands


def _run(folder: Path, commands: dict[str, list[str]], monkeypatch) -> dict[str, object]:
    monkeypatch.setenv("PYTHONPATH", str(folder))
    done = run_commands([Command(args, folder) for args in commands.values()], timeout=600)
    for name, run in zip(commands, done, strict=True):
        assert run.returncode == 0, (name, run.stdout[-2000:], run.stderr[-2000:])
    return dict(zip(commands, done, strict=True))


def _check(folder: Path, done: dict, kind: str) -> None:
    simulated = json.loads(done["simulate"].stdout)
    assert simulated["controller"] == kind and simulated["status"] == "ok"
    sil = json.loads(done["sil"].stdout)
    np.testing.assert_allclose(sil["rms_q"], simulated["rms_q"], rtol=1e-6)
    compared = json.loads(done["compare"].stdout)
    assert kind in json.dumps(compared)
    margins = json.loads(done["margins"].stdout)
    assert kind in json.dumps(margins) and "gain" in json.dumps(margins)
    assert len(list((folder / "generated").glob("*.h"))) == 1
    assert (folder / "study.sqlite").is_file()


@pytest.mark.slow
def test_a_registered_controller_module_gets_the_whole_route(tmp_path, monkeypatch):
    (tmp_path / "lead_lag.py").write_text(MODULE)
    (tmp_path / "sitecustomize.py").write_text("import lead_lag  # noqa: F401\n")
    (tmp_path / "scenario.yaml").write_text("controller: !LeadLag {}\ntiming: {duration: 1}\n")
    done = _run(tmp_path, _commands(tmp_path, "scenario.yaml", "lead_lag"), monkeypatch)
    _check(tmp_path, done, "lead_lag")
    tuned = json.loads(done["tune"].stdout)
    assert next(iter(tuned["controllers"])) == "lead_lag"  # the scenario's own kind first
    assert "!LeadLag" in (tmp_path / "tuned.yaml").read_text()


@pytest.mark.slow
def test_the_same_law_as_a_plugin_gets_the_same(tmp_path, monkeypatch):
    (tmp_path / "lead_lag_plugin.py").write_text(PLUGIN)
    (tmp_path / "scenario.yaml").write_text(
        "controller: !Python {file: lead_lag_plugin.py, class: LeadLagPlugin}\n"
        "timing: {duration: 1}\n"
    )
    done = _run(tmp_path, _commands(tmp_path, "scenario.yaml", "LeadLagPlugin"), monkeypatch)
    _check(tmp_path, done, "LeadLagPlugin")
    tuned = json.loads(done["tune"].stdout)
    assert next(iter(tuned["controllers"])) == "LeadLagPlugin"
    searched = tuned["controllers"]["LeadLagPlugin"]["settings"]
    assert searched["bandwidth"]["before"] == 30.0  # the __init__ default
    written = posfb.load_scenario(str(tmp_path / "tuned.yaml")).scenario.controller
    assert json.loads(written.settings)["bandwidth"] == searched["bandwidth"]["after"]
