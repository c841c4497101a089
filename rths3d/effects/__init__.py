"""Physical effects with an "off" value: the bench's effects for scenes, the vRTHS loop, the
diagnosis and synthetic measurements.

See :mod:`rths3d.effects.base` (the component), :mod:`rths3d.effects.library` (all effects)
and :mod:`rths3d.effects.blocks` (their per-step signal physics).
"""

from .base import (
    REGISTRY,
    STAGES,
    Effect,
    Param,
    ProbeData,
    bench_effects,
    get_effect,
    parse_effect_arg,
    parse_label,
    register,
)
from .library import WRENCH, describe, noise_sigma

__all__ = ["REGISTRY", "STAGES", "WRENCH", "Effect", "Param", "ProbeData", "bench_effects",
           "describe", "get_effect", "noise_sigma", "parse_effect_arg", "parse_label",
           "register"]
