"""A multi-DOF part: a rigid bar on a heave and a pitch spring whose tip hits a world-fixed
surface, tested through heave z and pitch ry."""

from __future__ import annotations

from typing import Any

from .base import ExperimentalPart, register_part
from .mjcf import BODY_HALF, CONTACT_GROUP, GRAVITY, MASS_HEIGHT, TIP_RADIUS, surface_height


@register_part
class MultiDofPart(ExperimentalPart):
    """Bar of mass ``m`` (kg) and pitch inertia ``inertia`` (kg·m²) on a heave spring ``k``
    (N/m, damper ``d``) and a pitch spring ``k_rot`` (N·m/rad, damper ``d_rot``); its tip
    ``arm`` (m) from the axis hits a surface ``h0`` (m) above it. MuJoCo only (no numpy
    model): the loop runs it behind a prescribed mount or on the platform."""

    kind = "multidof"
    has_contact = has_spring = True
    dofs = ("z", "ry")

    def contact_attrs(self) -> str:
        # the bar's tip is light (m_eff ≈ 0.14 kg): the penalty law would ring at ~130 Hz
        # against the platform's 1 ms step; MuJoCo's usual impedance-0.99 contact with the
        # time constant and damping ratio of k_c on the bar's mass stays stable
        c = self.cfg
        wc = (c.k_contact / c.m) ** 0.5
        zeta = max(c.d_contact / (2.0 * (c.k_contact * c.m) ** 0.5), 0.05)
        return (f'contype="{CONTACT_GROUP}" conaffinity="{CONTACT_GROUP}" condim="1" '
                f'solref="{1.0 / (zeta * wc):.9g} {zeta:.9g}" solimp="0.99 0.99 0.001 0.5 2" '
                f'margin="0"')

    def payload_xml(self) -> str:
        c = self.cfg
        sref = c.m * GRAVITY / c.k
        return (
            f'<body name="exp_bar" pos="0 0 {MASS_HEIGHT}">'
            f'<joint name="exp_heave" type="slide" axis="0 0 1" stiffness="{c.k:.12g}" '
            f'damping="{c.d:.12g}" springref="{sref:.12g}"/>'
            f'<joint name="exp_pitch" type="hinge" axis="0 1 0" stiffness="{c.k_rot:.12g}" '
            f'damping="{c.d_rot:.12g}"/>'
            f'<inertial pos="0 0 0" mass="{c.m:.12g}" '
            f'diaginertia="{c.inertia:.9g} {c.inertia:.9g} {c.inertia:.9g}"/>'
            f'<geom name="exp_body" type="box" size="{c.arm:.6g} 0.02 {BODY_HALF}" mass="0" '
            f'contype="0" conaffinity="0" rgba="0.2 0.5 0.9 1"/>'
            f'<geom name="exp_tip" type="sphere" size="{TIP_RADIUS}" '
            f'pos="{c.arm:.9g} 0 {BODY_HALF + TIP_RADIUS}" mass="0" {self.contact_attrs()} '
            f'rgba="0.9 0.3 0.2 1"/>'
            f'<site name="exp_com" pos="0 0 0" size="0.003"/></body>'
        )

    def world_xml(self, site_pos: tuple[float, float, float]) -> str:
        z = surface_height(self.cfg, site_pos[2]) + 0.005
        return (f'<geom name="exp_surface" type="box" size="0.04 0.04 0.005" '
                f'pos="{site_pos[0] + self.cfg.arm:.9g} {site_pos[1]:.9g} {z:.9g}" '
                f'{self.contact_attrs()} rgba="0.5 0.5 0.5 0.6"/>')

    def interface_matrices(self) -> tuple[list[list[float]], list[list[float]]]:
        c = self.cfg
        jm = c.inertia + c.m * MASS_HEIGHT**2
        return [[c.k, 0.0], [0.0, c.k_rot]], [[c.m, 0.0], [0.0, jm]]

    def damping_matrix(self) -> list[list[float]]:
        return [[self.cfg.d, 0.0], [0.0, self.cfg.d_rot]]

    def meta(self) -> dict[str, Any]:
        return {**super().meta(), "h0": self.cfg.h0}
