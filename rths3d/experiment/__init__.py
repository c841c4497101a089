"""Experimental parts: MJCF fragments for the FTS site and vectorised numpy models.

(a) the paper's contact system (Fig. 4), (b) its linear part (Fig. 5, Table 2), (c) a
multi-DOF bar (heave + pitch) with contact. ``Specimen1D`` is the numpy model of (a)/(b) for
the fast LTI path; ``MujocoSpecimen`` runs any part in MuJoCo behind a prescribed mount.
"""

from .mjcf import interface_matrices, payload_xml, specimen_model_xml, world_xml
from .mujoco_specimen import MujocoSpecimen
from .specimen import Specimen1D

__all__ = [
    "MujocoSpecimen",
    "Specimen1D",
    "interface_matrices",
    "payload_xml",
    "specimen_model_xml",
    "world_xml",
]
