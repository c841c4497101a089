"""Stepping the simulated platform at the interface rate: one test (fast path) or K at once.

:class:`PlatformSim` is what the vRTHS loop drives at 1 kHz: ``step(x, y, z, rx, ry, rz)``
takes the commanded pose (floats, relative to home), computes leg set-points (inverse
kinematics, gravity compensation, velocity feed-forward), advances MuJoCo by one interface
step and checks the safety limits. Reads (``pose``, ``leg_lengths``, ``leg_forces``,
``wrench``, ``interface_wrench``) are computed on demand from precomputed views.

:class:`PlatformBatch` does the same for K tests with ``mujoco.batch.Batch``.

Timing convention: MuJoCo evaluates sensors (and actuator forces) at the start of a physics
step, so after ``step`` the FTS wrench and leg forces describe the state one physics step
(``dt / substeps``) before the returned pose, like a sensor sampled before the plate moves.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import SafetyStop
from .kinematics import ScalarIK
from .model import PlatformConfig, build_model

__all__ = ["PlatformBatch", "PlatformSim", "StaticState", "static_state"]

_BADQACC = 5  # mujoco.mjtWarning.mjWARN_BADQACC
_MAXVAL = 1e10  # mjMAXVAL: MuJoCo flags |qacc| above this (or NaN) as a bad acceleration


@dataclass(frozen=True)
class StaticState:
    """Static equilibrium at home (computed at reset).

    Attributes
    ----------
    leg_forces:
        Actuator forces that hold the platform and payload at home (N), (6,).
    offsets:
        Gravity-compensation set-point offsets ``leg_forces / kp`` (m), (6,).
    preload:
        Static wrench of everything mounted on the FTS, as the plate exerts it, in world
        axes about the ``fts`` site origin: ``(0, 0, m g, τx, τy, 0)`` (N, N·m), (6,).
    payload_mass:
        Mass carried by the FTS (kg).
    """

    leg_forces: np.ndarray
    offsets: np.ndarray
    preload: np.ndarray
    payload_mass: float


class _Ids:
    """Indices into the MuJoCo arrays, resolved once by name."""

    def __init__(self, model) -> None:
        import mujoco

        self.slide_qpos = np.array([model.jnt_qposadr[model.joint(f"leg{i}_slide").id]
                                    for i in range(6)])
        self.slide_dof = np.array([model.jnt_dofadr[model.joint(f"leg{i}_slide").id]
                                   for i in range(6)])
        self.act = np.array([model.actuator(f"leg{i}").id for i in range(6)])
        free = model.joint("plate_free").id
        self.plate_qpos = int(model.jnt_qposadr[free])
        self.plate_dof = int(model.jnt_dofadr[free])
        self.plate_body = model.body("plate").id
        self.fts_body = model.body("fts_body").id
        self.fts_site = model.site("fts").id
        self.force_adr = int(model.sensor_adr[model.sensor("fts_force").id])
        self.torque_adr = int(model.sensor_adr[model.sensor("fts_torque").id])
        mech = []
        for i in range(6):
            for j in ("u1", "u2", "slide"):
                mech.append(int(model.jnt_dofadr[model.joint(f"leg{i}_{j}").id]))
        mech.extend(range(self.plate_dof, self.plate_dof + 6))
        self.mech_dof = np.array(mech)
        self.tip_site = [model.site(f"leg{i}_tip").id for i in range(6)]
        self.anchor_site = [model.site(f"plate_anchor{i}").id for i in range(6)]
        self.contiguous_slides = bool(np.all(np.diff(self.slide_qpos) ==
                                             self.slide_qpos[1] - self.slide_qpos[0]))
        del mujoco


def static_state(config: PlatformConfig, model, data, ids: _Ids | None = None) -> StaticState:
    """Solve the static equilibrium of the closed chain at the current (home) configuration.

    Unknowns: the six actuator forces and the 18 ``connect`` constraint forces; equations:
    generalised force balance ``Sᵀ f + J_eqᵀ λ = qfrc_bias`` on the 24 mechanism DOFs (legs
    and plate) at rest, where ``qfrc_bias`` holds the gravity of the plate *and* of everything
    mounted on it. Exact for a payload at rest.
    """
    import mujoco

    ids = ids or _Ids(model)
    data.qvel[:] = 0.0
    mujoco.mj_forward(model, data)
    nv = model.nv
    jeq = []
    jp = np.zeros((3, nv))
    for tip, anc in zip(ids.tip_site, ids.anchor_site, strict=True):
        mujoco.mj_jacSite(model, data, jp, None, tip)
        j1 = jp.copy()
        mujoco.mj_jacSite(model, data, jp, None, anc)
        jeq.append(j1 - jp)
    jeq = np.concatenate(jeq)  # (18, nv)
    D = ids.mech_dof
    S = np.zeros((len(D), 6))
    for i, dof in enumerate(ids.slide_dof):
        S[np.flatnonzero(D == dof)[0], i] = 1.0
    A = np.concatenate([S, jeq[:, D].T], axis=1)
    sol, *_ = np.linalg.lstsq(A, data.qfrc_bias[D].copy(), rcond=None)
    f = sol[:6]
    mass = float(model.body_subtreemass[ids.fts_body])
    g = -float(model.opt.gravity[2])
    fw = np.array([0.0, 0.0, mass * g])
    r = data.subtree_com[ids.fts_body] - data.site_xpos[ids.fts_site]
    pre = np.concatenate([fw, np.cross(r, fw)])
    kp = model.actuator_gainprm[ids.act, 0]  # per-model gains (a batch may expand them)
    return StaticState(leg_forces=f, offsets=f / kp, preload=pre, payload_mass=mass)


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


def _make_step(sim: PlatformSim):
    """Generate the unrolled 1 kHz step function of ``sim`` (its constants baked in).

    Plain-Python arithmetic on floats with the geometry as literals is the cheapest way to do
    inverse kinematics, limit checks and the set-point in CPython (small-array numpy costs
    several µs per call); the function is regenerated at every reset, when the
    gravity-compensation offsets change.
    """
    import mujoco

    g = sim.config.geometry
    b = g.base_anchors()
    p = g.top_anchors()
    home = sim._home
    off = sim._off
    dt = sim._dt
    lines = [
        "def step(x, y, z, rx, ry, rz):",
        "    cx = cos(rx); sx = sin(rx); cy = cos(ry); sy = sin(ry); cz = cos(rz); sz = sin(rz)",
        "    r00 = cz * cy; r01 = cz * sy * sx - sz * cx",
        "    r10 = sz * cy; r11 = sz * sy * sx + cz * cx",
        "    r20 = -sy; r21 = cy * sx",
        f"    tz = z + {g.home_height!r}",
    ]
    planar = not np.any(p[:, 2] != 0)
    if not planar:  # top anchors off the plate plane (a calibrated geometry)
        lines.append("    r02 = cz * sy * cx + sz * sx; r12 = sz * sy * cx - cz * sx; "
                     "r22 = cy * cx")
    for i in range(6):
        px, py, pz = float(p[i, 0]), float(p[i, 1]), float(p[i, 2])
        bx, by, bz = (float(v) for v in b[i])
        zx, zy, zz = ("", "", "") if planar else (
            f" + r02 * {pz!r}", f" + r12 * {pz!r}", f" + r22 * {pz!r}")
        lines += [
            f"    lx = x + r00 * {px!r} + r01 * {py!r}{zx} - {bx!r}",
            f"    ly = y + r10 * {px!r} + r11 * {py!r}{zy} - {by!r}",
            f"    lz = tz + r20 * {px!r} + r21 * {py!r}{zz} - {bz!r}",
            f"    L{i} = sqrt(lx * lx + ly * ly + lz * lz)",
        ]
    lines.append("    p0, p1, p2, p3, p4, p5 = prev")
    lines += [f"    d{i} = L{i} - p{i}" for i in range(6)]
    lo = [h - sim._smax for h in home]
    hi = [h + sim._smax for h in home]
    vd = sim._vmax * dt
    conds = " and ".join(f"{lo[i]!r} <= L{i} <= {hi[i]!r} and {-vd!r} <= d{i} <= {vd!r}"
                         for i in range(6))
    lines += [
        f"    if not ({conds}):",
        "        check_command((L0, L1, L2, L3, L4, L5))",
        "    ctrl[:] = (" + ", ".join(
            f"L{i} - {home[i] - off[i]!r} + {sim._ffg!r} * d{i}" for i in range(6)) + ")",
        "    prev[:] = lcmd[:] = (L0, L1, L2, L3, L4, L5)",
        "    mj_step(model, data, nsub)",
        "    count[0] += 1",
        "    if warn.number != count[1]:",
        "        divergence()",
        "    q0, q1, q2, q3, q4, q5 = slide_q.tolist()",
        "    v0, v1, v2, v3, v4, v5 = slide_v.tolist()",
        "    f0, f1, f2, f3, f4, f5 = force.tolist()",
        # chained comparisons on floats: ~3x cheaper than max()/min() over lists
        "    if not (" + " and ".join(
            f"{-lim!r} <= {v}{i} <= {lim!r}"
            for v, lim in (("q", sim._smax), ("v", sim._vmax), ("f", sim._fmax))
            for i in range(6)) + "):",
        "        check_measured(slide_q.tolist(), slide_v.tolist(), force.tolist())",
    ]
    env = {
        "cos": math.cos, "sin": math.sin, "sqrt": math.sqrt, "prev": sim._Lprev,
        "lcmd": sim._lcmd, "ctrl": sim._ctrl, "mj_step": mujoco.mj_step, "model": sim.model,
        "data": sim.data, "nsub": sim._nsub, "count": sim._count, "warn": sim._warn,
        "slide_q": sim._slide_q, "slide_v": sim._slide_v, "force": sim._force,
        "check_command": sim._check_command, "check_measured": sim._check_measured,
        "divergence": sim._divergence,
    }
    exec(compile("\n".join(lines), "<rths3d.platform.sim step>", "exec"), env)
    return env["step"]


class PlatformSim:
    """One simulated platform stepped at the interface rate ΔT = ``config.dt``.

    Parameters
    ----------
    config:
        Platform configuration (geometry, actuators, step).
    payload_xml, world_xml:
        MJCF fragments: the experimental part on the FTS, extra world bodies.
    settle:
        Simulated time (s) held at home during :meth:`reset` so the chain and the payload
        settle before the test starts.

    After ``reset()``, call ``step(x, y, z, rx, ry, rz)`` once per ΔT with the commanded pose
    (m, rad, relative to home). ``step`` raises :class:`~rths3d.errors.SafetyStop` when a
    commanded leg leaves its stroke or speed limit (before stepping), when a measured leg
    leaves its stroke, speed or force limit, or when MuJoCo reports a bad acceleration
    (divergence; MuJoCo would otherwise silently reset the state). The stop's time ``t`` is
    the time the offending step's command was meant for (``(k + 1)·ΔT`` for step k, as in
    the records of :func:`~rths3d.platform.tracking.track`). A stopped platform stays
    stopped, as a bench would: ``stopped_by`` holds the stop and every later ``step`` raises
    it again until :meth:`reset`.
    """

    def __init__(self, config: PlatformConfig | None = None, payload_xml: str | None = None,
                 world_xml: str | None = None, settle: float = 0.05):
        import mujoco

        self.config = config = config or PlatformConfig()
        self.model = build_model(config, payload_xml, world_xml)
        self.data = mujoco.MjData(self.model)
        self.ids = _Ids(self.model)
        self._mj_step = mujoco.mj_step
        self.settle = float(settle)
        g = config.geometry
        self._ik = ScalarIK(g).ik
        self._home = tuple(float(v) for v in g.home_leg_lengths())
        self._h = float(g.home_height)
        self._dt = float(config.dt)
        self._nsub = int(config.substeps)
        a = config.actuator
        self._ffg = (a.kv / a.kp / config.dt) if a.velocity_ff else 0.0
        half = config.stroke / 2
        self._smax = half
        self._vmax = float(config.velocity_limit)
        self._fmax = float(config.force_limit)
        d = self.data
        ids = self.ids
        # precomputed views (no name lookups per step)
        a0 = int(ids.act[0])
        if list(ids.act) != list(range(a0, a0 + 6)):  # pragma: no cover - generated model
            raise RuntimeError("leg actuators are not contiguous")
        self._ctrl = d.ctrl[a0:a0 + 6]
        self._qpos = d.qpos
        q0 = ids.slide_qpos[0]
        stride = int(ids.slide_qpos[1] - q0)
        if ids.contiguous_slides:
            self._slide_q = d.qpos[q0:q0 + 5 * stride + 1:stride]
            v0 = ids.slide_dof[0]
            vs = int(ids.slide_dof[1] - v0)
            self._slide_v = d.qvel[v0:v0 + 5 * vs + 1:vs]
        else:  # pragma: no cover - the generated model always orders legs this way
            raise RuntimeError("leg slide joints are not evenly spaced in qpos")
        a0 = int(ids.act[0])
        self._force = d.actuator_force[a0:a0 + 6]
        pq = ids.plate_qpos
        self._plate_q = d.qpos[pq:pq + 7]
        self._sens = d.sensordata[ids.force_adr:ids.force_adr + 3]
        self._sens_t = d.sensordata[ids.torque_adr:ids.torque_adr + 3]
        self._site_xmat = d.site_xmat[ids.fts_site]
        self._warn = d.warning[_BADQACC]
        self.static: StaticState | None = None
        self.stopped_by: SafetyStop | None = None
        """The SafetyStop that stopped the platform (``step`` raises it again), or None."""
        self.reset()

    # ------------------------------------------------------------------ setup
    def reset(self) -> None:
        """Home pose, static equilibrium with gravity compensation, settle; ``t = 0``."""
        import mujoco

        m, d = self.model, self.data
        mujoco.mj_resetData(m, d)
        st = static_state(self.config, m, d, self.ids)
        self.static = st
        off = st.offsets if self.config.actuator.gravity_comp else np.zeros(6)
        self._off = tuple(float(v) for v in off)
        for i, a in enumerate(self.ids.act):
            d.ctrl[a] = off[i]
            adr = m.actuator_actadr[a]
            if adr >= 0:
                d.act[adr] = off[i]
            if m.actuator_history[a, 0] > 0:
                n = int(m.actuator_history[a, 0])
                mujoco.mj_initCtrlHistory(m, d, int(a), None, np.full((n, 1), off[i]))
        self._pre = tuple(float(v) for v in st.preload)
        self._Lprev = list(self._home)
        self._lcmd = list(self._home)
        self._count = [0, self._warn.number]
        self.stopped_by = None
        self._step = self.step = _make_step(self)
        nset = int(round(self.settle / self.config.timestep))
        for _ in range(nset):
            mujoco.mj_step(m, d)
        if not nset:  # forces and sensors of the compensated state (a step computes them)
            mujoco.mj_forward(m, d)
        if self._warn.number != self._count[1]:
            stop = SafetyStop(f"divergence (MuJoCo bad acceleration at DOF "
                              f"{self._warn.lastinfo}) while settling at home, |qacc|",
                              math.inf, _MAXVAL, 0.0)
            self._halt(stop)
            raise stop

    # ------------------------------------------------------------------ hot path
    @property
    def t(self) -> float:
        """Simulated test time (s) since reset (interface steps × ΔT)."""
        return self._count[0] * self._dt

    def step(self, x: float, y: float, z: float, rx: float, ry: float, rz: float) -> None:
        """Command the pose (m, rad, relative to home) for one interface step ΔT.

        Replaced per instance by a generated, fully unrolled function (see :func:`_make_step`)
        at :meth:`reset`; this method documents the interface.
        """
        self._step(x, y, z, rx, ry, rz)

    def _stop(self, quantity: str, value: float, limit: float, unit: str,
              ahead: int = 0) -> None:
        stop = SafetyStop(quantity, value, limit, (self._count[0] + ahead) * self._dt, unit=unit)
        self._halt(stop)
        raise stop

    def _halt(self, stop: SafetyStop) -> None:
        """Keep the platform stopped: every later ``step`` raises ``stop`` again until reset.

        NaN previous leg lengths fail the step's speed check, which sends it to
        :meth:`_check_command` (no cost on the running path)."""
        self.stopped_by = stop
        self._Lprev[:] = [math.nan] * 6

    def _check_command(self, L: tuple) -> None:
        """Raise the SafetyStop for the first commanded leg outside stroke or speed."""
        if self.stopped_by is not None:
            s = self.stopped_by
            raise SafetyStop(s.quantity, s.value, s.limit, s.t, s.test, s.unit)
        dt = self._dt
        for i, Li in enumerate(L):
            s = Li - self._home[i]
            # `not <=`: a NaN command (a diverged or broken source) stops like an overrun
            if not abs(s) <= self._smax:
                self._stop(f"leg {i} commanded stroke", s, self._smax, "m", ahead=1)
            v = (Li - self._Lprev[i]) / dt
            if not abs(v) <= self._vmax:
                self._stop(f"leg {i} commanded velocity", v, self._vmax, "m/s", ahead=1)
        raise AssertionError("unreachable: command check found no violation")  # pragma: no cover

    def _check_measured(self, q: list, v: list, f: list) -> None:
        """Raise the SafetyStop for the first leg (then stroke, speed, force) out of limits."""
        for i in range(6):
            for name, vals, lim, unit in (("stroke", q, self._smax, "m"),
                                          ("velocity", v, self._vmax, "m/s"),
                                          ("force", f, self._fmax, "N")):
                if abs(vals[i]) > lim:
                    self._stop(f"leg {i} {name}", vals[i], lim, unit)

    # ------------------------------------------------------------------ reads
    @property
    def pose(self) -> tuple[float, float, float, float, float, float]:
        """Achieved plate pose relative to home (m, rad), from the plate body's state."""
        px, py, pz, w, qx, qy, qz = self._plate_q.tolist()
        rx, ry, rz = _quat_to_euler(w, qx, qy, qz)
        return px, py, pz - self._h, rx, ry, rz

    @property
    def leg_lengths(self) -> tuple[float, ...]:
        """Achieved leg lengths (m): home length + piston extension."""
        h = self._home
        return tuple(h[i] + s for i, s in enumerate(self._slide_q.tolist()))

    @property
    def leg_commands(self) -> tuple[float, ...]:
        """Leg lengths (m) commanded by the last step (inverse kinematics of the pose)."""
        return tuple(self._lcmd)

    def _divergence(self) -> None:
        self._count[1] = self._warn.number
        self._stop(f"divergence (MuJoCo bad acceleration at DOF {self._warn.lastinfo}, "
                   "state was reset) |qacc|", math.inf, _MAXVAL, "")

    @property
    def leg_forces(self) -> tuple[float, ...]:
        """Actuator forces (N), positive pushing the plate away from the base."""
        return tuple(self._force.tolist())

    @property
    def wrench(self) -> tuple[float, ...]:
        """Raw FTS wrench ``(fx, fy, fz, tx, ty, tz)`` in the ``fts`` site frame (N, N·m).

        The force and torque the plate exerts on the sensor's tool side and everything
        mounted on it (payload weight included), torque about the site origin.
        """
        return tuple(self._sens.tolist()) + tuple(self._sens_t.tolist())

    @property
    def interface_wrench(self) -> tuple[float, ...]:
        """Restoring wrench ``f_meas`` of the experimental part (N, N·m), 6 floats.

        World axes, static preload (payload weight at home) removed: the force the platform
        exerts on the specimen, so a positive value resists a positive displacement
        (docs/architecture.md). Torque about the ``fts`` site origin.
        """
        fx, fy, fz = self._sens.tolist()
        tx, ty, tz = self._sens_t.tolist()
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = self._site_xmat.tolist()
        p = self._pre
        return (r0 * fx + r1 * fy + r2 * fz - p[0],
                r3 * fx + r4 * fy + r5 * fz - p[1],
                r6 * fx + r7 * fy + r8 * fz - p[2],
                r0 * tx + r1 * ty + r2 * tz - p[3],
                r3 * tx + r4 * ty + r5 * tz - p[4],
                r6 * tx + r7 * ty + r8 * tz - p[5])

    def equality_gap(self) -> float:
        """Largest distance between a leg tip and its plate anchor (m)."""
        import mujoco

        mujoco.mj_kinematics(self.model, self.data)
        x = self.data.site_xpos
        return float(max(np.linalg.norm(x[a] - x[b]) for a, b in
                         zip(self.ids.tip_site, self.ids.anchor_site, strict=True)))


