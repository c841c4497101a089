"""Checks of a coupled surrogate reference, its band and its reliability flag.

An identified part model can explain the record well and still give a wrong ẑ^r: coupled to
the numerical substructure it may run where the record never went, or grow through a regime
that the record pinned down badly. These checks judge the *coupled prediction itself*, run
by run, and turn the members' disagreement into a band and a flag:

- **Coupled consistency** (:func:`consistent`). With the switch fixed at the start of each
  step, each regime's exactly coupled one-step map is linear; a passive part on a damped
  numerical substructure gives a reference that decays in every regime (only the exchange's
  delay destabilises a test, and the reference has none). A regime of coupled spectral
  radius ρ_r above :data:`~rths3d.surrogate.estimator.STABLE_RADIUS` occupied for n_r steps
  of the coupled run can grow it by up to ρ_r^n_r; a run where this exceeds :data:`GROWTH`
  in some regime grows where the real part decays, and is rejected. A regime the run
  barely visits may be unstable without harm (a contact regime identified from a few short
  touches, in a reference that never touches).
- **Extrapolation**: a run whose part force exceeds :data:`EXTRAPOLATION` times the
  largest force in the record drives the model where it was never identified.
- **The band** (:func:`band`): the smallest and the largest ê_rel,ref over the members (the
  estimate, its refits on each half of the record, every consistent candidate that validates
  within ``accept`` times the best), each widened by the relative floor
  :data:`BAND_FLOOR` plus the chosen model's held-out output error.
- **The flag** (:func:`flag_reasons`): the estimate is *unreliable* when no candidate
  couples consistently, when the chosen model, replaying the record (driven by the
  measured z'), misses the measured force by more than :data:`VALIDATION_LIMIT`, when
  the members disagree by more than :data:`SPREAD_LIMIT` (max/min of their ê_rel,ref) or
  when ẑ^r extrapolates the part.
  Each reason is a sentence; a test whose every member diverges gets the status ``failed``
  with its reason (its estimate NaN), never a silent NaN.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import LagModel

GROWTH = 2.0
"""Largest growth ρ_r^n_r a regime may give the coupled run over the n_r steps it occupies."""
EXTRAPOLATION = 3.0
"""Largest part force of a coupled run, in multiples of the record's peak |F'_m|."""
BAND_FLOOR = 0.05
"""Relative widening of the members' range of ê_rel,ref that every band gets."""
VALIDATION_LIMIT = 0.5
"""Replay error of the chosen model (driven by the measured z' over the whole record,
relative RMS force error) above which the estimate is flagged."""
SPREAD_LIMIT = 3.0
"""Ratio of the largest to the smallest member's ê_rel,ref above which it is flagged."""


@dataclass(frozen=True)
class RunCheck:
    """The check of one coupled run: ``ok`` (consistent), ``reason`` (why not, or ""),
    ``radius`` (the largest coupled spectral radius over the regimes it occupies),
    ``force_ratio`` (its peak part force over the record's peak |F'_m|)."""

    ok: bool
    reason: str
    radius: float
    force_ratio: float


def regime_share(model: LagModel, z: np.ndarray, f: np.ndarray) -> float:
    """Share of the steps of a run (ẑ^r, its part force (N, d)) spent in the high regime
    (the switch read at the start of each step, as the coupling does)."""
    sw = model.switch_
    if not np.isfinite(sw.h) or len(z) < 2:
        return 0.0
    w = z[:-1] @ np.asarray(sw.a, float) - f[:-1] @ np.asarray(sw.c, float) - sw.h
    return float(np.mean(w > 0))


def check_run(model: LagModel, radii: tuple[float, float], z: np.ndarray, f: np.ndarray,
              f_peak: float, stable_radius: float) -> RunCheck:
    """:class:`RunCheck` of ``model`` coupled (``z`` ẑ^r, ``f`` its force, (N, d); NaN: the
    run diverged); ``radii``: coupled spectral radii of its (low, high) regime."""
    if not (np.isfinite(z).all() and np.isfinite(f).all()):
        return RunCheck(False, "its coupled run diverged", np.inf, np.inf)
    hi = regime_share(model, z, f)
    steps = (len(z) - 1) * np.array([1.0 - hi, hi])
    r = np.asarray(radii, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        growth = np.where(r > stable_radius, steps * np.log(np.maximum(r, 1e-300)), 0.0)
    used = r[steps > 0]
    radius = float(used.max()) if len(used) else float(r.max())
    ratio = float(np.max(np.abs(f))) / max(f_peak, 1e-300)
    if not np.all(growth <= np.log(GROWTH)):
        q = int(np.argmax(np.nan_to_num(growth, nan=np.inf)))
        which = ("model" if not np.isfinite(model.switch_.h) else
                 ("low" if q == 0 else "high") + " regime")
        return RunCheck(False, f"it grows when coupled (spectral radius {r[q]:.5f} of its "
                        f"{which}, occupied {int(steps[q])} steps)", float(r[q]), ratio)
    return RunCheck(True, "", radius, ratio)


def band(values: np.ndarray, validation: float) -> tuple[float, float]:
    """(lo, hi) of ê_rel,ref: the members' range widened by :data:`BAND_FLOOR` plus the
    chosen model's held-out error ``validation`` (relative, both sides)."""
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if not len(v):
        return float("nan"), float("nan")
    u = BAND_FLOOR + (validation if np.isfinite(validation) else 1.0)
    return float(v.min() / (1.0 + u)), float(v.max() * (1.0 + u))


def flag_reasons(any_consistent: bool, best_check: RunCheck, replay: float,
                 values: np.ndarray) -> list[str]:
    """Why the estimate should not be trusted (empty: reliable); see the module docstring.
    ``replay``: the chosen model's replay error, run freely over the whole record driven by
    the measured z', RMS(F_sim − F'_m)/RMS(F'_m)."""
    out = []
    if not any_consistent:
        out.append(f"no identified part model couples without growing ({best_check.reason})")
    if not replay <= VALIDATION_LIMIT:
        out.append(f"the part model, driven by the measured z', misses F'_m by {replay:.3g} "
                   f"(relative RMS; limit {VALIDATION_LIMIT:g}): the part lies outside the "
                   "model classes")
    v = np.asarray(values, float)
    v = v[np.isfinite(v)]
    if len(v) > 1 and v.max() > SPREAD_LIMIT * max(v.min(), 1e-300):
        out.append(f"the members disagree: ê_rel,ref from {v.min():.3g} to {v.max():.3g} "
                   f"(more than {SPREAD_LIMIT:g}×)")
    if best_check.force_ratio > EXTRAPOLATION:
        out.append(f"ẑ^r drives the part model to {best_check.force_ratio:.3g}× the largest "
                   f"measured force (limit {EXTRAPOLATION:g}×): extrapolated")
    return out


__all__ = ["BAND_FLOOR", "EXTRAPOLATION", "GROWTH", "RunCheck", "SPREAD_LIMIT",
           "VALIDATION_LIMIT", "band", "check_run", "flag_reasons", "regime_share"]
