"""Kinematic calibration of the six-leg (6-UPS) Stewart platform: the classic 42 parameters.

A real platform differs from its drawing: every base anchor ``b_i`` (world frame) and top
anchor ``p_i`` (plate frame) sits a little off its nominal place, and every leg encoder reads
the geometric leg length plus an offset ``δ_i`` (its zero was set against a nominal length).
The encoder reading of leg i at pose q is

    L_i(q; θ) = ‖ (0, 0, h) + t + R(q) p_i − b_i ‖ + δ_i                          (1)

with θ = (b_0 … b_5, p_0 … p_5, δ_0 … δ_5), 6·3 + 6·3 + 6 = 42 parameters (m). *Inverse
calibration* measures poses q_k with an external, absolute 6-DOF pose measurement (laser
tracker, photogrammetry, CMM) together with the encoder lengths L_ik, and minimises the
leg-length residuals ``L_i(q_k; θ) − L_ik`` over θ through (1) — one inverse kinematics per
pose, no forward kinematics, and an analytic Jacobian

    ∂L_i/∂b_i = −u_i,    ∂L_i/∂p_i = Rᵀ u_i,    ∂L_i/∂δ_i = 1                      (2)

(u_i: unit leg vector). Rows of leg i depend only on leg i's seven parameters, so the
identification Jacobian is block diagonal, one 7-column block per leg.

**Frames (the gauge convention).** From leg lengths alone a rigid motion of all base anchors
(moving the world frame) or of all top anchors (moving the plate frame) is invisible: the
poses would move with it. Here the poses are *measured*, so the frames are those of the pose
measurement: ``b_i`` are expressed in the world frame the pose measurement reports in, ``p_i``
in the plate frame whose pose it reports (for the simulated platform: MuJoCo's world frame and
the ``plate`` body frame). Nothing else is fixed, because re-expressing the anchors in frames
defined by the anchors themselves would change what a commanded pose means: the calibrated
geometry must take the poses the pose measurement reads. Whether the pose set actually pins
each of the 12 rigid motions (six of the base frame, six of the plate frame) is part of the
:class:`IdentifiabilityReport`, beside the parameters it cannot see.

Leg-offset sign: an encoder reads the geometric length **plus** ``leg_offset[i]``. The
kinematics functions (:func:`~rths3d.platform.kinematics.inverse_kinematics`, …) work with
geometric lengths; :meth:`CalibratedGeometry.encoder_lengths` and
:meth:`CalibratedGeometry.pose_from_encoders` include the offsets.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import ConfigError
from ..geometry import DEFAULT_GEOMETRY, StewartGeometry
from ..kinematics import (
    forward_kinematics,
    inverse_kinematics,
    rotation_matrix,
)

__all__ = [
    "DOFS",
    "FORMAT",
    "N_PARAMETERS",
    "CalibratedGeometry",
    "IdentifiabilityReport",
    "KinematicCalibration",
    "gauge_directions",
    "geometry_from_parameters",
    "identifiability",
    "identification_jacobian",
    "leg_residuals",
    "load_geometry",
    "parameter_names",
    "parameter_vector",
]

FORMAT = "rths3d.calibrated_geometry/1"
"""Value of the ``format`` key of a calibrated-geometry JSON file."""

DOFS = ("x", "y", "z", "rx", "ry", "rz")
N_PARAMETERS = 42
_AXES = ("x", "y", "z")


def parameter_names() -> tuple[str, ...]:
    """Names of the 42 parameters in vector order: ``base_anchor[i].x`` … ``top_anchor[i].z``
    … ``leg_offset[i]`` (all in m)."""
    return (tuple(f"base_anchor[{i}].{a}" for i in range(6) for a in _AXES)
            + tuple(f"top_anchor[{i}].{a}" for i in range(6) for a in _AXES)
            + tuple(f"leg_offset[{i}]" for i in range(6)))


# ---------------------------------------------------------------------------- geometry
def _triples(name: str, value: Any) -> tuple[tuple[float, float, float], ...]:
    a = np.asarray(value, dtype=float) if value is not None else np.zeros(0)
    if a.shape != (6, 3) or not np.all(np.isfinite(a)):
        raise ConfigError(f"geometry.{name}", f"array of shape {a.shape}",
                          "need 6 finite (x, y, z) anchor positions in m")
    return tuple(tuple(float(v) for v in row) for row in a)  # type: ignore[return-value]


@dataclass(frozen=True)
class CalibratedGeometry(StewartGeometry):
    """A :class:`StewartGeometry` with per-leg anchor positions and encoder offsets.

    Every function that takes a ``StewartGeometry`` (inverse/forward kinematics, Jacobian,
    workspace check, the MuJoCo model, the simulators) accepts it: they read the anchors
    through :meth:`base_anchors` / :meth:`top_anchors`. The scalar fields (radii, gaps,
    ``home_height``, limits, masses) keep their meaning; the radii and gaps only describe the
    nominal pattern and the visual meshes. Empty anchor/offset tuples (the defaults) take the
    nominal pattern of the scalar fields and zero offsets, so ``CalibratedGeometry()`` is the
    default platform.

    Attributes
    ----------
    base_anchor_xyz:
        Base anchors ``b_i`` in the world frame, six (x, y, z) triples (m).
    top_anchor_xyz:
        Top anchors ``p_i`` in the plate frame, six (x, y, z) triples (m); they need not lie
        in the plane z = 0.
    leg_offset:
        Encoder offsets ``δ_i`` (m): an encoder reads the geometric length plus ``δ_i``.
    """

    base_anchor_xyz: tuple[tuple[float, float, float], ...] = ()
    top_anchor_xyz: tuple[tuple[float, float, float], ...] = ()
    leg_offset: tuple[float, ...] = field(default=())

    def __post_init__(self) -> None:
        nominal = StewartGeometry(**{f.name: getattr(self, f.name)
                                     for f in fields(StewartGeometry)})
        b = nominal.base_anchors() if len(self.base_anchor_xyz) == 0 else self.base_anchor_xyz
        p = nominal.top_anchors() if len(self.top_anchor_xyz) == 0 else self.top_anchor_xyz
        object.__setattr__(self, "base_anchor_xyz", _triples("base_anchor_xyz", b))
        object.__setattr__(self, "top_anchor_xyz", _triples("top_anchor_xyz", p))
        d = np.zeros(6) if len(self.leg_offset) == 0 else \
            np.asarray(self.leg_offset, dtype=float)
        if d.shape != (6,) or not np.all(np.isfinite(d)):
            raise ConfigError("geometry.leg_offset", f"array of shape {d.shape}",
                              "need 6 finite leg offsets in m")
        bad = np.flatnonzero(np.abs(d) >= self.stroke / 2)
        if bad.size:
            i = int(bad[0])
            raise ConfigError(f"geometry.leg_offset[{i}]", float(d[i]),
                              f"must be within ±stroke/2 = ±{self.stroke / 2:.4g} m")
        object.__setattr__(self, "leg_offset", tuple(float(v) for v in d))
        super().__post_init__()
        if np.any(self.home_leg_vectors()[:, 2] <= 0):
            i = int(np.flatnonzero(self.home_leg_vectors()[:, 2] <= 0)[0])
            raise ConfigError(f"geometry.top_anchor_xyz[{i}]", self.top_anchor_xyz[i],
                              "the top anchor must be above its base anchor at home")

    # ---------------------------------------------------------------- anchors
    def base_anchors(self) -> np.ndarray:
        """Base anchors ``b_i`` in the world frame, shape (6, 3), m."""
        return np.array(self.base_anchor_xyz)

    def top_anchors(self) -> np.ndarray:
        """Top anchors ``p_i`` in the plate frame, shape (6, 3), m."""
        return np.array(self.top_anchor_xyz)

    def base_angles(self) -> np.ndarray:
        """Polar angles of the base anchors (rad), leg order (for drawing)."""
        b = self.base_anchors()
        return np.arctan2(b[:, 1], b[:, 0])

    def top_angles(self) -> np.ndarray:
        """Polar angles of the top anchors in the plate frame (rad), leg order."""
        p = self.top_anchors()
        return np.arctan2(p[:, 1], p[:, 0])

    def leg_offsets(self) -> np.ndarray:
        """Encoder offsets ``δ_i`` (6,), m: encoder reading = geometric length + δ_i."""
        return np.array(self.leg_offset)

    # ---------------------------------------------------------------- encoders
    def encoder_lengths(self, poses: np.ndarray) -> np.ndarray:
        """What the leg encoders read at poses (..., 6) relative to home: (..., 6), m."""
        return inverse_kinematics(self, poses) + self.leg_offsets()

    def pose_from_encoders(self, lengths: np.ndarray, guess: np.ndarray | None = None,
                           tol: float = 1e-12, max_iter: int = 50) -> np.ndarray:
        """Pose(s) relative to home (..., 6) from encoder readings (..., 6) (m): forward
        kinematics of the lengths minus the offsets."""
        return forward_kinematics(self, np.asarray(lengths, dtype=float) - self.leg_offsets(),
                                  guess=guess, tol=tol, max_iter=max_iter)

    # ---------------------------------------------------------------- construction
    @classmethod
    def from_nominal(cls, nominal: StewartGeometry = DEFAULT_GEOMETRY,
                     base_anchors: np.ndarray | None = None,
                     top_anchors: np.ndarray | None = None,
                     leg_offsets: np.ndarray | None = None) -> CalibratedGeometry:
        """The nominal geometry's scalar fields with these anchors (m) and offsets (m);
        ``None`` keeps the nominal's."""
        kw = {f.name: getattr(nominal, f.name) for f in fields(StewartGeometry)}
        return cls(**kw,
                   base_anchor_xyz=nominal.base_anchors() if base_anchors is None
                   else base_anchors,
                   top_anchor_xyz=nominal.top_anchors() if top_anchors is None
                   else top_anchors,
                   leg_offset=(np.zeros(6) if not isinstance(nominal, CalibratedGeometry)
                               else nominal.leg_offsets()) if leg_offsets is None
                   else tuple(np.asarray(leg_offsets, dtype=float).reshape(-1)))

    def nominal(self) -> StewartGeometry:
        """The plain :class:`StewartGeometry` of the scalar fields (the drawing)."""
        return StewartGeometry(**{f.name: getattr(self, f.name)
                                  for f in fields(StewartGeometry)})

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict: ``format`` and every field (SI units); see :meth:`from_dict`."""
        out: dict[str, Any] = {"format": FORMAT}
        for f in fields(self):
            v = getattr(self, f.name)
            out[f.name] = [list(row) for row in v] if f.name.endswith("_xyz") else \
                list(v) if isinstance(v, tuple) else v
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> CalibratedGeometry:
        """Inverse of :meth:`to_dict`. Unknown keys raise :class:`ConfigError` naming them;
        a ``calibration`` key (the summary the CLI writes beside the geometry) is ignored."""
        if not isinstance(data, dict):
            raise ConfigError("geometry", type(data).__name__, "must be a JSON object")
        fmt = data.get("format", FORMAT)
        if fmt != FORMAT:
            raise ConfigError("geometry.format", fmt, f"expected {FORMAT!r}")
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - names - {"format", "calibration"})
        if unknown:
            raise ConfigError(f"geometry.{unknown[0]}", data[unknown[0]],
                              f"unknown field; known: {', '.join(sorted(names))}")
        kw: dict[str, Any] = {}
        for k in names & set(data):
            v = data[k]
            if k.endswith("_xyz"):
                v = _triples(k, v)
            elif k == "leg_offset":
                v = tuple(np.asarray(v, dtype=float).reshape(-1).tolist())
            elif not isinstance(v, int | float) or isinstance(v, bool):
                raise ConfigError(f"geometry.{k}", v, "must be a number (SI units)")
            kw[k] = v
        return cls(**kw)


def load_geometry(path: str | os.PathLike) -> CalibratedGeometry:
    """Read a calibrated-geometry JSON file (as written by ``rths3d platform calibrate``)."""
    import json

    p = Path(path)
    try:
        data = json.loads(p.read_text())
    except OSError as exc:
        raise ConfigError(str(p), None, "", message=f"{p}: cannot read: "
                          f"{exc.strerror or exc}") from None
    except ValueError as exc:
        raise ConfigError(str(p), None, "", message=f"{p}: not valid JSON: {exc}") from None
    return CalibratedGeometry.from_dict(data)


def parameter_vector(geom: StewartGeometry) -> np.ndarray:
    """The 42 parameters θ of a geometry (m), in :func:`parameter_names` order."""
    d = geom.leg_offsets() if isinstance(geom, CalibratedGeometry) else np.zeros(6)
    return np.concatenate([geom.base_anchors().reshape(-1), geom.top_anchors().reshape(-1), d])


def geometry_from_parameters(nominal: StewartGeometry, theta: np.ndarray) -> CalibratedGeometry:
    """The :class:`CalibratedGeometry` with parameters θ (42,) and ``nominal``'s scalar fields."""
    th = np.asarray(theta, dtype=float)
    if th.shape != (N_PARAMETERS,):
        raise ConfigError("theta", f"array of shape {th.shape}", "need 42 parameters (m)")
    return CalibratedGeometry.from_nominal(nominal, th[:18].reshape(6, 3),
                                           th[18:36].reshape(6, 3), th[36:])


