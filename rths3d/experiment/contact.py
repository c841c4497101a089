"""The paper's contact part (Fig. 4, Table 1): the linear part whose mass hits a world-fixed
surface h_0 above it (penalty contact k_c, d_c, acting only in compression)."""

from __future__ import annotations

from typing import Any

from .base import register_part
from .linear import LinearPart
from .mjcf import BODY_HALF, TIP_RADIUS, penalty_contact_attrs, surface_height


@register_part
class ContactPart(LinearPart):
    """Mass ``m`` on spring ``k`` / damper ``d`` whose tip hits a surface ``h0`` (m) above it
    at static equilibrium; contact stiffness ``k_contact`` (N/m), damping ``d_contact``
    (N·s/m). MuJoCo's soft contact is set to the same penalty law as the numpy model."""

    kind = "contact"
    has_contact = True

    def _tip_xml(self) -> str:
        return (f'<geom name="exp_tip" type="sphere" size="{TIP_RADIUS}" '
                f'pos="0 0 {BODY_HALF + TIP_RADIUS}" mass="0" {self.contact_attrs()} '
                f'rgba="0.9 0.3 0.2 1"/>')

    def contact_attrs(self) -> str:
        """MJCF attributes of the tip and its surface (penalty law on the part's mass)."""
        c = self.cfg
        return penalty_contact_attrs(c.k_contact, c.d_contact, c.m)

    def world_xml(self, site_pos: tuple[float, float, float]) -> str:
        z = surface_height(self.cfg, site_pos[2]) + 0.005
        return (f'<geom name="exp_surface" type="box" size="0.04 0.04 0.005" '
                f'pos="{site_pos[0]:.9g} {site_pos[1]:.9g} {z:.9g}" {self.contact_attrs()} '
                f'rgba="0.5 0.5 0.5 0.6"/>')

    def contact_gap(self) -> float:
        return float(self.cfg.h0)

    def meta(self) -> dict[str, Any]:
        return {**super().meta(), "h0": self.cfg.h0}
