"""Identifying an LTI model from a measured response: the excitation (a Schroeder multisine)
and the fit of a transfer function with a transport delay to a frequency response.

Used by the platform's heave identification (:mod:`rths3d.platform.calibrate.heave`), the
inverse-model compensator's identification (:mod:`rths3d.compensation.inverse`) and the RTHS
benchmark's calibration test (:mod:`rths3d.community.compensated`).
"""

from __future__ import annotations

import numpy as np

from ..errors import ConfigError

__all__ = ["fit_transfer_function", "multisine"]


def multisine(f_min: float = 0.1, f_max: float = 50.0, n_lines: int = 40, period: float = 10.0,
              amplitude: float = 5e-4, velocity: float = 5e-3,
              dt: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
    """One period of a heave multisine: (lines in Hz, samples (N,) in m).

    Lines are log-spaced multiples of ``1/period`` between ``f_min`` and ``f_max``; each has
    amplitude ``min(amplitude, velocity / (2π f))`` (m) and a Schroeder phase, which keeps the
    crest factor low. Samples at ``t_k = (k+1)·dt``.
    """
    if not (0 < f_min < f_max <= 0.5 / dt):
        raise ConfigError("frequency range", (f_min, f_max),
                          f"need 0 < f_min < f_max <= Nyquist {0.5 / dt:g} Hz")
    df = 1.0 / period
    k = np.unique(np.round(np.geomspace(f_min / df, f_max / df, n_lines)).astype(int))
    f = k * df
    amp = np.minimum(amplitude, velocity / (2 * np.pi * f))
    phase = -np.pi * np.arange(len(k)) * (np.arange(len(k)) + 1) / len(k)
    n = int(round(period / dt))
    t = (np.arange(n) + 1) * dt
    z = (amp[None, :] * np.sin(2 * np.pi * f[None, :] * t[:, None] + phase)).sum(axis=1)
    return f, z


def _tf_eval(num: np.ndarray, den: np.ndarray, delay: float, f: np.ndarray) -> np.ndarray:
    s = 2j * np.pi * f
    return np.polyval(num, s) / np.polyval(den, s) * np.exp(-s * delay)


def fit_transfer_function(f: np.ndarray, H: np.ndarray, n_num: int = 1, n_den: int = 2,
                          guess: tuple[np.ndarray, np.ndarray, float] | None = None,
                          gain_tol: float = 0.01, delay_tol: float = 1e-4
                          ) -> tuple[np.ndarray, np.ndarray, float, float]:
    """Fit ``num(s)/den(s)·exp(−sT)`` (den with constant term 1) to H at f (Hz).

    The residual per line is the complex log ratio ``log(G/H)``: its real part (relative gain
    error) scaled by ``gain_tol`` and its imaginary part turned into a phase-delay error
    (``∠(G/H)/ω``, s) scaled by ``delay_tol`` — so a 1 % gain error weighs as much as a 0.1 ms
    delay error at every frequency, and the low-frequency delay that matters for RTHS
    stability is kept. The delay (T ≥ 0) and the denominator coefficients (≥ 0, necessary
    for stable poles) are bounded. Returns ``(num, den, delay,
    fit_error)`` with descending-power coefficients and the relative RMS complex error
    ``‖G − H‖ / ‖H‖``. Coefficients are fitted in time-scaled form (powers of s·τ_ref).
    """
    from scipy.optimize import least_squares

    f = np.asarray(f, float)
    H = np.asarray(H, complex)
    w = 2 * np.pi * f
    tau = 1.0 / (2 * np.pi * np.sqrt(f.min() * f.max()))  # reference time scale (s)
    num0 = np.zeros(n_num + 1)
    num0[-1] = 1.0
    den0 = np.zeros(n_den + 1)
    den0[-1] = 1.0
    delay0 = 0.0
    if guess is not None:
        gn, gd, delay0 = np.asarray(guess[0], float), np.asarray(guess[1], float), guess[2]
        k = min(len(gn), n_num + 1)
        num0[-k:] = gn[-k:]
        k = min(len(gd), n_den + 1)
        den0[-k:] = gd[-k:]
        den0[-1] = 1.0
    pn = np.arange(n_num, -1, -1)
    pd = np.arange(n_den, 0, -1)
    x0 = np.concatenate([num0 / tau ** pn, den0[:-1] / tau ** pd, [max(delay0, 0.0) / tau]])

    def unpack(x: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        num = x[: n_num + 1] * tau ** pn
        den = np.concatenate([x[n_num + 1: n_num + 1 + n_den] * tau ** pd, [1.0]])
        return num, den, float(x[-1] * tau)

    def resid(x: np.ndarray) -> np.ndarray:
        num, den, d = unpack(x)
        r = np.log(_tf_eval(num, den, d, f) / H)
        return np.concatenate([r.real / gain_tol, r.imag / w / delay_tol])

    # denominator coefficients >= 0 (necessary for stable poles) and delay >= 0
    lo = np.full(x0.size, -np.inf)
    lo[n_num + 1:] = 0.0
    x0 = np.maximum(x0, lo)
    sol = least_squares(resid, x0, bounds=(lo, np.inf), method="trf", xtol=1e-15,
                        ftol=1e-15, gtol=1e-15, max_nfev=20000)
    num, den, d = unpack(sol.x)
    err = float(np.linalg.norm(_tf_eval(num, den, d, f) - H) / np.linalg.norm(H))
    return num, den, d, err
