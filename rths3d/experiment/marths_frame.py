"""The maRTHS benchmark's experimental one-bay frame as a part on the Stewart platform.

The benchmark's physical substructure (Condori Uribe et al. 2023) is a one-storey, one-bay
steel frame whose top node the actuators move in a translation x and a rotation θ; the
benchmark simulates it as the tuned 5-DOF frame of :func:`rths3d.community.marths.model.
specimen` ([X, θ1, θ2, θ3, θ4]) with the unmeasured rotations condensed statically,
[θ2, θ3, θ4] = G [x, θ]. Here the same frame is tested through the platform's x and ry (ry
is the benchmark's θ): its interface stiffness, damping and mass over (x, ry) are those the
benchmark's feedback force applies on x and θ1,

    K_if = K5[:2] T,   C_if = sym(C5[:2] T),   M_if = M5[:2] T,   T = [I; G],

and the frame's base is fixed to the world. In MuJoCo the frame is a rigid body of mass
M_if[x, x] and pitch inertia M_if[ry, ry] on the FTS, tied to world anchors by four spatial
tendons along x (length ``TENDON_LENGTH``): a tendon of stiffness k at height h above the
FTS origin gives k [1, h][1, h]ᵀ over (x, ry), so two of them at h = b/a ± √(det)/a with
a/2 each realise any symmetric positive-definite [[a, b], [b, c]]; two more give C_if the
same way. Small motions are linear (the tendons' transverse stretch is second order).
The numpy twin (:class:`FrameTwin`) gives the same wrench from the mount's motion for the
reference and the transfer systems without legs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..config import ExperimentConfig
from .base import ExperimentalPart, register_part

TENDON_LENGTH = 0.5
"""Length (m) of the tendons from the frame's body to their world anchors (along −x)."""


def frame_matrices() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(K_if N/m·N·N·m, C_if, M_if kg·kg·m²) of the benchmark's frame over (x, θ)."""
    from ..community.marths.model import specimen

    s = specimen()
    T = np.vstack([np.eye(2), s.G])
    K = s.K5[:2] @ T
    C = s.C5[:2] @ T
    return 0.5 * (K + K.T), 0.5 * (C + C.T), s.M5[:2] @ T


def tendon_pair(A: np.ndarray) -> tuple[float, tuple[float, float]]:
    """Stiffness (each) and heights (m) of two x-tendons realising the 2×2 SPD ``A``."""
    a, b, c = float(A[0, 0]), float(A[0, 1]), float(A[1, 1])
    d = math.sqrt(a * c - b * b) / a
    return 0.5 * a, (b / a + d, b / a - d)


class FrameTwin:
    """K frames driven by their mount: F = K_if z + C_if ż + M_if z̈ (N, N·m) at the end
    of a step in which the mount moves linearly from ``z_from`` to ``z_to`` ((K, 2) m, rad),
    ż = the step's velocity, z̈ = its change from the previous step's over ΔT (the tendons
    are linear springs and dampers, the body rigid on the mount)."""

    n_if = 2
    tolerance = 1e-12

    def __init__(self, K: int, dt: float):
        self.K = K
        self.dt = float(dt)
        Kif, Cif, Mif = frame_matrices()
        self._KT, self._CT, self._MT = Kif.T.copy(), Cif.T.copy(), Mif.T.copy()
        self._v = np.zeros((K, 2))

    def reset(self) -> None:
        self._v[:] = 0.0

    def advance(self, z_from: np.ndarray, z_to: np.ndarray) -> np.ndarray:
        v = (np.asarray(z_to) - np.asarray(z_from)) / self.dt
        a = (v - self._v) / self.dt
        self._v = v
        return np.asarray(z_to) @ self._KT + v @ self._CT + a @ self._MT

    def get_state(self) -> np.ndarray:
        return self._v.copy()

    def set_state(self, state: np.ndarray) -> None:
        self._v = np.array(state, dtype=float)

    def compiled(self) -> None:
        return None


@register_part
class MarthsFramePart(ExperimentalPart):
    """The maRTHS one-bay frame (the benchmark's 5-DOF specimen, condensed to x and ry)
    with its base fixed to the world; no scene parameters (its numbers are the
    benchmark's)."""

    kind = "marths_frame"
    dofs = ("x", "ry")

    def _tendons(self) -> list[tuple[str, float, float, float]]:
        K, C, _ = frame_matrices()
        k, hk = tendon_pair(K)
        c, hc = tendon_pair(C)
        return [("k1", k, 0.0, hk[0]), ("k2", k, 0.0, hk[1]),
                ("c1", 0.0, c, hc[0]), ("c2", 0.0, c, hc[1])]

    def payload_xml(self) -> str:
        _, _, M = frame_matrices()
        m, j = float(M[0, 0]), float(M[1, 1])
        sites = "".join(f'<site name="exp_{n}_p" pos="0 0 {h:.12g}" size="0.003"/>'
                        for n, _, _, h in self._tendons())
        return (f'<body name="exp_frame" pos="0 0 0">'
                f'<inertial pos="0 0 0" mass="{m:.12g}" diaginertia="{j:.12g} {j:.12g} '
                f'{j:.12g}"/>'
                f'<geom name="exp_body" type="box" size="0.38 0.02 0.02" pos="0 0 0.02" '
                f'mass="0" contype="0" conaffinity="0" rgba="0.2 0.5 0.9 1"/>'
                f'{sites}<site name="exp_com" pos="0 0 0" size="0.003"/></body>')

    def world_xml(self, site_pos: tuple[float, float, float]) -> str:
        x, y, z = site_pos
        return "".join(f'<site name="exp_{n}_w" pos="{x - TENDON_LENGTH:.12g} {y:.12g} '
                       f'{z + h:.12g}" size="0.003"/>' for n, _, _, h in self._tendons())

    def extra_xml(self) -> str:
        ts = "".join(f'<spatial name="exp_{n}" stiffness="{k:.12g}" damping="{c:.12g}" '
                     f'springlength="{TENDON_LENGTH:.12g}" width="0.002">'
                     f'<site site="exp_{n}_w"/><site site="exp_{n}_p"/></spatial>'
                     for n, k, c, _ in self._tendons())
        return f"<tendon>{ts}</tendon>"

    def interface_matrices(self) -> tuple[list[list[float]], list[list[float]]]:
        K, _, M = frame_matrices()
        return K.tolist(), M.tolist()

    def damping_matrix(self) -> list[list[float]]:
        return frame_matrices()[1].tolist()

    @classmethod
    def numpy_model(cls, cfgs: Sequence[ExperimentConfig], dt: float, *, substeps: int,
                    method: str) -> FrameTwin:
        return FrameTwin(len(cfgs), dt)

    def meta(self) -> dict[str, Any]:
        return {**super().meta(), "source": "maRTHS 5-DOF specimen, condensed to (x, θ)"}
