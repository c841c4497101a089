"""The six-leg Stewart platform: geometry, kinematics, MuJoCo model, simulation, tracking,
kinematic and force-torque-sensor calibration.

Pose convention: ``(x, y, z, rx, ry, rz)`` of the top plate relative to home, translations in
the world frame (m), rotations ``R = Rz(rz) @ Ry(ry) @ Rx(rx)`` (rad). See docs/platform.md.
"""

from .calibrate.fts import FTSCalibration, PayloadEstimator, load_wrench
from .calibrate.heave import HeaveTF, identify_heave, load_heave_tf
from .calibrate.kinematic import (
    CalibratedGeometry,
    IdentifiabilityReport,
    KinematicCalibration,
    identifiability,
    load_geometry,
)
from .calibrate.poses import select_poses
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
from .model import ActuatorConfig, PlatformConfig, build_model, build_spec, predicted_delay
from .sim import PlatformBatch, StaticState
from .single import PlatformSim
from .tracking import TrackingFigures, sine_delay, sine_trajectory, track, tracking_figures

__all__ = [
    "DEFAULT_GEOMETRY",
    "ActuatorConfig",
    "CalibratedGeometry",
    "FTSCalibration",
    "IdentifiabilityReport",
    "KinematicCalibration",
    "PayloadEstimator",
    "identifiability",
    "load_geometry",
    "load_wrench",
    "select_poses",
    "PlatformBatch",
    "PlatformConfig",
    "PlatformSim",
    "StaticState",
    "TrackingFigures",
    "build_model",
    "build_spec",
    "predicted_delay",
    "sine_delay",
    "sine_trajectory",
    "track",
    "tracking_figures",
    "ForwardKinematicsError",
    "HeaveTF",
    "ScalarIK",
    "StewartGeometry",
    "check_workspace",
    "forward_kinematics",
    "identify_heave",
    "inverse_kinematics",
    "jacobian",
    "load_heave_tf",
    "rotation_matrix",
]
