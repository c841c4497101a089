"""Payload identification: the ten inertial parameters of a rigid payload from wrench and pose.

The wrench a rigid payload exerts on a six-axis sensor is linear in its ten inertial
parameters (An, Atkeson and Hollerbach 1985; Khalil and Dombre, *Modeling, Identification and
Control of Robots*)::

    φ = (m, m·c_x, m·c_y, m·c_z, I_xx, I_xy, I_xz, I_yy, I_yz, I_zz)
    [f; τ] = A(a − g, ω, ω̇) φ
    f = m (a − g) + ([ω̇]× + [ω]×[ω]×) m c
    τ = I ω̇ + ω × (I ω) − [a − g]× m c

all in the sensor frame: ``a`` the acceleration of the sensor origin, ``g`` gravity, ``ω``
and ``ω̇`` the angular velocity and acceleration, ``c`` the centre of mass from the sensor
origin and ``I`` the inertia about the sensor origin (kg·m²). ``[f; τ]`` is the wrench the
sensor carries the payload with (the raw reading zeroed *unloaded*: statically ``+m g``
upwards), torque about the sensor origin.

:class:`PayloadIdentification` computes ``a``, ``ω``, ``ω̇`` from the plate pose (measured or
commanded, (N, 6) relative to home, R = Rz Ry Rx) by differentiating it twice, after the same
zero-phase low-pass (Butterworth, forward and backward) is applied to the pose and to the
wrench, and solves the linear least-squares problem. It reports the condition number of the
column-scaled regressor and the parameters the motion cannot see: static poses give m and m·c
only; the inertia needs angular acceleration about all three axes; the products of inertia
need two axes moving at once.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..platform.kinematics import rotation_matrix, skew

__all__ = ["PARAMETERS", "PayloadIdentification", "inertia_about_com", "payload_parameters",
           "regressor"]

PARAMETERS: tuple[str, ...] = ("m", "m*cx", "m*cy", "m*cz", "Ixx", "Ixy", "Ixz", "Iyy",
                               "Iyz", "Izz")
"""The ten inertial parameters φ (kg, kg·m, kg·m²; inertia about the sensor origin)."""

UNITS: tuple[str, ...] = ("kg", "kg·m", "kg·m", "kg·m", "kg·m²", "kg·m²", "kg·m²", "kg·m²",
                          "kg·m²", "kg·m²")


def _dot_mat(w: np.ndarray) -> np.ndarray:
    """L(w) (N, 3, 6) with I w = L(w) (Ixx, Ixy, Ixz, Iyy, Iyz, Izz)."""
    L = np.zeros(w.shape[:-1] + (3, 6))
    wx, wy, wz = w[..., 0], w[..., 1], w[..., 2]
    L[..., 0, 0], L[..., 0, 1], L[..., 0, 2] = wx, wy, wz
    L[..., 1, 1], L[..., 1, 3], L[..., 1, 4] = wx, wy, wz
    L[..., 2, 2], L[..., 2, 4], L[..., 2, 5] = wx, wy, wz
    return L


def regressor(acc: np.ndarray, omega: np.ndarray, domega: np.ndarray) -> np.ndarray:
    """The regressor A (N, 6, 10) of ``[f; τ] = A φ`` from the sensor-frame ``acc`` = a − g
    (m/s²), ``omega`` (rad/s) and ``domega`` (rad/s²), each (N, 3)."""
    acc, omega, domega = (np.atleast_2d(np.asarray(x, dtype=float))
                          for x in (acc, omega, domega))
    n = acc.shape[0]
    A = np.zeros((n, 6, 10))
    W, dW = skew(omega), skew(domega)
    A[:, :3, 0] = acc
    A[:, :3, 1:4] = dW + W @ W
    A[:, 3:, 1:4] = -skew(acc)
    A[:, 3:, 4:] = _dot_mat(domega) + W @ _dot_mat(omega)
    return A


def payload_parameters(mass: float, com: Sequence[float],
                       inertia: Sequence[float] | np.ndarray) -> np.ndarray:
    """φ (10,) of a payload of ``mass`` (kg) with its centre of mass ``com`` (m, sensor frame)
    and inertia about its centre of mass: a 3×3 tensor, six numbers (Ixx, Iyy, Izz, Ixy, Ixz,
    Iyz) as the scene gives them, or a scalar (kg·m²). The inertia in φ is about the sensor
    origin (parallel-axis theorem)."""
    c = np.asarray(com, dtype=float).reshape(3)
    Ic = _tensor(inertia)
    Io = Ic + mass * (float(c @ c) * np.eye(3) - np.outer(c, c))
    return np.array([mass, *(mass * c), Io[0, 0], Io[0, 1], Io[0, 2], Io[1, 1], Io[1, 2],
                     Io[2, 2]])


def _tensor(inertia: Any) -> np.ndarray:
    a = np.asarray(inertia, dtype=float)
    if a.size == 1:
        return float(a) * np.eye(3)
    if a.size == 6:
        xx, yy, zz, xy, xz, yz = a.reshape(6)
        return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    return a.reshape(3, 3)


def inertia_about_com(phi: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """(mass kg, centre of mass (3,) m, inertia about the centre of mass (3, 3) kg·m²) of φ."""
    m = float(phi[0])
    c = np.asarray(phi[1:4]) / m if m != 0 else np.full(3, np.nan)
    xx, xy, xz, yy, yz, zz = phi[4:]
    Io = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
    return m, c, Io - m * (float(c @ c) * np.eye(3) - np.outer(c, c))


class PayloadIdentification:
    """Least-squares estimate of a rigid payload's ten inertial parameters.

    Parameters
    ----------
    sensor:
        The sensor frame on the plate: (x, y, z, rx, ry, rz) (m, rad) of the sensor origin and
        orientation in the plate frame (the platform's FTS site: (0, 0, fts_height, 0, 0, 0)).
    cutoff:
        Corner frequency (Hz) of the zero-phase Butterworth low-pass applied to the pose
        (before it is differentiated) and to the wrench alike.
    order:
        Order of the Butterworth filter (applied forward and backward: twice the order).
    trim:
        Time (s) left out at each end, where the filter and the differences start.
    gravity:
        Gravitational acceleration (m/s², along −z of the world).

    Attributes (after :meth:`fit`)
    -------------------------------
    phi_:
        The ten parameters (:data:`PARAMETERS`), inertia about the sensor origin.
    std_:
        Their standard deviations from the residual (``inf`` where unobservable).
    mass_, com_, inertia_:
        Mass (kg), centre of mass (m, sensor frame), inertia tensor about the centre of mass
        (kg·m²).
    condition_number_:
        Condition number of the regressor with its columns scaled to unit norm (``inf`` when
        a column is zero: a parameter the motion does not excite at all).
    singular_values_:
        Singular values of the column-scaled regressor, descending.
    unseen_:
        The parameters the motion cannot see: on a direction whose scaled singular value is
        below ``rcond`` times the largest.
    residual_rms_:
        RMS residual per wrench component (N, N·m) on the samples fitted.
    """

    def __init__(self, sensor: Sequence[float] = (0.0, 0.0, 0.03, 0.0, 0.0, 0.0), *,
                 cutoff: float = 20.0, order: int = 4, trim: float = 0.1,
                 gravity: float = 9.81, rcond: float = 1.0e-4):
        s = np.asarray(sensor, dtype=float)
        if s.shape != (6,) or not np.all(np.isfinite(s)):
            raise ConfigError("sensor", list(np.ravel(s)), "need 6 finite numbers (m, rad)")
        if not (math.isfinite(cutoff) and cutoff > 0):
            raise ConfigError("cutoff", cutoff, "must be > 0 Hz")
        self.sensor = s
        self.cutoff = float(cutoff)
        self.order = int(order)
        self.trim = float(trim)
        self.gravity = float(gravity)
        self.rcond = float(rcond)

    # ------------------------------------------------------------------ kinematics
    def _filter(self, x: np.ndarray, dt: float) -> np.ndarray:
        from scipy.signal import butter, sosfiltfilt

        nyq = 0.5 / dt
        if self.cutoff >= nyq:
            return np.array(x, dtype=float)
        sos = butter(self.order, self.cutoff / nyq, output="sos")
        return sosfiltfilt(sos, x, axis=0)

    def motion(self, poses: np.ndarray, dt: float, *, filtered: bool = False
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Sensor-frame (a − g, ω, ω̇), each (N, 3), of plate poses (N, 6) sampled at ``dt``
        (s): filtered (unless ``filtered``), differentiated by central differences."""
        q = np.asarray(poses, dtype=float)
        if q.ndim != 2 or q.shape[1] != 6 or q.shape[0] < 5:
            raise ConfigError("poses", f"array of shape {q.shape}", "need (N, 6), N >= 5")
        if not (math.isfinite(dt) and dt > 0):
            raise ConfigError("dt", dt, "must be > 0 s")
        if not filtered:
            q = self._filter(q, dt)
        R = rotation_matrix(q[:, 3], q[:, 4], q[:, 5])
        Rs = rotation_matrix(*self.sensor[3:])
        Rw = R @ Rs  # sensor frame in world axes
        p = q[:, :3] + R @ self.sensor[:3]
        acc_w = np.gradient(np.gradient(p, dt, axis=0), dt, axis=0)
        acc_w[:, 2] += self.gravity  # a − g with g = (0, 0, −g)
        dR = np.gradient(R, dt, axis=0)
        Om = dR @ np.swapaxes(R, 1, 2)  # [ω]× in world axes
        om_w = 0.5 * np.stack([Om[:, 2, 1] - Om[:, 1, 2], Om[:, 0, 2] - Om[:, 2, 0],
                               Om[:, 1, 0] - Om[:, 0, 1]], axis=1)
        dom_w = np.gradient(om_w, dt, axis=0)
        RT = np.swapaxes(Rw, 1, 2)
        return ((RT @ acc_w[:, :, None])[..., 0], (RT @ om_w[:, :, None])[..., 0],
                (RT @ dom_w[:, :, None])[..., 0])

    def _rows(self, n: int, dt: float) -> slice:
        k = int(round(self.trim / dt))
        if n - 2 * k < 20:
            raise ConfigError("trim", self.trim, f"leaves fewer than 20 of {n} samples")
        return slice(k, n - k)

    # ------------------------------------------------------------------ estimator
    def fit(self, poses: np.ndarray, wrench: np.ndarray, dt: float) -> PayloadIdentification:
        """Fit φ from plate poses (N, 6) (m, rad, relative to home) and the sensor's wrench
        (N, 6) (N, N·m, sensor frame, zeroed unloaded), sampled at ``dt`` (s)."""
        w = np.asarray(wrench, dtype=float)
        q = np.asarray(poses, dtype=float)
        if w.shape != q.shape:
            raise ConfigError("wrench", f"array of shape {w.shape}",
                              f"need the poses' shape {q.shape}")
        rows = self._rows(q.shape[0], dt)
        acc, om, dom = self.motion(q, dt)
        A = regressor(acc[rows], om[rows], dom[rows]).reshape(-1, 10)
        y = self._filter(w, dt)[rows].reshape(-1)
        # forces and torques in one regression: weight each by its spread so that neither
        # unit dominates
        wt = np.tile(1.0 / np.maximum(np.std(w[rows], axis=0), 1e-9), A.shape[0] // 6)
        Aw, yw = A * wt[:, None], y * wt
        norms = np.linalg.norm(Aw, axis=0)
        As = Aw / np.where(norms > 0, norms, 1.0)
        U, s, Vt = np.linalg.svd(As, full_matrices=False)
        self.singular_values_ = s
        self.condition_number_ = float(s[0] / s[-1]) if s[-1] > 0 and np.all(norms > 0) \
            else math.inf
        keep = s > self.rcond * s[0]
        theta = Vt[keep].T @ ((U[:, keep].T @ yw) / s[keep])
        phi = theta / np.where(norms > 0, norms, 1.0)
        res = yw - Aw @ phi
        dof = max(res.size - int(keep.sum()), 1)
        s2 = float(res @ res) / dof
        var = (Vt[keep].T ** 2) @ (1.0 / s[keep] ** 2) * s2
        std = np.sqrt(var) / np.where(norms > 0, norms, 1.0)
        unseen: list[str] = []
        for k in np.flatnonzero(~keep):
            for j in np.flatnonzero(np.abs(Vt[k]) >= 0.25):
                if PARAMETERS[j] not in unseen:
                    unseen.append(PARAMETERS[j])
        for j in np.flatnonzero(norms == 0):
            if PARAMETERS[j] not in unseen:
                unseen.append(PARAMETERS[j])
        std[[PARAMETERS.index(n) for n in unseen]] = math.inf
        self.phi_ = phi
        self.std_ = std
        self.unseen_ = tuple(n for n in PARAMETERS if n in unseen)
        self.mass_, self.com_, self.inertia_ = inertia_about_com(phi)
        r = (y - A @ phi).reshape(-1, 6)
        self.residual_rms_ = np.sqrt(np.mean(r ** 2, axis=0))
        self.n_samples_ = int(A.shape[0] // 6)
        return self

    def predict(self, poses: np.ndarray, dt: float, phi: np.ndarray | None = None
                ) -> np.ndarray:
        """The (filtered) wrench (N, 6) the payload φ (default: the fitted) exerts on the
        sensor along the plate poses (N, 6)."""
        acc, om, dom = self.motion(poses, dt)
        p = self.phi_ if phi is None else np.asarray(phi, dtype=float)
        return regressor(acc, om, dom) @ p

    def lines(self) -> list[str]:
        """Human-readable report: the parameters, their standard deviations, the condition
        number and what the motion cannot see."""
        out = [f"payload identification: {self.n_samples_} samples, condition number "
               f"{self.condition_number_:.4g} (column-scaled)",
               f"  mass {self.mass_:.4g} kg, centre of mass "
               f"({', '.join(f'{1e3 * v:.3g}' for v in self.com_)}) mm in the sensor frame"]
        for n, v, s, u in zip(PARAMETERS, self.phi_, self.std_, UNITS, strict=True):
            out.append(f"  {n:5s} = {v:+.5g} ± {s:.2g} {u}")
        out.append("  cannot see: " + (", ".join(self.unseen_) if self.unseen_ else
                                      "nothing (every parameter excited)"))
        return out
