"""The control plant of the benchmark: servo-valve, actuator with control–structure
interaction (CSI), and the specimen (paper Fig. 11, Eqs. 21–22).

From the command y_gc (m, held over each step):

* servo-loop error   e_s = gain·y_gc − x                (x: true specimen displacement, m)
* servo-valve        Q̈ + β₁ Q̇ + β₂ Q = a₁β₀ e_s
* actuator with CSI  Ḟ = −a₃ F + Q − a₂ ẋ                (F: actuator force, N)
* specimen           m_e ẍ + c_e ẋ + k_e x = F

State ``p = [Q, Q̇, F, x, ẋ]``. In the Simulink model ẋ in the CSI term comes from a
Derivative block, whose rule within an RK4 step (SPEC §7) is reproduced by
:func:`plant_step_matrices`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from ..errors import ConfigError
from ..lti import ContinuousSS, affine_step_matrices, ss

__all__ = ["PLANT_STD", "PlantParams", "plant_ss", "plant_step_matrices", "plant_tf"]


@dataclass(frozen=True)
class PlantParams:
    """Plant parameters (SI); defaults are the benchmark code's nominal values.

    gain (-) command gain; a1_beta0 (N/(m·s²)… servo-valve gain); beta1 (1/s), beta2 (1/s²)
    servo-valve; a2 (N·s/m) CSI velocity feedback; a3 (1/s) actuator pole; m_e (kg),
    k_e (N/m), zeta_e (-) specimen, with c_e = 2 ζ_e √(k_e m_e) (N·s/m).
    """

    gain: float = 1.0261
    a1_beta0: float = 2.1283e13
    beta1: float = 425.0
    beta2: float = 9.9976e4
    a2: float = 4.2297e6
    a3: float = 3.3
    m_e: float = 29.13
    k_e: float = 1.19e6
    zeta_e: float = 0.0097

    def __post_init__(self) -> None:
        for name in ("a1_beta0", "beta2", "m_e", "k_e"):
            v = getattr(self, name)
            if not (v > 0.0 and math.isfinite(v)):
                raise ConfigError(f"plant.{name}", v, "must be > 0")
        for name in ("gain", "beta1", "a2", "a3", "zeta_e"):
            v = getattr(self, name)
            if not math.isfinite(v):
                raise ConfigError(f"plant.{name}", v, "must be finite")

    @property
    def c_e(self) -> float:
        """Specimen damping 2 ζ_e √(k_e m_e), N·s/m."""
        return 2.0 * self.zeta_e * math.sqrt(self.k_e * self.m_e)

    def perturbed(self, rng: np.random.Generator) -> PlantParams:
        """One perturbed trial: k_e, β₁, β₂, a₃ drawn in this order from normal(nominal, std).

        (SPEC §5.2; c_e follows k_e; a₁β₀, a₂, m_e and the gain stay nominal.)
        """
        draws = {k: float(rng.normal(getattr(self, k), s)) for k, s in PLANT_STD.items()}
        return replace(self, **draws)


PLANT_STD: dict[str, float] = {"k_e": 5e4, "beta1": 3.3, "beta2": 3.3e3, "a3": 1.3}
"""Standard deviations of the perturbed parameters, in draw order (SI)."""


def plant_tf(p: PlantParams) -> tuple[np.ndarray, np.ndarray]:
    """``G_P(s) = gain·a₁β₀ / (A₅s⁵ + … + A₀)`` from y_gc to x, ideal derivatives (Eq. 21–22)."""
    me, ce, ke = p.m_e, p.c_e, p.k_e
    b1, b2, a2, a3 = p.beta1, p.beta2, p.a2, p.a3
    A5 = me
    A4 = ce + me * a3 + me * b1
    A3 = (ke + ce * a3 + a2) + (ce + me * a3) * b1 + me * b2
    A2 = ke * a3 + (ke + ce * a3 + a2) * b1 + (ce + me * a3) * b2
    A1 = ke * a3 * b1 + (ke + ce * a3 + a2) * b2
    A0 = ke * a3 * b2 + p.a1_beta0
    return np.array([p.gain * p.a1_beta0]), np.array([A5, A4, A3, A2, A1, A0])


def _plant_A(p: PlantParams, csi_from_velocity: bool) -> tuple[np.ndarray, np.ndarray]:
    """State matrix of ``p = [Q, Q̇, F, x, ẋ]`` without (or with) the CSI term, and B (y_gc)."""
    A = np.zeros((5, 5))
    A[0, 1] = 1.0
    A[1, 0], A[1, 1], A[1, 3] = -p.beta2, -p.beta1, -p.a1_beta0
    A[2, 0], A[2, 2] = 1.0, -p.a3
    if csi_from_velocity:
        A[2, 4] = -p.a2
    A[3, 4] = 1.0
    A[4, 2], A[4, 3], A[4, 4] = 1.0 / p.m_e, -p.k_e / p.m_e, -p.c_e / p.m_e
    B = np.zeros(5)
    B[1] = p.a1_beta0 * p.gain
    return A, B


def plant_ss(p: PlantParams) -> ContinuousSS:
    """Continuous plant with ideal derivatives: input y_gc (m), outputs x (m) and F (N)."""
    A, B = _plant_A(p, True)
    C = np.zeros((2, 5))
    C[0, 3] = 1.0
    C[1, 2] = 1.0
    return ss(A, B[:, None], C)


def plant_step_matrices(p: PlantParams, h: float, derivative: str = "simulink"
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One RK4 step of the plant as ``p_{k+1} = Φ p_k + g_y y_gc,k + g_x x_{k−1}``.

    ``derivative="simulink"`` evaluates the CSI Derivative block per RK4 stage as Simulink
    does (SPEC §7): stage 1 ``(x_k − x_{k−1})/h``, stages 2–3 ``(x_stage − x_k)/(h/2)``, stage
    4 ``(x_stage − x_k)/h``. ``derivative="exact"`` uses the state velocity ẋ (g_x = 0).
    Returns ``(Φ (5×5), g_y (5,), g_x (5,))``.
    """
    if derivative not in ("simulink", "exact"):
        raise ConfigError("derivative", derivative, "must be 'simulink' or 'exact'")
    exact = derivative == "exact"
    A, B = _plant_A(p, exact)
    csi = np.zeros(5)
    csi[2] = -p.a2

    def step(x: np.ndarray, u: np.ndarray) -> np.ndarray:
        ygc, x_prev = u[0], u[1]
        xk = x[3]

        def f(z: np.ndarray, D: float) -> np.ndarray:
            out = A @ z + B * ygc
            return out if exact else out + csi * D

        k1 = f(x, (xk - x_prev) / h)
        z2 = x + 0.5 * h * k1
        k2 = f(z2, (z2[3] - xk) / (0.5 * h))
        z3 = x + 0.5 * h * k2
        k3 = f(z3, (z3[3] - xk) / (0.5 * h))
        z4 = x + h * k3
        k4 = f(z4, (z4[3] - xk) / h)
        return x + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)

    Phi, G = affine_step_matrices(step, 5, 2)
    return Phi, G[:, 0].copy(), G[:, 1].copy()
