"""Inverse and forward kinematics, Jacobian and workspace check of the Stewart platform.

Pose convention (docs/architecture.md): ``q = (x, y, z, rx, ry, rz)`` is the pose of the plate
relative to home — translation of the plate frame in the world frame (m) and fixed-axis
roll–pitch–yaw angles (rad) with ``R = Rz(rz) @ Ry(ry) @ Rx(rx)``. Leg i has length

    L_i(q) = ‖ (0, 0, h) + t + R p_i − b_i ‖

with base anchor ``b_i`` (world) and top anchor ``p_i`` (plate frame) from
:class:`~rths3d.platform.geometry.StewartGeometry`.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ConfigError, RthsError
from .geometry import StewartGeometry

__all__ = [
    "ForwardKinematicsError",
    "ScalarIK",
    "check_workspace",
    "euler_from_matrix",
    "forward_kinematics",
    "inverse_kinematics",
    "jacobian",
    "rotation_matrix",
    "skew",
]


class ForwardKinematicsError(RthsError):
    """Newton iteration of the forward kinematics did not converge."""


def rotation_matrix(rx: np.ndarray | float, ry: np.ndarray | float,
                    rz: np.ndarray | float) -> np.ndarray:
    """``R = Rz(rz) @ Ry(ry) @ Rx(rx)`` for angles of any broadcastable shape → (..., 3, 3)."""
    rx, ry, rz = np.broadcast_arrays(np.asarray(rx, float), np.asarray(ry, float),
                                     np.asarray(rz, float))
    cx, sx = np.cos(rx), np.sin(rx)
    cy, sy = np.cos(ry), np.sin(ry)
    cz, sz = np.cos(rz), np.sin(rz)
    R = np.empty(rx.shape + (3, 3))
    R[..., 0, 0] = cz * cy
    R[..., 0, 1] = cz * sy * sx - sz * cx
    R[..., 0, 2] = cz * sy * cx + sz * sx
    R[..., 1, 0] = sz * cy
    R[..., 1, 1] = sz * sy * sx + cz * cx
    R[..., 1, 2] = sz * sy * cx - cz * sx
    R[..., 2, 0] = -sy
    R[..., 2, 1] = cy * sx
    R[..., 2, 2] = cy * cx
    return R


def euler_from_matrix(R: np.ndarray) -> np.ndarray:
    """Angles ``(rx, ry, rz)`` (rad) of ``R = Rz Ry Rx``, (..., 3, 3) → (..., 3); |ry| < π/2."""
    R = np.asarray(R, float)
    rx = np.arctan2(R[..., 2, 1], R[..., 2, 2])
    ry = np.arctan2(-R[..., 2, 0], np.hypot(R[..., 2, 1], R[..., 2, 2]))
    rz = np.arctan2(R[..., 1, 0], R[..., 0, 0])
    return np.stack([rx, ry, rz], axis=-1)


def _as_poses(poses: np.ndarray | list | tuple, name: str = "pose") -> np.ndarray:
    q = np.asarray(poses, dtype=float)
    if q.shape[-1:] != (6,):
        raise ConfigError(name, f"array of shape {q.shape}",
                          "last axis must hold the 6 DOFs x, y, z (m), rx, ry, rz (rad)")
    if not np.all(np.isfinite(q)):
        raise ConfigError(name, "NaN/inf", "all pose values must be finite")
    return q


def _leg_vectors(geom: StewartGeometry, q: np.ndarray) -> np.ndarray:
    """World leg vectors ``l_i`` for poses (..., 6) → (..., 6, 3), m."""
    R = rotation_matrix(q[..., 3], q[..., 4], q[..., 5])
    p = geom.top_anchors()
    rp = np.einsum("...jk,ik->...ij", R, p)
    t = q[..., None, :3] + geom.home_position()
    return t + rp - geom.base_anchors()


def inverse_kinematics(geom: StewartGeometry, poses: np.ndarray) -> np.ndarray:
    """Leg lengths ``L_i`` (m) of poses relative to home, vectorised: (..., 6) → (..., 6)."""
    q = _as_poses(poses)
    return np.linalg.norm(_leg_vectors(geom, q), axis=-1)


def jacobian(geom: StewartGeometry, pose: np.ndarray) -> np.ndarray:
    """Length Jacobian ``J = ∂L/∂q`` (6×6; rows legs, columns x, y, z, rx, ry, rz).

    Columns 0–2 in m/m, columns 3–5 in m/rad (derivatives with respect to the fixed-axis
    angles, not to an angular velocity). Row i is ``[u_i, (R p_i × u_i)ᵀ E(q)]`` with the unit
    leg vector ``u_i`` and ``E = [Rz Ry e_x, Rz e_y, e_z]``. Accepts (..., 6) poses and
    returns (..., 6, 6). At home ``E = I``.
    """
    q = _as_poses(pose)
    lv = _leg_vectors(geom, q)
    u = lv / np.linalg.norm(lv, axis=-1, keepdims=True)
    R = rotation_matrix(q[..., 3], q[..., 4], q[..., 5])
    rp = np.einsum("...jk,ik->...ij", R, geom.top_anchors())
    m = np.cross(rp, u)  # (..., 6, 3): moment arm, ∂L/∂ω
    cy, sy = np.cos(q[..., 4]), np.sin(q[..., 4])
    cz, sz = np.cos(q[..., 5]), np.sin(q[..., 5])
    E = np.zeros(q.shape[:-1] + (3, 3))
    E[..., 0, 0] = cz * cy
    E[..., 1, 0] = sz * cy
    E[..., 2, 0] = -sy
    E[..., 0, 1] = -sz
    E[..., 1, 1] = cz
    E[..., 2, 2] = 1.0
    return np.concatenate([u, m @ E], axis=-1)


def forward_kinematics(geom: StewartGeometry, lengths: np.ndarray,
                       guess: np.ndarray | None = None, tol: float = 1e-12,
                       max_iter: int = 50) -> np.ndarray:
    """Pose (relative to home) that gives leg lengths ``lengths`` (m), by Newton iteration.

    Vectorised: lengths (..., 6) → poses (..., 6). Starts from ``guess`` (default: home) and
    stops when every leg-length residual is below ``tol`` (m). Raises
    :class:`ForwardKinematicsError` naming the sample (of several) and its leg lengths if
    ``max_iter`` iterations do not converge (e.g. lengths that no pose reaches), if the
    Jacobian is singular, or if the pose found puts the plate at or below the base plane
    (``z + home_height <= 0``: the mirrored assembly branch, reached from a guess below the
    base).
    """
    L = np.asarray(lengths, dtype=float)
    if L.shape[-1:] != (6,) or not np.all(np.isfinite(L)) or np.any(L <= 0):
        raise ConfigError("lengths", f"array of shape {L.shape}",
                          "need (..., 6) finite positive leg lengths in m")
    q = np.zeros(L.shape) if guess is None else np.array(
        np.broadcast_to(_as_poses(guess, "guess"), L.shape), dtype=float)
    flat_L = L.reshape(-1, 6)

    def where(k: int) -> str:
        w = f"lengths {np.array2string(flat_L[k], precision=6)} m"
        return f"sample {k}, {w}" if flat_L.shape[0] > 1 else w

    res = np.inf
    r = np.zeros(L.shape)
    for _ in range(int(max_iter)):
        r = inverse_kinematics(geom, q) - L
        res = float(np.max(np.abs(r))) if r.size else 0.0
        if res < tol:
            z = q.reshape(-1, 6)[:, 2] + geom.home_height
            if np.any(z <= 0):
                k = int(np.flatnonzero(z <= 0)[0])
                raise ForwardKinematicsError(
                    f"forward kinematics: {where(k)}: the solution puts the plate at "
                    f"z = {z[k]:.6g} m, at or below the base (mirrored assembly branch); "
                    "start from a guess above the base")
            return q
        J = jacobian(geom, q)
        try:
            dq = np.linalg.solve(J, r[..., None])[..., 0]
        except np.linalg.LinAlgError as exc:
            cond = np.linalg.cond(J.reshape(-1, 6, 6))
            k = int(np.argmax(np.where(np.isfinite(cond), cond, np.inf)))
            raise ForwardKinematicsError(
                f"forward kinematics: {where(k)}: singular Jacobian (pose at a "
                "singularity)") from exc
        q = q - dq
        if not np.all(np.isfinite(q)):
            k = int(np.flatnonzero(~np.all(np.isfinite(q.reshape(-1, 6)), axis=1))[0])
            raise ForwardKinematicsError(
                f"forward kinematics: {where(k)}: the Newton iteration diverged (lengths "
                "unreachable or guess too far)")
    rk = np.abs(r).reshape(-1, 6).max(axis=1)
    k = int(np.argmax(rk))
    raise ForwardKinematicsError(
        f"forward kinematics did not converge in {max_iter} iterations: {where(k)}: leg-length "
        f"residual {rk[k]:.3g} m > tol {tol:.3g} m (lengths unreachable or guess too far)")


def check_workspace(geom: StewartGeometry, pose: np.ndarray) -> np.ndarray:
    """Check that pose(s) (..., 6) are reachable; return the leg lengths (..., 6), m.

    Raises :class:`~rths3d.errors.ConfigError` naming the first offending sample, the leg,
    the quantity (length or joint angle), the value and the limit.
    """
    q = _as_poses(pose)
    lv = _leg_vectors(geom, q)
    L = np.linalg.norm(lv, axis=-1)
    lo, hi = geom.leg_length_limits()
    home = geom.home_leg_vectors()
    cosang = np.einsum("...ik,ik->...i", lv, home) / (L * geom.home_leg_lengths())
    ang = np.arccos(np.clip(cosang, -1.0, 1.0))
    flat_q = q.reshape(-1, 6)
    for name, val, bad in (
        ("length", L, (L < lo) | (L > hi)),
        ("joint angle", ang, ang > geom.joint_angle_limit),
    ):
        if np.any(bad):
            k, i = np.unravel_index(int(np.flatnonzero(bad.reshape(-1))[0]),
                                    (flat_q.shape[0], 6))
            v = float(val.reshape(-1, 6)[k, i])
            where = f"pose {np.array2string(flat_q[k], precision=4)}"
            if flat_q.shape[0] > 1:
                where = f"sample {k}, " + where
            if name == "length":
                limit = f"[{lo[i]:.6g}, {hi[i]:.6g}] m (stroke ±{geom.stroke / 2:.4g} m)"
                msg = (f"{where}: leg {i} length {v:.6g} m is outside its range {limit}")
            else:
                limit = f"{geom.joint_angle_limit:.4g} rad"
                msg = (f"{where}: leg {i} joint angle {v:.4g} rad exceeds the limit {limit}")
            raise ConfigError(f"leg {i} {name}", v, limit, message=msg)
    return L


class ScalarIK:
    """Inverse kinematics in plain ``math`` for one pose at a time (the 1 kHz fast path).

    ``ik(x, y, z, rx, ry, rz)`` returns the six leg lengths (m) as a tuple of floats, with no
    numpy involved (small-array numpy costs several µs per call). Top anchors off the plate
    plane (a calibrated geometry, ``p_i,z ≠ 0``) take the third column of R as well.
    """

    __slots__ = ("_b", "_p", "_h", "_pz")

    def __init__(self, geom: StewartGeometry):
        self._b = tuple(tuple(float(v) for v in row) for row in geom.base_anchors())
        top = geom.top_anchors()
        self._p = tuple(tuple(float(v) for v in row[:2]) for row in top)
        self._pz = tuple(float(v) for v in top[:, 2]) if np.any(top[:, 2] != 0) else None
        self._h = float(geom.home_height)

    def ik(self, x: float, y: float, z: float, rx: float, ry: float,
           rz: float) -> tuple[float, float, float, float, float, float]:
        """Leg lengths (m) of the pose (m, rad) relative to home."""
        cx = math.cos(rx)
        sx = math.sin(rx)
        cy = math.cos(ry)
        sy = math.sin(ry)
        cz = math.cos(rz)
        sz = math.sin(rz)
        # the first two columns of R act on planar top anchors (p_z = 0; third one below)
        r00 = cz * cy
        r01 = cz * sy * sx - sz * cx
        r10 = sz * cy
        r11 = sz * sy * sx + cz * cx
        r20 = -sy
        r21 = cy * sx
        tz = z + self._h
        sqrt = math.sqrt
        out = []
        if self._pz is not None:
            r02 = cz * sy * cx + sz * sx
            r12 = sz * sy * cx - cz * sx
            r22 = cy * cx
            for (px, py), pz, (bx, by, bz) in zip(self._p, self._pz, self._b, strict=True):
                lx = x + r00 * px + r01 * py + r02 * pz - bx
                ly = y + r10 * px + r11 * py + r12 * pz - by
                lz = tz + r20 * px + r21 * py + r22 * pz - bz
                out.append(sqrt(lx * lx + ly * ly + lz * lz))
            return tuple(out)  # type: ignore[return-value]
        for (px, py), (bx, by, bz) in zip(self._p, self._b, strict=True):
            lx = x + r00 * px + r01 * py - bx
            ly = y + r10 * px + r11 * py - by
            lz = tz + r20 * px + r21 * py - bz
            out.append(sqrt(lx * lx + ly * ly + lz * lz))
        return tuple(out)  # type: ignore[return-value]


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices ``[v]×`` of vectors (..., 3) → (..., 3, 3): ``[v]× w = v × w``."""
    v = np.asarray(v, dtype=float)
    S = np.zeros(v.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2] = -v[..., 2], v[..., 1]
    S[..., 1, 0], S[..., 1, 2] = v[..., 2], -v[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -v[..., 1], v[..., 0]
    return S
