"""The maRTHS benchmark's structure, partitioning, specimen and coupler (Condori Uribe et al.
2023; FermandoisLab/maRTHS-bmk-RoDeAC), built from the numbers the benchmark states.

* Reference: the 29-DOF frame (K, M from the SAP2000 export, :func:`.data.
  load_reference_matrices`), Rayleigh damping 5 % at 13.493 and 165.125 rad/s, influence
  vector 1 at the three floor sways (equations 27, 26, 13).
* Numerical substructure: the reference minus the "ideal" 3-DOF physical model (x = eq. 27,
  rotations eq. 29 and eq. 21): K_N = K − KP, C_N = C − CP at those DOFs, M_N(27, 27) −= MP₁₁.
  The code's quirks are kept: ρ = 785e3 kg/m³ and the sign of KP₂₃ (:func:`ideal_physical`).
* Specimen as simulated (the feedback force): a 5-DOF frame [X, θ1, θ2, θ3, θ4] with modal
  damping 5 % (ω rounded to 0.01 rad/s), its unmeasured rotations condensed statically from
  the measured [x, θ] (:func:`specimen`).
* Coupler kinematics both ways (:func:`frame_to_actuator`, :func:`actuator_to_frame`), with
  the model's ``s`` (not asin s) inside the cosine.
* Newmark average acceleration as the benchmark's MATLAB Function block steps it
  (:func:`newmark_matrices`, :func:`newmark_step`, :func:`newmark_response`).

Equation numbers in this module are SAP2000's, 1-based (``EQ_X = 27`` is row 26).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from ..structure import modal_damping

__all__ = [
    "COUPLER", "EQ_R2", "EQ_R3", "EQ_THETA", "EQ_THETA2", "EQ_X", "EQ_X2", "EQ_X3",
    "NewmarkMatrices", "Partition", "Specimen", "actuator_to_frame", "frame_to_actuator",
    "ideal_physical", "newmark_matrices", "newmark_response", "newmark_step", "partition",
    "rayleigh", "specimen",
]

INCH = 0.0254
EQ_X, EQ_THETA, EQ_THETA2 = 27, 21, 29
"""Interface DOFs: floor-1 sway (x), rotation of joint 7 (θ = −U(21)), joint 6."""
EQ_X2, EQ_R2, EQ_X3, EQ_R3 = 26, 22, 13, 3
"""Evaluation DOFs of J8/J10: 2nd-story sway and rotation, 3rd-story sway and rotation."""
EQ_GROUND = (13, 26, 27)
"""Equations loaded by the ground acceleration (the floor sways)."""

OMEGA_RAYLEIGH = (13.493, 165.125)  # rad/s, SAP2000 modes 1 and 3
ZETA = 0.05


def rayleigh(wi: float, wj: float, zeta: float) -> tuple[float, float]:
    """(α in 1/s, β in s) of C = αM + βK with damping ``zeta`` at ``wi`` and ``wj`` rad/s."""
    A = 0.5 * np.array([[1.0 / wi, wi], [1.0 / wj, wj]])
    a, b = np.linalg.solve(A, [zeta, zeta])
    return float(a), float(b)


def ideal_physical() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The 3-DOF "ideal" physical model [x, θ(eq 29), θ(eq 21)] the code subtracts: KP (N/m,
    N, N·m), MP (kg, kg·m²) and CP (Rayleigh 5 % at its 1st and 3rd eigenfrequencies, with
    the full MP). As in ``build_physical_ideal.m``: ρ = 785e3 kg/m³ and KP₂₃ = −2EI_b/L_b."""
    E, Lb, Lc = 200e9, 0.762, 0.635
    Ic, Ib = 2.520 * INCH**4, 0.6132 * INCH**4
    Ac, Ab = 1.670 * INCH**2, 0.947 * INCH**2
    rho = 785e3
    KP = np.array([
        [6 * E * Ic / Lc**3, -3 * E * Ic / Lc**2, -3 * E * Ic / Lc**2],
        [-3 * E * Ic / Lc**2, 3 * E * Ic / Lc + 4 * E * Ib / Lb, -2 * E * Ib / Lb],
        [-3 * E * Ic / Lc**2, -2 * E * Ib / Lb, 3 * E * Ic / Lc + 4 * E * Ib / Lb]])
    M1 = rho * Ab * Lb + rho * Ac * Lc
    M2 = (rho * Ab * Lb / 2) * Lb**2 / 12 + (rho * Ac * Lc / 2) * Lc**2 / 12
    MP = np.diag([M1, M2, M2])
    import scipy.linalg

    w = np.sqrt(np.sort(scipy.linalg.eigh(KP, MP, eigvals_only=True)))
    a, b = rayleigh(float(w[0]), float(w[2]), ZETA)
    return KP, MP, a * MP + b * KP


