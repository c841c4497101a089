"""Delay compensators as components: one class per file behind one protocol
(:mod:`.base`), registered by name in :data:`COMPENSATORS`.

===============  =========================================================================
name             command u from the desired z (and the measured z_meas)
===============  =========================================================================
``none``         u = z
``velocity``     u = z + τ_c ż (fixed)
``polynomial``   Lagrange extrapolation of z τ_c ahead (fixed)
``lead``         phase lead G_T(s) z by Tustin (fixed; the RTHS benchmark's outer compensation)
``ats``          u = a0 z + a1 ż + a2 z̈, a by moving-window least squares (Chae et al. 2013)
``inverse``      inverse of an identified transfer function, filtered (feed-forward)
``rls``          FIR inverse model per channel by recursive least squares (RoDeAC-style)
``model_based``  inverse-model feed-forward + PI feedback on the tracking error
``rodeac``       RoDeAC: RLS FIR inverse per channel, θ used at once, P₀ matrix (maRTHS)
===============  =========================================================================

``CALIBRATIONS`` holds the offline calibrations (``velocity``, ``polynomial``: τ_c = the
measured delay; ``ats``, ``rls``: initial coefficients;
``inverse``, ``model_based``: the identified model) from a recorded test. See
``docs/compensation.md`` for the protocol, parameters, defaults and their sources.
"""

from . import ats as _ats
from . import inverse as _inverse
from . import polynomial as _polynomial
from . import rls as _rls
from . import rodeac as _rodeac
from . import velocity as _velocity
from .ats import ATSCompensator, ATSConfig
from .base import (
    COMPENSATORS,
    BaseCompensator,
    Compensator,
    CompensatorConfig,
    WatchConfig,
    build,
    compensator_class,
    compensator_names,
    config_from_dict,
    register,
)
from .inverse import InverseCompensator, InverseConfig, InverseModel, design_inverse
from .lead import LeadCompensator, LeadConfig
from .model_based import ModelBasedCompensator, ModelBasedConfig
from .none import NoCompensation, NoneConfig
from .polynomial import PolynomialCompensator, PolynomialConfig, lagrange_weights
from .rls import RLSCompensator, RLSConfig
from .rodeac import RoDeACCompensator, RoDeACConfig
from .velocity import VelocityCompensator, VelocityConfig

CALIBRATIONS = {
    "velocity": _velocity.calibrate,
    "polynomial": _polynomial.calibrate,
    "ats": _ats.calibrate,
    "rls": _rls.calibrate,
    "rodeac": _rodeac.calibrate,
    "inverse": _inverse.calibrate,
    "model_based": _inverse.calibrate,
}
"""name → ``calibrate(u, z_meas, dt, config) -> config``: offline calibration from a test
record (the commands sent and the measurements passed at the same calls)."""

__all__ = [
    "CALIBRATIONS", "COMPENSATORS", "ATSCompensator", "ATSConfig", "BaseCompensator",
    "Compensator", "CompensatorConfig", "InverseCompensator", "InverseConfig", "InverseModel",
    "LeadCompensator", "LeadConfig", "ModelBasedCompensator", "ModelBasedConfig",
    "NoCompensation", "NoneConfig", "PolynomialCompensator", "PolynomialConfig",
    "RLSCompensator", "RLSConfig", "RoDeACCompensator", "RoDeACConfig",
    "VelocityCompensator", "VelocityConfig", "WatchConfig",
    "build", "compensator_class", "compensator_names", "config_from_dict", "design_inverse",
    "lagrange_weights", "register",
]
