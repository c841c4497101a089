"""General linear time-invariant machinery: systems, discretisation, stepping, controllers,
converters, noise and ground-motion records.

The design-time objects are python-control's (``control.StateSpace``; :class:`ContinuousSS`
and :class:`DiscreteSS` add a few conveniences); what is ours is the per-step side: the
steppers, difference equations, converters, noise and records. Used by the RTHS benchmark
(:mod:`rths3d.community`) and the compensators.
"""

from .controllers import DifferenceEquation, controller_from_dict, lead_lag, pi_controller
from .converters import Converter, quantize, round_half_away, saturate
from .discretize import DiscreteSS, c2d, foh_matrices, lsim_foh, recur, tustin_tf
from .ground_motion import GroundMotion, load_ground_motion
from .noise import (
    band_limited_std,
    band_limited_white_noise,
    normal_sequence,
    simulink_randn,
    simulink_seed_state,
)
from .stepper import RK4Stepper, ScalarStepper, StateSpaceStepper, affine_step_matrices, rk4_step
from .systems import (
    ContinuousSS,
    feedback,
    parallel,
    series,
    ss,
    system_from_dict,
    tf,
    tf_coefficients,
)

__all__ = [
    "ContinuousSS", "Converter", "DifferenceEquation", "DiscreteSS", "GroundMotion",
    "RK4Stepper", "ScalarStepper", "StateSpaceStepper", "affine_step_matrices",
    "band_limited_std", "band_limited_white_noise", "c2d", "controller_from_dict",
    "feedback", "foh_matrices", "lead_lag", "load_ground_motion", "lsim_foh",
    "normal_sequence", "parallel", "pi_controller", "quantize", "recur", "rk4_step",
    "round_half_away", "saturate", "series", "simulink_randn", "simulink_seed_state", "ss",
    "system_from_dict", "tf", "tf_coefficients", "tustin_tf",
]
