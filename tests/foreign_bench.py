"""A Stewart-platform bench made with other code than rths3d's bench model, for the tests.

Everything here is written independently of ``rths3d.bench`` / ``rths3d.platform``: the MJCF
of the whole bench (legs, plate, sensor, the part's fragment under the sensor and its
world-fixed bodies), the controller (inverse kinematics of the controller's anchors,
backward-difference velocity feed-forward, a whole-sample transport delay, gravity
compensation found by letting the bench settle, a **zero-order hold** of every set-point
over the interface step), the stepping loop (a finer physics step than the replay's) and
the channels, **sampled at the start of each interval** (before the new set-point acts),
zeroed as docs/records.md says (displacement from the measured rest pose, interface and leg
forces tared at rest, absolute pose and encoders as they are, the raw wrench zeroed
unloaded), with white noise at the documented levels. The record is written as CSV with a
``.meta.json`` that names no bench: the diagnosis gets only the file and a scene.

What a scene cannot state about a bench (the plate's inertia tensor, the shape of the leg
bodies) is taken as the scene's model assumes it; everything a scene can state (anchors,
home height, masses, servo, conventions, the part) is this module's own.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, replace
from pathlib import Path

import mujoco
import numpy as np
import scipy.linalg
from scipy.spatial.transform import Rotation

DOFS = ("x", "y", "z", "rx", "ry", "rz")
WRENCH = ("fx", "fy", "fz", "tx", "ty", "tz")
NOISE = {"pose": (1e-6, 5e-6), "leg_len": 1e-6, "leg_force": 0.5, "force": 0.1,
         "torque": 0.005}
"""Noise σ per channel at level 1 (docs/records.md): m, rad, m, N, N, N·m."""
LAST_RUN: dict[str, float] = {}
"""Facts of the last run: ``contact_fraction``, the share of interface steps that end with a
contact active."""


def anchor_pairs(radius: float, angle0: float, gap: float, shift: float) -> np.ndarray:
    """Six anchors (6, 3) on a circle, in three pairs 120° apart centred on
    ``angle0 + shift + k·120°``, each pair split by ``gap`` (rad)."""
    out = []
    for k in range(3):
        c = angle0 + shift + 2 * math.pi * k / 3
        for s in (-0.5, 0.5):
            a = c + s * gap
            out.append((radius * math.cos(a), radius * math.sin(a), 0.0))
    return np.array(out)


@dataclass(frozen=True)
class ForeignBench:
    """A bench (SI units). ``base``/``top``: the true anchors (world / plate frame, m);
    ``ctrl_base``/``ctrl_top``: the anchors the controller's inverse kinematics uses (None:
    the true ones). ``part_xml``: MJCF bodies mounted under the sensor (sensor frame);
    ``world_xml``: world-fixed bodies (world frame)."""

    base: np.ndarray
    top: np.ndarray
    home_height: float
    plate_mass: float = 12.0
    plate_inertia: tuple[float, ...] = (0.2, 0.2, 0.38)
    plate_ipos: tuple[float, float, float] = (0.0, 0.0, -0.01)
    plate_iquat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    cylinder_mass: float = 2.0
    piston_mass: float = 1.0
    fts_pose: tuple[float, ...] = (0.0, 0.0, 0.03, 0.0, 0.0, 0.0)
    kp: float = 2.0e5
    kv: float = 2.0e3
    delay_samples: int = 0
    velocity_ff: bool = True
    hold: str = "zoh"
    sample: str = "start"
    dt: float = 1.0e-3
    physics_dt: float = 0.25e-3
    part_xml: str = ""
    world_xml: str = ""
    ctrl_base: np.ndarray | None = None
    ctrl_top: np.ndarray | None = None
    encoder_offsets: tuple[float, ...] = (0.0,) * 6
    gravity_comp_scale: float = 1.0
    kp_scale: tuple[float, ...] = (1.0,) * 6
    friction: tuple[float, ...] = (0.0,) * 6
    """Dry friction of each slide (N), a stiff friction constraint (time constant 2 ms)."""
    damping: tuple[float, ...] = (0.0,) * 6
    """Viscous friction of each slide (N·s/m)."""
    leg_delay: tuple[int, ...] = (0,) * 6
    """Extra transport delay of each leg's set-point (whole samples)."""
    leg_lag: tuple[float, ...] = (0.0,) * 6
    """First-order lag of each leg's set-point (s), y += (1 − e^{−ΔT/τ})(u − y) per sample."""
    fts_matrix: np.ndarray | None = None
    fts_offset: tuple[float, ...] = (0.0,) * 6
    """The sensor reads C w + b (a miscalibrated sensor)."""
    site_offset: tuple[float, float, float] = (0.0, 0.0, 0.0)
    """The sensor's reference point off its place (m), the part unmoved."""
    fixture_mass: float = 0.0
    """An adapter mass (kg) on the sensor, 5 mm above its face."""
    servo_lag: float = 0.0
    """The servo's continuous first-order lag after the hold (s): the slide is driven
    towards x, ẋ = (u − x)/τ of the held command u (a valve or amplifier), x an activation
    of the servo's own actuator integrated with the physics at the physics step; 0: none."""
    closure: tuple[float, float] = (0.002, 1.0)
    """MuJoCo ``solref`` (time constant s, damping ratio) of the legs' tip-to-plate
    connections: how stiffly the bench's chain closes (the bench model's is 2 ms)."""
    integrator: str = "RK4"
    """MuJoCo's integrator of the bench's physics (another than the replay's: a bench the
    model cannot fully explain)."""
    frame_damping: float = 0.0
    """Viscous damping in every universal joint's hinges (N·m·s/rad): structural damping of
    the frame, which no effect of the library has."""
    valve_hz: float = 0.0
    valve_damping: float = 0.7
    """A servo-valve after the hold (Hz, damping ratio; 0 Hz: none): the servo's set-point is
    the valve's output y, ÿ + 2ζωẏ + ω²y = ω²u of the held command u, advanced exactly over
    each physics step (its transition matrix) and given to the servo as its mean over the
    step; at the end of an interface step, where the channels are sampled, the servo's
    set-point is the valve's output at that instant."""

    def with_(self, **kw) -> ForeignBench:
        return replace(self, **kw)

    # ------------------------------------------------------------------ MJCF
    def xml(self) -> str:
        b, p, h = np.asarray(self.base), np.asarray(self.top), self.home_height
        legs = []
        for i in range(6):
            v = p[i] + [0.0, 0.0, h] - b[i]
            L = float(np.linalg.norm(v))
            u = v / L
            # z axis onto u: the quaternion of the shortest rotation, via scipy
            ax = np.cross([0.0, 0.0, 1.0], u)
            s = float(np.linalg.norm(ax))
            q = (Rotation.from_rotvec(ax / s * math.atan2(s, u[2])).as_quat(scalar_first=True)
                 if s > 1e-15 else np.array([1.0, 0.0, 0.0, 0.0]))
            cl = 0.55 * L
            legs.append(f"""
    <body name="c{i}" pos="{b[i][0]} {b[i][1]} {b[i][2]}" quat="{q[0]} {q[1]} {q[2]} {q[3]}">
      <joint name="u{i}a" type="hinge" axis="1 0 0" damping="{self.frame_damping}"/>
      <joint name="u{i}b" type="hinge" axis="0 1 0" damping="{self.frame_damping}"/>
      <geom type="cylinder" size="0.02 {cl / 2}" pos="0 0 {cl / 2}" mass="{self.cylinder_mass}"
            contype="0" conaffinity="0"/>
      <body name="s{i}">
        <joint name="sl{i}" type="slide" axis="0 0 1" frictionloss="{self.friction[i]}"
               solreffriction="0.002 1" damping="{self.damping[i]}"/>
        <geom type="cylinder" size="0.012 {cl / 2}" pos="0 0 {L - cl / 2}"
              mass="{self.piston_mass}" contype="0" conaffinity="0"/>
        <site name="tip{i}" pos="0 0 {L}"/>
      </body>
    </body>""")
        fx, fy, fz, frx, fry, frz = self.fts_pose
        fq = Rotation.from_euler("xyz", [frx, fry, frz]).as_quat(scalar_first=True)
        ip, iq, ii = self.plate_ipos, self.plate_iquat, self.plate_inertia
        so = self.site_offset
        fixture = (f'<geom type="sphere" size="0.01" pos="0 0 0.005" mass="{self.fixture_mass}" '
                   'contype="0" conaffinity="0"/>' if self.fixture_mass else "")
        anchors = "\n".join(f'      <site name="a{i}" pos="{p[i][0]} {p[i][1]} {p[i][2]}"/>'
                            for i in range(6))
        conn = "\n".join(f'    <connect site1="tip{i}" site2="a{i}" '
                          f'solref="{self.closure[0]} {self.closure[1]}" '
                         f'solimp="0.99 0.999 0.0001"/>' for i in range(6))
        kps = [self.kp * s for s in self.kp_scale]
        dyn = (f'dyntype="filter" dynprm="{self.servo_lag!r}" ' if self.servo_lag > 0
               else "")
        acts = "\n".join(f'    <general name="servo{i}" joint="sl{i}" {dyn}gainprm="{kps[i]}" '
                         f'biastype="affine" biasprm="0 {-kps[i]} {-self.kv}"/>'
                         for i in range(6))
        return f"""<mujoco model="foreign_bench">
  <option timestep="{self.physics_dt}" integrator="{self.integrator}" gravity="0 0 -9.81"/>
  <worldbody>
{"".join(legs)}
    <body name="top" pos="0 0 {h}">
      <freejoint name="top_free"/>
      <inertial pos="{ip[0]} {ip[1]} {ip[2]}" quat="{iq[0]} {iq[1]} {iq[2]} {iq[3]}"
                mass="{self.plate_mass}" diaginertia="{ii[0]} {ii[1]} {ii[2]}"/>
{anchors}
      <body name="sensor_side" pos="{fx} {fy} {fz}" quat="{fq[0]} {fq[1]} {fq[2]} {fq[3]}">
        <site name="sensor" pos="{so[0]} {so[1]} {so[2]}"/>
        {fixture}
{self.part_xml}
      </body>
    </body>
{self.world_xml}
  </worldbody>
  <equality>
{conn}
  </equality>
  <actuator>
{acts}
  </actuator>
  <sensor>
    <force name="sf" site="sensor"/>
    <torque name="st" site="sensor"/>
  </sensor>
</mujoco>"""

    # ------------------------------------------------------------------ controller
    def _ik(self, pose: np.ndarray, base: np.ndarray, top: np.ndarray) -> np.ndarray:
        R = Rotation.from_euler("xyz", pose[3:]).as_matrix()
        t = pose[:3] + [0.0, 0.0, self.home_height]
        return np.linalg.norm(t + top @ R.T - base, axis=1)

    def run(self, poses: np.ndarray, *, noise: float = 1.0, seed: int = 0,
            settle: float = 0.4) -> dict[str, np.ndarray]:
        """Step the bench through commanded poses (N, 6) (row n + 1: the pose commanded at
        interface step n, the target for its end; row 0 home) and return the channels (N
        rows each, row 0: the rest state before the first step)."""
        model = mujoco.MjModel.from_xml_string(self.xml())
        data = mujoco.MjData(model)
        nsub = int(round(self.dt / self.physics_dt))
        slide = [model.jnt_qposadr[model.joint(f"sl{i}").id] for i in range(6)]
        slide_v = [model.jnt_dofadr[model.joint(f"sl{i}").id] for i in range(6)]
        fa = model.sensor_adr[model.sensor("sf").id]
        ta = model.sensor_adr[model.sensor("st").id]
        free = model.jnt_qposadr[model.joint("top_free").id]
        site = model.site("sensor").id
        base, top = np.asarray(self.base), np.asarray(self.top)
        cb = base if self.ctrl_base is None else np.asarray(self.ctrl_base)
        ct = top if self.ctrl_top is None else np.asarray(self.ctrl_top)
        true_home = self._ik(np.zeros(6), base, top)
        ctrl_home = self._ik(np.zeros(6), cb, ct)
        enc_off = np.asarray(self.encoder_offsets, dtype=float)
        # a leg commanded to encoder length E is driven until its encoder reads E: the slide
        # set-point is E − (true home length + encoder offset)
        shift = ctrl_home - true_home - enc_off

        valve = None
        if self.valve_hz > 0:
            # the valve's state (y, ẏ, ∫y, u) per leg over one physics step, u held: its
            # exact transition matrix; the servo gets the mean of y over the step
            w, zeta, h = 2 * math.pi * self.valve_hz, self.valve_damping, self.physics_dt
            A = np.array([[0.0, 1.0, 0.0, 0.0], [-w * w, -2 * zeta * w, 0.0, w * w],
                          [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]])
            valve = {"E": scipy.linalg.expm(A * h), "y": None, "yd": np.zeros(6), "h": h}

        def physics_step(u: np.ndarray) -> None:
            if valve is None:
                data.ctrl[:6] = u
            else:
                if valve["y"] is None:  # at rest on the first command
                    valve["y"] = np.array(u, dtype=float)
                st = np.stack([valve["y"], valve["yd"], np.zeros(6), u])
                st = valve["E"] @ st
                valve["y"], valve["yd"] = st[0], st[1]
                data.ctrl[:6] = st[2] / valve["h"]
            mujoco.mj_step(model, data)

        def advance(seconds: float, ctrl: np.ndarray) -> None:
            for _ in range(int(round(seconds / self.physics_dt))):
                physics_step(ctrl)

        # gravity compensation: let the bench settle on its servos, read the holding forces,
        # offset the set-points by force / kp, three times
        grav = np.zeros(6)
        for _ in range(3):
            advance(0.25, shift + grav)
            mujoco.mj_forward(model, data)
            grav = data.actuator_force[:6] / (self.kp * np.asarray(self.kp_scale))
        grav = grav * self.gravity_comp_scale
        data.qvel[:] = 0.0
        advance(settle, shift + grav)
        mujoco.mj_forward(model, data)

        N = poses.shape[0]
        rec = {k: np.zeros((N, 6)) for k in ("pose", "leg", "legf", "fts", "fw")}

        def sample(row: int) -> None:
            q = data.qpos[free:free + 7]
            rot = Rotation.from_quat(q[3:], scalar_first=True)
            rec["pose"][row, :3] = q[:3] - [0.0, 0.0, self.home_height]
            rec["pose"][row, 3:] = rot.as_euler("xyz")
            rec["leg"][row] = data.qpos[slide] + true_home + enc_off
            rec["legf"][row] = data.actuator_force[:6]
            w = np.r_[data.sensordata[fa:fa + 3], data.sensordata[ta:ta + 3]]
            if self.fts_matrix is not None or any(self.fts_offset):
                C = np.eye(6) if self.fts_matrix is None else np.asarray(self.fts_matrix)
                w = C @ w + np.asarray(self.fts_offset)
            rec["fts"][row] = w
            Rs = data.site_xmat[site].reshape(3, 3)
            rec["fw"][row] = np.r_[Rs @ w[:3], Rs @ w[3:]]

        sample(0)
        rest = {k: v[0].copy() for k, v in rec.items()}
        d = self.delay_samples
        extra = max(self.leg_delay)
        hist = [shift + grav] * (d + 1 + extra)
        tcs = np.asarray(self.leg_lag, dtype=float)
        lag = (shift + grav).copy() if np.any(tcs > 0) else None
        alpha = np.where(tcs > 0, 1.0 - np.exp(-self.dt / np.where(tcs > 0, tcs, 1.0)), 1.0)
        Lprev = ctrl_home.copy()
        c_prev = shift + grav
        ffg = self.kv / self.kp / self.dt if self.velocity_ff else 0.0
        ends: list[int] = []
        contacts = 0
        for k in range(N - 1):
            if self.sample == "start":
                sample(k + 1)  # the state at t_k, before the new set-point acts
            L = self._ik(poses[k + 1], cb, ct)
            c = L - ctrl_home + ffg * (L - Lprev) + shift + grav
            Lprev = L
            hist.append(c)
            cd = hist[-1 - d].copy()
            hist.pop(0)
            if extra:
                for i in range(6):
                    cd[i] = hist[-1 - d - self.leg_delay[i]][i]
            if lag is not None:
                lag[:] = lag + alpha * (cd - lag)
                cd = lag.copy()
            if self.hold == "zoh":
                advance(self.dt, cd)
            else:  # a ramp from the previous set-point, one value per physics step
                for j in range(1, nsub + 1):
                    physics_step(c_prev + (cd - c_prev) * (j - 0.5) / nsub)
                data.ctrl[:6] = cd
            c_prev = cd
            if valve is not None:  # the servo's set-point now: the valve's output
                data.ctrl[:6] = valve["y"]
            mujoco.mj_forward(model, data)
            contacts += data.ncon > 0
            if self.sample == "end":
                sample(k + 1)
            ends.append(k)
            if not np.all(np.isfinite(data.qpos)) or np.max(np.abs(data.qvel[slide_v])) > 5:
                raise RuntimeError(f"foreign bench diverged at step {k}")
        LAST_RUN["contact_fraction"] = contacts / max(N - 1, 1)
        rng = np.random.default_rng(seed)
        sp, sr = NOISE["pose"]
        out: dict[str, np.ndarray] = {}
        for j, dof in enumerate(DOFS):
            s = sp if j < 3 else sr
            out[f"pose_cmd.{dof}"] = poses[:, j].copy()
            out[f"pose_meas.{dof}"] = rec["pose"][:, j] + noise * s * rng.standard_normal(N)
            out[f"z_meas.{dof}"] = rec["pose"][:, j] - rest["pose"][j] + \
                noise * s * rng.standard_normal(N)
            sf = NOISE["force"] if j < 3 else NOISE["torque"]
            out[f"f_meas.{dof}"] = rec["fw"][:, j] - rest["fw"][j] + \
                noise * sf * rng.standard_normal(N)
        for i in range(6):
            out[f"leg_len.{i}"] = rec["leg"][:, i] + noise * NOISE["leg_len"] * \
                rng.standard_normal(N)
            out[f"leg_force.{i}"] = rec["legf"][:, i] - rest["legf"][i] + \
                noise * NOISE["leg_force"] * rng.standard_normal(N)
        for j, c in enumerate(WRENCH):
            sf = NOISE["force"] if j < 3 else NOISE["torque"]
            out[f"fts.{c}"] = rec["fts"][:, j] + noise * sf * rng.standard_normal(N)
        return out


