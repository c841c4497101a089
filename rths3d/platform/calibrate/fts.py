"""Calibration of the 6-axis force-torque sensor (FTS) and identification of a payload.

Sign and frame convention (docs/platform.md): the FTS reports the wrench the plate exerts on
everything mounted on it, in the sensor frame, torque about the sensor origin. A payload of
mass m with centre of mass c (sensor frame) at rest, with the sensor frame at orientation R
(sensor → world), under an extra external force f (world axes, acting at the payload's
centre of mass) and couple τ_e (world axes), gives the ideal reading

    F = Rᵀ (m g e_z − f),      T = c × F − Rᵀ τ_e                                (1)

(:func:`load_wrench`). A real sensor reads

    r = M w + o                                                                   (2)

with the 6×6 matrix M (gains on the diagonal, cross-talk off it; the identity for an ideal
sensor) and the offset o. :class:`FTSCalibration` fits M and o from known loads (linear least
squares, one row of (2) per channel); ``correct(r) = M⁻¹ (r − o)`` gives the wrench back.

**Mounting.** A sensor mounted rotated by R_m and with its measuring origin displaced by d
(nominal sensor frame, m) reads ``F_s = R_mᵀ F``, ``T_s = R_mᵀ (T − d × F)``: the mounting
is part of M. :class:`FTSCalibration` separates it under the usual assumption that the
electrical cross-talk between force and torque channels is nil (then
``M_TT⁻¹ M_TF = −[d]×`` exactly) and that the force block's own cross-talk is symmetric
(then the orthogonal factor of the polar decomposition of ``M_FF`` is ``R_mᵀ``): a mounting
rotation cannot be told from antisymmetric cross-talk by any load.

:class:`PayloadEstimator` fits a payload's mass and centre of mass from the wrench at several
orientations (gravity seen in the sensor frame, (1) with f = τ_e = 0), from a sensor zeroed
unloaded (the reading carries the payload's weight: ``offset="zero"``) or tared at rest / with
an unknown bias (``offset="fit"``).
"""

from __future__ import annotations

import math

import numpy as np

from ...errors import ConfigError
from ..kinematics import rotation_matrix, skew

__all__ = ["FTSCalibration", "PayloadEstimator", "load_wrench", "orientations_to_matrices",
           "skew"]

GRAVITY = 9.81


def orientations_to_matrices(orientations: np.ndarray, name: str = "orientations") -> np.ndarray:
    """Sensor orientations as rotation matrices (N, 3, 3), sensor frame → world.

    Accepts matrices (N, 3, 3), fixed-axis angles (N, 3) ``(rx, ry, rz)`` (rad,
    ``R = Rz Ry Rx``) or platform poses (N, 6) (the sensor frame parallel to the plate frame,
    as in the platform model).
    """
    a = np.asarray(orientations, dtype=float)
    if a.ndim == 3 and a.shape[1:] == (3, 3):
        R = a
    elif a.ndim == 2 and a.shape[1] in (3, 6):
        ang = a[:, -3:]
        R = rotation_matrix(ang[:, 0], ang[:, 1], ang[:, 2])
    else:
        raise ConfigError(name, f"array of shape {a.shape}",
                          "need (N, 3, 3) rotations, (N, 3) angles or (N, 6) poses")
    if not np.all(np.isfinite(R)):
        raise ConfigError(name, "NaN/inf", "must be finite")
    err = np.abs(np.einsum("kji,kjl->kil", R, R) - np.eye(3)).max(axis=(1, 2))
    if np.any(err > 1e-6):
        k = int(np.argmax(err))
        raise ConfigError(f"{name}[{k}]", f"RᵀR − I = {err[k]:.3g}", "not a rotation matrix")
    return R


def load_wrench(orientations: np.ndarray, mass: float | np.ndarray,
                com: np.ndarray, force: np.ndarray | None = None,
                torque: np.ndarray | None = None, gravity: float = GRAVITY) -> np.ndarray:
    """Ideal static FTS readings (N, 6) of known loads, equation (1): sensor frame, N and
    N·m about the sensor origin.

    ``mass`` (kg) and ``com`` (m, sensor frame) per sample or shared; ``force`` (N) and
    ``torque`` (N·m): external loads in world axes, (N, 3) or (3,), the force acting at the
    centre of mass (``None``: none).
    """
    R = orientations_to_matrices(orientations)
    n = R.shape[0]
    m = np.broadcast_to(np.asarray(mass, dtype=float), (n,))
    c = np.broadcast_to(np.asarray(com, dtype=float), (n, 3))
    if not (np.all(np.isfinite(m)) and np.all(m >= 0)):
        raise ConfigError("mass", mass, "must be finite and >= 0 kg")
    Fw = np.zeros((n, 3))
    Fw[:, 2] = m * gravity
    if force is not None:
        Fw = Fw - np.broadcast_to(np.asarray(force, dtype=float), (n, 3))
    Fs = np.einsum("kji,kj->ki", R, Fw)
    Ts = np.cross(c, Fs)
    if torque is not None:
        Ts = Ts - np.einsum("kji,kj->ki", R, np.broadcast_to(np.asarray(torque, float),
                                                              (n, 3)))
    return np.concatenate([Fs, Ts], axis=1)


