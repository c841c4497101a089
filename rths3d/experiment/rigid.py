"""A rigid payload tested through all six interface DOFs: a bench's multi-axis test piece."""

from __future__ import annotations

import numpy as np

from ..config import ExperimentConfig
from ..errors import ConfigError
from .base import ExperimentalPart, register_part
from .mjcf import MASS_HEIGHT


def inertia_matrix(values: tuple[float, ...] | list[float]) -> np.ndarray:
    """The 3×3 inertia tensor (kg·m²) of ``(Ixx, Iyy, Izz, Ixy, Ixz, Iyz)`` (MuJoCo's
    ``fullinertia`` order)."""
    xx, yy, zz, xy, xz, yz = (float(v) for v in values)
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def check_inertia(field: str, values: tuple[float, ...] | list[float]) -> None:
    """Raise :class:`ConfigError` unless ``values`` (Ixx, Iyy, Izz, Ixy, Ixz, Iyz; kg·m²)
    is the inertia of a real body about its centre of mass: positive definite, and its
    principal moments satisfy the triangle inequality I_a + I_b >= I_c."""
    if len(values) != 6:
        raise ConfigError(field, list(values), "need 6 numbers Ixx, Iyy, Izz, Ixy, Ixz, Iyz "
                          "(kg·m²) or one scalar")
    ev = np.linalg.eigvalsh(inertia_matrix(values))
    if ev[0] <= 0:
        raise ConfigError(field, list(values), f"must be positive definite (smallest "
                          f"principal moment {ev[0]:.4g} kg·m² must be > 0)")
    if ev[0] + ev[1] < ev[2] * (1 - 1e-9):
        raise ConfigError(field, list(values), f"principal moments {ev[0]:.4g}, {ev[1]:.4g}, "
                          f"{ev[2]:.4g} kg·m² violate the triangle inequality (the two "
                          "smaller must add up to at least the largest)")


def _skew(c: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -c[2], c[1]], [c[2], 0.0, -c[0]], [-c[1], c[0], 0.0]])


@register_part
class RigidPart(ExperimentalPart):
    """A rigid block of mass ``m`` (kg) fixed on the FTS. By default its centre of mass sits
    ``MASS_HEIGHT`` above the sensor on its axis with the principal inertia ``inertia``
    (kg·m², about each axis through the centre); a scene may give the centre of mass in 3-D
    (``com``, sensor frame, m) and the full inertia tensor about it (``inertia = [Ixx, Iyy,
    Izz, Ixy, Ixz, Iyz]``, checked positive definite and physically consistent). Its
    restoring wrench is its inertia (and weight, tared at rest): k_EXP = 0. Tested through
    x, y, z, rx, ry, rz, it moves the platform in all six DOFs (kinematic and FTS
    calibration, payload identification). MuJoCo only (no numpy model: the prescribed-mount
    MuJoCo specimen off the platform)."""

    kind = "rigid"
    rigid_payload = True
    dofs = ("x", "y", "z", "rx", "ry", "rz")

    @classmethod
    def validate(cls, cfg: ExperimentConfig) -> None:
        if cfg.com:
            if len(cfg.com) != 3 or max(abs(v) for v in cfg.com) > 1.0:
                raise ConfigError("experiment.com", list(cfg.com), "need (x, y, z) in m, each "
                                  "within 1 m of the FTS origin")
        if cfg.inertia_tensor:
            check_inertia("experiment.inertia", cfg.inertia_tensor)

    def com(self) -> np.ndarray:
        """Centre of mass (3,) in the sensor frame (m)."""
        return np.array(self.cfg.com if self.cfg.com else (0.0, 0.0, MASS_HEIGHT))

    def inertia(self) -> np.ndarray:
        """Inertia tensor (3, 3) about the centre of mass (kg·m²)."""
        c = self.cfg
        return inertia_matrix(c.inertia_tensor) if c.inertia_tensor else np.eye(3) * c.inertia

    def _default(self) -> bool:
        return not self.cfg.com and not self.cfg.inertia_tensor

    def payload_xml(self) -> str:
        c = self.cfg
        if self._default():
            return (f'<body name="exp_mass" pos="0 0 {MASS_HEIGHT}">'
                    f'<inertial pos="0 0 0" mass="{c.m:.12g}" diaginertia="{c.inertia:.9g} '
                    f'{c.inertia:.9g} {c.inertia:.9g}"/>'
                    f'<geom name="exp_body" type="box" size="0.04 0.04 0.02" mass="0" '
                    f'contype="0" conaffinity="0" rgba="0.2 0.5 0.9 1"/>'
                    f'<site name="exp_com" pos="0 0 0" size="0.003"/></body>')
        pos = " ".join(f"{v:.12g}" for v in self.com())
        inert = (" ".join(f"{v:.12g}" for v in c.inertia_tensor) if c.inertia_tensor else
                 " ".join([f"{c.inertia:.12g}"] * 3 + ["0"] * 3))
        return (f'<body name="exp_mass" pos="{pos}">'
                f'<inertial pos="0 0 0" mass="{c.m:.12g}" fullinertia="{inert}"/>'
                f'<geom name="exp_body" type="box" size="0.04 0.04 0.02" mass="0" '
                f'contype="0" conaffinity="0" rgba="0.2 0.5 0.9 1"/>'
                f'<site name="exp_com" pos="0 0 0" size="0.003"/></body>')

    def interface_matrices(self) -> tuple[list[list[float]], list[list[float]]]:
        c = self.cfg
        k = [[0.0] * 6 for _ in range(6)]
        if self._default():
            j = c.inertia + c.m * MASS_HEIGHT ** 2
            m = [[0.0] * 6 for _ in range(6)]
            for i, v in enumerate((c.m, c.m, c.m, j, j, c.inertia)):
                m[i][i] = v
            return k, m
        # the spatial inertia about the FTS origin: [[m 1, −m [c]×], [m [c]×, I_c − m [c]×²]]
        cc = self.com()
        S = _skew(cc)
        M = np.zeros((6, 6))
        M[:3, :3] = c.m * np.eye(3)
        M[:3, 3:] = -c.m * S
        M[3:, :3] = c.m * S
        M[3:, 3:] = self.inertia() - c.m * S @ S
        return k, M.tolist()

    def damping_matrix(self) -> list[list[float]]:
        return [[0.0] * 6 for _ in range(6)]