def multisine(duration: float, dt: float = 1e-3, *, trans: float = 2.0e-3,
              rot: float = 0.012, axes: tuple[int, ...] = (0, 1, 2, 3, 4, 5),
              seed: int = 0, fade: float = 0.2) -> np.ndarray:
    """Commanded poses (N, 6): on each axis a sum of five sines (0.7–11 Hz, amplitudes
    falling as 1/√f so that the leg speeds stay well below their limit), faded in and out
    over ``fade`` seconds; row 0 at home."""
    rng = np.random.default_rng(seed)
    t = np.arange(int(round(duration / dt)) + 1) * dt
    env = np.clip(np.minimum(t, t[-1] - t) / fade, 0.0, 1.0)
    env = env * env * (3 - 2 * env)
    q = np.zeros((t.size, 6))
    for j in axes:
        amp = trans if j < 3 else rot
        fs = np.sort(rng.uniform(0.7, 11.0, 5))
        for f in fs:
            q[:, j] += amp / 2.5 / math.sqrt(f) * np.sin(2 * math.pi * f * t +
                                                          rng.uniform(0, 2 * math.pi))
    return q * env[:, None]


def plate_inertial(model) -> dict:
    """The plate's inertial (mass, ipos, iquat, diagonal inertia; the sensor housing
    included) as the description's model (a compiled ``MjModel`` with a body ``plate``)
    assumes it: the one property of the bench a scene cannot state."""
    b = model.body("plate").id
    return {"plate_mass": float(model.body_mass[b]),
            "plate_ipos": tuple(float(v) for v in model.body_ipos[b]),
            "plate_iquat": tuple(float(v) for v in model.body_iquat[b]),
            "plate_inertia": tuple(float(v) for v in model.body_inertia[b])}


def write_record(path: Path, channels: dict[str, np.ndarray], dt: float,
                 meta: dict | None = None) -> Path:
    """The channels as CSV (columns ``t`` and the channel names, SI units) with a
    ``<file>.meta.json`` (the interface step; no bench), as docs/records.md describes."""
    n = len(next(iter(channels.values())))
    names = ["t", *channels]
    data = np.column_stack([np.arange(n) * dt, *channels.values()])
    path = Path(path)
    np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt="%.17g")
    side = path.with_name(path.name + ".meta.json")
    side.write_text(json.dumps({"dt": dt, **(meta or {})}))
    return path
