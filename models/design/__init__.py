"""The design maths of Sec. 3 (Eq. 5-25): configuration, augmented system and LQR,
SPR/KYP check, bounds, position-only filters, discretisation and the linear
closed-loop checks. ``compute_design`` puts them together."""

from posfb.models.design.config import (
    ControllerConfig,
    LqrWeights,
    NonlinearTorqueConfig,
    PidGains,
    UncertaintyBounds,
    diagonal,
)
from posfb.models.design.synthesis import Check, Design, compute_design

__all__ = [
    "Check",
    "ControllerConfig",
    "Design",
    "LqrWeights",
    "NonlinearTorqueConfig",
    "PidGains",
    "UncertaintyBounds",
    "compute_design",
    "diagonal",
]
