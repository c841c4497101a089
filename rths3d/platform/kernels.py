"""The platform's compiled per-step kernels (numba): inverse kinematics and set-points, the
servo's hold, the measured channels and the limits, for K tests at once. The Python driver
(:class:`~rths3d.platform.sim.PlatformBatch`) calls them one step at a time; the compiled
range (:mod:`rths3d.platform.compiled`) calls the same kernels around MuJoCo's C API, so both
compute the same arithmetic."""

from __future__ import annotations

import math

import numba
import numpy as np

from ..kernels import njit

__all__ = ["copy_fts", "end_ramp", "fts_distort", "interface_command", "leg_lengths_of",
           "leg_setpoints", "measured_over", "plate_pose", "quat_rows", "ramp_ctrl",
           "read_interface", "rotation", "take_sample", "world_wrench", "leg_channels",
           "commands_out"]


def _quat_to_euler(w: float, x: float, y: float, z: float) -> tuple[float, float, float]:
    """Fixed-axis angles (rx, ry, rz) of a unit quaternion, R = Rz Ry Rx."""
    r20 = 2.0 * (x * z - w * y)
    r21 = 2.0 * (y * z + w * x)
    r22 = 1.0 - 2.0 * (x * x + y * y)
    r10 = 2.0 * (x * y + w * z)
    r00 = 1.0 - 2.0 * (y * y + z * z)
    r20 = -1.0 if r20 < -1.0 else (1.0 if r20 > 1.0 else r20)
    return math.atan2(r21, r22), -math.asin(r20), math.atan2(r10, r00)


def plate_pose(q: np.ndarray, home_height: float) -> np.ndarray:
    """Poses (..., 6) relative to home (m, rad) of plate ``qpos`` rows (..., 7).

    ``q`` = [x, y, z, w, qx, qy, qz] (MuJoCo free joint: position, unit quaternion); the
    angles are the fixed-axis (rx, ry, rz) of :func:`_quat_to_euler`, R = Rz Ry Rx. Loops keep
    the raw rows per step and convert whole histories at once with this.
    """
    w, x, y, z = q[..., 3], q[..., 4], q[..., 5], q[..., 6]
    out = np.empty(q.shape[:-1] + (6,))
    out[..., :3] = q[..., :3]
    out[..., 2] -= home_height
    out[..., 3] = np.arctan2(2 * (y * z + w * x), 1 - 2 * (x * x + y * y))
    out[..., 4] = np.arcsin(np.clip(2 * (w * y - x * z), -1.0, 1.0))
    out[..., 5] = np.arctan2(2 * (x * y + w * z), 1 - 2 * (y * y + z * z))
    return out



@numba.njit(cache=True, nogil=True, inline="always")
def rotation(rx, ry, rz):  # pragma: no cover - jit
    """R = Rz(rz) Ry(ry) Rx(rx) of fixed-axis angles, as its 9 entries row by row (the
    platform's inverse kinematics and the per-leg channels share it)."""
    cx, sx = math.cos(rx), math.sin(rx)
    cy, sy = math.cos(ry), math.sin(ry)
    cz, sz = math.cos(rz), math.sin(rz)
    return (cz * cy, cz * sy * sx - sz * cx, cz * sy * cx + sz * sx,
            sz * cy, sz * sy * sx + cz * cx, sz * sy * cx - cz * sx,
            -sy, cy * sx, cy * cx)


