"""The ANN's input feature sets of the paper's Table 3, as names of :func:`compute_measures` keys.

Reading of the table. In the available text of the paper, Table 3 is flattened: every row
shows a mark under all 15 columns, so the sets are reconstructed from the paper's words:

- **Set 1** (15): all features, "the tracking errors from (1)–(4) ..., the FEI (and hence A
  and d), E_error, E_input and HSEM^S", the partitioning φ, κ, ζ and the three τ-ratios
  (eqs. 12–14).
- **Set 2** (12): "all input features that are available after test and do not need knowledge
  about the dynamics of the experimental structure": set 1 without the three that need the
  experimental stiffness k_EXP: κ, τ_ratio,DYN (ω_0,DYN) and τ_ratio,max (the phase margin of
  the coupled loop). HSEM^S stays ("an assumption of the order of magnitude is sufficient"),
  and so does φ (m_EXP can be weighed).
- **Set 3** (7): the features the sensitivity analysis "always ranked more important":
  e_rel,track, e_MTE,track, e_rel,track,f, d, τ_ratio,NUM, τ_ratio,DYN and E_error.
"""

from __future__ import annotations

from collections.abc import Sequence

SET_1: tuple[str, ...] = (
    "e_rel_track", "e_mte_track", "e_peak_track", "e_rel_track_f", "fei_A", "fei_d",
    "e_error", "e_input", "hsem_s", "phi", "kappa", "zeta", "tau_ratio_dyn",
    "tau_ratio_num", "tau_ratio_max",
)
"""Set 1: all 15 features of Table 3, in the table's column order."""

SET_2: tuple[str, ...] = tuple(f for f in SET_1
                               if f not in ("kappa", "tau_ratio_dyn", "tau_ratio_max"))
"""Set 2: the 12 features that need no k_EXP."""

SET_3: tuple[str, ...] = ("e_rel_track", "e_mte_track", "e_rel_track_f", "fei_d",
                          "tau_ratio_num", "tau_ratio_dyn", "e_error")
"""Set 3: the 7 features always ranked important in the paper's sensitivity analysis."""

FEATURE_SETS: dict[int, tuple[str, ...]] = {1: SET_1, 2: SET_2, 3: SET_3}
"""Feature set number → measure names (keys of :func:`rths3d.metrics.compute_measures`)."""

SURROGATE: tuple[str, ...] = ("e_rel_ref_hat", "e_rel_ref_hat_std", "surrogate_validation")
"""Reference-free inputs beyond Table 3 (:mod:`rths3d.metrics.fidelity`): the surrogate
estimate ê_rel,ref, its spread over members and the part model's held-out output error. The
paper's sets 1–3 do not contain them; a physics-informed set is a Table-3 set plus these."""

INPUTS: tuple[str, ...] = SET_1 + SURROGATE
"""Every name a feature list may hold: Table 3 and the surrogate inputs."""

TARGETS: tuple[str, ...] = ("e_rel_ref", "e_mre_ref", "e_peak_ref", "e_rel_ref_f")
"""Reference errors (need z^r); ``e_rel_ref`` is the paper's ANN target."""


def feature_names(feature_set: int | Sequence[str], field: str = "set") -> tuple[str, ...]:
    """Names of Table-3 feature set 1, 2 or 3, or of a chosen list of inputs given as names:
    Table-3 features (e.g. a set 3 chosen on one's own data, as the paper chose its set 3 by
    sensitivity) and the surrogate inputs :data:`SURROGATE`; ``field`` names the input in
    the error."""
    from ..errors import ConfigError

    if isinstance(feature_set, str):
        feature_set = [feature_set]
    if not isinstance(feature_set, int):
        names = tuple(feature_set)
        unknown = [n for n in names if n not in INPUTS]
        if not names or unknown:
            raise ConfigError(field, unknown[0] if unknown else "",
                              "a feature set 1, 2, 3 or Table-3 feature names and "
                              "surrogate inputs: " + ", ".join(INPUTS))
        if len(set(names)) != len(names):
            raise ConfigError(field, ",".join(names), "each feature at most once")
        return names
    if feature_set not in FEATURE_SETS:
        raise ConfigError(field, feature_set, "must be 1, 2 or 3 (paper Table 3)")
    return FEATURE_SETS[feature_set]