# ---------------------------------------------------------------------------- model
def _check_data(poses: Any, leg_lengths: Any | None = None) -> tuple[np.ndarray, np.ndarray]:
    q = np.asarray(poses, dtype=float)
    if q.ndim != 2 or q.shape[1] != 6:
        raise ConfigError("poses", f"array of shape {q.shape}",
                          "need (N, 6) poses x, y, z (m), rx, ry, rz (rad)")
    bad = np.argwhere(~np.isfinite(q))
    if bad.size:
        k, j = bad[0]
        raise ConfigError(f"poses[{k}].{DOFS[j]}", float(q[k, j]), "must be finite")
    if leg_lengths is None:
        return q, np.zeros((0, 6))
    L = np.asarray(leg_lengths, dtype=float)
    if L.shape != q.shape:
        raise ConfigError("leg_lengths", f"array of shape {L.shape}",
                          f"need the shape of the poses {q.shape} (m)")
    bad = np.argwhere(~(np.isfinite(L) & (L > 0)))
    if bad.size:
        k, i = bad[0]
        raise ConfigError(f"leg_lengths[{k}][{i}]", float(L[k, i]),
                          "must be a finite length > 0 m")
    return q, L


def _model(theta: np.ndarray, q: np.ndarray, R: np.ndarray,
           h: float) -> tuple[np.ndarray, np.ndarray]:
    """Encoder lengths (N, 6) of model (1) and the Jacobian (N, 6, 42) of (2) straight from
    the parameter vector (no geometry object, so optimiser trial steps need no validation)."""
    b = theta[:18].reshape(6, 3)
    p = theta[18:36].reshape(6, 3)
    lv = np.einsum("kab,ib->kia", R, p) - b
    lv[..., :2] += q[:, None, :2]
    lv[..., 2] += q[:, None, 2] + h
    n_ = np.linalg.norm(lv, axis=-1)
    u = lv / n_[..., None]
    J = np.zeros(q.shape[:1] + (6, N_PARAMETERS))
    rtu = np.einsum("kba,kib->kia", R, u)  # Rᵀ u_i
    for i in range(6):
        J[:, i, 3 * i:3 * i + 3] = -u[:, i]
        J[:, i, 18 + 3 * i:18 + 3 * i + 3] = rtu[:, i]
        J[:, i, 36 + i] = 1.0
    return n_ + theta[36:], J