@numba.njit(cache=True, nogil=True)
def leg_channels(poses, rates, b, p, hh, home, q, s_des, s_rate, s_meas):
    """The per-leg channels of K platforms, in one pass: the desired extensions
    s = |l| − L_home with l = t + R p_i − b_i (the platform's inverse kinematics, home height
    ``hh``), their rates ṡ = l·(ṫ + ω × R p_i)/|l| under the pose rates ``rates`` (K, 6)
    (m/s, rad/s of the fixed-axis angles) and the measured extensions (the slide positions
    ``q``), each (K, 6) in m or m/s (per-leg compensation, :mod:`rths3d.transfer.legs`)."""
    for k in range(poses.shape[0]):
        r00, r01, r02, r10, r11, r12, r20, r21, r22 = rotation(
            poses[k, 3], poses[k, 4], poses[k, 5])
        cz, sz = math.cos(poses[k, 5]), math.sin(poses[k, 5])
        # ω = ṙz e_z + ṙy Rz e_y + ṙx Rz Ry e_x (R = Rz Ry Rx; Rz Ry e_x is R's first column)
        ax, ay, az = rates[k, 3], rates[k, 4], rates[k, 5]
        wx = -sz * ay + r00 * ax
        wy = cz * ay + r10 * ax
        wz = az + r20 * ax
        for i in range(6):
            px, py, pz = p[i, 0], p[i, 1], p[i, 2]
            rx = r00 * px + r01 * py + r02 * pz
            ry = r10 * px + r11 * py + r12 * pz
            rz = r20 * px + r21 * py + r22 * pz
            lx = poses[k, 0] + rx - b[i, 0]
            ly = poses[k, 1] + ry - b[i, 1]
            lz = poses[k, 2] + hh + rz - b[i, 2]
            vx = rates[k, 0] + wy * rz - wz * ry
            vy = rates[k, 1] + wz * rx - wx * rz
            vz = rates[k, 2] + wx * ry - wy * rx
            L = math.sqrt(lx * lx + ly * ly + lz * lz)
            s_des[k, i] = L - home[i]
            s_rate[k, i] = (lx * vx + ly * vy + lz * vz) / L
            s_meas[k, i] = q[k, i]


@numba.njit(cache=True, nogil=True)
def commands_out(u, home, L):
    """The lengths to command, L = L_home + u."""
    for k in range(L.shape[0]):
        for i in range(6):
            L[k, i] = home[i] + u[k, i]


@numba.njit(cache=True, nogil=True, inline="always")
def ik_row(poses, k, b, p, hh, L):  # pragma: no cover - jit
    """Leg lengths ``L[k]`` of pose ``poses[k]`` (relative to home): L_i = |t + R p_i − b_i|,
    R = :func:`rotation`, t the plate position with the home height ``hh`` added."""
    x, y, tz = poses[k, 0], poses[k, 1], poses[k, 2] + hh
    r00, r01, r02, r10, r11, r12, r20, r21, r22 = rotation(poses[k, 3], poses[k, 4],
                                                           poses[k, 5])
    for i in range(6):
        px, py, pz = p[i, 0], p[i, 1], p[i, 2]
        lx = x + r00 * px + r01 * py + r02 * pz - b[i, 0]
        ly = y + r10 * px + r11 * py + r12 * pz - b[i, 1]
        lz = tz + r20 * px + r21 * py + r22 * pz - b[i, 2]
        L[k, i] = math.sqrt(lx * lx + ly * ly + lz * lz)


@njit
def leg_lengths_of(poses, b, p, hh, L):
    """Leg lengths (K, 6) of the poses (K, 6) relative to home: the inverse kinematics of
    :func:`leg_setpoints`."""
    for k in range(poses.shape[0]):
        ik_row(poses, k, b, p, hh, L)


@njit
def leg_setpoints(poses, b, p, hh, home, ffg, Lprev, L, sp, half, vdt, run, ik,
                  ffn, Lnext, ahead):
    """Inverse kinematics, command limits and leg set-points of K platforms.

    Leg i of test k: L = |t + R p_i − b_i| with R = :func:`rotation` and t the plate position
    (home height ``hh`` added); the set-point ``L − L_home + g_ff·ΔL`` (velocity feed-forward
    g_ff = kv/(kp ΔT); the set-point blocks, gravity compensation and encoder bias follow in
    :func:`ramp_ctrl`) written to ``sp[k, i]`` for the tests in ``run``. ``ahead``: the
    lengths ``Lnext`` of the next commanded poses are known (an open-loop replay) and the
    forward difference adds ``ffn·(L_next − L)`` (central feed-forward: ``ffg = ffn =
    kv/(2 kp ΔT)``). Returns the number
    of running tests whose command leaves the stroke (±``half``) or the speed
    (|ΔL| ≤ ``vdt``); those keep their set-point and ``Lprev`` (the caller stops them).
    ``ik`` False: the lengths already in ``L`` are the ones to command (per-leg
    compensation, :attr:`PlatformBatch.leg_hook`).
    """
    bad = 0
    for k in range(poses.shape[0]):
        if ik:
            ik_row(poses, k, b, p, hh, L)
        ok = True
        for i in range(6):
            # `not <=`: a NaN command stops like an overrun
            if not (abs(L[k, i] - home[i]) <= half and abs(L[k, i] - Lprev[k, i]) <= vdt):
                ok = False
        if not run[k]:
            continue
        if not ok:
            bad += 1
            continue
        for i in range(6):
            sp[k, i] = L[k, i] - home[i] + ffg[k] * (L[k, i] - Lprev[k, i])
            Lprev[k, i] = L[k, i]
        if ahead:
            for i in range(6):
                sp[k, i] += ffn[k] * (Lnext[k, i] - L[k, i])
    return bad


