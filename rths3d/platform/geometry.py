"""Geometry of the six-leg (6-UPS) Stewart platform.

The base plane is the world plane z = 0. Leg i runs from its base anchor ``b_i`` (world
frame, m) to its top anchor ``p_i`` (plate frame, m). The plate frame sits at the centre of
the top-anchor circle; at the home pose it is at ``(0, 0, home_height)`` with its axes
parallel to the world axes. Anchors come in three pairs 120° apart; the base pairs are
centred on ``base_angle + k·120°`` and the top pairs on ``base_angle + 60° + k·120°``, each
pair split by its ``gap`` angle, so that every leg crosses from one base pair to the
neighbouring top pair (the classic well-conditioned arrangement).

Leg stroke is centred on the home length: the piston extension ``L_i − L_i,home`` must stay
within ``±stroke/2``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError

__all__ = ["DEFAULT_GEOMETRY", "StewartGeometry"]


def _positive(name: str, value: float, unit: str) -> None:
    if not (isinstance(value, int | float) and math.isfinite(value) and value > 0):
        raise ConfigError(f"geometry.{name}", value, f"must be a finite number > 0 {unit}")


@dataclass(frozen=True)
class StewartGeometry:
    """Dimensions, limits and masses of a Stewart platform (SI units).

    Attributes
    ----------
    base_radius, top_radius:
        Radii of the base- and top-anchor circles (m).
    base_gap, top_gap:
        Angle between the two anchors of a pair on the base and on the plate (rad).
    base_angle:
        Rotation of the whole anchor pattern about the world z axis (rad).
    home_height:
        Height of the plate frame (top-anchor plane) above the base plane at home (m).
    stroke:
        Total piston stroke (m), centred on the home leg length (±stroke/2).
    leg_velocity_limit:
        Largest admissible piston speed |dL/dt| (m/s).
    leg_force_limit:
        Largest admissible actuator force |f| (N).
    joint_angle_limit:
        Largest admissible angle between a leg and its home direction (rad), the range of
        the base universal joint and the plate ball joint.
    plate_mass, cylinder_mass, piston_mass, fts_mass:
        Masses of the top plate, of each leg cylinder (on the base joint), of each piston
        (on the slide joint) and of the small force-torque-sensor body (kg).
    plate_thickness, fts_height:
        Thickness of the plate (its upper face is at the plate frame, m) and height of the
        force-torque-sensor body whose upper face carries the ``fts`` site (m).
    """

    base_radius: float = 0.40
    top_radius: float = 0.25
    base_gap: float = math.radians(15.0)
    top_gap: float = math.radians(15.0)
    base_angle: float = 0.0
    home_height: float = 0.35
    stroke: float = 0.10
    leg_velocity_limit: float = 0.30
    leg_force_limit: float = 3000.0
    joint_angle_limit: float = math.radians(35.0)
    plate_mass: float = 12.0
    cylinder_mass: float = 2.0
    piston_mass: float = 1.0
    fts_mass: float = 0.3
    plate_thickness: float = 0.02
    fts_height: float = 0.03

    def __post_init__(self) -> None:
        for name, unit in (
            ("base_radius", "m"), ("top_radius", "m"), ("home_height", "m"), ("stroke", "m"),
            ("leg_velocity_limit", "m/s"), ("leg_force_limit", "N"),
            ("joint_angle_limit", "rad"), ("plate_mass", "kg"), ("cylinder_mass", "kg"),
            ("piston_mass", "kg"), ("fts_mass", "kg"), ("plate_thickness", "m"),
            ("fts_height", "m"),
        ):
            _positive(name, getattr(self, name), unit)
        for name in ("base_gap", "top_gap"):
            v = getattr(self, name)
            if not (math.isfinite(v) and 0.0 <= v < math.radians(110.0)):
                raise ConfigError(f"geometry.{name}", v, "must be in [0, 1.92) rad")
        if not math.isfinite(self.base_angle):
            raise ConfigError("geometry.base_angle", self.base_angle, "must be finite (rad)")
        short = float(self.home_leg_lengths().min())
        if self.stroke / 2 >= short:
            raise ConfigError("geometry.stroke", self.stroke,
                              f"half the stroke must be shorter than the home leg length "
                              f"{short:.4g} m")

    # ------------------------------------------------------------------ anchors
    def base_angles(self) -> np.ndarray:
        """Polar angles of the six base anchors (rad), leg order."""
        c = self.base_angle + np.repeat(np.arange(3) * (2 * math.pi / 3), 2)
        return c + np.tile([-self.base_gap / 2, self.base_gap / 2], 3)

    def top_angles(self) -> np.ndarray:
        """Polar angles of the six top anchors in the plate frame (rad), leg order.

        Leg 0 (base anchor at ``base_angle − base_gap/2``) reaches the top anchor at
        ``base_angle − 60° + top_gap/2``: each leg leans towards the neighbouring pair.
        """
        c = self.base_angle + math.pi / 3 + np.repeat(np.arange(3) * (2 * math.pi / 3), 2)
        a = c + np.tile([-self.top_gap / 2, self.top_gap / 2], 3)
        return np.roll(a, 1)

    def base_anchors(self) -> np.ndarray:
        """Base anchors ``b_i`` in the world frame, shape (6, 3), m."""
        a = self.base_angles()
        return np.stack([self.base_radius * np.cos(a), self.base_radius * np.sin(a),
                         np.zeros(6)], axis=1)

    def top_anchors(self) -> np.ndarray:
        """Top anchors ``p_i`` in the plate frame, shape (6, 3), m."""
        a = self.top_angles()
        return np.stack([self.top_radius * np.cos(a), self.top_radius * np.sin(a),
                         np.zeros(6)], axis=1)

    def with_anchors(self, base_anchors: np.ndarray, top_anchors: np.ndarray,
                     leg_offsets: np.ndarray | None = None) -> StewartGeometry:
        """This platform's limits, masses and heights with explicit anchor points that
        override the parametric ones: ``base_anchors`` ``b_i`` (6, 3) in the world frame and
        ``top_anchors`` ``p_i`` (6, 3) in the plate frame at home (m), in leg order;
        ``leg_offsets`` (6,) the encoder offsets (m, default 0). The result (a
        :class:`~rths3d.platform.calibration.CalibratedGeometry`) is accepted wherever a
        StewartGeometry is: inverse kinematics, the MuJoCo model (legs, anchor sites and the
        meshes through ``base_angles()``/``top_angles()``), the simulators."""
        from .calibration import CalibratedGeometry

        return CalibratedGeometry.from_nominal(self, np.asarray(base_anchors, dtype=float),
                                               np.asarray(top_anchors, dtype=float),
                                               np.zeros(6) if leg_offsets is None
                                               else leg_offsets)

    def home_position(self) -> np.ndarray:
        """World position of the plate frame at home, (3,), m."""
        return np.array([0.0, 0.0, self.home_height])

    def home_leg_vectors(self) -> np.ndarray:
        """Leg vectors ``p_i + (0,0,h) − b_i`` at home, (6, 3), m."""
        return self.top_anchors() + self.home_position() - self.base_anchors()

    def home_leg_lengths(self) -> np.ndarray:
        """Leg lengths ``L_i,home`` at the home pose, (6,), m."""
        return np.linalg.norm(self.home_leg_vectors(), axis=1)

    def leg_length_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """Shortest and longest admissible leg lengths, each (6,), m."""
        h = self.home_leg_lengths()
        return h - self.stroke / 2, h + self.stroke / 2


DEFAULT_GEOMETRY = StewartGeometry()
"""The default platform: a 0.8 m base, 0.5 m plate, 0.35 m home height, ±50 mm stroke.

Its length Jacobian at home has a condition number of 5.70 in SI units and 1.77 with the
rotation columns scaled by the top radius (see ``kinematics.jacobian``), i.e. the platform is
nearly isotropic at home.
"""
