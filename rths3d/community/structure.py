"""The benchmark's reference structure and its four partitioning cases (Silva et al., §2–3).

A planar 3-story, 2-bay steel frame with pinned bases. Its 12-DOF analytical stiffness (floor
sways and joint rotations) is condensed statically to the three lateral floor DOFs; masses are
lumped per floor; damping is modal with ζ equal in all modes and the natural frequencies
rounded to 0.01 rad/s (as the benchmark's ``modes.m`` does). The first story is the
experimental substructure (specimen m_e, c_e, k_e at floor 1, interface vector γ = [1, 0, 0]ᵀ);
the numerical substructure is the rest: M_n = M − M_e, C_n = C − C_e, K_n = K − K_e.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError

__all__ = ["CASES", "E_STEEL", "I_BEAM", "I_COLUMN", "L_BEAM", "L_COLUMN", "CaseMatrices",
           "PartitionCase", "case_matrices", "frame_stiffness", "modal_damping"]

E_STEEL = 200e9  # Pa
I_COLUMN = 2.520 * 0.0254**4  # m⁴ (S3×5.7 column, 2.520 in⁴)
I_BEAM = 255267e-12  # m⁴ (255 267 mm⁴)
L_COLUMN = 0.635  # m, story height
L_BEAM = 0.762  # m, bay width


def frame_stiffness(E: float = E_STEEL, Ic: float = I_COLUMN, Ib: float = I_BEAM,
                    h: float = L_COLUMN, L: float = L_BEAM) -> np.ndarray:
    """Lateral 3×3 stiffness (N/m) of the frame: K = K_tt − K_rtᵀ K_rr⁻¹ K_rt.

    The 12-DOF model has floor sways 1–3 then joint rotations (exterior, interior, exterior)
    of floors 1, 2, 3; entries as in the benchmark's ``KK_mat.m``.
    """
    k = np.zeros((12, 12))

    def put(i: int, j: int, v: float) -> None:
        k[i - 1, j - 1] = v
        k[j - 1, i - 1] = v

    put(1, 1, 45 * Ic / h**3)
    put(2, 2, 72 * Ic / h**3)
    put(3, 3, 36 * Ic / h**3)
    put(1, 2, -36 * Ic / h**3)
    put(2, 3, -36 * Ic / h**3)
    for a, b, c in ((4, 6, 5), (7, 9, 8), (10, 12, 11)):
        col = {4: 7, 7: 8, 10: 4}[a] * Ic / h
        put(a, a, col + 4 * Ib / L)
        put(b, b, col + 4 * Ib / L)
        put(c, c, col + 8 * Ib / L)
    for j in (4, 5, 6):
        put(1, j, -3 * Ic / h**2)
        put(2, j, 6 * Ic / h**2)
    for j in (7, 8, 9):
        put(1, j, -6 * Ic / h**2)
    for j in (10, 11, 12):
        put(2, j, -6 * Ic / h**2)
    for j in range(7, 13):
        put(3, j, 6 * Ic / h**2)
    for i, j in ((4, 5), (5, 6), (7, 8), (8, 9), (10, 11), (11, 12)):
        put(i, j, 2 * Ib / L)
    for i, j in ((4, 7), (5, 8), (6, 9), (7, 10), (8, 11), (9, 12)):
        put(i, j, 2 * Ic / h)
    k *= E
    t, r = slice(0, 3), slice(3, 12)
    K = k[t, t] - k[r, t].T @ np.linalg.solve(k[r, r], k[r, t])
    return 0.5 * (K + K.T)


def modal_damping(M: np.ndarray, K: np.ndarray, zeta: float,
                  round_omega: float | None = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """Classical damping ``C = Φ⁻ᵀ diag(2 ζ ω_i m̂_i) Φ⁻¹`` (N·s/m) and the ω_i used (rad/s).

    ω_i are sorted ascending and, as in the benchmark, rounded to ``round_omega`` rad/s
    (half away from zero) before use; ``None`` keeps them exact.
    """
    lam, Phi = np.linalg.eig(np.linalg.solve(M, K))
    order = np.argsort(lam.real)
    lam, Phi = lam.real[order], Phi.real[:, order]
    omega = np.sqrt(lam)
    if round_omega:
        omega = np.array([math.floor(w / round_omega + 0.5) * round_omega for w in omega])
    mhat = np.einsum("ji,jk,ki->i", Phi, M, Phi)
    Pinv = np.linalg.inv(Phi)
    C = Pinv.T @ np.diag(2.0 * zeta * omega * mhat) @ Pinv
    return 0.5 * (C + C.T), omega


@dataclass(frozen=True)
class PartitionCase:
    """One partitioning case: floor mass m (kg) and modal damping ratio ζ (-)."""

    number: int
    floor_mass: float
    zeta: float


CASES: dict[int, PartitionCase] = {
    1: PartitionCase(1, 1000.0, 0.05),
    2: PartitionCase(2, 1100.0, 0.04),
    3: PartitionCase(3, 1300.0, 0.03),
    4: PartitionCase(4, 1000.0, 0.03),
}


@dataclass(frozen=True, eq=False)
class CaseMatrices:
    """Reference (M, C, K) and numerical (M_n, C_n, K_n) matrices of a case (SI)."""

    case: int
    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    Mn: np.ndarray
    Cn: np.ndarray
    Kn: np.ndarray
    omega: np.ndarray
    gamma: np.ndarray
    iota: np.ndarray


def case_matrices(case: int, m_e: float, c_e: float, k_e: float) -> CaseMatrices:
    """Matrices of partitioning ``case`` (1–4) with a specimen (m_e kg, c_e N·s/m, k_e N/m)."""
    if case not in CASES:
        raise ConfigError("case", case, "must be 1, 2, 3 or 4")
    pc = CASES[case]
    K = frame_stiffness()
    M = np.eye(3) * pc.floor_mass
    C, omega = modal_damping(M, K, pc.zeta)
    E = np.zeros((3, 3))
    E[0, 0] = 1.0
    return CaseMatrices(case, M, C, K, M - m_e * E, C - c_e * E, K - k_e * E, omega,
                        np.array([1.0, 0.0, 0.0]), np.ones(3))