@njit
def measured_over(q, v, f, half, vmax, fmax, run):
    """Whether a running test's legs left stroke, speed or force (|·| above the limit)."""
    for k in range(q.shape[0]):
        if not run[k]:
            continue
        for i in range(q.shape[1]):
            if abs(q[k, i]) > half or abs(v[k, i]) > vmax or abs(f[k, i]) > fmax:
                return True
    return False


@njit
def world_wrench(R, sens_f, sens_t, pre, rows, out):
    """Rows ``rows`` of the FTS wrench in world axes minus the preload (N, N·m), (K, len)."""
    for k in range(out.shape[0]):
        for c in range(rows.shape[0]):
            r = rows[c]
            a = r % 3
            src = sens_f if r < 3 else sens_t
            out[k, c] = (R[k, 3 * a] * src[k, 0] + R[k, 3 * a + 1] * src[k, 1]
                         + R[k, 3 * a + 2] * src[k, 2]) - pre[k, r]


@njit
def read_interface(q, hh, idx, R, sens_f, sens_t, pre, z, f, rest):
    """Achieved interface DOFs ``idx`` (of x y z rx ry rz) from the plate qpos rows (K, 7),
    relative to the rest pose ``rest`` (K, 6), and the measured interface wrench rows
    ``idx`` (world axes, tare ``pre`` removed)."""
    for k in range(q.shape[0]):
        w, x, y, zq = q[k, 3], q[k, 4], q[k, 5], q[k, 6]
        for c in range(idx.shape[0]):
            i = idx[c]
            if i < 3:
                z[k, c] = q[k, i] - (hh if i == 2 else 0.0)
            elif i == 3:
                z[k, c] = math.atan2(2 * (y * zq + w * x), 1 - 2 * (x * x + y * y))
            elif i == 4:
                z[k, c] = math.asin(min(max(2 * (w * y - x * zq), -1.0), 1.0))
            else:
                z[k, c] = math.atan2(2 * (x * y + w * zq), 1 - 2 * (y * y + zq * zq))
            z[k, c] -= rest[k, i]
            a = i % 3
            src = sens_f if i < 3 else sens_t
            f[k, c] = (R[k, 3 * a] * src[k, 0] + R[k, 3 * a + 1] * src[k, 1]
                       + R[k, 3 * a + 2] * src[k, 2]) - pre[k, i]


@njit
def interface_command(u, idx, poses):
    """The interface DOFs ``idx`` of the commanded poses set to ``u`` (K, len(idx))."""
    for k in range(u.shape[0]):
        for c in range(idx.shape[0]):
            poses[k, idx[c]] = u[k, c]


