"""MuJoCo behind the platform: the resolved ids, the static equilibrium at home, and the
steppers of one ``MjData`` (K = 1) or of a ``mujoco.batch.Batch`` (K > 1)."""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import mujoco.batch
import numpy as np

from .model import PlatformConfig

__all__ = ["StaticState", "assemble", "static_state"]

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
        self.slide_qpos = np.array([model.jnt_qposadr[model.joint(f"leg{i}_slide").id]
                                    for i in range(6)])
        self.slide_dof = np.array([model.jnt_dofadr[model.joint(f"leg{i}_slide").id]
                                   for i in range(6)])
        self.act = np.array([model.actuator(f"leg{i}").id for i in range(6)])
        names = {model.actuator(j).name for j in range(model.nu)}
        self.lag_act = np.array([model.actuator(f"leg{i}_lag").id for i in range(6)
                                 if f"leg{i}_lag" in names], dtype=np.int64)
        """The servo-lag actuators (``lag = "servo"``), empty without."""
        valve = "leg0_valve" in names
        self.valve_act = np.array([model.actuator(f"leg{i}_valve").id for i in range(6)]
                                  if valve else [], dtype=np.int64)
        """The servo-valve's stiffness actuators (``valve_hz`` > 0), empty without."""
        self.spool_qpos = np.array([model.jnt_qposadr[model.joint(f"leg{i}_spool").id]
                                    for i in range(6)] if valve else [], dtype=np.int64)
        """The valve spools' positions (scaled, :data:`~.model.SPOOL_SCALE`), empty
        without."""
        self.slide_total_force = bool(self.lag_act.size or valve)
        """Whether a leg's force is every actuator's on its slide (a servo lag or a valve
        after the hold), not the ``leg{i}`` actuator's alone."""
        free = model.joint("plate_free").id
        self.plate_qpos = int(model.jnt_qposadr[free])
        self.plate_dof = int(model.jnt_dofadr[free])
        self.plate_body = model.body("plate").id
        self.fts_body = model.body("fts_body").id
        self.fts_site = model.site("fts").id
        self.force_adr = int(model.sensor_adr[model.sensor("fts_force").id])
        self.torque_adr = int(model.sensor_adr[model.sensor("fts_torque").id])
        self.legf_adr = int(model.sensor_adr[model.sensor("leg0_force").id])
        self.quat_adr = int(model.sensor_adr[model.sensor("fts_quat").id])
        mech = []
        for i in range(6):
            for j in ("u1", "u2", "slide"):
                mech.append(int(model.jnt_dofadr[model.joint(f"leg{i}_{j}").id]))
        mech.extend(range(self.plate_dof, self.plate_dof + 6))
        self.mech_dof = np.array(mech)
        self.cyl_body = [model.body(f"leg{i}_cyl").id for i in range(6)]
        self.u_qpos = np.array([[model.jnt_qposadr[model.joint(f"leg{i}_{u}").id]
                                 for u in ("u1", "u2")] for i in range(6)])
        self.tip_site = [model.site(f"leg{i}_tip").id for i in range(6)]
        self.anchor_site = [model.site(f"plate_anchor{i}").id for i in range(6)]
        self.contiguous_slides = bool(np.all(np.diff(self.slide_qpos) ==
                                             self.slide_qpos[1] - self.slide_qpos[0]))


def assemble(model, data, slides: np.ndarray, ids: _Ids | None = None, *,
             tol: float = 1e-13, max_iter: int = 20) -> None:
    """Put the closed chain, from the model's reference configuration (``qpos0``, the
    plate at home), where leg i is extended by ``slides[i]`` (m): the plate pose whose leg
    lengths are the home lengths plus ``slides`` (Newton iteration on the plate's
    translation and rotation), the universal joints along the legs, the slides set — the
    pose a leg set-point bias holds at rest, so the bench starts there instead of moving
    to it while it settles. Writes ``data.qpos`` (legs and plate; the part's joints keep
    ``qpos0``) and runs the kinematics. Tolerance ``tol`` on every leg length (m)."""
    ids = ids or _Ids(model)
    mujoco.mj_resetData(model, data)
    mujoco.mj_kinematics(model, data)
    cyl = ids.cyl_body
    base = data.xpos[cyl].copy()  # the universal joints' centres (world)
    R0 = data.xmat[cyl].reshape(6, 3, 3).copy()  # the cylinders' frames at u1 = u2 = 0
    tip = data.site_xpos[ids.tip_site]
    ell0 = np.linalg.norm(tip - base, axis=1)  # joint centre to tip at slide 0
    p0 = data.xpos[ids.plate_body].copy()
    Rp0 = data.xmat[ids.plate_body].reshape(3, 3).copy()
    a = (data.site_xpos[ids.anchor_site] - p0) @ Rp0  # plate anchors, plate frame
    target = ell0 + np.asarray(slides, dtype=float)
    t = np.zeros(3)
    R = Rp0.copy()
    for _ in range(max_iter):
        ra = a @ R.T
        v = p0 + t + ra - base
        L = np.linalg.norm(v, axis=1)
        r = L - target
        if np.max(np.abs(r)) < tol:
            break
        u = v / L[:, None]
        J = np.hstack([u, np.cross(ra, u)])  # ∂L/∂(t, δφ), δφ a rotation in world axes
        dx = np.linalg.solve(J, -r)
        t += dx[:3]
        angle = float(np.linalg.norm(dx[3:]))
        quat, dR = np.zeros(4), np.zeros(9)
        mujoco.mju_axisAngle2Quat(quat, dx[3:] / (angle or 1.0), angle)
        mujoco.mju_quat2Mat(dR, quat)
        R = dR.reshape(3, 3) @ R
    else:
        raise RuntimeError(f"assemble: no plate pose within {tol:g} m of the leg lengths "
                           f"{target} m after {max_iter} iterations")
    qa = ids.plate_qpos
    data.qpos[qa:qa + 3] = p0 + t
    mujoco.mju_mat2Quat(data.qpos[qa + 3:qa + 7], R.ravel())
    for i in range(6):
        d = R0[i].T @ (v[i] / L[i])  # the leg's direction in its cylinder's frame
        # the leg frame is Rx(u1) Ry(u2): its z axis (sin u2, −sin u1 cos u2, cos u1 cos u2)
        data.qpos[ids.u_qpos[i, 0]] = np.arctan2(-d[1], d[2])
        data.qpos[ids.u_qpos[i, 1]] = np.arcsin(d[0])
        data.qpos[ids.slide_qpos[i]] = L[i] - ell0[i]
    mujoco.mj_kinematics(model, data)


