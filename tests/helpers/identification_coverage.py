"""The coverage of identification's stated intervals (issue 42, item 3), on logs of the
independent generator (``independent_logs``: Pinocchio, its own RK4, a quantised
encoder, held voltages): a random spatial arm (``spatial_arm``) is the description, a
perturbed copy of it the true arm, and ``identify_serial`` (with the log's reference:
instrumental variables and the motor-constant ratios) estimates the base parameters and
ratios from the log. The truth is the true arm's base parameters scaled by joint 1's
nominal over its true motor constant (joint 1's is the one scale the log cannot give)
and its ratios relative to joint 1's; a value is covered when it lies within
``SIGMAS`` stated standard errors. ``tests/models/identification/test_identification_honest.py``
runs a small form, ``bench/bench_identification_coverage.py`` the full one.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from helpers.independent_logs import fourier_reference, perturbed_urdf, simulate_log
from helpers.spatial_arm import spatial_arm_urdf
from posfb.analysis.identification.log import read_log
from posfb.models.identification.checks import IDENTIFIABLE_RELATIVE_STD
from posfb.models.identification.estimate import FilterSettings
from posfb.models.identification.serial import (
    SerialIdentification,
    SerialModel,
    identify_serial,
)
from posfb.models.identification.serial_regressor import true_parameters
from posfb.models.plant import PlantConfig, build_arm_diagram

#: Half-width of the interval judged, in stated standard errors.
SIGMAS = 3.0

#: The reference's amplitude (rad) and base frequency (Hz): every joint moves faster
#: than identification's stiction velocity most of the time.
AMPLITUDE, BASE_HZ = 1.0, 0.2


@dataclass(frozen=True)
class Coverage:
    """One arm's log judged: per identifiable value its name and ``z`` (the error in
    stated standard errors), the seconds the identification took, the identification
    and the nominal URDF it started from."""

    names: tuple[str, ...]
    z: np.ndarray
    seconds: float
    result: SerialIdentification
    nominal: Path

    @property
    def covered(self) -> int:
        return int(np.sum(np.abs(self.z) <= SIGMAS))


def _model(urdf: Path) -> tuple[SerialModel, np.ndarray, np.ndarray]:
    """The arm's identification model, standard parameters and motor constants."""
    _, arm, context = build_arm_diagram(PlantConfig(urdf=str(urdf)))
    model = SerialModel.of_arm(arm, context, str(urdf))
    return model, true_parameters(arm, context), np.asarray(model.motor_constant)


def arm_coverage(
    folder: Path,
    seed: int,
    *,
    joints: int = 4,
    counts: int = 4096,
    duration: float = 20.0,
    sample_time: float = 0.001,
    substeps: int = 4,
    settings: FilterSettings | None = None,
) -> Coverage:
    """Identify arm ``seed`` (nominal ``spatial_arm_urdf(joints, seed)``, true arm
    ``perturbed_urdf`` of it with the same seed) from a ``duration`` s log of a Fourier
    reference at ``counts`` counts per revolution, and judge its intervals."""
    folder.mkdir(parents=True, exist_ok=True)
    nominal = spatial_arm_urdf(joints, folder, seed=seed)
    truth = perturbed_urdf(nominal, folder / f"true_{seed}.urdf", seed=seed)
    reference = fourier_reference(
        joints, duration, sample_time, seed=seed, amplitude=AMPLITUDE, base_hz=BASE_HZ
    )
    log = folder / f"log_{seed}_{counts}_{duration:g}.csv"
    simulate_log(truth, nominal, reference, counts=counts, substeps=substeps).write_csv(log)
    model, _, kappa = _model(nominal)  # the base combinations are the kinematics'; shared
    _, standard, true_kappa = _model(truth)
    scale = kappa[0] / true_kappa[0]
    expected = np.concatenate(
        [scale * model.base.combine(standard), (true_kappa[1:] / kappa[1:]) * scale]
    )
    record = read_log(log, joints=joints)
    started = time.perf_counter()  # the identification's own cost (bench)
    result = identify_serial(
        model, record.time, record.q, record.u, reference=record.reference,
        quantisation_step=np.full(joints, 2.0 * np.pi / counts), settings=settings,
    )  # fmt: skip
    seconds = time.perf_counter() - started
    estimate = result.estimate
    identifiable = estimate.relative_std <= IDENTIFIABLE_RELATIVE_STD
    z = (estimate.values - expected) / estimate.std
    names = tuple(n for n, keep in zip(estimate.names, identifiable, strict=True) if keep)
    return Coverage(names, z[identifiable], seconds, result, nominal)