@dataclass(frozen=True, eq=False)
class Partition:
    """Reference (M, C, K) and numerical-substructure (MN, CN, KN) matrices, 29×29 (SI), and
    the influence vector ``l`` (29,)."""

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    MN: np.ndarray
    CN: np.ndarray
    KN: np.ndarray
    l: np.ndarray  # noqa: E741 (the benchmark's name)


def partition(K: np.ndarray, M: np.ndarray) -> Partition:
    """Reference damping and the numerical substructure from the reference K and M."""
    a, b = rayleigh(*OMEGA_RAYLEIGH, ZETA)
    C = a * M + b * K
    KP, MP, CP = ideal_physical()
    idx = np.array([EQ_X, EQ_THETA2, EQ_THETA]) - 1
    KN, CN, MN = K.copy(), C.copy(), M.copy()
    KN[np.ix_(idx, idx)] -= KP
    CN[np.ix_(idx, idx)] -= CP
    MN[EQ_X - 1, EQ_X - 1] -= MP[0, 0]
    l = np.zeros(K.shape[0])  # noqa: E741
    l[np.array(EQ_GROUND) - 1] = 1.0
    return Partition(M, C, K, MN, CN, KN, l)


@dataclass(frozen=True, eq=False)
class Specimen:
    """The 5-DOF specimen frame [X, θ1, θ2, θ3, θ4]: K5 (N/m, N, N·m), M5, C5, the modal ω
    used (rad/s) and the condensation G (3×2: [θ2, θ3, θ4] = G [x, θ])."""

    K5: np.ndarray
    M5: np.ndarray
    C5: np.ndarray
    omega: np.ndarray
    G: np.ndarray


def specimen() -> Specimen:
    """The tuned 5-DOF frame of ``physicalFrame_feedbackForce.m`` (Euler–Bernoulli columns
    and beam, axial deformation neglected, I_c × 0.7, masses × 1.1)."""
    E, Lb, Lc, rho = 200e9, 0.762, 0.64135, 7850.0
    Ic, Ib = 0.7 * 2.520 * INCH**4, 4.21372e-7
    Ac, Ab = 1.670 * INCH**2, 7.56e-4
    ci, bi = E * Ic, E * Ib
    K = np.zeros((5, 5))
    # columns: top (X, θ1) over base θ4, and (X, θ2) over base θ3
    for top, base in ((1, 4), (2, 3)):
        K[0, 0] += 12 * ci / Lc**3
        for r in (top, base):
            K[0, r] += 6 * ci / Lc**2
            K[r, 0] += 6 * ci / Lc**2
            K[r, r] += 4 * ci / Lc
        K[top, base] += 2 * ci / Lc
        K[base, top] += 2 * ci / Lc
    K[1, 1] += 4 * bi / Lb
    K[2, 2] += 4 * bi / Lb
    K[1, 2] += 2 * bi / Lb
    K[2, 1] += 2 * bi / Lb
    mb, mc = rho * Ab * Lb, rho * Ac * Lc
    M = 1.1 * np.diag([(mb + 2 * mc) / 2, (mb * Lb**2 / 2 + mc * Lc**2 / 2) / 3,
                       (mb * Lb**2 / 2 + mc * Lc**2 / 2) / 3, (mc * Lc**2 / 2) / 3,
                       (mc * Lc**2 / 2) / 3])
    C, omega = modal_damping(M, K, ZETA, 0.01)
    G = -np.linalg.solve(K[2:, 2:], K[2:, :2])
    return Specimen(K, M, C, omega, G)