def _rotations(q: np.ndarray) -> np.ndarray:
    return rotation_matrix(q[:, 3], q[:, 4], q[:, 5])


def leg_residuals(geom: StewartGeometry, poses: np.ndarray,
                  leg_lengths: np.ndarray) -> np.ndarray:
    """Model minus measured encoder lengths, (N, 6), m (model (1); offsets of a plain
    ``StewartGeometry`` are zero)."""
    q, L = _check_data(poses, leg_lengths)
    return _model(parameter_vector(geom), q, _rotations(q), geom.home_height)[0] - L


def identification_jacobian(geom: StewartGeometry, poses: np.ndarray) -> np.ndarray:
    """∂L/∂θ of the encoder lengths, (6N, 42), rows pose-major (pose k, leg i → row 6k + i),
    columns in :func:`parameter_names` order; dimensionless (m/m). Equation (2)."""
    q, _ = _check_data(poses)
    J = _model(parameter_vector(geom), q, _rotations(q), geom.home_height)[1]
    return J.reshape(6 * q.shape[0], N_PARAMETERS)


def gauge_directions(geom: StewartGeometry) -> list[tuple[str, np.ndarray, str]]:
    """The 12 rigid motions of the two frames as parameter-space directions ∂θ/∂g.

    Returns ``(name, direction (42,), unit)``: translations of all base (or top) anchors by
    1 m along an axis (unit m) and infinitesimal rotations of them about an axis through
    the frame origin per rad (unit rad). Leg offsets do not move.
    """
    b = geom.base_anchors()
    p = geom.top_anchors()
    out: list[tuple[str, np.ndarray, str]] = []
    for frame, pts, start in (("base", b, 0), ("plate", p, 18)):
        for a in range(3):
            g = np.zeros(N_PARAMETERS)
            g[start + a:start + 18:3] = 1.0
            out.append((f"{frame} frame translation {_AXES[a]}", g, "m"))
        for a in range(3):
            e = np.zeros(3)
            e[a] = 1.0
            g = np.zeros(N_PARAMETERS)
            g[start:start + 18] = np.cross(e, pts).reshape(-1)
            out.append((f"{frame} frame rotation {_AXES[a]}", g, "rad"))
    return out


