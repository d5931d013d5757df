"""The design maths of Sec. 3 (Eq. 5-25): configuration, augmented system and LQR,
SPR/KYP check, bounds, position-only filters, discretisation and the linear
closed-loop checks. ``compute_design`` puts them together."""

from functools import lru_cache

from posfb.models.design.closed_loop import NO_EFFECTS, CompliantGear, LoopEffects
from posfb.models.design.config import (
    ControllerConfig,
    LqrWeights,
    NonlinearTorqueConfig,
    PidGains,
    UncertaintyBounds,
    diagonal,
)
from posfb.models.design.loop_context import LoopContext
from posfb.models.design.synthesis import (
    DESIGNED_LOOPS,
    Check,
    Design,
    DesignedLoop,
    compute_design,
    design_loop,
    designed_feedback,
    held_design_loop,
    held_design_radius,
    plant_spectral_radii,
    with_configurations,
    with_effects,
)

#: Designs are pure functions of the (frozen, hashable) config: reuse them.
cached_design = lru_cache(maxsize=32)(compute_design)

__all__ = [
    "LoopContext",
    "cached_design",
    "designed_feedback",
    "DESIGNED_LOOPS",
    "DesignedLoop",
    "plant_spectral_radii",
    "Check",
    "ControllerConfig",
    "Design",
    "LqrWeights",
    "NonlinearTorqueConfig",
    "PidGains",
    "UncertaintyBounds",
    "compute_design",
    "design_loop",
    "held_design_loop",
    "held_design_radius",
    "diagonal",
    "with_effects",
    "with_configurations",
    "CompliantGear",
    "LoopEffects",
    "NO_EFFECTS",
]
