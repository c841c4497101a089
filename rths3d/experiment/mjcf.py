"""MJCF helpers shared by the experimental parts and the prescribed-mount specimen model.

Geometry is mirrored from paper Fig. 4 (see docs/architecture.md): a part's bodies sit above
the FTS site (coordinates in the site frame, z up); a contact surface is ``h0`` above the
part's contact tip at static equilibrium. Each part writes its own fragments
(:mod:`rths3d.experiment.contact`, ``linear``, ``multidof``); this module holds the shared
dimensions, the penalty-contact attributes and :func:`specimen_model_xml`.

Contact uses MuJoCo's soft contact (frictionless, condim 1) set to the penalty law of the
numpy model: negative solref (stiffness k_c/m, damping d_c/m, mass-normalised) with a small
impedance (:data:`CONTACT_IMPEDANCE`), see :func:`penalty_contact_attrs`.

:func:`specimen_model_xml` builds a specimen-only model whose mount follows a prescribed
motion (the ideal and LTI transfer systems): heavy mount joints for the interface DOFs driven
each physics step so that the mount reaches the commanded pose exactly.
"""

from __future__ import annotations

from typing import Protocol

from ..config import ExperimentConfig

GRAVITY = 9.81
MASS_HEIGHT = 0.02
"""Height of the specimen body above the FTS site (m)."""
TIP_RADIUS = 0.005
BODY_HALF = 0.01
CONTACT_GROUP = 4
"""contype/conaffinity bit used only by the specimen tip and its surface."""

CONTACT_IMPEDANCE = 0.01
"""MuJoCo solimp impedance d of the specimen contact. With a negative solref the contact
acceleration is a = (1 − d)·a₀ + (k_c·p + d_c·ṗ)/m_eff (MuJoCo's soft-constraint law), so a
small d makes it the penalty law of the numpy model up to d·a₀."""


class _Fragments(Protocol):
    def payload_xml(self) -> str: ...

    def world_xml(self, site_pos: tuple[float, float, float]) -> str: ...

    def extra_xml(self) -> str: ...


def contact_solref(k_contact: float, d_contact: float, mass: float) -> str:
    """MuJoCo solref (negative: mass-normalised stiffness and damping) of the penalty
    contact (k_c N/m, d_c N·s/m) at a tip of effective mass ``mass`` (kg)."""
    return f"{-k_contact / mass:.9g} {-d_contact / mass:.9g}"


def penalty_contact_attrs(k_contact: float, d_contact: float, mass: float) -> str:
    """MJCF attributes of a contact geom with the penalty law k_c, d_c at a tip of effective
    mass ``mass`` (kg)."""
    d = CONTACT_IMPEDANCE
    return (f'contype="{CONTACT_GROUP}" conaffinity="{CONTACT_GROUP}" condim="1" '
            f'solref="{contact_solref(k_contact, d_contact, mass)}" '
            f'solimp="{d} {d} 0.001 0.5 2" margin="0"')


def surface_height(cfg: ExperimentConfig, site_z: float) -> float:
    """World z (m) of the surface's lower face for an FTS site at ``site_z`` (home)."""
    return site_z + MASS_HEIGHT + BODY_HALF + 2 * TIP_RADIUS + cfg.h0


_MOUNT_JOINT = {"x": ("slide", "1 0 0"), "y": ("slide", "0 1 0"), "z": ("slide", "0 0 1"),
                "rz": ("hinge", "0 0 1"), "ry": ("hinge", "0 1 0"), "rx": ("hinge", "1 0 0")}
MOUNT_ARMATURE = 1.0e7
"""Armature of the prescribed mount joints (kg or kg·m²): the specimen's reaction changes
the mount acceleration by < 1e-5 relative."""


def specimen_model_xml(part: _Fragments, kind: str, dofs: tuple[str, ...],
                       timestep: float) -> str:
    """A specimen-only MJCF model: prescribed mount (joints for ``dofs``), FTS, payload."""
    order = [d for d in ("x", "y", "z", "rz", "ry", "rx") if d in dofs]
    joints = "".join(
        f'<joint name="mount_{d}" type="{_MOUNT_JOINT[d][0]}" axis="{_MOUNT_JOINT[d][1]}" '
        f'armature="{MOUNT_ARMATURE:g}" damping="0"/>' for d in order)
    return (
        f'<mujoco model="specimen_{kind}"><compiler angle="radian"/>'
        f'<option timestep="{timestep:.12g}" gravity="0 0 -{GRAVITY}" integrator="Euler"/>'
        f'<worldbody>{part.world_xml((0.0, 0.0, 0.0))}'
        f'<body name="mount" pos="0 0 0">{joints}'
        f'<geom type="box" size="0.05 0.05 0.005" pos="0 0 -0.005" mass="1" contype="0" '
        f'conaffinity="0"/>'
        f'<body name="ft_body" pos="0 0 0"><site name="fts" pos="0 0 0" size="0.004"/>'
        f'{part.payload_xml()}</body></body></worldbody>'
        f'<sensor><force name="fts_force" site="fts"/><torque name="fts_torque" site="fts"/>'
        f'</sensor>{part.extra_xml()}</mujoco>'
    )
