"""What an estimate says about itself (``posfb identify``'s ``warnings``):

* a parameter whose relative standard error exceeds ``IDENTIFIABLE_RELATIVE_STD`` is
  not identifiable from this log;
* a condition number of the scaled regressor above ``POOR_CONDITION`` is poor
  excitation (Swevers et al. 1997 aim well below it);
* an encoder too coarse for this log: its quantisation biases an identifiable parameter
  by more than the parameter's standard error (``_coarse_encoder``). Least squares
  only: instrumental variables (a log with the controller's reference) are not biased by
  the encoder, whose noise their stated intervals carry (the check's second dose would
  measure that scatter, not a bias);
* a log the scenario's own model cannot have come from (``unit_warning``): the model's
  voltage along the log's motion more than ``SCALE_FACTOR`` times the log's, or less
  than its share, in RMS on a joint, is a log in other units (mV, degrees) or of
  another arm far more often than an arm that far from its description.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from posfb.models.identification.estimate import (
    Estimate,
    FilterSettings,
    filtered_motion,
    kept_samples,
)

#: Relative standard error above which a parameter counts as not identifiable.
IDENTIFIABLE_RELATIVE_STD = 0.10

#: Condition number of the scaled regressor above which the excitation is poor.
POOR_CONDITION = 100.0

#: How far (a factor, either way) the scenario's model's voltage along a log's motion may
#: be from the log's own, in RMS on a joint, before ``unit_warning`` names the likely
#: cause: a description 10 x off is rare, a log in mV (1000 x) or degrees (20-60 x on
#: the paper's arm) is not.
SCALE_FACTOR = 10.0


def unit_warning(
    time: np.ndarray,
    q_measured: np.ndarray,
    voltage: np.ndarray,
    regressor: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray],
    nominal: np.ndarray,
    target: Callable[[np.ndarray], np.ndarray] | None,
    settings: FilterSettings,
) -> list[str]:
    """A warning when the scenario's model (``regressor(...) @ nominal``, the log's
    motion filtered as the fit's) asks for a voltage whose RMS on some joint is more than
    ``SCALE_FACTOR`` times larger or smaller than the log's (``target`` maps voltages to
    the regressor's units, as in ``fit_log``; module docstring)."""
    motion = filtered_motion(time, q_measured, voltage, settings)
    kept = kept_samples(motion)
    predicted = regressor(motion.q[kept], motion.qdot[kept], motion.qddot[kept]) @ nominal
    applied = (motion.voltage if target is None else target(motion.voltage))[kept]
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = np.sqrt(np.mean(predicted**2, axis=0) / np.mean(applied**2, axis=0))
    off = np.flatnonzero(~((ratio >= 1.0 / SCALE_FACTOR) & (ratio <= SCALE_FACTOR)))
    if off.size == 0:
        return []
    listed = ", ".join(f"joint {j + 1} {ratio[j]:.3g} x" for j in off)
    return [
        f"the scenario's model asks along this log's motion for voltages far from the log's "
        f"(RMS: {listed}): a log whose voltages are in mV rather than V, whose positions "
        "are in degrees rather than rad, or of another arm is the usual cause"
    ]


def _coarse_encoder(
    estimate: Estimate,
    refit: Callable[[np.ndarray], Estimate],
    q_measured: np.ndarray,
    step: np.ndarray,
) -> list[str]:
    """The coarse-encoder check: the log refitted with the encoder's error added once
    more (uniform over one count, seeded). The noise in ``q''`` biases the inertias
    towards 0 by about its variance's share (errors in variables), so the shift the
    second dose causes measures the bias the first one left; a shift beyond the
    parameter's standard error means the stated interval misses it."""
    noise = np.random.default_rng(0).uniform(-0.5, 0.5, q_measured.shape) * step
    shift = np.abs(refit(q_measured + noise).values - estimate.values)
    identifiable = estimate.relative_std <= IDENTIFIABLE_RELATIVE_STD
    biased = np.flatnonzero(identifiable & (shift > estimate.std))
    if biased.size == 0:
        return []
    worst = biased[np.argmax(shift[biased] / estimate.std[biased])]
    return [
        f"encoder too coarse for this log ({', '.join(f'{s:.3g}' for s in step)} rad per "
        f"count): its quantisation biases {', '.join(estimate.names[i] for i in biased)} by "
        f"more than their standard errors (errors in the filtered q''; "
        f"{estimate.names[worst]} by about {shift[worst]:.3g}, "
        f"{shift[worst] / estimate.std[worst]:.1f} standard errors); a finer encoder, a "
        "lower cutoff_hz or faster excitation reduces it"
    ]


def estimate_warnings(
    estimate: Estimate,
    refit: Callable[[np.ndarray], Estimate] | None,
    q_measured: np.ndarray,
    step: np.ndarray | None,
) -> list[str]:
    """The warnings of the module docstring; ``refit`` (the same fit of other measured
    positions) and the encoder ``step`` (rad per count) enable the coarse-encoder check."""
    warnings = []
    for name, value, std, relative in zip(
        estimate.names, estimate.values, estimate.std, estimate.relative_std, strict=True
    ):
        if relative > IDENTIFIABLE_RELATIVE_STD:
            warnings.append(
                f"{name} is not identifiable from this log: {value:.4g} +- {std:.2g} "
                f"(relative standard error {100 * min(relative, 1e6):.0f} % > "
                f"{100 * IDENTIFIABLE_RELATIVE_STD:.0f} %)"
            )
    if estimate.condition_number > POOR_CONDITION:
        warnings.append(
            f"poor excitation: the scaled regressor's condition number is "
            f"{estimate.condition_number:.0f} > {POOR_CONDITION:.0f} (posfb identify plan "
            "writes an exciting trajectory)"
        )
    if refit is not None and step is not None:
        warnings += _coarse_encoder(estimate, refit, q_measured, np.asarray(step, dtype=float))
    return warnings
