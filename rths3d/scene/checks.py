"""The checks of a scene across its sections: what one section's values allow of another's
(the explicit integrator against the part's stiffness, the support motion against the
platform's reach). Called by :func:`rths3d.scene.scene_from_dict` and by the cheaper
validation of a changed numerical substructure (:func:`rths3d.scene.scene_with`)."""

from __future__ import annotations

import math

import numpy as np

from ..config import ExcitationConfig, ExperimentConfig, NumericalConfig, SafetyLimits
from ..errors import ConfigError
from ..experiment import part_class
from ..numerical.modal import coupled_fastest_eigenfrequency

__all__ = ["check_coupled_stability", "check_reach"]


def check_coupled_stability(num: NumericalConfig, exp: ExperimentConfig,
                             dofs: tuple[str, ...], dt: float) -> None:
    """Refuse ``central_difference`` when the coupled test's fastest mode has ω·ΔT ≥ 2.

    The part's spring k_EXP acts on the numerical DOFs through Γ; its mass sits behind that
    spring and does not slow the fastest mode (at ω ΔT ≈ 2 it barely moves), so the explicit
    integrator sees ω_max of (K + Γ k_EXP Γᵀ) v = ω² M v.
    """
    k_exp = np.array(part_class(exp.kind)(exp).interface_matrices()[0])
    w = coupled_fastest_eigenfrequency(np.array(num.M), np.array(num.K), np.array(num.gamma),
                                       np.zeros_like(k_exp), k_exp)
    if w * dt >= 2.0:
        raise ConfigError("numerical.integrator", num.integrator,
                          f"unstable: coupled ω_max·ΔT = {w * dt:.3g} must be < 2 "
                          f"(ω_max = {w:.4g} rad/s of K + Γ k_EXP Γᵀ on M, ΔT = {dt:g} s); "
                          "use 'exact'")


def check_reach(saf: SafetyLimits, exc: ExcitationConfig, exp: ExperimentConfig,
                 stroke: float) -> None:
    """Reject strokes the platform (leg ``stroke``, m) cannot reach and support motions
    beyond the stroke."""
    reach = stroke / 2.0
    if saf.stroke > reach:
        raise ConfigError("safety.stroke", saf.stroke, f"unreachable: the platform's leg "
                          f"stroke allows at most {reach:g} m of heave")
    if exc.kind == "support" and exc.signal == "raised_cosine":
        peak = exp.h0 + exc.overtravel if not math.isnan(exc.overtravel) else exc.amplitude
        if peak > saf.stroke:
            raise ConfigError("excitation.overtravel" if not math.isnan(exc.overtravel)
                              else "excitation.amplitude", peak,
                              f"support motion peak {peak:g} m is beyond the stroke limit "
                              f"safety.stroke = {saf.stroke:g} m")
    if exc.kind == "support" and exc.signal == "sine" and abs(exc.amplitude) > saf.stroke:
        raise ConfigError("excitation.amplitude", exc.amplitude,
                          f"support motion beyond the stroke limit safety.stroke = "
                          f"{saf.stroke:g} m")
