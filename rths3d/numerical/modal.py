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
