"""Tracking errors of the transfer system: commanded z against achieved z' (paper eqs. 1–4).

All four are dimensionless ratios. The gap is g = z − z'. The paper's ANN features normalise
eq. (1) by the command z, eq. (4) by its spectrum Z, and eqs. (2) and (3) by the achieved z'
("(1) was normalized with z, (4) with Z and (2) and (3) with z'"); these are the defaults, and
``norm="commanded"`` / ``norm="measured"`` choose the other. Peaks are taken as max |·| (the
paper writes max(z), which equals max |z| for a signal symmetric about zero and stays
meaningful for one that is not).

A zero normaliser (e.g. a zero command) makes the ratio undefined: NaN is returned.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from numpy.typing import ArrayLike

from ._signals import as_pair, out, peak, ratio, rms

Norm = Literal["commanded", "measured"]


def _norm_signal(z: np.ndarray, zp: np.ndarray, norm: str) -> np.ndarray:
    if norm == "commanded":
        return z
    if norm == "measured":
        return zp
    from ..errors import ConfigError

    raise ConfigError("norm", norm, "must be 'commanded' or 'measured'")


def e_rel_track(z: ArrayLike, z_meas: ArrayLike, norm: Norm = "commanded") -> float | np.ndarray:
    """Relative RMS tracking error e_rel,track = RMS(z − z') / RMS(z), eq. (1).

    Parameters
    ----------
    z, z_meas:
        Commanded z and achieved z' interface displacement, (N,) or (N, ndof), m or rad.
    norm:
        ``"commanded"`` (paper feature, default) divides by RMS(z), ``"measured"`` by RMS(z').

    For z = sin ωt and z' = a sin ω(t − τ) over whole periods this is
    √(1 + a² − 2a cos ωτ). Dimensionless; NaN when the normaliser is zero.
    """
    a, b, one = as_pair(z, z_meas, ("z", "z_meas"))
    return out(ratio(rms(a - b), rms(_norm_signal(a, b, norm))), one)


def e_mte_track(z: ArrayLike, z_meas: ArrayLike, norm: Norm = "measured") -> float | np.ndarray:
    """Maximum tracking error e_MTE,track = max|z − z'| / max|z'|, eq. (2).

    Normalised by the achieved z' (paper feature, default) or by z (``norm="commanded"``).
    Dimensionless; NaN when the normaliser is zero.
    """
    a, b, one = as_pair(z, z_meas, ("z", "z_meas"))
    return out(ratio(peak(a - b), peak(_norm_signal(a, b, norm))), one)


def e_peak_track(z: ArrayLike, z_meas: ArrayLike, norm: Norm = "measured") -> float | np.ndarray:
    """Peak tracking error e_peak,track = |max|z| − max|z'|| / max|z'|, eq. (3).

    Compares the peaks only (timing is ignored). Normalised by z' (paper feature, default)
    or by z. Dimensionless; NaN when the normaliser is zero.
    """
    a, b, one = as_pair(z, z_meas, ("z", "z_meas"))
    pa, pb = peak(a), peak(b)
    return out(ratio(np.abs(pa - pb), peak(_norm_signal(a, b, norm))), one)


def one_sided_amplitude(x: np.ndarray) -> np.ndarray:
    """One-sided complex amplitude spectrum of the columns of x (N, ndof).

    rfft with the interior bins doubled (bins 0 and, for even N, N/2 are not), so that
    |X_j| is the amplitude of the sinusoid at f_j = j / (N ΔT).
    """
    spec = np.fft.rfft(x, axis=0)
    stop = spec.shape[0] - 1 if x.shape[0] % 2 == 0 else spec.shape[0]
    spec[1:stop] *= 2.0
    return spec


def e_rel_track_f(z: ArrayLike, z_meas: ArrayLike, *,
                  magnitude_only: bool = False) -> float | np.ndarray:
    """Relative RMS tracking error in the frequency domain e_rel,track,f, eq. (4).

    Default (the reading this package uses): RMS over the one-sided bins of |Z − Z'|
    divided by RMS(|Z|), Z and Z' the one-sided spectra of z and z'. By Parseval this is the
    spectral twin of eq. (1) and is linearly related to e_rel,track, which is what the paper
    reports ("fully correlated") for its own implementation.

    ``magnitude_only=True`` evaluates eq. (4) as printed, RMS(|Z| − |Z'|) / RMS(|Z|): it
    compares amplitude spectra only and is blind to delay (a pure delay gives 0), so it is
    *not* linearly related to e_rel,track on delayed signals (tested).

    Dimensionless; NaN when Z is identically zero.
    """
    a, b, one = as_pair(z, z_meas, ("z", "z_meas"))
    return out(spectral_rel_error(one_sided_amplitude(a), one_sided_amplitude(b),
                                  magnitude_only), one)


def spectral_rel_error(spec: np.ndarray, spec_other: np.ndarray,
                       magnitude_only: bool = False) -> np.ndarray:
    """RMS(|S − S'|) / RMS(|S|) (or RMS(|S| − |S'|) / RMS(|S|)) over one-sided bins, per DOF."""
    diff = np.abs(spec) - np.abs(spec_other) if magnitude_only else np.abs(spec - spec_other)
    return ratio(rms(diff), rms(np.abs(spec)))
