"""Eigen-analysis for the τ-ratios (paper eqs. 12–13), multi-DOF generalisation.

ω_0,NUM is the fastest undamped eigenfrequency of the numerical substructure, from the
generalised eigenproblem K v = ω² M v. ω_0,DYN is the fastest eigenfrequency of the coupled
system with the experimental part condensed to interface mass and stiffness matrices:
(K + Γ k_EXP Γᵀ) v = ω² (M + Γ m_EXP Γᵀ) v. For one DOF this is eq. (12),
ω_0,DYN = √((k_NUM + k_EXP)/(m_NUM + m_EXP)).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike


def fastest_eigenfrequency(M: np.ndarray, K: np.ndarray) -> float:
    """Largest undamped circular eigenfrequency ω (rad/s) of K v = ω² M v."""
    M = np.atleast_2d(np.asarray(M, float))
    K = np.atleast_2d(np.asarray(K, float))
    if M.shape == (1, 1):
        return float(np.sqrt(max(K[0, 0] / M[0, 0], 0.0)))
    w2 = scipy.linalg.eigh(K, M, eigvals_only=True)
    return float(np.sqrt(max(float(w2.max()), 0.0)))


def coupled_fastest_eigenfrequency(M: np.ndarray, K: np.ndarray, gamma: np.ndarray,
                                   m_exp: np.ndarray, k_exp: np.ndarray) -> float:
    """ω_0,DYN (rad/s): fastest eigenfrequency with the experimental part's interface mass
    ``m_exp`` and stiffness ``k_exp`` (n_if × n_if) added through Γ (n × n_if)."""
    G = np.atleast_2d(np.asarray(gamma, float))
    Mc = np.asarray(M, float) + G @ np.atleast_2d(m_exp) @ G.T
    Kc = np.asarray(K, float) + G @ np.atleast_2d(k_exp) @ G.T
    return fastest_eigenfrequency(Mc, Kc)


def part_impedance(w: np.ndarray, m_exp: ArrayLike, c_exp: ArrayLike, k_exp: ArrayLike
                   ) -> np.ndarray:
    """Interface impedance Z(iω) = F/z' (N/m, N·m/rad) of parts that sit *behind* their
    springs on the mount (this package's experimental parts, contact open): per interface DOF
    Z = (c s + k)·m s² / (m s² + c s + k), s = iω. Shape (len(w), n_if, n_if), diagonal."""
    s = 1j * np.asarray(w, float)[:, None]
    m = np.diag(np.atleast_2d(np.asarray(m_exp, float)))
    c = np.diag(np.atleast_2d(np.asarray(c_exp, float)))
    k = np.diag(np.atleast_2d(np.asarray(k_exp, float)))
    z = (c * s + k) * m * s * s / (m * s * s + c * s + k)
    out = np.zeros(z.shape + (z.shape[1],), complex)
    idx = np.arange(z.shape[1])
    out[:, idx, idx] = z
    return out


def interface_delay_margin(M: np.ndarray, C: np.ndarray, K: np.ndarray, gamma: np.ndarray,
                           m_exp: ArrayLike, c_exp: ArrayLike, k_exp: ArrayLike, *,
                           n_grid: int = 1500) -> tuple[float, float, float]:
    """(τ_cr s, ω_c rad/s, PM rad): the smallest interface delay that destabilises the
    coupled linear test, the crossover that sets it and its phase margin.

    With a delay τ on the achieved motion, z' = z e^(−sτ), the coupled system's
    characteristic equation is det(I + L(iω) e^(−iωτ)) = 0 with the interface loop
    L = Z Γᵀ P⁻¹ Γ, P = −ω²M + iωC + K, Z the part's impedance (:func:`part_impedance`). A
    delay can destabilise only where an eigenvalue μ of L has |μ| = 1 (a crossover ω_c);
    there the phase margin is PM = angle(μ) + π (mod 2π) and the delay margin PM/ω_c.
    Returns (inf, nan, nan) when |μ| < 1 at every frequency (stable for any delay). The
    coupled system without delay is assumed stable. Crossings are bracketed on a log grid
    around all the eigenfrequencies and refined by bisection on |μ| − 1 (μ sorted by modulus).
    """
    M = np.atleast_2d(np.asarray(M, float))
    C = np.atleast_2d(np.asarray(C, float))
    K = np.atleast_2d(np.asarray(K, float))
    G = np.atleast_2d(np.asarray(gamma, float))
    me, ce, ke = (np.atleast_2d(np.asarray(a, float)) for a in (m_exp, c_exp, k_exp))
    from scipy.optimize import brentq

    def mus(w: np.ndarray) -> np.ndarray:
        if M.shape == (1, 1) and me.shape == (1, 1):
            # one DOF each side: L = Z Γ² / P, no matrix algebra (sweeps call this per test)
            s1 = 1j * w
            m_, c_, k_ = me[0, 0], ce[0, 0], ke[0, 0]
            z = (c_ * s1 + k_) * m_ * s1 * s1 / (m_ * s1 * s1 + c_ * s1 + k_)
            return (z * G[0, 0] ** 2 / (M[0, 0] * s1 * s1 + C[0, 0] * s1 + K[0, 0]))[:, None]
        s = 1j * w[:, None, None]
        P = s * s * M + s * C + K
        L = part_impedance(w, me, ce, ke) @ (G.T @ np.linalg.solve(P, np.broadcast_to(G, (
            w.size,) + G.shape)))
        mu = np.linalg.eigvals(L)
        return np.take_along_axis(mu, np.argsort(np.abs(mu), axis=1), axis=1)

    wn = [fastest_eigenfrequency(M, K), np.sqrt(np.diag(ke) / np.diag(me)).max(),
          coupled_fastest_eigenfrequency(M, K, G, me, ke)]
    lo, hi = 1e-2 * min(w for w in wn if w > 0), 1e2 * max(wn)
    grid = np.geomspace(lo, hi, int(n_grid))
    table = np.abs(mus(grid)) - 1.0
    best = (np.inf, np.nan, np.nan)
    for j in range(table.shape[1]):
        sgn = np.signbit(table[:, j])
        for i in np.flatnonzero(sgn[1:] != sgn[:-1]):
            wc = float(np.exp(brentq(
                lambda lw, j=j: abs(mus(np.array([np.exp(lw)]))[0, j]) - 1.0,
                np.log(grid[i]), np.log(grid[i + 1]), xtol=1e-12)))
            mu = mus(np.array([wc]))[0, j]
            pm = float((np.angle(mu) + np.pi) % (2 * np.pi))
            if pm / wc < best[0]:
                best = (pm / wc, wc, pm)
    return best


def interface_delay_margins_1dof(m: ArrayLike, c: ArrayLike, k: ArrayLike, gamma: ArrayLike,
                                 m_exp: ArrayLike, c_exp: ArrayLike, k_exp: ArrayLike, *,
                                 n_grid: int = 1500, iterations: int = 60
                                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`interface_delay_margin` of T tests with one DOF on each side, all at once:
    arrays (T,) of τ_cr (s), ω_c (rad/s) and PM (rad) for the numerical m (kg), c (N·s/m),
    k (N/m), Γ and the part's m_exp, c_exp, k_exp (one value or one per test).

    The same grid and brackets as the scalar function; each bracket is refined by
    ``iterations`` bisections on log ω for every test together (60 halve the grid's
    bracket far below the scalar function's 1e-12), so the margins agree with it to
    rounding. Tests whose eigenfrequencies do not give a finite grid (a massless part) get
    NaN: the caller asks the scalar function for them."""
    m, c, k, g, me, ce, ke = np.broadcast_arrays(*(np.asarray(a, float).reshape(-1) for a in
                                                   (m, c, k, gamma, m_exp, c_exp, k_exp)))
    T = m.size
    with np.errstate(divide="ignore", invalid="ignore"):
        wn = np.stack([np.sqrt(np.maximum(k / m, 0.0)), np.sqrt(ke / me),
                       np.sqrt(np.maximum((k + g * g * ke) / (m + g * g * me), 0.0))])
        pos = np.where(wn > 0, wn, np.inf).min(axis=0)
        lo, hi = 1e-2 * pos, 1e2 * wn.max(axis=0)
    ok = np.isfinite(lo) & np.isfinite(hi) & (lo > 0) & (hi > lo)
    tau = np.full(T, np.inf)
    wc_out = np.full(T, np.nan)
    pm_out = np.full(T, np.nan)
    tau[~ok] = np.nan
    if not ok.any():
        return tau, wc_out, pm_out
    idx = np.flatnonzero(ok)

    def mu(w: np.ndarray, r: np.ndarray) -> np.ndarray:
        s1 = 1j * w
        z = (ce[r] * s1 + ke[r]) * me[r] * s1 * s1 / (me[r] * s1 * s1 + ce[r] * s1 + ke[r])
        return z * g[r] ** 2 / (m[r] * s1 * s1 + c[r] * s1 + k[r])

    # the scalar function's grid, np.geomspace per test (the same floating-point points)
    grid = np.geomspace(lo[idx], hi[idx], int(n_grid), axis=1)
    # where |μ| crosses 1 on the grid: |μ|² in real arithmetic (the complex μ of every grid
    # point cost 0.15 s for 512 tests), the same sign but where |μ| is 1 to rounding
    w2 = grid * grid
    rows = idx[:, None]
    num2 = (ke[rows] ** 2 + (ce[rows] * grid) ** 2) * (me[rows] * w2) ** 2 * g[rows] ** 4
    den2 = ((ke[rows] - me[rows] * w2) ** 2 + (ce[rows] * grid) ** 2) * \
        ((k[rows] - m[rows] * w2) ** 2 + (c[rows] * grid) ** 2)
    sgn = np.signbit(num2 - den2)
    ti, gi = np.nonzero(sgn[:, 1:] != sgn[:, :-1])
    if not ti.size:
        return tau, wc_out, pm_out
    r = idx[ti]
    a, b = np.log(grid[ti, gi]), np.log(grid[ti, gi + 1])
    fa = np.abs(mu(np.exp(a), r)) - 1.0
    for _ in range(int(iterations)):
        mid = 0.5 * (a + b)
        fm = np.abs(mu(np.exp(mid), r)) - 1.0
        left = np.signbit(fm) == np.signbit(fa)
        a = np.where(left, mid, a)
        fa = np.where(left, fm, fa)
        b = np.where(left, b, mid)
    wc = np.exp(0.5 * (a + b))
    pm = (np.angle(mu(wc, r)) + np.pi) % (2 * np.pi)
    t = pm / wc
    for j in np.argsort(-t):  # the smallest delay of each test written last
        tau[r[j]], wc_out[r[j]], pm_out[r[j]] = t[j], wc[j], pm[j]
    return tau, wc_out, pm_out
