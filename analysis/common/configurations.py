"""A scenario's configuration set (``models.design.configurations``): its desired path over
the run's duration at ``timing.configuration_spacing``, on its nominal model's ``M*(q)``.
Every linear verdict of a scenario (``posfb design``, ``scenario check``, ``design
--margins``, ``tune``) takes it from here."""

from __future__ import annotations

from functools import lru_cache

from posfb.diagrams.loop_config import ClosedLoopConfig
from posfb.models.design.configurations import ConfigurationSet, path_configurations
from posfb.models.nominal import NominalModel, nominal_model
from posfb.models.trajectory import Trajectory


def scenario_configurations(config: ClosedLoopConfig) -> ConfigurationSet:
    """The configuration set of a resolved scenario's ``config``: its path over
    ``timing.duration`` every ``timing.configuration_spacing`` seconds, plus the extremes
    of ``M0*^-1 M*(q)`` along it, on the nominal model the controllers are designed on
    (kept for the last few scenarios: a study's samples share their base's)."""
    key = (config.design.nominal, config.trajectory, config.timing.duration,
           config.timing.configuration_spacing)  # fmt: skip
    try:
        hash(key)
    except TypeError:  # a trajectory form without a hash: computed each time
        return _configurations.__wrapped__(*key)
    return _configurations(*key)


@lru_cache(maxsize=16)
def _configurations(
    nominal: NominalModel, trajectory: Trajectory, duration: float, spacing: float
) -> ConfigurationSet:
    return path_configurations(nominal_model(nominal), trajectory, duration, spacing)
