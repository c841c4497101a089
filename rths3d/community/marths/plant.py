"""The maRTHS control plant: the identified 2×2 actuator model with its uncertainty
(Condori Uribe et al. 2023, ``ID_Control_plant_100Hz.mat``, ``fcn_build_uncert_plant.m``).

``y = H(s) u`` with commands u and displacements y of the two actuators in mm; each entry
``H_ij = k_ij ∏(s − z)/∏(s − p)`` (rad/s). Column j is actuator j's command; the pair
(−50 ± 63j)·2π rad/s is shared by all four entries. A perturbed plant multiplies zeros and
poles by (1 + σ n) with nine standard-normal draws in the benchmark's order, then rescales
each entry's gain to its nominal low-frequency magnitude (H11 at 0.01 Hz as the code; the
others at DC, where the code takes the first point of MATLAB's automatic Bode grid — below
0.1 % apart). The loop advances the plant by one RK4 step with the command held (Simulink
ode4): ``x_{k+1} = Φ x_k + Γ u_k``, ``y_k = C x_k`` (:meth:`PlantZPK.step_matrices`).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, replace

import numpy as np

from ...lti import ContinuousSS, ss

__all__ = ["NOMINAL", "PlantZPK", "perturbed_plants"]

TWO_PI = 2.0 * np.pi
FRAME_POLE = complex(-50.0, 63.0) * TWO_PI


@dataclass(frozen=True)
class PlantZPK:
    """The plant's zeros and poles (rad/s) and gains, by entry (ij = row, column)."""

    z1: tuple[float, float] = (-120.0 * TWO_PI, -90.0 * TWO_PI)   # H11, H21 zeros
    p1: tuple[float, float] = (-2.65 * TWO_PI, -40.0 * TWO_PI)    # H11, H21 real poles
    frame: complex = FRAME_POLE                                   # shared pair (and conj.)
    z12: float = -3.0 * TWO_PI
    z22: float = -5.0 * TWO_PI
    p2: tuple[float, float] = (-3.5 * TWO_PI, -18.5 * TWO_PI)     # H12, H22 real poles
    k11: float = 2165.2
    k21: float = 349.95
    k12: float = 4.5394e6
    k22: float = 1.9238e7

    def entry(self, i: int, j: int) -> tuple[np.ndarray, np.ndarray, float]:
        """(zeros, poles, gain) of H_ij (1-based)."""
        fr = [self.frame, self.frame.conjugate()]
        if j == 1:
            return (np.array(self.z1, dtype=complex), np.array([*fr, *self.p1]),
                    self.k11 if i == 1 else self.k21)
        z = self.z12 if i == 1 else self.z22
        return np.array([z], dtype=complex), np.array([*fr, *self.p2]), \
            self.k12 if i == 1 else self.k22

    def freqresp(self, w: np.ndarray) -> np.ndarray:
        """H(jω) (len(w), 2, 2)."""
        s = 1j * np.asarray(w, dtype=float)
        out = np.empty((s.size, 2, 2), dtype=complex)
        for i in (1, 2):
            for j in (1, 2):
                z, p, k = self.entry(i, j)
                out[:, i - 1, j - 1] = k * np.prod(s[:, None] - z, axis=1) / \
                    np.prod(s[:, None] - p, axis=1)
        return out

    def dc_gain(self) -> np.ndarray:
        """H(0) (2×2)."""
        return self.freqresp(np.array([0.0]))[0].real

    def realization(self) -> ContinuousSS:
        """An 8-state realisation: one column's common denominator per actuator (4 states),
        both outputs read from it (controllable canonical form)."""
        import scipy.signal

        A = np.zeros((8, 8))
        B = np.zeros((8, 2))
        C = np.zeros((2, 8))
        for j in (1, 2):
            nums = []
            for i in (1, 2):
                z, p, k = self.entry(i, j)
                nums.append(np.real(k * np.poly(z)))
            den = np.real(np.poly(p))
            num = np.zeros((2, den.size))
            for i, nm in enumerate(nums):
                num[i, den.size - nm.size:] = nm
            with warnings.catch_warnings():  # the zero-padded numerator rows
                warnings.simplefilter("ignore", scipy.signal.BadCoefficients)
                a, b, c, _ = scipy.signal.tf2ss(num, den)
            sl = slice(4 * (j - 1), 4 * j)
            A[sl, sl], B[sl, j - 1], C[:, sl] = a, b[:, 0], c
        return ss(A, B, C)

    def step_matrices(self, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """``(Φ (8×8), Γ (8×2), C (2×8))`` of one classical RK4 step of length ``dt`` (s) with
        the command held: Φ = Σ_{i≤4} (hA)^i/i!, Γ = h Σ_{i≤3} (hA)^i/(i+1)! B."""
        sys = self.realization()
        A, B, C = np.asarray(sys.A), np.asarray(sys.B), np.asarray(sys.C)
        hA = dt * A
        Phi = np.eye(8)
        S = np.eye(8)
        term = np.eye(8)
        for i in range(1, 5):
            term = term @ hA / i
            Phi = Phi + term
            if i < 4:
                S = S + term / (i + 1)
        return Phi, dt * S @ B, C.copy()

    def perturbed(self, rng: np.random.Generator) -> PlantZPK:
        """One perturbed plant: nine draws n1…n9 in the benchmark's order, then the gains
        renormalised to the nominal low-frequency magnitudes."""
        n = rng.standard_normal(9)
        z1 = (self.z1[0] * (1 + 0.055 * n[0]), self.z1[1] * (1 + 0.055 * n[1]))
        p1 = (self.p1[0] * (1 + 0.06 * n[2]), self.p1[1] * (1 + 0.06 * n[3]))
        frame = self.frame * (1 + 0.05 * n[4])
        z12 = self.z12 * (1 + 0.03 * n[5])
        p2 = (self.p2[0] * (1 + 0.03 * n[6]), self.p2[1] * (1 + 0.03 * n[7]))
        z22 = self.z22 * (1 + 0.03 * n[8])
        out = replace(self, z1=z1, p1=p1, frame=frame, z12=z12, p2=p2, z22=z22)
        w0 = np.array([TWO_PI * 0.01, 0.0])
        Hn, Hp = self.freqresp(w0), out.freqresp(w0)
        # H11 at 0.01 Hz as the code, the others at DC
        scale = np.abs(Hn[1]) / np.abs(Hp[1])
        scale[0, 0] = abs(Hn[0, 0, 0]) / abs(Hp[0, 0, 0])
        return replace(out, k11=self.k11 * scale[0, 0], k21=self.k21 * scale[1, 0],
                       k12=self.k12 * scale[0, 1], k22=self.k22 * scale[1, 1])


NOMINAL = PlantZPK()


def perturbed_plants(n: int, seed: int = 123, nominal: PlantZPK = NOMINAL) -> list[PlantZPK]:
    """``n`` perturbed plants drawn from ``numpy.random.default_rng(seed)``."""
    rng = np.random.default_rng(seed)
    return [nominal.perturbed(rng) for _ in range(int(n))]
