"""Frequency Evaluation Index FEI (Guo et al. 2014; paper eqs. 5–8).

Weights come from the *commanded* spectrum: Z_n,j = |Z_j|^l (eq. 5, l = 2 by default).
With Z, Z' the one-sided spectra of z and z' (bins j = 1 … N/2, f_j = j / (N ΔT)):

    FEI  = Σ (Z'_j / Z_j) Z_n,j / Σ Z_n,j        f_eq = Σ f_j Z_n,j / Σ Z_n,j      (eq. 6)
    A    = |FEI|                                                                  (eq. 7)
    Φ    = atan2(Im FEI, Re FEI)   d = −Φ / (2π f_eq)                             (eq. 8)

Conventions chosen (and why):

- The DC bin (f = 0) is left out: it carries no phase, and a signal with an offset (the
  paper's contact test moves from 0 to a positive peak) would otherwise pull A towards the
  ratio of the means and f_eq towards 0.
- Φ uses atan2 (range (−π, π]), not atan as printed and as in the public MATLAB code, which
  folds Φ into ±π/2 and flips the sign of d for phase lags beyond 90°.
- (Z'_j / Z_j) |Z_j|^l is evaluated as Z'_j conj(Z_j) |Z_j|^(l−2): no division, so bins where
  Z_j vanishes contribute nothing instead of dividing by zero.
- d is a phase delay: it is unique only while ω_eq d < π (half a period of f_eq).
- No window: the known-answer property (d = τ, A = a for a delayed, scaled sine) is exact on
  whole periods; on other lengths spectral leakage biases d by several per cent (a 2 Hz sine
  delayed by τ = 10 ms gives d = 9.23 ms on 4.2 periods, 9.59 ms on 10.3 periods).
- Bins where |Z_j| ≤ 1e-9 · max|Z| (over all bins, DC included) are left out: a constant
  command leaves round-off there, whose ratio Z'/Z is meaningless.

Units: A dimensionless, Φ rad, d s, f_eq Hz. All NaN when the command has no AC content.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from ._signals import as_pair, check_dt
from .tracking import one_sided_amplitude


@dataclass(frozen=True)
class FEIResult:
    """FEI and the quantities derived from it (floats, or (ndof,) arrays for several DOFs).

    ``fei``: complex FEI (eq. 6); ``A`` amplitude ratio (eq. 7); ``phi`` phase Φ in rad
    (eq. 8); ``d`` delay in s (eq. 8); ``f_eq`` equivalent frequency in Hz (eq. 6).
    """

    fei: complex | np.ndarray
    A: float | np.ndarray
    phi: float | np.ndarray
    d: float | np.ndarray
    f_eq: float | np.ndarray


FLOOR = 1e-9
"""Bins with |Z_j| ≤ FLOOR · max|Z| are treated as empty (round-off, not content)."""


def fei_spectra(z_spec: np.ndarray, zp_spec: np.ndarray, freqs: np.ndarray,
                l: float = 2.0, floor: np.ndarray | None = None
                ) -> tuple[np.ndarray, np.ndarray]:
    """FEI and f_eq from one-sided spectra (bins × DOFs, DC already removed) and f_j (Hz).

    ``floor`` (per DOF, unit of z): bins with |Z_j| ≤ floor are left out; default
    :data:`FLOOR` times the largest |Z_j| given.
    """
    mag = np.abs(z_spec)
    if floor is None:
        floor = FLOOR * (mag.max(axis=0) if mag.size else np.zeros(mag.shape[1]))
    keep = mag > floor
    w = np.where(keep, mag**l, 0.0)
    if l == 2.0:
        num = np.einsum("ij,ij->j", zp_spec, np.conj(z_spec) * keep)
    else:
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(keep, mag ** (l - 2.0), 0.0)
        num = np.einsum("ij,ij->j", zp_spec, np.conj(z_spec) * scale)
    den = np.ones(w.shape[0]) @ w
    with np.errstate(divide="ignore", invalid="ignore"):
        fei = np.where(den > 0.0, num / den, np.nan + 0j)
        f_eq = np.where(den > 0.0, freqs @ w / den, np.nan)
    return fei, f_eq


def fei(z: ArrayLike, z_meas: ArrayLike, dt: float, l: float = 2.0) -> FEIResult:
    """Frequency Evaluation Index of commanded z against achieved z' (eqs. 5–8).

    Parameters
    ----------
    z, z_meas:
        (N,) or (N, ndof) commanded and achieved displacement (m or rad).
    dt:
        Sample interval ΔT (s).
    l:
        Weight exponent of eq. (5) (default 2, the paper's and Guo's choice); must be > 0.

    For z = sin 2πft and z' = a sin 2πf(t − τ) on whole periods: A = a, d = τ, f_eq = f.
    On records that are not whole periods leakage biases d by several per cent: for
    f = 2 Hz, τ = 10 ms, d = 9.23 ms on 4.2 periods and 9.59 ms on 10.3 periods. NaN when
    the command has no AC content (constant, or zero).
    """
    from ..errors import ConfigError

    step = check_dt(dt)
    if not (np.isfinite(l) and l > 0):
        raise ConfigError("l", l, "FEI weight exponent must be finite and > 0")
    a, b, one = as_pair(z, z_meas, ("z", "z_meas"))
    return fei_from_spectra(one_sided_amplitude(a), one_sided_amplitude(b), a.shape[0], step,
                            l, one)


def fei_from_spectra(z_spec: np.ndarray, zp_spec: np.ndarray, n: int, dt: float,
                     l: float = 2.0, one_d: bool = False) -> FEIResult:
    """FEI from one-sided spectra (all rfft bins of n samples, DC included, then dropped)."""
    freqs = np.fft.rfftfreq(int(n), dt)[1:]
    # the floor counts the DC bin: a constant command's round-off is tiny next to its mean
    floor = FLOOR * np.abs(z_spec).max(axis=0)
    f, f_eq = fei_spectra(z_spec[1:], zp_spec[1:], freqs, float(l), floor)
    return _result(f, f_eq, one_d)


def _result(f: np.ndarray, f_eq: np.ndarray, one: bool) -> FEIResult:
    amp = np.abs(f)
    phi = np.arctan2(f.imag, f.real)
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.where(f_eq > 0, -phi / (2.0 * np.pi * f_eq), np.nan)
    if one:
        return FEIResult(complex(f[0]), float(amp[0]), float(phi[0]), float(d[0]),
                         float(f_eq[0]))
    return FEIResult(f, amp, phi, d, f_eq)
