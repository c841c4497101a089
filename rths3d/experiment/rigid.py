"""A rigid payload tested through all six interface DOFs: a bench's multi-axis test piece."""

from __future__ import annotations

from .base import ExperimentalPart, register_part
from .mjcf import MASS_HEIGHT


@register_part
class RigidPart(ExperimentalPart):
    """A rigid block of mass ``m`` (kg) fixed on the FTS, its centre ``MASS_HEIGHT`` above
    the sensor, principal inertia ``inertia`` (kg·m², about each axis through its centre).
    Its restoring wrench is its inertia (and weight, tared at rest): k_EXP = 0. Tested
    through x, y, z, rx, ry, rz, it moves the platform in all six DOFs (kinematic and FTS
    calibration, payload identification). MuJoCo only."""

    kind = "rigid"
    dofs = ("x", "y", "z", "rx", "ry", "rz")

    def payload_xml(self) -> str:
        c = self.cfg
        return (f'<body name="exp_mass" pos="0 0 {MASS_HEIGHT}">'
                f'<inertial pos="0 0 0" mass="{c.m:.12g}" diaginertia="{c.inertia:.9g} '
                f'{c.inertia:.9g} {c.inertia:.9g}"/>'
                f'<geom name="exp_body" type="box" size="0.04 0.04 0.02" mass="0" contype="0" '
                f'conaffinity="0" rgba="0.2 0.5 0.9 1"/>'
                f'<site name="exp_com" pos="0 0 0" size="0.003"/></body>')

    def interface_matrices(self) -> tuple[list[list[float]], list[list[float]]]:
        c = self.cfg
        j = c.inertia + c.m * MASS_HEIGHT ** 2
        k = [[0.0] * 6 for _ in range(6)]
        m = [[0.0] * 6 for _ in range(6)]
        for i, v in enumerate((c.m, c.m, c.m, j, j, c.inertia)):
            m[i][i] = v
        return k, m

    def damping_matrix(self) -> list[list[float]]:
        return [[0.0] * 6 for _ in range(6)]
