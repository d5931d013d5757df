"""The sampling rule that the plug-in baselines (``pd_gravity``, ``adrc``) tune by, and
the checks of their settings.

A loop's bandwidth ``omega`` defaults to ``2 pi / (20 T_s)``: 20 samples per period of
the closed-loop bandwidth, the fast end of the 20-40 samples of Franklin, Powell and
Workman ("Digital Control of Dynamic Systems", 3rd ed., Sec. 11.2); every pole a
controller places (a derivative filter, an observer) must stay below the Nyquist
frequency ``pi / T_s``.
"""

from __future__ import annotations

import math

from posfb.models.controllers.plugin import PluginError
from posfb.models.design.initial import SAMPLES_PER_BANDWIDTH


def positive_setting(owner: str, name: str, value: object) -> float:
    """``value`` as a finite float > 0, or ``PluginError`` naming ``controller.name``."""
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not (math.isfinite(value) and value > 0)
    ):
        raise PluginError(
            f"controller.{name} = {value!r} ({owner}); a finite number > 0 is required"
        )
    return float(value)


def loop_bandwidth(owner: str, bandwidth: float, sample_time: float) -> float:
    """``bandwidth`` (rad/s), or ``2 pi / (20 T_s)`` when it is 0; validated."""
    if bandwidth == 0:
        return 2.0 * math.pi / (SAMPLES_PER_BANDWIDTH * sample_time)
    return positive_setting(owner, "bandwidth", bandwidth)


def require_below_nyquist(owner: str, what: str, pole: float, sample_time: float) -> None:
    """Refuse a pole (rad/s) at or above the Nyquist frequency ``pi / T_s``."""
    nyquist = math.pi / sample_time
    if pole >= nyquist:
        raise PluginError(
            f"controller.{what} = {pole:.4g} rad/s ({owner}) is not below the Nyquist "
            f"frequency pi / T_s = {nyquist:.4g} rad/s"
        )