def _wrenches(name: str, w: np.ndarray, n: int | None = None) -> np.ndarray:
    a = np.asarray(w, dtype=float)
    if a.ndim != 2 or a.shape[1] != 6 or (n is not None and a.shape[0] != n):
        want = f"({n}, 6)" if n is not None else "(N, 6)"
        raise ConfigError(name, f"array of shape {a.shape}",
                          f"need {want} wrenches fx, fy, fz (N), tx, ty, tz (N·m)")
    bad = np.argwhere(~np.isfinite(a))
    if bad.size:
        k, j = bad[0]
        raise ConfigError(f"{name}[{k}][{j}]", float(a[k, j]), "must be finite")
    return a


def _vee(A: np.ndarray) -> np.ndarray:
    """Vector of the skew-symmetric part of a 3×3 matrix: ``[v]× = (A − Aᵀ)/2``."""
    S = 0.5 * (A - A.T)
    return np.array([S[2, 1], S[0, 2], S[1, 0]])


class FTSCalibration:
    """The 6×6 calibration matrix and offset of an FTS from known loads (``fit``/``predict``).

    Model (2): ``reading = matrix_ @ wrench + offset_``. Each reading channel is one linear
    least-squares problem in the seven unknowns (its row of M and its offset), solved with
    column-scaled regressors. Needs at least seven loads whose wrenches span all six axes
    (with ``fit_offset``) — e.g. known payloads at several tilts plus known lateral forces
    and couples.

    Fitted attributes
    -----------------
    matrix_:
        M (6, 6): rows readings, columns wrench axes (fx, fy, fz in N; tx, ty, tz in N·m).
    offset_:
        o (6,) (N, N·m).
    gains_:
        The diagonal of M.
    residual_rms_:
        RMS residual per channel (6,) (N, N·m).
    condition_:
        Condition number of the column-scaled regressor matrix.
    mounting_offset_:
        Displacement d (3,) of the sensor's measuring origin from the nominal sensor origin
        (m, nominal sensor frame), from ``M_TT⁻¹ M_TF = −[d]×`` (skew part).
    mounting_rotation_:
        Rotation vector (3,) (rad) of the mounting rotation R_m, from the polar
        decomposition of the force block (see the module docstring for the assumptions).
    """

    def __init__(self, fit_offset: bool = True):
        self.fit_offset = bool(fit_offset)

    def fit(self, wrench: np.ndarray, readings: np.ndarray) -> FTSCalibration:
        """Fit M and o to known load wrenches (N, 6) and the sensor's readings (N, 6)."""
        from scipy.linalg import polar
        from scipy.spatial.transform import Rotation

        W = _wrenches("wrench", wrench)
        Y = _wrenches("readings", readings, W.shape[0])
        X = np.concatenate([W, np.ones((W.shape[0], 1))], axis=1) if self.fit_offset else W
        need = X.shape[1]
        if W.shape[0] < need:
            raise ConfigError("wrench", W.shape[0], f"need at least {need} loads")
        scale = np.linalg.norm(X, axis=0)
        if np.any(scale == 0):
            j = int(np.flatnonzero(scale == 0)[0])
            raise ConfigError("wrench", f"axis {j} never loaded",
                              "every wrench axis needs a non-zero load")
        Xs = X / scale
        sv = np.linalg.svd(Xs, compute_uv=False)
        cond = float(sv[0] / sv[-1]) if sv[-1] > 0 else math.inf
        if not cond < 1e8:
            raise ConfigError("wrench", f"condition number {cond:.3g}",
                              "the loads do not span the six wrench axes (and the offset): "
                              "add loads along the missing axes")
        B, *_ = np.linalg.lstsq(Xs, Y, rcond=None)
        B = B / scale[:, None]
        self.matrix_ = B[:6].T.copy()
        self.offset_ = B[6].copy() if self.fit_offset else np.zeros(6)
        self.gains_ = np.diag(self.matrix_).copy()
        res = Y - self.predict(W)
        dof = max(W.shape[0] - need, 1)
        self.residual_rms_ = np.sqrt(np.sum(res ** 2, axis=0) / dof)
        self.condition_ = cond
        M = self.matrix_
        try:
            self.mounting_offset_ = -_vee(np.linalg.solve(M[3:, 3:], M[3:, :3]))
        except np.linalg.LinAlgError:
            self.mounting_offset_ = np.full(3, np.nan)
        U, _ = polar(M[:3, :3], side="left")  # M_FF = P U, U = R_mᵀ
        self.mounting_rotation_ = Rotation.from_matrix(U.T).as_rotvec() \
            if np.linalg.det(U) > 0 else np.full(3, np.nan)
        return self

    def _check(self) -> None:
        if not hasattr(self, "matrix_"):
            raise ConfigError("FTSCalibration", None, "", message="FTSCalibration: call "
                              "fit(wrench, readings) first")

    def predict(self, wrench: np.ndarray) -> np.ndarray:
        """Readings (N, 6) model (2) gives for wrenches (N, 6)."""
        self._check()
        return _wrenches("wrench", wrench) @ self.matrix_.T + self.offset_

    def correct(self, readings: np.ndarray) -> np.ndarray:
        """Calibrated wrenches (N, 6) from raw readings (N, 6): ``M⁻¹ (r − o)``."""
        self._check()
        return np.linalg.solve(self.matrix_, (_wrenches("readings", readings)
                                              - self.offset_).T).T