# ---------------------------------------------------------------------------- identifiability
@dataclass(frozen=True)
class IdentifiabilityReport:
    """What a pose set can and cannot identify of the 42 parameters.

    Attributes
    ----------
    n_poses:
        Number of poses N (6N leg-length equations).
    sigma:
        Leg-length noise σ (m) the standard deviations are scaled by.
    tolerance:
        Largest standard deviation (m; rad rotations: ``tolerance / top radius``) for which
        a parameter or rigid motion counts as identified.
    condition_number:
        Condition number of the identification Jacobian with its columns scaled to unit
        norm (``inf`` when a column is zero). The parameters all have the unit m, so the
        scaling only equalises sensitivities.
    rank:
        Numerical rank of the Jacobian (singular values above 1e-10 of the largest).
    singular_values:
        Singular values of the column-scaled Jacobian, descending (42).
    parameter_std:
        Standard deviation of each parameter (m), ``σ·sqrt(diag((JᵀJ)⁺))`` in parameter
        order; ``inf`` for a parameter on an exactly unobservable direction.
    unobservable:
        Names of the parameters the pose set cannot see at all (structurally: they move
        along an exactly null direction of the Jacobian, standard deviation ``inf``), e.g.
        every anchor coordinate from heave-only poses, or the anchor heights ``b_i,z`` and
        ``p_i,z`` from poses without tilt.
    unidentifiable:
        Names of the parameters whose standard deviation exceeds ``tolerance`` (the
        unobservable ones and the poorly determined ones).
    weak_directions:
        The parameter combinations the pose set cannot see: per direction its singular
        value ``s`` (unscaled, m/m), standard deviation ``σ/s`` (m, ``inf`` if exactly
        null) and its largest components ``(name, weight)`` (unit vector).
    gauge:
        For each rigid motion of the base or plate frame (:func:`gauge_directions`): name,
        standard deviation, unit and whether the pose set pins it (``seen``).
    """

    n_poses: int
    sigma: float
    tolerance: float
    condition_number: float
    rank: int
    singular_values: tuple[float, ...]
    parameter_std: tuple[float, ...]
    unobservable: tuple[str, ...]
    unidentifiable: tuple[str, ...]
    weak_directions: tuple[dict[str, Any], ...]
    gauge: tuple[dict[str, Any], ...]

    @property
    def identifiable(self) -> bool:
        """True when every parameter is identified within ``tolerance``."""
        return not self.unidentifiable

    def std(self, name: str) -> float:
        """Standard deviation (m) of the parameter ``name`` (e.g. ``"leg_offset[4]"``)."""
        names = parameter_names()
        if name not in names:
            raise ConfigError("parameter", name, "e.g. base_anchor[2].z, top_anchor[0].x, "
                                                 "leg_offset[4]")
        return self.parameter_std[names.index(name)]

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict (non-finite numbers stay floats; the CLI prints them as null)."""
        return {
            "n_poses": self.n_poses, "sigma_m": self.sigma, "tolerance_m": self.tolerance,
            "condition_number": self.condition_number, "rank": self.rank,
            "singular_values": list(self.singular_values),
            "parameter_std_m": dict(zip(parameter_names(), self.parameter_std, strict=True)),
            "unobservable": list(self.unobservable),
            "unidentifiable": list(self.unidentifiable),
            "weak_directions": [dict(d, components=[list(c) for c in d["components"]])
                                for d in self.weak_directions],
            "gauge": [dict(g) for g in self.gauge],
            "frames": "the pose measurement's world and plate frames",
        }

    def lines(self) -> list[str]:
        """Human-readable summary lines."""
        s = self.singular_values
        out = [f"identifiability: {self.n_poses} poses, rank {self.rank}/42, condition "
               f"number {self.condition_number:.4g} (column-scaled), singular values "
               f"{s[0]:.3g} … {s[-1]:.3g}",
               f"  (σ = {self.sigma * 1e6:.3g} µm per leg length; a parameter counts as "
               f"identified when its standard deviation is ≤ {self.tolerance * 1e3:.3g} mm)"]
        weak = [n for n in self.unidentifiable if n not in self.unobservable]
        if self.unobservable:
            out.append(f"  cannot see {len(self.unobservable)} parameter(s) at all "
                       "(unobservable): " + ", ".join(self.unobservable))
        if weak:
            out.append(f"  {len(weak)} parameter(s) poorly determined (std > "
                       f"{self.tolerance * 1e3:.3g} mm): " + ", ".join(
                           f"{n} ({self.std(n) * 1e3:.2g} mm)" for n in weak))
        if not self.unidentifiable:
            out.append("  every parameter identified")
        for d in self.weak_directions[:12]:
            comp = " ".join(f"{w:+.2f}·{n}" for n, w in d["components"])
            std = "unobservable" if not math.isfinite(d["std"]) else \
                f"std {d['std'] * 1e3:.3g} mm"
            out.append(f"  unseen direction ({std}): {comp}")
        if len(self.weak_directions) > 12:
            out.append(f"  … and {len(self.weak_directions) - 12} more unseen directions")
        if any(math.isfinite(d["std"]) for d in self.weak_directions):
            out.append("  (a move of one standard deviation along an unseen direction changes "
                       "the leg lengths at these poses by σ/√(6N) RMS: predictions inside the "
                       "measured workspace are safe, outside it they are not)")
        unseen = [g["name"] for g in self.gauge if not g["seen"]]
        out.append("  frames: the pose measurement's; "
                   + ("every rigid motion of the base and plate frames is pinned by the poses"
                      if not unseen else "not pinned by these poses: " + ", ".join(unseen)))
        return out


def _std_along(V: np.ndarray, s: np.ndarray, null: np.ndarray, g: np.ndarray,
               sigma: float) -> float:
    """σ·sqrt(gᵀ (JᵀJ)⁺ g), inf when g has a component on an exactly null direction."""
    w = V.T @ g
    gn = float(np.linalg.norm(g)) or 1.0
    if np.any(np.abs(w[null]) > 1e-8 * gn):
        return math.inf
    keep = ~null
    return float(sigma * math.sqrt(float(np.sum((w[keep] / s[keep]) ** 2))))


def identifiability(geom: StewartGeometry, poses: np.ndarray, sigma: float = 1.0e-5,
                    tolerance: float = 1.0e-4, rcond: float = 1.0e-10) -> IdentifiabilityReport:
    """Identifiability of the 42 parameters from the pose set ``poses`` (N, 6).

    Linearised at ``geom``; ``sigma`` is the leg-length noise (m) and ``tolerance`` the
    largest standard deviation (m) that counts as identified. A direction of parameter space
    whose singular value ``s`` is below ``rcond`` times the largest is exactly unobservable
    (standard deviation ``inf``); otherwise its standard deviation is ``σ/s``.
    """
    if not (math.isfinite(sigma) and sigma > 0):
        raise ConfigError("sigma", sigma, "must be > 0 m")
    if not (math.isfinite(tolerance) and tolerance > 0):
        raise ConfigError("tolerance", tolerance, "must be > 0 m")
    q, _ = _check_data(poses)
    J = identification_jacobian(geom, q)
    norms = np.linalg.norm(J, axis=0)
    Js = J / np.where(norms > 0, norms, 1.0)
    ss = np.linalg.svd(Js, compute_uv=False)
    cond = float(ss[0] / ss[-1]) if ss[-1] > 0 and np.all(norms > 0) else math.inf
    # the unscaled SVD gives the physical standard deviations (all parameters are in m)
    # full V (42×42) without the (6N)² U of a long record
    _, s, Vt = np.linalg.svd(J, full_matrices=J.shape[0] < N_PARAMETERS)
    s = np.concatenate([s, np.zeros(N_PARAMETERS - s.size)])
    V = Vt.T
    null = s <= rcond * s[0]
    rank = int(np.sum(~null))
    names = parameter_names()
    std = np.array([_std_along(V, s, null, np.eye(N_PARAMETERS)[j], sigma)
                    for j in range(N_PARAMETERS)])
    unseen = tuple(n for n, v in zip(names, std, strict=True) if not v <= tolerance)
    unobservable = tuple(n for n, v in zip(names, std, strict=True) if not math.isfinite(v))
    weak = []
    for k in np.flatnonzero(null | (sigma / np.where(s > 0, s, 1.0) > tolerance)):
        v = V[:, k]
        order = np.argsort(-np.abs(v))
        comps = tuple((names[j], round(float(v[j]), 4)) for j in order
                      if abs(v[j]) >= 0.25)[:8]
        weak.append({"singular_value": float(s[k]),
                     "std": math.inf if null[k] else float(sigma / s[k]),
                     "components": comps})
    weak.sort(key=lambda d: d["singular_value"])
    rot_tol = tolerance / max(float(np.linalg.norm(geom.top_anchors(), axis=1).mean()), 1e-9)
    gauge = []
    for name, g, unit in gauge_directions(geom):
        v = _std_along(V, s, null, g, sigma)
        gauge.append({"name": name, "std": v, "unit": unit,
                      "seen": bool(v <= (tolerance if unit == "m" else rot_tol))})
    return IdentifiabilityReport(
        n_poses=int(q.shape[0]), sigma=float(sigma), tolerance=float(tolerance),
        condition_number=cond, rank=rank, singular_values=tuple(float(v) for v in ss),
        parameter_std=tuple(float(v) for v in std), unobservable=unobservable,
        unidentifiable=unseen,
        weak_directions=tuple(weak), gauge=tuple(gauge))


# ---------------------------------------------------------------------------- estimator
class KinematicCalibration:
    """Inverse kinematic calibration of the 42 parameters (estimator: ``fit`` / ``predict``).

    Minimises the leg-length residuals of model (1) over θ with
    ``scipy.optimize.least_squares`` (Levenberg–Marquardt, analytic Jacobian (2)), starting
    from ``nominal``. A weak Gaussian prior ``θ ~ N(θ_nominal, prior_sigma²)`` keeps the
    directions the pose set cannot see at their nominal values instead of letting them
    drift; at the default (10 mm against ``sigma`` = 10 µm) it moves identified parameters
    by far less than their standard deviation. ``prior_sigma=None`` fits without it.

    Parameters
    ----------
    nominal:
        The drawing's geometry (a :class:`CalibratedGeometry` starts from its anchors and
        offsets).
    sigma:
        Leg-length noise (m) used to weigh the prior; the identifiability report uses the
        fitted residual RMS instead.
    prior_sigma:
        A-priori standard deviation of each parameter about its nominal value (m), or None.
    tolerance:
        Identifiability threshold of :func:`identifiability` (m).

    Fitted attributes
    -----------------
    geometry_:
        The calibrated :class:`CalibratedGeometry`.
    params_, deviation_, std_:
        θ (42,), θ − θ_nominal (42,) and the standard deviations (42,) (m).
    residuals_:
        Leg-length residuals (N, 6) after the fit, model − measured (m).
    rms_, nominal_rms_:
        RMS leg-length residual after the fit and of the nominal geometry (m).
    sigma_:
        Estimated leg-length noise ``sqrt(SS / (6N − rank))`` (m).
    report_:
        :class:`IdentifiabilityReport` of the pose set at the fitted geometry with ``sigma_``.
    nfev_, success_:
        Function evaluations and the optimiser's success flag.
    """

    def __init__(self, nominal: StewartGeometry = DEFAULT_GEOMETRY, sigma: float = 1.0e-5,
                 prior_sigma: float | None = 0.01, tolerance: float = 1.0e-4):
        if not isinstance(nominal, StewartGeometry):
            raise ConfigError("nominal", type(nominal).__name__, "must be a StewartGeometry")
        if not (math.isfinite(sigma) and sigma > 0):
            raise ConfigError("sigma", sigma, "must be > 0 m")
        if prior_sigma is not None and not (math.isfinite(prior_sigma) and prior_sigma > 0):
            raise ConfigError("prior_sigma", prior_sigma, "must be > 0 m or None")
        if not (math.isfinite(tolerance) and tolerance > 0):
            raise ConfigError("tolerance", tolerance, "must be > 0 m")
        self.nominal = nominal
        self.sigma = float(sigma)
        self.prior_sigma = prior_sigma
        self.tolerance = float(tolerance)

    def fit(self, poses: np.ndarray, leg_lengths: np.ndarray) -> KinematicCalibration:
        """Fit θ to measured poses (N, 6; m, rad, relative to home, absolute) and encoder
        lengths (N, 6; m). Needs N ≥ 7 (seven parameters per leg)."""
        from scipy.optimize import least_squares

        q, L = _check_data(poses, leg_lengths)
        if q.shape[0] < 7:
            raise ConfigError("poses", q.shape[0], "need at least 7 poses (7 parameters "
                                                   "per leg)")
        th0 = parameter_vector(self.nominal)
        nominal = self.nominal
        R = _rotations(q)
        h = float(nominal.home_height)
        L0 = _model(th0, q, R, h)[0]
        far = np.abs(L0 - L) > nominal.stroke / 2
        if np.any(far):
            k, i = (int(v) for v in np.argwhere(far)[0])
            raise ConfigError(f"leg_lengths[{k}][{i}]", float(L[k, i]), "", message=(
                f"leg_lengths[{k}][{i}]: {L[k, i]:.6g} m is {L[k, i] - L0[k, i]:+.4g} m off the "
                f"nominal model's {L0[k, i]:.6g} m at that pose, more than half the stroke "
                f"({nominal.stroke / 2:.4g} m): check units (m, rad) and the leg order"))
        w = 1.0 / self.sigma
        wp = None if self.prior_sigma is None else 1.0 / self.prior_sigma

        def fun(th: np.ndarray) -> np.ndarray:
            r = ((_model(th, q, R, h)[0] - L) * w).reshape(-1)
            return r if wp is None else np.concatenate([r, (th - th0) * wp])

        def jac(th: np.ndarray) -> np.ndarray:
            J = _model(th, q, R, h)[1].reshape(-1, N_PARAMETERS) * w
            return J if wp is None else np.vstack([J, np.eye(N_PARAMETERS) * wp])

        sol = least_squares(fun, th0, jac=jac, method="lm", xtol=1e-15, ftol=1e-15,
                            gtol=1e-15, max_nfev=200)
        th = sol.x
        try:
            self.geometry_ = geometry_from_parameters(nominal, th)
        except ConfigError as exc:
            raise ConfigError("poses/leg_lengths", None, "", message=(
                f"the fitted geometry is implausible ({exc}): check the units (m, rad), the "
                "leg order and that the poses are absolute measurements")) from None
        self.params_ = th
        self.deviation_ = th - th0
        self.residuals_ = leg_residuals(self.geometry_, q, L)
        self.rms_ = float(np.sqrt(np.mean(self.residuals_ ** 2)))
        self.nominal_rms_ = float(np.sqrt(np.mean(leg_residuals(nominal, q, L) ** 2)))
        rank = int(np.linalg.matrix_rank(identification_jacobian(self.geometry_, q)))
        dof = max(L.size - rank, 1)
        self.sigma_ = float(max(np.sqrt(np.sum(self.residuals_ ** 2) / dof), 1e-12))
        self.report_ = identifiability(self.geometry_, q, sigma=self.sigma_,
                                       tolerance=self.tolerance)
        self.std_ = np.array(self.report_.parameter_std)
        self.nfev_ = int(sol.nfev)
        self.success_ = bool(sol.success)
        return self

    def _fitted(self) -> CalibratedGeometry:
        if not hasattr(self, "geometry_"):
            raise ConfigError("KinematicCalibration", None, "", message="KinematicCalibration: "
                              "call fit(poses, leg_lengths) first")
        return self.geometry_

    def predict(self, poses: np.ndarray) -> np.ndarray:
        """Encoder lengths (N, 6) the calibrated geometry predicts at poses (N, 6), m."""
        return self._fitted().encoder_lengths(_check_data(poses)[0])

    def predict_pose(self, leg_lengths: np.ndarray,
                     guess: np.ndarray | None = None) -> np.ndarray:
        """Poses (..., 6) the calibrated geometry gives for encoder lengths (..., 6) (FK)."""
        return self._fitted().pose_from_encoders(leg_lengths, guess=guess)

    def deviations(self) -> dict[str, float]:
        """Fitted minus nominal value of each parameter, by name (m)."""
        self._fitted()
        return dict(zip(parameter_names(), (float(v) for v in self.deviation_), strict=True))

    def summary(self) -> dict[str, Any]:
        """JSON-ready figures: RMS before/after, parameters, deviations, std, report."""
        g = self._fitted()
        names = parameter_names()
        return {
            "rms_nominal_m": self.nominal_rms_, "rms_calibrated_m": self.rms_,
            "sigma_m": self.sigma_, "n_poses": self.report_.n_poses,
            "success": self.success_, "nfev": self.nfev_,
            "parameters": [{"name": n, "value_m": float(v), "deviation_m": float(d),
                            "std_m": float(s), "identified": bool(s <= self.tolerance)}
                           for n, v, d, s in zip(names, self.params_, self.deviation_,
                                                 self.std_, strict=True)],
            "identifiability": self.report_.as_dict(),
            "geometry": g.to_dict(),
        }
