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
