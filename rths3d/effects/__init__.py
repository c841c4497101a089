"""Physical effects with an "off" value, for the model of a bench and synthetic measurements.

See :mod:`rths3d.effects.base` (the component) and :mod:`rths3d.effects.library` (all effects).
"""

from .base import REGISTRY, STAGES, Effect, Param, get_effect, parse_effect_arg, register
from .library import NOISE_SIGMA, OUTPUTS, describe

__all__ = ["REGISTRY", "STAGES", "Effect", "Param", "get_effect", "parse_effect_arg", "register",
           "NOISE_SIGMA", "OUTPUTS", "describe"]