@njit
def ramp_ctrl(y, off, bias, cprev, cnew, ctrl, a0, inv_dt, run, zoh, act, s0, lag):
    """Set-points of K platforms for the end of the step, ``cnew = y + off + bias`` (block
    output, gravity compensation, encoder bias), and the set-point rate ``(cnew − cprev)/ΔT``
    written to ``ctrl[k, a0 + i]`` (the servo integrates it: a linear ramp over the step);
    a zero-order hold (``zoh[k]``) instead sets the servo's set-point (activation
    ``act[k, s0 + i]``) to ``cnew`` now and holds it (rate 0); stopped tests hold (rate 0).

    ``lag = (a1, s1, itau)``: the servo's continuous lag after the hold
    (:mod:`rths3d.platform.model`, actuators ``leg{i}_lag`` from ``a1``, activations from
    ``s1``; ``a1 < 0``: none), ``itau[k]`` 1/τ (1/s). Its filter takes the same set-point
    rate; at a held set-point's jump its activation jumps by Δc/τ, so that the lagged
    set-point ``act − τ·f`` stays continuous."""
    a1, s1, itau = lag
    for k in range(y.shape[0]):
        for i in range(6):
            if run[k]:
                c = y[k, i] + off[k, i] + bias[k, i]
                if zoh[k]:
                    if a1 >= 0:
                        act[k, s1 + i] += (c - cprev[k, i]) * itau[k]
                        ctrl[k, a1 + i] = 0.0
                    act[k, s0 + i] = c
                    ctrl[k, a0 + i] = 0.0
                else:
                    r = (c - cprev[k, i]) * inv_dt
                    ctrl[k, a0 + i] = r
                    if a1 >= 0:
                        ctrl[k, a1 + i] = r
                cnew[k, i] = c
            else:
                ctrl[k, a0 + i] = 0.0
                if a1 >= 0:
                    ctrl[k, a1 + i] = 0.0


@njit
def end_ramp(cnew, cprev, act, s0, run):
    """After the step: the servo set-points (activations ``act[k, s0 + i]``) are exactly
    ``cnew`` (no rounding drift of the integration), and ``cprev = cnew``."""
    for k in range(cnew.shape[0]):
        if run[k]:
            for i in range(6):
                act[k, s0 + i] = cnew[k, i]
                cprev[k, i] = cnew[k, i]


@njit
def take_sample(start, want, q, lq, lf, R, qm, lqm, lfm, Rm, sf, st, C, bo, reading):
    """The measured channels of the tests whose sampling instant ``start[k]`` is ``want``:
    plate qpos, leg extensions and forces, the FTS orientation (row-major) and its reading
    ``C w + b`` copied from the live state into the sample buffers."""
    for k in range(q.shape[0]):
        if start[k] != want:
            continue
        for c in range(q.shape[1]):
            qm[k, c] = q[k, c]
        for i in range(6):
            lqm[k, i] = lq[k, i]
            lfm[k, i] = lf[k, i]
        for c in range(9):
            Rm[k, c] = R[k, c]
        for r in range(6):
            acc = bo[k, r]
            for c in range(3):
                acc += C[k, r, c] * sf[k, c] + C[k, r, 3 + c] * st[k, c]
            reading[k, r] = acc


@njit
def quat_rows(q, R):
    """Row-major rotation matrices (K, 9) of unit quaternions (K, 4) (w, x, y, z)."""
    for k in range(q.shape[0]):
        w, x, y, z = q[k, 0], q[k, 1], q[k, 2], q[k, 3]
        R[k, 0] = 1 - 2 * (y * y + z * z)
        R[k, 1] = 2 * (x * y - w * z)
        R[k, 2] = 2 * (x * z + w * y)
        R[k, 3] = 2 * (x * y + w * z)
        R[k, 4] = 1 - 2 * (x * x + z * z)
        R[k, 5] = 2 * (y * z - w * x)
        R[k, 6] = 2 * (x * z - w * y)
        R[k, 7] = 2 * (y * z + w * x)
        R[k, 8] = 1 - 2 * (x * x + y * y)


@njit
def copy_fts(sf, st, out):
    """The FTS reading (K, 6) of an ideal sensor: MuJoCo's force and torque."""
    for k in range(sf.shape[0]):
        for c in range(3):
            out[k, c] = sf[k, c]
            out[k, 3 + c] = st[k, c]


@njit
def fts_distort(sf, st, C, b, of, ot):
    """Raw FTS reading of a miscalibrated sensor: ``w' = C w + b`` per test (K, 6, 6)."""
    for k in range(sf.shape[0]):
        for r in range(6):
            acc = b[k, r]
            for c in range(3):
                acc += C[k, r, c] * sf[k, c] + C[k, r, 3 + c] * st[k, c]
            if r < 3:
                of[k, r] = acc
            else:
                ot[k, r - 3] = acc
