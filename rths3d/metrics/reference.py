"""Reference errors: the tracking measures with the reference solution z^r in place of z.

"... can be calculated similar to the tracking errors in (1)–(4) by replacing z by z^r"
(paper). The compared signal is the achieved interface displacement z' by default (what the
experimental part really did; pass z instead to compare the command), and every ratio is
normalised by the reference z^r, the true behaviour:

    e_rel,ref   = RMS(z^r − z') / RMS(z^r)            (the paper's ANN target)
    e_MRE,ref   = max|z^r − z'| / max|z^r|
    e_peak,ref  = |max|z^r| − max|z'|| / max|z^r|
    e_rel,ref,f = RMS(|Z^r − Z'|) / RMS(|Z^r|)        (same reading of eq. 4 as e_rel,track,f)

Dimensionless; identical signals give exactly 0; NaN when the reference is identically zero.
Both signals must cover the same samples: a reference run of another length is an error,
not silently truncated.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ._signals import as_pair, out, peak, ratio, rms
from .tracking import one_sided_amplitude, spectral_rel_error


def _pair(z_ref, z_test):
    return as_pair(z_ref, z_test, ("z_ref", "z_meas"))


def e_rel_ref(z_ref: ArrayLike, z_test: ArrayLike) -> float | np.ndarray:
    """Relative RMS reference error e_rel,ref = RMS(z^r − z') / RMS(z^r) (eq. 1 with z^r)."""
    r, y, one = _pair(z_ref, z_test)
    return out(ratio(rms(r - y), rms(r)), one)


def e_mre_ref(z_ref: ArrayLike, z_test: ArrayLike) -> float | np.ndarray:
    """Maximum reference error e_MRE,ref = max|z^r − z'| / max|z^r| (eq. 2 with z^r)."""
    r, y, one = _pair(z_ref, z_test)
    return out(ratio(peak(r - y), peak(r)), one)


def e_peak_ref(z_ref: ArrayLike, z_test: ArrayLike) -> float | np.ndarray:
    """Peak reference error e_peak,ref = |max|z^r| − max|z'|| / max|z^r| (eq. 3 with z^r)."""
    r, y, one = _pair(z_ref, z_test)
    pr = peak(r)
    return out(ratio(np.abs(pr - peak(y)), pr), one)


def e_rel_ref_f(z_ref: ArrayLike, z_test: ArrayLike, *,
                magnitude_only: bool = False) -> float | np.ndarray:
    """Relative RMS reference error in the frequency domain e_rel,ref,f (eq. 4 with z^r).

    RMS(|Z^r − Z'|) / RMS(|Z^r|) over the one-sided bins; ``magnitude_only=True`` uses
    RMS(|Z^r| − |Z'|) as printed (see :func:`rths3d.metrics.tracking.e_rel_track_f`).
    """
    r, y, one = _pair(z_ref, z_test)
    return out(spectral_rel_error(one_sided_amplitude(r), one_sided_amplitude(y),
                                  magnitude_only), one)
