"""The 3-D scene: base, six legs, top plate, force-torque sensor, experimental part, contact
surface, a schematic of the numerical substructure and the measured interface wrench.

Everything is drawn in the MuJoCo world frame (z up) in metres. The top plate follows the
measured pose (``pose_meas.*``; else the measured interface displacement ``z_meas.*``, the
interface DOFs being top-plate DOFs; else the leg lengths ``leg_len.*`` through forward
kinematics). Each leg is a cylinder hinged at its base anchor and a piston whose end sits at
the top anchor; when ``leg_len.*`` is recorded the piston extends to the recorded length.
Platform motions are millimetres on a metre-sized machine, so a display *exaggeration* k
multiplies the pose, the specimen's spring deflection and the numerical displacements (k = 1
is true scale); the force arrow has its own scale (m per N).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..platform import DEFAULT_GEOMETRY, StewartGeometry
from ..platform.kinematics import ForwardKinematicsError, forward_kinematics
from ..record import DOFS, RecordBuffer
from .kinematics import leg_segments, quat_from_matrix, rotation_matrix
from .stream import group_indices

BASE_COLOR = (90, 96, 110)
CYLINDER_COLOR = (35, 42, 60)
PISTON_COLOR = (200, 205, 215)
PLATE_COLOR = (70, 130, 180)
FTS_COLOR = (230, 160, 40)
SPECIMEN_COLOR = (200, 60, 60)
CONTACT_COLOR = (120, 120, 120)
GHOST_COLOR = (60, 180, 110)
FORCE_COLOR = (220, 30, 30)
TORQUE_COLOR = (150, 40, 200)

ARROW_LENGTH = 0.15
"""Length (m) the largest interface force (or torque) of the stream is drawn with."""

ARROW_OFFSET = (0.14, 0.0, 0.15)
"""The wrench arrows start at this offset (m, plate frame) from the sensor origin, beside the
specimen that would otherwise hide them and above the plate so downward forces show too."""


def _meta_number(meta: dict[str, Any], *keys: str) -> float | None:
    """First finite number found under ``keys`` in ``meta``, ``meta['params']`` or
    ``meta['experiment']`` (flat keys, SI)."""
    for where in (meta, meta.get("params") or {}, meta.get("experiment") or {}):
        if not isinstance(where, dict):
            continue
        for k in keys:
            v = where.get(k)
            if isinstance(v, (int, float)) and math.isfinite(v):
                return float(v)
    return None


def geometry_from_meta(meta: dict[str, Any]) -> StewartGeometry:
    """The platform geometry a stream was recorded with (``meta['geometry']`` fields), or
    the default geometry."""
    fields = meta.get("geometry")
    if isinstance(fields, dict):
        known = StewartGeometry.__dataclass_fields__
        return StewartGeometry(**{k: v for k, v in fields.items() if k in known})
    return DEFAULT_GEOMETRY


@dataclass(frozen=True)
class SpecimenLayout:
    """Drawing of the experimental part: a mass on a spring standing on the FTS.

    ``k_exp`` (N/m) turns the measured force into the spring deflection F'_m,z / k_exp, so the
    mass visibly moves against the plate; ``contact_gap`` h_0 (m) places the world-fixed
    contact surface above the mass at equilibrium (None: no contact surface).
    """

    spring_length: float = 0.10
    mass_size: float = 0.08
    k_exp: float | None = None
    contact_gap: float | None = None

    @classmethod
    def from_meta(cls, meta: dict[str, Any]) -> SpecimenLayout:
        """Spring stiffness and contact gap from record metadata where recorded."""
        k = None
        exp = meta.get("experiment") or {}
        kmat = exp.get("k_exp") if isinstance(exp, dict) else None
        if isinstance(kmat, (list, tuple)) and kmat:
            try:
                kz = np.atleast_2d(np.asarray(kmat, dtype=float))
                dofs = list(meta.get("dofs") or [])
                j = dofs.index("z") if "z" in dofs and len(dofs) == kz.shape[0] else -1
                k = float(kz[j, j]) if (j >= 0 or kz.size == 1) else None
            except (TypeError, ValueError):
                k = None
        if k is None:
            k = _meta_number(meta, "k_exp", "k")
        gap = _meta_number(meta, "h0", "h_0", "contact_gap", "gap")
        return cls(k_exp=k if k and k > 0 else None, contact_gap=gap)


class PlatformScene:
    """viser scene nodes of the platform and their update from one stream sample.

    Parameters
    ----------
    server:
        A ``viser.ViserServer``.
    buffer:
        The stream (its column index is looked up once here).
    geometry:
        Platform geometry (m).
    specimen:
        Drawing of the experimental part.
    """

    def __init__(self, server: Any, buffer: RecordBuffer, geometry: StewartGeometry,
                 specimen: SpecimenLayout | None = None):
        import trimesh

        self.server = server
        self.geometry = geometry
        self.specimen = specimen or SpecimenLayout.from_meta(buffer.meta)
        self.exaggeration = 1.0
        self.force_scale = 1e-3  # m per N, set by set_wrench_scale
        self.torque_scale = 1e-2  # m per N·m
        idx = buffer.index
        self._pose_cols = group_indices(idx, "pose_meas", DOFS)
        self._model_pose_cols = group_indices(idx, "model.pose_meas", DOFS)
        self._leg_cols = group_indices(idx, "leg_len", tuple(str(i) for i in range(6)))
        self._iface = [idx.get(f"z_meas.{d}", -1) for d in DOFS]
        self._force_cols = [idx.get(f"f_meas.{d}", -1) for d in ("x", "y", "z")]
        self._torque_cols = [idx.get(f"f_meas.{d}", -1) for d in ("rx", "ry", "rz")]
        self._fz_col = idx.get("f_meas.z", -1)
        nums = sorted((k for k in idx if k.startswith("x_num.")),
                      key=lambda k: int(k.split(".")[1]) if k.split(".")[1].isdigit() else 0)
        self._num_cols = [idx[k] for k in nums] or [idx.get("z_cmd.z", -1)]
        self._last_pose = np.zeros(6)

        g = geometry
        scene = server.scene
        self.base = g.base_anchors()
        self.top = g.top_anchors()
        self.home = g.home_position()
        lo, hi = g.leg_length_limits()
        self.cylinder_length = float(max(0.55 * hi.max(), 0.5 * (lo.min() + hi.max() / 2)))
        scene.set_up_direction("+z")
        scene.add_grid("/ground", width=2.0, height=2.0, cell_size=0.1, position=(0, 0, -0.03))
        r_base = g.base_radius + 0.06
        disc = trimesh.creation.cylinder(radius=r_base, height=0.03, sections=48)
        scene.add_mesh_simple("/platform/base", disc.vertices, disc.faces, color=BASE_COLOR,
                              position=(0.0, 0.0, -0.015))
        for i, b in enumerate(self.base):
            scene.add_icosphere(f"/platform/base_joint_{i}", radius=0.022, color=(40, 40, 40),
                                position=tuple(b))
        # Legs as two batched meshes (one message per update for all six cylinders, one for
        # all six pistons).
        c = self.cylinder_length
        cyl_mesh = trimesh.creation.cylinder(radius=0.024, height=c, sections=20)
        pis_mesh = trimesh.creation.cylinder(radius=0.013, height=c, sections=16)
        home_tips = self.top + self.home
        cyl, piston, quats, _ = leg_segments(self.base, home_tips, c)
        self.cylinders = scene.add_batched_meshes_simple(
            "/platform/leg_cylinders", cyl_mesh.vertices, cyl_mesh.faces,
            batched_wxyzs=quats, batched_positions=cyl, batched_colors=CYLINDER_COLOR,
            lod="off")
        self.pistons = scene.add_batched_meshes_simple(
            "/platform/leg_pistons", pis_mesh.vertices, pis_mesh.faces,
            batched_wxyzs=quats, batched_positions=piston, batched_colors=PISTON_COLOR,
            lod="off")
        # The plate frame: plate, sensor and specimen are its children, so one transform
        # per update moves them all.
        self.plate_frame = scene.add_frame("/platform/top", show_axes=False,
                                           position=tuple(self.home))
        plate = trimesh.creation.cylinder(radius=g.top_radius + 0.04,
                                          height=g.plate_thickness, sections=6)
        scene.add_mesh_simple("/platform/top/plate", plate.vertices, plate.faces,
                              color=PLATE_COLOR, position=(0, 0, -g.plate_thickness / 2))
        for i, p in enumerate(self.top):
            scene.add_icosphere(f"/platform/top/joint_{i}", radius=0.018, color=(40, 40, 40),
                                position=tuple(p))
        scene.add_cylinder("/platform/top/fts", radius=0.045, height=g.fts_height,
                           color=FTS_COLOR, position=(0, 0, g.fts_height / 2))
        scene.add_label("/platform/top/fts_label", "FTS", position=(0.07, 0, g.fts_height))
        # Experimental part: a coil spring (trimesh helix sweep) and the mass on it.
        sp = self.specimen
        self.spring_base = g.fts_height
        helix = _helix_mesh(radius=0.03, wire=0.005, turns=6, length=1.0)
        self.spring = scene.add_mesh_simple(
            "/platform/top/specimen/spring", helix.vertices, helix.faces, color=(110, 110, 120),
            position=(0, 0, self.spring_base), scale=(1.0, 1.0, sp.spring_length))
        self.mass = scene.add_box(
            "/platform/top/specimen/mass", dimensions=(sp.mass_size,) * 3, color=SPECIMEN_COLOR,
            position=(0, 0, self.spring_base + sp.spring_length + sp.mass_size / 2))
        self.mass_top_home = float(self.home[2] + self.spring_base + sp.spring_length
                                   + sp.mass_size)
        self.contact = None
        if sp.contact_gap is not None:
            self._add_contact_surface(sp.contact_gap)
        # A model's prediction of the plate (diagnosis records): a translucent twin.
        self.model_frame = None
        if self._model_pose_cols.size:
            self.model_frame = scene.add_frame("/model/top", show_axes=False,
                                               position=tuple(self.home))
            scene.add_mesh_simple("/model/top/plate", plate.vertices, plate.faces,
                                  color=(255, 127, 14), opacity=0.35,
                                  position=(0, 0, -g.plate_thickness / 2 + 0.001))
        # Numerical substructure: a ghost schematic of its masses and springs beside the bench.
        self._add_ghost(len(self._num_cols))
        fts_world = self.home + np.array([0.0, 0.0, g.fts_height])
        self.fts_origin = fts_world
        self._arrow_pts = np.zeros((1, 2, 3), dtype=np.float32)
        self._arrow_pts[0, :, :] = fts_world + np.array([0.25, 0.0, 0.0])
        self.force_arrow = scene.add_arrows("/wrench/force", self._arrow_pts.copy(),
                                            colors=FORCE_COLOR, shaft_radius=0.008,
                                            head_radius=0.02, head_length=0.04)
        self.torque_arrow = scene.add_arrows("/wrench/torque", self._arrow_pts.copy(),
                                             colors=TORQUE_COLOR, shaft_radius=0.006,
                                             head_radius=0.016, head_length=0.03,
                                             visible=any(c >= 0 for c in self._torque_cols))
        self.force_label = scene.add_label("/wrench/force_label", "F'_m", anchor="bottom-left",
                                           position=tuple(fts_world + ARROW_OFFSET + [0.02, 0, 0]))

    # ------------------------------------------------------------------ construction
    def _add_contact_surface(self, gap: float) -> None:
        # World-fixed, h_0 above the mass top at equilibrium; drawn k·h_0 above it so that the
        # exaggerated mass touches it exactly when the real one does.
        self.contact_gap = gap
        z = self._contact_z()
        self.contact = self.server.scene.add_box(
            "/experiment/contact_surface", dimensions=(0.30, 0.30, 0.015), color=CONTACT_COLOR,
            opacity=0.85, position=(0.0, 0.0, z + 0.0075))
        self.contact_label = self.server.scene.add_label(
            "/experiment/contact_label", "contact surface", anchor="bottom-right",
            position=(-0.16, 0.0, z + 0.02))
        self._contact_k = self.exaggeration

    def _contact_z(self) -> float:
        return self.mass_top_home + self.exaggeration * float(self.contact_gap)

    def _add_ghost(self, ndof: int) -> None:
        import trimesh

        scene = self.server.scene
        x0 = -(self.geometry.base_radius + 0.45)
        self.ghost_x = x0
        self.ghost_spacing = 0.16
        scene.add_box("/numerical/ground", dimensions=(0.22, 0.22, 0.02), color=GHOST_COLOR,
                      opacity=0.35, position=(x0, 0.0, 0.0))
        box = trimesh.creation.box(extents=(0.16, 0.16, 0.06))
        self._ghost_pos = np.array([[x0, 0.0, self._ghost_z(i, 0.0)] for i in range(ndof)])
        self.ghost_masses = scene.add_batched_meshes_simple(
            "/numerical/masses", box.vertices, box.faces,
            batched_wxyzs=np.tile([1.0, 0.0, 0.0, 0.0], (ndof, 1)),
            batched_positions=self._ghost_pos, batched_colors=GHOST_COLOR, opacity=0.45,
            lod="off")
        self._ghost_lines = np.zeros((ndof, 2, 3), dtype=np.float32)
        self._update_ghost_lines([0.0] * ndof)
        self.ghost_springs = scene.add_line_segments(
            "/numerical/springs", self._ghost_lines.copy(), colors=GHOST_COLOR, thickness=3.0,
            thickness_units="screen")
        scene.add_label("/numerical/label", "numerical substructure", anchor="top-center",
                        position=(x0, 0.0, -0.03))

    def _ghost_z(self, i: int, x: float) -> float:
        return self.ghost_spacing * (i + 1) + self.exaggeration * x

    def _update_ghost_lines(self, xs: list[float]) -> None:
        prev = 0.01
        for i, x in enumerate(xs):
            z = self._ghost_z(i, x)
            self._ghost_lines[i, 0] = (self.ghost_x, 0.0, prev)
            self._ghost_lines[i, 1] = (self.ghost_x, 0.0, z - 0.03)
            prev = z + 0.03

    # ------------------------------------------------------------------ updates
    def set_wrench_scale(self, f_max: float, t_max: float) -> None:
        """Draw the largest force ``f_max`` (N) and torque ``t_max`` (N·m) ARROW_LENGTH long."""
        self.force_scale = ARROW_LENGTH / f_max if f_max > 0 else 1e-3
        self.torque_scale = ARROW_LENGTH / t_max if t_max > 0 else 1e-2

    def pose_of(self, row: np.ndarray) -> np.ndarray:
        """Measured top-plate pose (m, rad) of one sample, before exaggeration."""
        if self._pose_cols.size:
            return row[self._pose_cols]
        if any(c >= 0 for c in self._iface):
            return np.array([row[c] if c >= 0 else 0.0 for c in self._iface])
        if self._leg_cols.size:
            try:
                self._last_pose = forward_kinematics(self.geometry, row[self._leg_cols],
                                                     guess=self._last_pose, tol=1e-10)
            except ForwardKinematicsError:
                pass
            return self._last_pose
        return np.zeros(6)

    def update(self, row: np.ndarray) -> None:
        """Move every node to sample ``row`` (one row of the stream's data)."""
        k = self.exaggeration
        pose = self.pose_of(row) * k
        R = rotation_matrix(pose[3], pose[4], pose[5])
        centre = self.home + pose[:3]
        self.plate_frame.position = centre
        self.plate_frame.wxyz = quat_from_matrix(R)
        tips = self.top @ R.T + centre
        cyl, piston, quats, lengths = leg_segments(self.base, tips, self.cylinder_length)
        if self._leg_cols.size:
            # Show the recorded leg length (exaggerated about home) along the drawn axis.
            home_len = self.geometry.home_leg_lengths()
            rec = home_len + k * (row[self._leg_cols] - home_len)
            unit = (tips - self.base) / lengths[:, None]
            piston = self.base + unit * (rec - 0.5 * self.cylinder_length)[:, None]
        self.cylinders.batched_positions = cyl
        self.cylinders.batched_wxyzs = quats
        self.pistons.batched_positions = piston
        self.pistons.batched_wxyzs = quats
        if self.model_frame is not None:
            mp = row[self._model_pose_cols] * k
            self.model_frame.position = self.home + mp[:3]
            self.model_frame.wxyz = quat_from_matrix(rotation_matrix(mp[3], mp[4], mp[5]))
        # Specimen: the spring carries F'_m,z = k_exp · (deflection), mass moves by −F/k.
        sp = self.specimen
        if sp.k_exp and self._fz_col >= 0:
            length = max(sp.spring_length - k * row[self._fz_col] / sp.k_exp,
                         0.2 * sp.spring_length)
            self.spring.scale = (1.0, 1.0, length)
            self.mass.position = (0.0, 0.0, self.spring_base + length + sp.mass_size / 2)
        if self.contact is not None and self._contact_k != k:
            z = self._contact_z()
            self.contact.position = (0.0, 0.0, z + 0.0075)
            self.contact_label.position = (-0.16, 0.0, z + 0.02)
            self._contact_k = k
        # Wrench arrows from the sensor site.
        origin = centre + R @ (np.array(ARROW_OFFSET) + [0.0, 0.0, self.geometry.fts_height])
        if any(c >= 0 for c in self._force_cols):
            f = np.array([row[c] if c >= 0 else 0.0 for c in self._force_cols])
            self._arrow_pts[0, 0] = origin
            self._arrow_pts[0, 1] = origin + f * self.force_scale
            self.force_arrow.points = self._arrow_pts.copy()
        if any(c >= 0 for c in self._torque_cols):
            tq = np.array([row[c] if c >= 0 else 0.0 for c in self._torque_cols])
            self._arrow_pts[0, 0] = origin
            self._arrow_pts[0, 1] = origin + tq * self.torque_scale
            self.torque_arrow.points = self._arrow_pts.copy()
        xs = [row[c] if c >= 0 else 0.0 for c in self._num_cols]
        for i, x in enumerate(xs):
            self._ghost_pos[i, 2] = self._ghost_z(i, x)
        self.ghost_masses.batched_positions = self._ghost_pos.copy()
        self._update_ghost_lines(xs)
        self.ghost_springs.points = self._ghost_lines.copy()


def _helix_mesh(radius: float, wire: float, turns: int, length: float):
    """A coil-spring tube mesh (trimesh) along +z from 0 to ``length`` (m)."""
    import trimesh

    n, m = 24 * turns, 8
    s = np.linspace(0.0, 1.0, n)
    a = 2 * np.pi * turns * s
    centre = np.stack([radius * np.cos(a), radius * np.sin(a), length * s], axis=1)
    radial = np.stack([np.cos(a), np.sin(a), np.zeros(n)], axis=1)
    phi = np.linspace(0.0, 2 * np.pi, m, endpoint=False)
    # Ring of the wire section in the (radial, z) plane around each centre point.
    ez = np.array([0.0, 0.0, 1.0])
    verts = (centre[:, None, :] + wire * (np.cos(phi)[None, :, None] * radial[:, None, :]
                                          + np.sin(phi)[None, :, None] * ez))
    verts = verts.reshape(-1, 3)
    i = np.arange(n - 1)[:, None] * m
    j = np.arange(m)[None, :]
    a0, a1 = i + j, i + (j + 1) % m
    b0, b1 = a0 + m, a1 + m
    faces = np.concatenate([np.stack([a0, a1, b1], -1).reshape(-1, 3),
                            np.stack([a0, b1, b0], -1).reshape(-1, 3)])
    return trimesh.Trimesh(vertices=verts, faces=faces, process=False)