class PayloadEstimator:
    """Mass and centre of mass of a payload from static FTS wrenches at several orientations.

    With ``γ_k = R_kᵀ (0, 0, g)`` (gravity's reaction in the sensor frame), equation (1)
    without external loads is linear in ``m`` and ``m c``:

        F_k = m γ_k + o_F,      T_k = −[γ_k]× (m c) + o_T

    ``offset="zero"``: the sensor was zeroed unloaded, so the readings carry the payload's
    weight (o = 0; one orientation gives m and the horizontal CoM, a tilt the height).
    ``offset="fit"``: an unknown constant offset, e.g. readings tared at rest with the
    payload on (o = −payload wrench at the tare pose) — mass and CoM then come only from the
    change of gravity's direction, so the orientations must tilt about two axes.

    Fitted attributes
    -----------------
    mass_, mass_std_:
        Mass (kg) and its standard deviation.
    com_, com_std_:
        Centre of mass in the sensor frame (3,) (m) and its standard deviation.
    offset_:
        Offset (6,) (N, N·m); zero with ``offset="zero"``.
    residual_rms_:
        RMS residual per channel (6,) (N, N·m).
    """

    def __init__(self, offset: str = "fit", gravity: float = GRAVITY):
        if offset not in ("fit", "zero"):
            raise ConfigError("offset", offset, "one of 'fit', 'zero'")
        if not (math.isfinite(gravity) and gravity > 0):
            raise ConfigError("gravity", gravity, "must be > 0 m/s²")
        self.offset = offset
        self.gravity = float(gravity)

    def _gamma(self, orientations: np.ndarray) -> np.ndarray:
        R = orientations_to_matrices(orientations)
        return R[:, 2, :] * self.gravity  # Rᵀ (0, 0, g)

    def fit(self, wrench: np.ndarray, orientations: np.ndarray) -> PayloadEstimator:
        """Fit to wrenches (N, 6) (sensor frame) at sensor orientations (N, 3, 3)/(N, 3)/(N, 6)
        (see :func:`orientations_to_matrices`)."""
        gam = self._gamma(orientations)
        W = _wrenches("wrench", wrench, gam.shape[0])
        n = gam.shape[0]
        fit_o = self.offset == "fit"
        eye = np.tile(np.eye(3), (n, 1))
        AF = gam.reshape(-1, 1)
        AT = -skew(gam).reshape(-1, 3)
        if fit_o:
            AF = np.concatenate([AF, eye], axis=1)
            AT = np.concatenate([AT, eye], axis=1)
        sols, covs, rms = [], [], []
        for A, y, what in ((AF, W[:, :3].reshape(-1), "mass"),
                           (AT, W[:, 3:].reshape(-1), "centre of mass")):
            sv = np.linalg.svd(A / np.linalg.norm(A, axis=0), compute_uv=False)
            if A.shape[0] <= A.shape[1] or not sv[-1] > 1e-8 * sv[0]:
                hint = ("apart from the offset: tilt the payload about two axes" if fit_o
                        else "from one orientation: tilt the payload at least once")
                raise ConfigError("orientations", f"{n} orientations",
                                  f"cannot determine the {what} {hint}")
            x, *_ = np.linalg.lstsq(A, y, rcond=None)
            r = (y - A @ x).reshape(n, 3)
            s2 = float(np.sum(r ** 2) / max(A.shape[0] - A.shape[1], 1))
            sols.append(x)
            covs.append(s2 * np.linalg.inv(A.T @ A))
            rms.append(np.sqrt(np.mean(r ** 2, axis=0)))
        m = float(sols[0][0])
        if not m > 0:
            raise ConfigError("wrench", f"mass {m:.4g} kg", "the fitted mass is not positive "
                              "(wrong sign convention or no payload)")
        mc = sols[1][:3]
        self.mass_ = m
        self.mass_std_ = float(math.sqrt(covs[0][0, 0]))
        self.com_ = mc / m
        var_c = np.diag(covs[1])[:3] / m ** 2 + (mc / m ** 2) ** 2 * covs[0][0, 0]
        self.com_std_ = np.sqrt(var_c)
        self.offset_ = np.concatenate([sols[0][1:4], sols[1][3:6]]) if fit_o else np.zeros(6)
        self.residual_rms_ = np.concatenate(rms)
        return self

    def predict(self, orientations: np.ndarray) -> np.ndarray:
        """Wrenches (N, 6) the fitted payload (and offset) gives at the orientations."""
        if not hasattr(self, "mass_"):
            raise ConfigError("PayloadEstimator", None, "", message="PayloadEstimator: call "
                              "fit(wrench, orientations) first")
        return load_wrench(orientations, self.mass_, self.com_, gravity=self.gravity) \
            + self.offset_