# ---------------------------------------------------------------------------------------
# coupler kinematics

@dataclass(frozen=True)
class Coupler:
    """Geometry of the two actuators' attachment on the coupler: offsets (m) and the angles
    α (degrees, as ``fcn_coupler_geometry.m`` states them: ±25.4633°, which is atan(y/x)
    rounded — the rounded value is the benchmark's)."""

    xv1: float = 0.26670
    yv1: float = -0.127
    xv2: float = 0.26670
    yv2: float = 0.127
    alpha1_deg: float = -25.4633
    alpha2_deg: float = 25.4633

    @property
    def dv1(self) -> float:
        return math.hypot(self.xv1, self.yv1)

    @property
    def dv2(self) -> float:
        return math.hypot(self.xv2, self.yv2)

    @property
    def alpha1(self) -> float:
        return math.radians(self.alpha1_deg)

    @property
    def alpha2(self) -> float:
        return math.radians(self.alpha2_deg)

    def params(self) -> np.ndarray:
        """[d_v1, d_v2, α1, α2] for the kernels."""
        return np.array([self.dv1, self.dv2, self.alpha1, self.alpha2])


COUPLER = Coupler()


@njit(cache=True, nogil=True, inline="always")
def _f2a(x, th, kin):
    d1, d2, a1, a2 = kin[0], kin[1], kin[2], kin[3]
    return (1000.0 * (x + d1 * (math.cos(th + a1) - math.cos(a1))),
            1000.0 * (x + d2 * (math.cos(th + a2) - math.cos(a2))))


@njit(cache=True, nogil=True, inline="always")
def _a2f(xa1, xa2, kin):
    d1, d2, a1, a2 = kin[0], kin[1], kin[2], kin[3]
    p1, p2 = 1e-3 * xa1, 1e-3 * xa2
    s = (p1 - p2) / (2.0 * d2 * math.sin(a2))
    if s > 1.0:
        s = 1.0
    elif s < -1.0:
        s = -1.0
    return p1 - d1 * (math.cos(a1 + s) - math.cos(a1)), math.asin(s)


def frame_to_actuator(x: np.ndarray | float, theta: np.ndarray | float,
                      coupler: Coupler = COUPLER) -> tuple[np.ndarray, np.ndarray]:
    """Actuator displacements (mm) imposing ``x`` (m) and ``theta`` (rad) on the node."""
    x, th = np.asarray(x, float), np.asarray(theta, float)
    d1, d2, a1, a2 = coupler.params()
    return (1000.0 * (x + d1 * (np.cos(th + a1) - np.cos(a1))),
            1000.0 * (x + d2 * (np.cos(th + a2) - np.cos(a2))))


def actuator_to_frame(xa1: np.ndarray | float, xa2: np.ndarray | float,
                      coupler: Coupler = COUPLER) -> tuple[np.ndarray, np.ndarray]:
    """(x in m, θ in rad) from the actuator displacements (mm), as the model wires it:
    s = (a1 − a2)/(2 d_v2 sin α2), θ = asin s, x = a1 − d_v1 (cos(α1 + s) − cos α1)."""
    d1, d2, a1, a2 = coupler.params()
    p1, p2 = 1e-3 * np.asarray(xa1, float), 1e-3 * np.asarray(xa2, float)
    s = np.clip((p1 - p2) / (2.0 * d2 * np.sin(a2)), -1.0, 1.0)
    return p1 - d1 * (np.cos(a1 + s) - np.cos(a1)), np.arcsin(s)