class PlatformBatch:
    """K platforms (one model, per-test parameters) stepped together with ``mujoco.batch``.

    ``step(poses)`` takes commanded poses (K, 6) (m, rad, relative to home). A test that
    leaves a limit is frozen at its last safe state (its commands no longer change) and
    flagged: ``stopped[k]`` is True and ``reasons[k]`` holds the :class:`SafetyStop`
    message; the other tests go on. Reads are arrays: ``pose`` (K, 6), ``leg_lengths``
    (K, 6), ``leg_forces`` (K, 6), ``wrench`` (K, 6) and ``interface_wrench`` (K, 6).

    Per-test model parameters: ``batch.batch.expand(field)`` (see
    ``mujoco.batch.Batch.expand``), e.g. payload masses through
    ``batch.batch.body(name).mass = masses[:, None]`` (with ``.inertia`` scaled alike: a
    heavier payload of one shape); then call ``reset(set_const=True)`` so that the static
    equilibrium (gravity compensation, FTS preload) follows. ``variants`` (one
    ``(config, payload_xml, world_xml)`` per test, one model structure) run each test on its
    own compiled model; a payload or world of another structure raises ConfigError.
    """

    def __init__(self, config: PlatformConfig | None = None, nsim: int = 1, nthread: int = 0,
                 payload_xml: str | None = None, world_xml: str | None = None,
                 settle: float = 0.05, *,
                 variants: Sequence[tuple[PlatformConfig, str | None, str | None]] | None = None):
        import mujoco
        from mujoco.batch import Batch

        from ..errors import ConfigError

        if not (isinstance(nsim, int) and nsim >= 1):
            raise ConfigError("nsim", nsim, "must be an integer >= 1")
        if variants is not None:
            # per-test (config, payload, world): one model structure, per-test parameters
            if len(variants) != nsim:
                raise ConfigError("variants", len(variants), f"need one per test ({nsim})")
            config = variants[0][0]
            shared = ("geometry", "dt", "substeps", "stroke", "velocity_limit", "force_limit")
            for cfg_k, _, _ in variants:
                for name in shared:
                    if getattr(cfg_k, name) != getattr(config, name):
                        raise ConfigError(f"platform.{name}", getattr(cfg_k, name),
                                          "must be the same for tests stepped together")
                if (cfg_k.actuator.delay, cfg_k.actuator.timeconst > 0) != \
                        (config.actuator.delay, config.actuator.timeconst > 0):
                    raise ConfigError("platform.actuator", cfg_k.actuator,
                                      "delay and lag (on/off) must match for tests stepped "
                                      "together (they change the model's structure)")
            payload_xml, world_xml = variants[0][1], variants[0][2]
        self.config = config = config or PlatformConfig()
        self.model = build_model(config, payload_xml, world_xml)
        self.nsim = nsim
        self.ids = _Ids(self.model)
        self.settle = float(settle)
        self.batch = Batch(self.model, nsim, nthread)
        self._cfgs = [config] * nsim
        if variants is not None and len(set(variants)) > 1:
            compiled: dict = {variants[0]: self.model}
            for v in variants:
                if v not in compiled:
                    compiled[v] = build_model(*v)
            try:
                self.batch.set_models([compiled[v] for v in variants])
            except (ValueError, mujoco.FatalError) as exc:
                # FatalError: a payload or world of another structure (bodies, joints, ...)
                raise ConfigError("variants", None, "", message="variants: tests stepped "
                                  "together need one model structure (the same payload and "
                                  f"world bodies, joints and sensors): {exc}") from exc
            self._cfgs = [v[0] for v in variants]
        self._ctrl = self.batch.bind("ctrl")
        self._qpos = self.batch.bind("qpos")
        self._qvel = self.batch.bind("qvel")
        self._sensor = self.batch.bind("sensordata")
        self._force = self.batch.bind("actuator_force")
        self._xmat = self.batch.bind("site_xmat")
        self._time = self.batch.bind("time")
        self._mujoco = mujoco
        g = config.geometry
        self._home = g.home_leg_lengths()
        from .kinematics import inverse_kinematics

        self._inverse_kinematics = inverse_kinematics
        self._half = config.stroke / 2
        self._vmax = float(config.velocity_limit)
        self._vdt = self._vmax * config.dt
        self._fmax = float(config.force_limit)
        # velocity feed-forward gain per test (K, 1)
        self._ffg = np.array([[(c.actuator.kv / c.actuator.kp / c.dt)
                               if c.actuator.velocity_ff else 0.0] for c in self._cfgs])
        if not self._ffg.any():
            self._ffg = 0.0
        ids = self.ids
        a0 = int(ids.act[0])
        self._act_slice = (a0, a0 + 6)
        qs = int(ids.slide_qpos[1] - ids.slide_qpos[0])
        self._q_slice = (int(ids.slide_qpos[0]), int(ids.slide_qpos[-1]) + 1, qs)
        vs = int(ids.slide_dof[1] - ids.slide_dof[0])
        self._v_slice = (int(ids.slide_dof[0]), int(ids.slide_dof[-1]) + 1, vs)
        self._any_stopped = False
        # anchors precomputed for the per-step inverse kinematics over tests
        self._b = g.base_anchors()
        self._p = g.top_anchors()
        self._pz = self._p[:, 2].copy() if np.any(self._p[:, 2] != 0) else None
        self._hh = float(g.home_height)
        # pure translation (R = I): leg vector = q_xyz + (p − b) + [0, 0, h_home]
        self._a = (self._p - self._b) + np.array([0.0, 0.0, self._hh])
        pa = self.ids.plate_qpos
        self.plate_qpos = self._qpos[:, pa:pa + 7]
        """Live (K, 7) view of the plate's free-joint qpos (position m, quaternion wxyz)."""
        fa = self.ids.force_adr
        self._fts_force = self._sensor[:, fa:fa + 3]
        self._fts_R = self._xmat[:, self.ids.fts_site].reshape(nsim, 3, 3)
        self.stopped = np.zeros(nsim, dtype=bool)
        self.reasons = [""] * nsim
        self.stop_time = np.full(nsim, np.nan)
        self.k = 0
        self.reset()

    def reset(self, set_const: bool = False) -> None:
        """All tests to home with gravity compensation; clears stop flags; ``t = 0``.

        ``set_const=True`` first recomputes MuJoCo's derived constants per test (needed after
        changing masses or inertias, e.g. ``batch.batch.body("payload").mass = m[:, None]``);
        with ``variants`` it recomputes them on each test's own model (``batch.batch.models``).
        """
        mujoco = self._mujoco
        if set_const:
            models = self.batch.models
            if models is None:
                self.batch.set_const()
            else:  # caller models: the batch refuses set_const, so run it per model
                models = [models] * self.nsim if isinstance(models, mujoco.MjModel) \
                    else list(models)
                for mk in {id(mk): mk for mk in models}.values():
                    mujoco.mj_setConst(mk, mujoco.MjData(mk))
                self.batch.set_models(models)
        m = self.model
        cfg = self.config
        offs = np.zeros((self.nsim, 6))
        pre = np.zeros((self.nsim, 6))
        d = mujoco.MjData(m)
        state_fields = {}
        for k in range(self.nsim):
            mk = self.batch.get_model(k)
            mujoco.mj_resetData(mk, d)
            st = static_state(self._cfgs[k], mk, d, self.ids)
            if self._cfgs[k].actuator.gravity_comp:
                offs[k] = st.offsets
            pre[k] = st.preload
            d.ctrl[self.ids.act] = offs[k]
            for i, a in enumerate(self.ids.act):
                adr = mk.actuator_actadr[a]
                if adr >= 0:
                    d.act[adr] = offs[k, i]
                if mk.actuator_history[a, 0] > 0:
                    n = int(mk.actuator_history[a, 0])
                    mujoco.mj_initCtrlHistory(mk, d, int(a), None, np.full((n, 1), offs[k, i]))
            for name in ("qpos", "qvel", "act", "ctrl", "history"):
                arr = getattr(d, name)
                if arr.size:
                    state_fields.setdefault(name, np.zeros((self.nsim,) + arr.shape))[k] = arr
        self._time[:] = 0.0
        for name, arr in state_fields.items():
            self.batch.bind(name)[:] = arr
        self._off = offs
        self._pre = pre
        self._Lprev = np.tile(self._home, (self.nsim, 1))
        self.stopped[:] = False
        self._any_stopped = False
        self.reasons = [""] * self.nsim
        self.stop_time[:] = np.nan
        nset = int(round(self.settle / cfg.timestep))
        self._t0 = nset * cfg.timestep
        if nset:
            self.batch.step(nstep=nset)
        else:  # forces and sensors of the compensated state (a step computes them)
            self.batch.forward()
        self.k = 0
        self._check_status(settling=True)

    @property
    def t(self) -> float:
        """Simulated test time (s) since reset."""
        return self.k * self.config.dt

    def _ik(self, q: np.ndarray) -> np.ndarray:
        """Leg lengths (K, 6) of poses (K, 6): the kinematics of ``inverse_kinematics``
        with the anchors precomputed (the third column of R only for non-planar top anchors)."""
        cx, sx = np.cos(q[:, 3:4]), np.sin(q[:, 3:4])
        cy, sy = np.cos(q[:, 4:5]), np.sin(q[:, 4:5])
        cz, sz = np.cos(q[:, 5:6]), np.sin(q[:, 5:6])
        px, py = self._p[:, 0], self._p[:, 1]
        b = self._b
        lx = q[:, 0:1] + (cz * cy) * px + (cz * sy * sx - sz * cx) * py - b[:, 0]
        ly = q[:, 1:2] + (sz * cy) * px + (sz * sy * sx + cz * cx) * py - b[:, 1]
        lz = (q[:, 2:3] + self._hh) - sy * px + (cy * sx) * py - b[:, 2]
        if self._pz is not None:  # top anchors off the plate plane (a calibrated geometry)
            pz = self._pz
            lx = lx + (cz * sy * cx + sz * sx) * pz
            ly = ly + (sz * sy * cx - cz * sx) * pz
            lz = lz + (cy * cx) * pz
        return np.sqrt(lx * lx + ly * ly + lz * lz)

    def _ik_translation(self, q: np.ndarray) -> np.ndarray:
        """Leg lengths (K, 6) of pure translations (rotation columns of ``q`` ignored)."""
        a = self._a
        lx = q[:, 0:1] + a[:, 0]
        ly = q[:, 1:2] + a[:, 1]
        lz = q[:, 2:3] + a[:, 2]
        return np.sqrt(lx * lx + ly * ly + lz * lz)

    def _freeze(self, k: int, stop: SafetyStop) -> None:
        if not self.stopped[k]:
            self._any_stopped = True
            self.stopped[k] = True
            self.reasons[k] = stop.reason
            self.stop_time[k] = stop.t

    def _check_status(self, settling: bool = False) -> None:
        """Flag tests whose simulation failed or diverged.

        MuJoCo resets a simulation whose acceleration blows up (bad-acceleration warning)
        and carries on from time 0; the batch does not expose the warning counters, so a
        simulation time behind the expected one is the signature of that reset.
        """
        expected = self._t0 + self.k * self.config.dt - 0.5 * self.config.timestep
        status = self.batch.status
        if self._time.min() >= expected and not status.any():
            return
        bad = ((self._time < expected) | (status != 0)) & ~self.stopped
        if bad.any():
            for k in np.flatnonzero(bad):
                msg = self.batch.error(int(k)).strip()
                what = msg or "MuJoCo bad acceleration, state was reset"
                self._freeze(int(k), SafetyStop(f"divergence ({what}) |qacc|", math.inf,
                                                _MAXVAL, 0.0 if settling else self.t,
                                                test=int(k)))

    def step(self, poses: np.ndarray, translation_only: bool = False) -> None:
        """Command poses (K, 6) (m, rad, relative to home) for one interface step ΔT.

        ``translation_only``: the caller guarantees rx = ry = rz = 0 (an interface without
        rotational DOFs), so the inverse kinematics skips the rotation.
        """
        cfg = self.config
        poses = np.asarray(poses, dtype=float)
        if poses.shape != (self.nsim, 6):
            from ..errors import ConfigError

            raise ConfigError("poses", f"array of shape {poses.shape}",
                              f"need ({self.nsim}, 6)")
        L = self._ik_translation(poses) if translation_only else self._ik(poses)
        s = L - self._home
        dL = L - self._Lprev
        half, vdt = self._half, self._vdt
        # cheap whole-batch test first; per-test bookkeeping only when something is off
        if np.abs(s).max() > half or np.abs(dL).max() > vdt:
            self._command_limits(s, dL)
        cmd = s + self._off + self._ffg * dL
        a0, a1 = self._act_slice
        if not self._any_stopped:
            self._ctrl[:, a0:a1] = cmd
            self._Lprev[:] = L
            self.batch.step(nstep=cfg.substeps)
        else:
            # stopped tests hold their last set-point and are not stepped any more
            run = ~self.stopped
            self._ctrl[run, a0:a1] = cmd[run]
            self._Lprev[run] = L[run]
            if run.any():
                self.batch.step(ids=np.flatnonzero(run), nstep=cfg.substeps)
        self.k += 1
        self._check_status()
        q0, q1, qs = self._q_slice
        v0, v1, vs = self._v_slice
        q = self._qpos[:, q0:q1:qs]
        v = self._qvel[:, v0:v1:vs]
        f = self._force[:, a0:a1]
        if np.abs(q).max() > half or np.abs(v).max() > self._vmax or \
                np.abs(f).max() > self._fmax:
            self._measured_limits(q, v, f)

    def _command_limits(self, s: np.ndarray, dL: np.ndarray) -> None:
        """Freeze the running tests whose command leaves stroke or speed (before the step)."""
        dt = self.config.dt
        half, vdt = self._half, self._vdt
        t_next = (self.k + 1) * dt
        bad = ((np.abs(s) > half) | (np.abs(dL) > vdt)) & ~self.stopped[:, None]
        for k in np.flatnonzero(bad.any(axis=1)):
            i = int(np.flatnonzero(bad[k])[0])
            if abs(s[k, i]) > half:
                stop = SafetyStop(f"leg {i} commanded stroke", s[k, i], half, t_next,
                                  test=int(k), unit="m")
            else:
                stop = SafetyStop(f"leg {i} commanded velocity", dL[k, i] / dt, self._vmax,
                                  t_next, test=int(k), unit="m/s")
            self._freeze(int(k), stop)

    def _measured_limits(self, q: np.ndarray, v: np.ndarray, f: np.ndarray) -> None:
        """Freeze the running tests whose measured stroke, speed or force is out of limits."""
        over = ((np.abs(q) > self._half) | (np.abs(v) > self._vmax) |
                (np.abs(f) > self._fmax)) & ~self.stopped[:, None]
        for k in np.flatnonzero(over.any(axis=1)):
            i = int(np.flatnonzero(over[k])[0])
            for name, arr, lim, unit in (("stroke", q, self._half, "m"),
                                         ("velocity", v, self._vmax, "m/s"),
                                         ("force", f, self._fmax, "N")):
                if abs(arr[k, i]) > lim:
                    self._freeze(int(k), SafetyStop(f"leg {i} {name}", arr[k, i], lim,
                                                    self.t, test=int(k), unit=unit))
                    break

    # ------------------------------------------------------------------ reads
    @property
    def pose(self) -> np.ndarray:
        """Achieved plate poses relative to home (K, 6), m and rad."""
        return plate_pose(self.plate_qpos, self._hh)

    @property
    def leg_lengths(self) -> np.ndarray:
        """Achieved leg lengths (K, 6), m."""
        return self._home + self._qpos[:, self.ids.slide_qpos]

    @property
    def leg_forces(self) -> np.ndarray:
        """Actuator forces (K, 6), N."""
        return self._force[:, self.ids.act].copy()

    @property
    def wrench(self) -> np.ndarray:
        """Raw FTS wrench (K, 6) in the site frame (N, N·m); see :attr:`PlatformSim.wrench`."""
        ids = self.ids
        return np.concatenate([self._sensor[:, ids.force_adr:ids.force_adr + 3],
                               self._sensor[:, ids.torque_adr:ids.torque_adr + 3]], axis=1)

    @property
    def interface_wrench(self) -> np.ndarray:
        """Restoring wrench ``f_meas`` (K, 6): world axes, static preload removed (N, N·m)."""
        R = self._xmat[:, self.ids.fts_site].reshape(self.nsim, 3, 3)
        w = self.wrench
        out = np.empty((self.nsim, 6))
        out[:, :3] = np.einsum("kij,kj->ki", R, w[:, :3])
        out[:, 3:] = np.einsum("kij,kj->ki", R, w[:, 3:])
        return out - self._pre

    def interface_force(self, rows: np.ndarray) -> np.ndarray:
        """Translational rows ``rows`` (axes 0–2) of :attr:`interface_wrench`, (K, len(rows)).

        The same world-axis force with the preload removed, without the torque rotation (the
        hot path of interfaces that use only translations).
        """
        return (self._fts_R[:, rows, :] @ self._fts_force[:, :, None])[:, :, 0] \
            - self._pre[:, rows]
