"""The paper's linear part (Fig. 5, Table 2): a mass m_EXP on a spring k_EXP (damper d_EXP)
above the force-torque sensor, tested through heave z."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..config import ExperimentConfig
from .base import ExperimentalPart, register_part
from .mjcf import BODY_HALF, GRAVITY, MASS_HEIGHT
from .specimen import Specimen1D


@register_part
class LinearPart(ExperimentalPart):
    """Mass ``m`` (kg) on a spring ``k`` (N/m) and damper ``d`` (N·s/m) above the FTS.

    The joint spring carries ``springref`` so that gravity only preloads (equilibrium at
    q = 0, displacements from static equilibrium as in the paper)."""

    kind = "linear"
    has_spring = True
    dofs = ("z",)

    def payload_xml(self) -> str:
        c = self.cfg
        sref = c.m * GRAVITY / c.k
        return (
            f'<body name="exp_mass" pos="0 0 {MASS_HEIGHT}">'
            f'<joint name="exp_heave" type="slide" axis="0 0 1" stiffness="{c.k:.12g}" '
            f'damping="{c.d:.12g}" springref="{sref:.12g}" armature="0"/>'
            f'<geom name="exp_body" type="cylinder" size="0.03 {BODY_HALF}" mass="{c.m:.12g}" '
            f'contype="0" conaffinity="0" rgba="0.2 0.5 0.9 1"/>'
            f'{self._tip_xml()}<site name="exp_com" pos="0 0 0" size="0.003"/></body>'
        )

    def _tip_xml(self) -> str:
        """A contact tip on the mass (none for the linear part)."""
        return ""

    def interface_matrices(self) -> tuple[list[list[float]], list[list[float]]]:
        return [[self.cfg.k]], [[self.cfg.m]]

    def contact_gap(self) -> float:
        """Gap h_0 (m) to the contact surface (inf: none)."""
        return float("inf")

    @classmethod
    def numpy_model(cls, cfgs: Sequence[ExperimentConfig], dt: float, *, substeps: int,
                    method: str) -> Specimen1D:
        arr = lambda a: np.array([getattr(c, a) for c in cfgs])  # noqa: E731
        h0 = np.array([cls(c).contact_gap() for c in cfgs])
        return Specimen1D(len(cfgs), arr("m"), arr("k"), arr("d"), h0, arr("k_contact"),
                          arr("d_contact"), dt=dt, substeps=substeps, method=method)

