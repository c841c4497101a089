"""Accuracy measures of real-time hybrid tests: plain functions of arrays (SI units).

One module per kind (see docs/metrics.md for every symbol, equation, unit and convention):

- :mod:`.tracking` e_rel,track, e_MTE,track, e_peak,track, e_rel,track,f (paper eqs. 1–4)
- :mod:`.ssp` TI, Θ_PC, PAEI (Synchronization Subspace Plot)
- :mod:`.frequency` FEI → A, Φ, d, f_eq (eqs. 5–8)
- :mod:`.energy` E_error, E_input, E_strain, HSEM^S, HSEM^I (eqs. 9–11), EEI
- :mod:`.reference` e_rel,ref, e_MRE,ref, e_peak,ref, e_rel,ref,f
- :mod:`.susceptibility` φ, κ, ζ, τ-ratios (eqs. 12–14), delay margin, PSI
- :mod:`.criteria` the RTHS benchmark's J1–J9
- :mod:`.bench` the bench load: peak stroke, command velocity and interface force
- :mod:`.features` the ANN feature sets of Table 3 (and the surrogate inputs beside them)
- :mod:`.fidelity` the reference errors estimated from a surrogate reference (no z^r)
- :func:`compute_measures` / :func:`feature_row`: everything for one :class:`~rths3d.Record`.

Every signal argument is (N,) for one DOF (→ float) or (N, ndof) (→ (ndof,) array).
"""

from .bench import force_peak, stroke_peak, velocity_peak
from .energy import e_error, e_input, e_strain, eei, energy_balance_residual, hsem, hsem_i, hsem_s
from .features import FEATURE_SETS, SURROGATE, TARGETS, feature_names
from .fidelity import surrogate_measures
from .frequency import FEIResult, fei
from .measures import compute_measures, feature_row
from .reference import e_mre_ref, e_peak_ref, e_rel_ref, e_rel_ref_f
from .ssp import fit_ellipse, paei, paei_history, theta_pc, ti, ti_history
from .susceptibility import (
    InterfaceLoop,
    damping_ratio,
    delay_margin,
    interface_loop,
    mass_ratio,
    omega_dyn,
    omega_num,
    psi,
    stiffness_ratio,
    tau_ratio,
    tau_ratio_max,
)
from .tracking import e_mte_track, e_peak_track, e_rel_track, e_rel_track_f

__all__ = [
    "compute_measures", "damping_ratio", "delay_margin", "e_error", "e_input", "e_mre_ref",
    "e_mte_track", "e_peak_ref", "e_peak_track", "e_rel_ref", "e_rel_ref_f", "e_rel_track",
    "e_rel_track_f", "e_strain", "eei", "energy_balance_residual", "feature_names",
    "feature_row", "fei", "fit_ellipse", "force_peak", "hsem", "hsem_i", "hsem_s",
    "interface_loop", "mass_ratio", "omega_dyn", "omega_num", "paei", "paei_history", "psi",
    "stiffness_ratio", "stroke_peak", "surrogate_measures", "tau_ratio", "tau_ratio_max",
    "theta_pc", "ti", "ti_history", "velocity_peak", "FEATURE_SETS", "FEIResult",
    "InterfaceLoop", "SURROGATE", "TARGETS",
]
