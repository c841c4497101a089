"""The six-leg Stewart platform: geometry, kinematics, MuJoCo model, simulation, tracking.

Pose convention: ``(x, y, z, rx, ry, rz)`` of the top plate relative to home, translations in
the world frame (m), rotations ``R = Rz(rz) @ Ry(ry) @ Rx(rx)`` (rad). See docs/platform.md.
"""

from .geometry import DEFAULT_GEOMETRY, StewartGeometry
from .kinematics import (
    ForwardKinematicsError,
    ScalarIK,
    check_workspace,
    forward_kinematics,
    inverse_kinematics,
    jacobian,
    rotation_matrix,
)

__all__ = [
    "DEFAULT_GEOMETRY",
    "ForwardKinematicsError",
    "ScalarIK",
    "StewartGeometry",
    "check_workspace",
    "forward_kinematics",
    "inverse_kinematics",
    "jacobian",
    "rotation_matrix",
]
