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
from posfb.models.design.synthesis import (
    LOOP_CONTROLLERS,
    Check,
    Design,
    compute_design,
    plant_spectral_radii,
)

__all__ = [
    "LOOP_CONTROLLERS",
    "plant_spectral_radii",
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
