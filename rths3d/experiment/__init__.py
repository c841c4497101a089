"""Experimental parts: one class per kind (contact, linear, multi-DOF), registered by name.

Each part owns its MJCF fragments for the FTS site, its interface matrices and, where it has
one, a fast numpy/numba model (:class:`Specimen1D` for the 1-D parts); any part runs in
MuJoCo behind a prescribed mount (:class:`MujocoSpecimen`). :func:`build_part_model` is the
one builder of a part model for the transfer systems and the reference. A new part is one
subclass of :class:`ExperimentalPart` in one file, decorated with :func:`register_part`.
"""

from ..config import ExperimentConfig
from .base import (
    PARTS,
    ExperimentalPart,
    PartModel,
    has_numpy_model,
    make_part,
    part_class,
    part_kinds,
    register_part,
    uses_numpy,
)
from .build import build_part_model
from .contact import ContactPart
from .linear import LinearPart
from .marths_frame import MarthsFramePart
from .mjcf import specimen_model_xml
from .mjcf_part import MjcfPart
from .mujoco_specimen import MujocoSpecimen
from .multidof import MultiDofPart
from .rigid import RigidPart
from .specimen import Specimen1D

__all__ = [
    "PARTS",
    "ContactPart",
    "ExperimentalPart",
    "LinearPart",
    "MarthsFramePart",
    "MjcfPart",
    "MujocoSpecimen",
    "MultiDofPart",
    "RigidPart",
    "PartModel",
    "Specimen1D",
    "build_part_model",
    "has_numpy_model",
    "interface_matrices",
    "make_part",
    "part_class",
    "part_kinds",
    "payload_xml",
    "register_part",
    "specimen_model_xml",
    "uses_numpy",
    "world_xml",
]


def payload_xml(cfg: ExperimentConfig) -> str:
    """Bodies of the part of ``cfg`` in the FTS site frame (see
    :meth:`ExperimentalPart.payload_xml`)."""
    return make_part(cfg).payload_xml()


def world_xml(cfg: ExperimentConfig, site_pos: tuple[float, float, float]) -> str:
    """World-fixed parts of ``cfg`` for an FTS site at ``site_pos`` (m)."""
    return make_part(cfg).world_xml(site_pos)


def interface_matrices(cfg: ExperimentConfig, dofs: tuple[str, ...] = ()
                       ) -> tuple[list[list[float]], list[list[float]]]:
    """k_EXP and m_EXP of the part of ``cfg`` (see :meth:`ExperimentalPart.interface_matrices`)."""
    return make_part(cfg).interface_matrices()