def servo_gains(model, ids: _Ids | None = None) -> np.ndarray:
    """The six leg servos' position gains kp (N/m) of a compiled model (per model: a batch
    may expand them, an effect may change them): the ``leg{i}`` actuators' gain, or with a
    servo-valve the stiffness of its ``leg{i}_valve`` actuators."""
    ids = ids or _Ids(model)
    if ids.valve_act.size:
        return -model.actuator_biasprm[ids.valve_act, 1]
    return model.actuator_gainprm[ids.act, 0]


def static_state(config: PlatformConfig, model, data, ids: _Ids | None = None) -> StaticState:
    """Solve the static equilibrium of the closed chain at the current (home) configuration.

    Unknowns: the six actuator forces and the 18 ``connect`` constraint forces; equations:
    generalised force balance ``Sᵀ f + J_eqᵀ λ = qfrc_bias`` on the 24 mechanism DOFs (legs
    and plate) at rest, where ``qfrc_bias`` holds the gravity of the plate *and* of everything
    mounted on it. Exact for a payload at rest.
    """
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
    kp = servo_gains(model, ids)
    return StaticState(leg_forces=f, offsets=f / kp, preload=pre, payload_mass=mass)


class _OneSim:
    """The part of ``mujoco.batch.Batch`` the platform uses, for one ``MjData``."""

    def __init__(self, model) -> None:
        self.m = model
        self.d = mujoco.MjData(model)
        self.models = None
        self.batch = None
        """No ``mujoco.batch.Batch``: one ``MjData`` (``d``) stepped in place."""
        self._warn = self.d.warning[_BADQACC]
        self._seen = self._warn.number

    def bind(self, name: str) -> np.ndarray:
        return getattr(self.d, name)[None]

    def get_model(self, k: int):
        return self.m

    def set_time(self, t: float) -> None:
        self.d.time = t

    def reset(self) -> None:
        mujoco.mj_resetData(self.m, self.d)

    def set_const(self) -> None:
        mujoco.mj_setConst(self.m, self.d)

    def forward(self) -> None:
        mujoco.mj_forward(self.m, self.d)

    def step(self, nstep: int = 1, ids=None) -> None:
        mujoco.mj_step(self.m, self.d, nstep)

    def failed(self, expected: float) -> np.ndarray | None:
        """Which simulations diverged (MuJoCo's bad-acceleration warning since the last
        call; it then resets the state silently); None when none did."""
        n = self._warn.number
        if n == self._seen:
            return None
        self._seen = n
        return np.array([True])

    def error(self, k: int) -> str:
        return f"MuJoCo bad acceleration at DOF {self._warn.lastinfo}, state was reset"


class _ManySims:
    """``mujoco.batch.Batch`` with the adapter's extra methods."""

    def __init__(self, model, nsim: int, nthread: int) -> None:
        self.batch = mujoco.batch.Batch(model, nsim, nthread)
        self._time = self.batch.bind("time")

    def __getattr__(self, name: str):
        return getattr(self.batch, name)

    def set_time(self, t: float) -> None:
        self._time[:] = t

    def failed(self, expected: float) -> np.ndarray | None:
        """MuJoCo resets a simulation whose acceleration blows up and carries on from time 0;
        the batch does not expose the warning counters, so a simulation time behind the
        expected one (or a status) is the signature of that reset. None when none did."""
        if self._time.min() >= expected and not self.batch.status.any():
            return None
        return (self._time < expected) | (self.batch.status != 0)
