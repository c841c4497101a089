"""Measures read off the Synchronization Subspace Plot (SSP): z' plotted against z.

Orientation and sense of rotation. This package draws the SSP with the command z on the
horizontal axis and the achieved z' on the vertical axis. A lagging actuator
(z' = a sin ω(t − τ), τ > 0) then traces its ellipse *counter-clockwise*; drawn the paper's way
(z vertical, z' horizontal) the same record runs clockwise, as the paper's Fig. 2 says. The
sign conventions below do not depend on the drawing: lag gives TI < 0 and a positive PAEI
phase.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ._signals import as_pair, col_mean, out


def ti_history(z: ArrayLike, z_meas: ArrayLike) -> np.ndarray:
    """Running tracking indicator TI(t) of Mercan & Ricles, same shape as z.

    TI = ½ (A − TA), A = ∫ z' dz, TA = ∫ z dz' (cumulative trapezoidal sums, TI(t_0) = 0).
    For z = sin ωt, z' = a sin(ωt − φ) each whole period adds −π a sin φ: lag drives TI
    negative, lead positive. Units: (unit of z)². Qualitative only: it scales with the
    amplitude squared (paper).
    """
    a, b, one = as_pair(z, z_meas, ("z", "z_meas"), min_samples=2)
    # ½(A − TA) per step reduces to ½ (z'_i z_{i+1} − z_i z'_{i+1}) (trapezoid, exact algebra)
    inc = 0.5 * (b[:-1] * a[1:] - a[:-1] * b[1:])
    hist = np.zeros_like(a)
    np.cumsum(inc, axis=0, out=hist[1:])
    return hist[:, 0] if one else hist


def ti(z: ArrayLike, z_meas: ArrayLike) -> float | np.ndarray:
    """Tracking indicator TI at the end of the record (see :func:`ti_history`), (unit of z)²."""
    a, b, one = as_pair(z, z_meas, ("z", "z_meas"), min_samples=2)
    return out(0.5 * np.einsum("ij,ij->j", b[:-1], a[1:]) -
               0.5 * np.einsum("ij,ij->j", a[:-1], b[1:]), one)


def _moments(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    am = a - col_mean(a)
    bm = b - col_mean(b)
    n = a.shape[0]
    return (np.einsum("ij,ij->j", am, am) / n, np.einsum("ij,ij->j", am, bm) / n,
            np.einsum("ij,ij->j", bm, bm) / n)


def theta_pc(z: ArrayLike, z_meas: ArrayLike) -> float | np.ndarray:
    """Amplitude indicator Θ_PC: slope of the SSP's major axis, tan θ (dimensionless).

    θ is the angle of the first principal component of the centred samples (z, z'),
    θ = ½ atan2(2 s_zz', s_zz − s_z'z'). The slope tan θ is the amplitude ratio z'/z seen by
    the SSP: 1 = perfect, < 1 undershoot, > 1 overshoot. For z' = a z it equals a exactly;
    with phase lag the major axis also tilts, so it is an indicator, not the gain. NaN when
    the command z is constant (its centred variance s_zz ≤ 1e-18 mean(z²), i.e. round-off):
    the axis is then vertical and its slope undefined.
    """
    a, b, one = as_pair(z, z_meas, ("z", "z_meas"))
    sxx, sxy, syy = _moments(a, b)
    theta = 0.5 * np.arctan2(2.0 * sxy, sxx - syy)
    slope = np.tan(theta)
    # removing the mean of a constant leaves round-off, which tan(≈ π/2) blows up to ~1e16
    msq = np.einsum("ij,ij->j", a, a) / a.shape[0]
    return out(np.where(sxx > 1e-18 * msq, slope, np.nan), one)


def fit_ellipse(x: np.ndarray, y: np.ndarray) -> np.ndarray | None:
    """Direct least-squares ellipse fit (Fitzgibbon, Pilu & Fisher 1999).

    Numerically stable form of Halíř & Flusser (1998). Returns the conic coefficients
    (a, b, c, d, e, f) of a x² + b xy + c y² + d x + e y + f = 0 in the *given* coordinates,
    normalised to unit length, or None when no ellipse fits (collinear or too few points).
    """
    x = np.asarray(x, float)
    y = np.asarray(y, float)
    if x.size < 6:
        return None
    mx, my = x.mean(), y.mean()
    sx, sy = x.std(), y.std()
    if sx == 0.0 or sy == 0.0:
        return None
    u, v = (x - mx) / sx, (y - my) / sy  # conditioning: fit in scaled, centred coordinates
    d1 = np.column_stack((u * u, u * v, v * v))
    d2 = np.column_stack((u, v, np.ones_like(u)))
    s1, s2, s3 = d1.T @ d1, d1.T @ d2, d2.T @ d2
    try:
        t = -np.linalg.solve(s3, s2.T)
    except np.linalg.LinAlgError:
        return None
    m = s1 + s2 @ t
    m = np.array([m[2] / 2.0, -m[1], m[0] / 2.0])  # C1⁻¹ M, C1 the ellipse constraint
    try:
        w, vec = np.linalg.eig(m)
    except np.linalg.LinAlgError:
        return None
    vec = np.real(vec)
    cond = 4.0 * vec[0] * vec[2] - vec[1] ** 2
    ok = np.flatnonzero((cond > 0) & np.isfinite(cond))
    if ok.size == 0:
        return None
    a1 = vec[:, ok[np.argmin(np.abs(np.real(w[ok])))]]
    a2 = t @ a1
    A, B, C = a1
    D, E, F = a2
    # back to the original coordinates: u = (x − mx)/sx, v = (y − my)/sy
    a_ = A / sx**2
    b_ = B / (sx * sy)
    c_ = C / sy**2
    d_ = -2 * A * mx / sx**2 - B * my / (sx * sy) + D / sx
    e_ = -2 * C * my / sy**2 - B * mx / (sx * sy) + E / sy
    f_ = (A * mx**2 / sx**2 + B * mx * my / (sx * sy) + C * my**2 / sy**2
          - D * mx / sx - E * my / sy + F)
    coef = np.array([a_, b_, c_, d_, e_, f_])
    return coef / np.linalg.norm(coef)


def _paei_one(x: np.ndarray, y: np.ndarray, area_sign: float) -> tuple[float, float]:
    sxx = float(np.var(x))
    syy = float(np.var(y))
    if sxx == 0.0 or syy == 0.0:
        return float("nan"), float("nan")
    sxy = float(np.mean((x - x.mean()) * (y - y.mean())))
    # A straight line has no ellipse: zero phase, amplitude = slope of the line
    if sxx * syy - sxy * sxy <= 1e-12 * sxx * syy:
        return 0.0, float(np.sign(sxy) * np.sqrt(syy / sxx))
    coef = fit_ellipse(x, y)
    if coef is None:
        return float("nan"), float("nan")
    a, b, c = coef[:3]
    # z = A sin θ, z' = B sin(θ − φ) ⇔ (z/A)² − 2 cos φ (z/A)(z'/B) + (z'/B)² = sin² φ, so
    # B/A = √(a/c), cos φ = −sign(a) b / (2√(ac)), sin φ = √(4ac − b²) / (2√(ac)).
    amp = float(np.sqrt(a / c))
    phase = float(np.arctan2(np.sqrt(max(4 * a * c - b * b, 0.0)), -np.sign(a) * b))
    return (phase if area_sign <= 0 else -phase), amp


def paei(z: ArrayLike, z_meas: ArrayLike) -> tuple[float | np.ndarray, float | np.ndarray]:
    """Phase and Amplitude Error Indices (Mercan's PAEI) by an ellipse fit to the SSP.

    Fits z = A sin θ, z' = B sin(θ − φ) to the whole record by a direct least-squares
    ellipse fit (:func:`fit_ellipse`) and returns ``(phase, amp)``:

    - ``phase`` φ (rad): the actuator phase lag, positive for lag, negative for lead (sign from
      the sense of rotation, i.e. of TI); computed as atan2(sin φ, cos φ) from the conic so
      that it is well conditioned from 0 to π.
    - ``amp`` B/A (dimensionless): achieved over commanded amplitude, 1 = perfect.

    The record must cover at least half a cycle (paper). A straight-line SSP returns phase 0
    and the line's slope; constant signals or a failed fit return NaN. Assumes one dominant
    frequency (an ellipse); for broadband signals it is a least-squares compromise.
    """
    a, b, one = as_pair(z, z_meas, ("z", "z_meas"))
    sense = 0.5 * (np.einsum("ij,ij->j", b[:-1], a[1:]) - np.einsum("ij,ij->j", a[:-1], b[1:]))
    at, bt = np.ascontiguousarray(a.T), np.ascontiguousarray(b.T)
    res = [_paei_one(at[j], bt[j], float(sense[j])) for j in range(a.shape[1])]
    ph = np.array([r[0] for r in res])
    am = np.array([r[1] for r in res])
    return out(ph, one), out(am, one)


def paei_history(z: ArrayLike, z_meas: ArrayLike, dt: float, window: float,
                 step: float | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """PAEI on a moving window, as Mercan's indices are used online.

    Parameters
    ----------
    z, z_meas:
        (N,) commanded and achieved displacement of one DOF.
    dt:
        Sample interval (s).
    window:
        Window length (s); it must cover at least half a cycle of the motion (paper).
    step:
        Hop between windows (s), default window / 4.

    Returns ``(t_mid, phase, amp)``: window centre times measured from the first sample (s),
    phase lag φ (rad, positive for lag) and amplitude ratio B/A per window (NaN where a window
    has no ellipse, e.g. constant signals).
    """
    from ..errors import ConfigError
    from ._signals import check_dt

    step_s = check_dt(dt)
    a, b, one = as_pair(z, z_meas, ("z", "z_meas"))
    if not one:
        raise ConfigError("z", a.shape, "paei_history takes one DOF: (N,) signals")
    sizes = {}
    for name, value in (("window", window), ("step", step)):
        if value is None:
            continue
        try:
            sizes[name] = float(value)
        except (TypeError, ValueError) as exc:
            raise ConfigError(name, value, "s; must be a number") from exc
        if not (np.isfinite(sizes[name]) and sizes[name] > 0):
            raise ConfigError(name, sizes[name], "s; must be finite and > 0")
    w = int(round(sizes["window"] / step_s))
    if not (6 <= w <= a.shape[0]):
        raise ConfigError("window", window, f"s; must span 6 to {a.shape[0]} samples")
    h = max(1, int(round(sizes.get("step", sizes["window"] / 4) / step_s)))
    starts = np.arange(0, a.shape[0] - w + 1, h)
    x, y = np.ascontiguousarray(a[:, 0]), np.ascontiguousarray(b[:, 0])
    # TI increments; their sum over a window gives its sense of rotation
    inc = np.concatenate(([0.0], np.cumsum(0.5 * (y[:-1] * x[1:] - x[:-1] * y[1:]))))
    res = [_paei_one(x[s:s + w], y[s:s + w], float(inc[s + w - 1] - inc[s])) for s in starts]
    t_mid = (starts + (w - 1) / 2.0) * step_s
    return t_mid, np.array([r[0] for r in res]), np.array([r[1] for r in res])
