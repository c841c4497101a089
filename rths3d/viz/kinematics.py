"""Drawing kinematics: poses, quaternions and leg segments for the 3-D view.

Conventions are the project's (docs/architecture.md): MuJoCo world frame, z up, SI units
(m, rad). A platform pose is ``(x, y, z, rx, ry, rz)`` relative to home with rotation
``R = Rz(rz) @ Ry(ry) @ Rx(rx)``. viser wants orientations as unit quaternions ``(w, x, y, z)``.
These functions run at the view's update rate (≤ 30 Hz), never inside the 1 kHz loop.
"""

from __future__ import annotations

import math

import numpy as np


def rotation_matrix(rx: float, ry: float, rz: float) -> np.ndarray:
    """Rotation matrix ``R = Rz(rz) @ Ry(ry) @ Rx(rx)`` (fixed-axis roll–pitch–yaw, rad)."""
    cx, sx = math.cos(rx), math.sin(rx)
    cy, sy = math.cos(ry), math.sin(ry)
    cz, sz = math.cos(rz), math.sin(rz)
    return np.array([
        [cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx],
        [sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx],
        [-sy, cy * sx, cy * cx],
    ])


def quat_from_matrix(R: np.ndarray) -> np.ndarray:
    """Unit quaternion ``(w, x, y, z)`` of a rotation matrix (w ≥ 0)."""
    m = np.asarray(R, dtype=float)
    tr = m[0, 0] + m[1, 1] + m[2, 2]
    if tr > 0.0:
        s = 2.0 * math.sqrt(tr + 1.0)
        q = np.array([0.25 * s, (m[2, 1] - m[1, 2]) / s, (m[0, 2] - m[2, 0]) / s,
                      (m[1, 0] - m[0, 1]) / s])
    elif m[0, 0] > m[1, 1] and m[0, 0] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[0, 0] - m[1, 1] - m[2, 2])
        q = np.array([(m[2, 1] - m[1, 2]) / s, 0.25 * s, (m[0, 1] + m[1, 0]) / s,
                      (m[0, 2] + m[2, 0]) / s])
    elif m[1, 1] > m[2, 2]:
        s = 2.0 * math.sqrt(1.0 + m[1, 1] - m[0, 0] - m[2, 2])
        q = np.array([(m[0, 2] - m[2, 0]) / s, (m[0, 1] + m[1, 0]) / s, 0.25 * s,
                      (m[1, 2] + m[2, 1]) / s])
    else:
        s = 2.0 * math.sqrt(1.0 + m[2, 2] - m[0, 0] - m[1, 1])
        q = np.array([(m[1, 0] - m[0, 1]) / s, (m[0, 2] + m[2, 0]) / s,
                      (m[1, 2] + m[2, 1]) / s, 0.25 * s])
    q /= np.linalg.norm(q)
    return -q if q[0] < 0 else q


def quat_z_to(direction: np.ndarray) -> np.ndarray:
    """Shortest-arc quaternion ``(w, x, y, z)`` turning the +z axis onto ``direction``."""
    d = np.asarray(direction, dtype=float)
    d = d / np.linalg.norm(d)
    w = 1.0 + d[2]
    if w < 1e-12:  # anti-parallel: half turn about x
        return np.array([0.0, 1.0, 0.0, 0.0])
    q = np.array([w, -d[1], d[0], 0.0])  # (1 + z·d, z × d)
    return q / np.linalg.norm(q)


def quat_rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rotate vector ``v`` by unit quaternion ``q = (w, x, y, z)``."""
    w, u = q[0], np.asarray(q[1:], dtype=float)
    v = np.asarray(v, dtype=float)
    return v + 2.0 * np.cross(u, np.cross(u, v) + w * v)


def transform_points(points: np.ndarray, pose: np.ndarray, home: np.ndarray) -> np.ndarray:
    """World positions of points fixed to the top plate.

    ``points`` (k, 3) are in the plate frame, origin at the plate centre at home; ``pose`` is
    ``(x, y, z, rx, ry, rz)`` relative to home (m, rad); ``home`` the plate centre at home in
    world (m). Returns ``home + t + R @ p`` for each point.
    """
    R = rotation_matrix(float(pose[3]), float(pose[4]), float(pose[5]))
    return np.asarray(points, dtype=float) @ R.T + (np.asarray(home, float) + pose[:3])


def leg_segments(base: np.ndarray, tip: np.ndarray, cylinder_length: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Centres and orientations of the leg cylinders (fixed at the base) and pistons (at the tip).

    A leg is a cylinder of fixed length hinged at its base anchor and a piston of the same
    length sliding in it, its end at the top-plate anchor. For base anchors ``base`` (6, 3)
    and tips ``tip`` (6, 3) in world (m) returns ``(cyl_centres, piston_centres, quats,
    lengths)``: the cylinder occupies ``[0, c]`` along the leg axis from the base, the piston
    ``[L − c, L]``; ``quats`` (6, 4) turn +z onto each leg axis; ``lengths`` (6,) are L (m).
    """
    base = np.asarray(base, dtype=float)
    axis = np.asarray(tip, dtype=float) - base
    lengths = np.linalg.norm(axis, axis=1)
    unit = axis / lengths[:, None]
    c = float(cylinder_length)
    cyl = base + unit * (0.5 * c)
    piston = base + unit * (lengths - 0.5 * c)[:, None]
    quats = np.stack([quat_z_to(u) for u in unit])
    return cyl, piston, quats, lengths