# ---------------------------------------------------------------------------------------
# Newmark

@dataclass(frozen=True, eq=False)
class NewmarkMatrices:
    """One structure's Newmark step at dt: ``Kinv = (K + a0 M + a1 C)⁻¹``, ``RU = a0 M +
    a1 C``, ``RV = a2 M + a4 C``, ``RA = a3 M + a5 C``, ``Ml = M l`` and ``a = [a0 … a7]``."""

    Kinv: np.ndarray
    RU: np.ndarray
    RV: np.ndarray
    RA: np.ndarray
    Ml: np.ndarray
    a: np.ndarray


def newmark_constants(dt: float, gamma: float = 0.5, beta: float = 0.25) -> np.ndarray:
    """a0 … a7 of ``fcn_newmark_beta_const.m``."""
    return np.array([1 / (beta * dt**2), gamma / (beta * dt), 1 / (beta * dt),
                     1 / (2 * beta) - 1, gamma / beta - 1, dt / 2 * (gamma / beta - 2),
                     dt * (1 - gamma), gamma * dt])


def newmark_matrices(M: np.ndarray, C: np.ndarray, K: np.ndarray, l: np.ndarray,  # noqa: E741
                     dt: float) -> NewmarkMatrices:
    """The step matrices of ``M Ü + C U̇ + K U = −M l ẍ_g − F`` at ``dt`` (s)."""
    a = newmark_constants(dt)
    Kinv = np.linalg.inv(K + a[0] * M + a[1] * C)
    return NewmarkMatrices(np.ascontiguousarray(Kinv), a[0] * M + a[1] * C,
                           a[2] * M + a[4] * C, a[3] * M + a[5] * C, M @ l, a)


@njit(cache=True, nogil=True)
def newmark_step(U, V, A, Kinv, RU, RV, RA, Ml, a, ag, F, R):
    """One step in place: ``R̄ = M(a0U + a2V + a3A) + C(a1U + a4V + a5A) − F − M l ẍ_g``,
    ``U₁ = K̂⁻¹R̄``, ``A₁ = a0(U₁ − U) − a2V − a3A``, ``V₁ = V + a7A₁ + a6A`` (``R`` scratch)."""
    n = U.shape[0]
    for r in range(n):
        s = -F[r] - Ml[r] * ag
        for c in range(n):
            s += RU[r, c] * U[c] + RV[r, c] * V[c] + RA[r, c] * A[c]
        R[r] = s
    a0, a2, a3, a6, a7 = a[0], a[2], a[3], a[6], a[7]
    for r in range(n):
        u1 = 0.0
        for c in range(n):
            u1 += Kinv[r, c] * R[c]
        a1 = a0 * (u1 - U[r]) - a2 * V[r] - a3 * A[r]
        V[r] = V[r] + a7 * a1 + a6 * A[r]
        A[r] = a1
        U[r] = u1


@njit(cache=True, nogil=True)
def _newmark_run(Kinv, RU, RV, RA, Ml, a, ag, F, out):
    n = Kinv.shape[0]
    U, V, A, R = np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n)
    for k in range(ag.shape[0]):
        newmark_step(U, V, A, Kinv, RU, RV, RA, Ml, a, ag[k], F[k], R)
        out[k] = U


def newmark_response(nm: NewmarkMatrices, ag: np.ndarray, F: np.ndarray | None = None
                     ) -> np.ndarray:
    """Displacements U (N, n) at the samples of ``ag`` (m/s²), from rest, with the nodal
    loads ``F`` (N, n) subtracted (None: none) — the benchmark's reference when F = 0."""
    ag = np.ascontiguousarray(ag, dtype=float)
    n = nm.Kinv.shape[0]
    F = np.zeros((ag.size, n)) if F is None else np.ascontiguousarray(F, dtype=float)
    out = np.empty((ag.size, n))
    _newmark_run(nm.Kinv, nm.RU, nm.RV, nm.RA, nm.Ml, nm.a, ag, F, out)
    return out
