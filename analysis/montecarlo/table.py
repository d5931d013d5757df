"""A study's results as one tidy table: a row per (sample, controller).

``study_table`` reads a store (``analysis.montecarlo.store``) into a pandas
DataFrame that R, a spreadsheet or pandas take as it is; ``posfb montecarlo
export --db STORE --out FILE.parquet|.csv`` writes it
(``analysis.common.export.write_table``: atomic, CSV floats round-trip exactly). Columns,
in this order:

* ``sample``, ``controller``, ``status`` (``records.STATUSES``: ``ok | saturated | lost |
  diverged | error``);
* the run's metrics with units: ``rms_q1_rad`` .. ``rms_qn_rad``, ``rms_u1_V`` ..
  ``rms_un_V`` (``n`` joints), ``max_abs_q_err_rad``, ``saturated_fraction`` (NaN
  where the run produced none);
* the sample's plant, one column per scalar with its unit: ``link_mass_1_kg``,
  ``link_mass_2_kg``, ... ``motor_constant_n_N_m_per_V``, ``payload_mass_kg``,
  ``encoder_counts``, then every scenario key the study draws (``draws:``), under
  its dotted key (``timing.sample_time``). The values are ``models.plant.ArmParameters``'
  at the joint: ``rotor_inertia_j_kg_m2`` is the *reflected* rotor inertia (the URDF's
  ``drake:rotor_inertia`` at the motor times ``drake:gear_ratio`` squared), and
  ``damping``, ``coulomb`` and ``motor_constant`` are joint-side;
* for a study of the theta nominal model (the paper's), the identified lumped model
  ``theta1`` ... ``theta11`` and ``l1_m`` (``models.theta_of_plant``; the theta in the
  units of Table 1);
* the Assumption-1 ratios ``delta_M0_ratio`` ... ``delta_F_ratio`` (``||dX|| /
  D_X``, ``analysis.uncertainty.coverage``) and ``inside_bounds``;
* ``sampled_data_spectral_radius``: the controller's designed loop on this plant
  (NaN for PID, which has none);
* ``message``, ``wall_time_s``, ``code_version``.

Every value is the store's, unrounded: the table equals what the store holds.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pandas as pd

from posfb.analysis.common.export import write_table
from posfb.analysis.montecarlo.records import measured_columns
from posfb.analysis.montecarlo.store import RADIUS_COLUMN, ResultStore
from posfb.analysis.uncertainty.coverage import BOUND_NAMES
from posfb.analysis.uncertainty.study import study_joints
from posfb.models.plant import JOINT_PARAMETERS, PARAMETER_UNITS


def metric_names(joints: int) -> dict[str, str]:
    """Metric columns of the store and their names with units in the table."""
    names = {f"rms_q{j + 1}": f"rms_q{j + 1}_rad" for j in range(joints)}
    names.update({f"rms_u{j + 1}": f"rms_u{j + 1}_V" for j in range(joints)})
    return {
        **names,
        "max_abs_q_err": "max_abs_q_err_rad",
        "saturated_fraction": "saturated_fraction",
        **{column: f"{column}_rad" for column in measured_columns(joints)},
    }


#: The formats ``export_study`` writes (text columns rule out ``.npz``).
TABLE_FORMATS = (".parquet", ".csv")


def plant_columns(joints: int) -> tuple[str, ...]:
    """The physical plant's columns, in ``ArmParameters`` order."""
    return (
        *(
            f"{name}_{joint + 1}_{PARAMETER_UNITS[name]}"
            for name in JOINT_PARAMETERS
            for joint in range(joints)
        ),
        f"payload_mass_{PARAMETER_UNITS['payload_mass']}",
        "encoder_counts",
    )


#: The identified lumped model's columns (a study of the theta nominal model).
THETA_COLUMNS = (*(f"theta{i}" for i in range(1, 12)), "l1_m")


def _theta_values(theta: dict[str, float]) -> dict[str, float]:
    """``THETA_COLUMNS`` of a stored theta (empty for a URDF nominal model's study)."""
    if not theta:
        return {}
    return {**{f"theta{i}": float(theta[f"theta{i}"]) for i in range(1, 12)}, "l1_m": theta["l1"]}


#: The Assumption-1 ratio columns.
RATIO_COLUMNS = tuple(f"{name}_ratio" for name in BOUND_NAMES)


def _plant_values(sample: dict[str, object]) -> dict[str, object]:
    """The plant columns and the drawn scenario keys of one ``samples`` row."""
    parameters = dict(sample["parameters"])
    values: dict[str, object] = {}
    for name in JOINT_PARAMETERS:
        per_joint = parameters.pop(name)
        for joint in range(len(per_joint)):
            values[f"{name}_{joint + 1}_{PARAMETER_UNITS[name]}"] = float(per_joint[joint])
    values[f"payload_mass_{PARAMETER_UNITS['payload_mass']}"] = float(
        parameters.pop("payload_mass")
    )
    values["encoder_counts"] = int(sample["encoder_counts"])
    values.update(parameters)  # the draws: keys, in the study's order
    return values


def _number(value: object) -> float:
    return np.nan if value is None else float(value)


def study_table(store: ResultStore | str | os.PathLike[str]) -> pd.DataFrame:
    """One row per (sample, controller) of the finished samples (module docstring)."""
    if not isinstance(store, ResultStore):
        with ResultStore.open_existing(store) as opened:
            return study_table(opened)
    samples = {row["sample"]: row for row in store.sample_rows()}
    study = store.study()
    joints, draws = study_joints(study), list(study.draws)
    metrics = metric_names(joints)
    identified = any(sample["theta"] for sample in samples.values())
    rows = []
    for run in store.run_rows():
        sample = samples[run["sample"]]
        rows.append(
            {
                "sample": int(run["sample"]),
                "controller": run["controller"],
                "status": run["status"],
                **{name: _number(run[column]) for column, name in metrics.items()},
                **_plant_values(sample),
                **_theta_values(sample["theta"]),
                **{f"{name}_ratio": float(sample["bound_ratios"][name]) for name in BOUND_NAMES},
                "inside_bounds": bool(sample["inside_bounds"]),
                RADIUS_COLUMN: _number(run[RADIUS_COLUMN]),
                "message": run["message"],
                "wall_time_s": _number(run["wall_time_s"]),
                "code_version": sample["code_version"],
            }
        )
    columns = [
        "sample", "controller", "status", *metrics.values(), *plant_columns(joints), *draws,
        *(THETA_COLUMNS if identified else ()), *RATIO_COLUMNS, "inside_bounds", RADIUS_COLUMN,
        "message",
        "wall_time_s", "code_version",
    ]  # fmt: skip
    table = pd.DataFrame(rows, columns=columns)
    return table.astype({"sample": "int64", "encoder_counts": "int64", "inside_bounds": "bool"})


def export_study(db: str | os.PathLike[str], out: str | os.PathLike[str]) -> Path:
    """Write ``study_table(db)`` to ``out`` (``TABLE_FORMATS``)."""
    return write_table(study_table(db), out)
