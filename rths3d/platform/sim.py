"""Stepping the simulated platform at the interface rate, K tests at once (K = 1 included).

:class:`PlatformBatch` is what the vRTHS loop drives at 1 kHz: ``step(poses)`` computes the
leg set-points (inverse kinematics, gravity compensation, velocity feed-forward), checks the
command limits, advances MuJoCo one interface step (``mujoco.batch.Batch`` for K > 1, one
``MjData`` for K = 1) and checks the measured limits. This one-step-at-a-time driver is the
readable reference; the compiled kernels (:mod:`rths3d.platform.compiled`,
:mod:`rths3d.platform.closed`) take the batch's arrays through :meth:`~PlatformBatch.
kernel_arrays` (:mod:`rths3d.platform.kernel_io`), hand stops back to it and give the same
records. :class:`~rths3d.platform.single.PlatformSim` is one platform on top of it.

The controller's conventions are each test's ``ActuatorConfig`` data (``hold``, ``sample``,
``feedforward``); the defaults are the convention below (ramp, end, backward difference).

Timing and zeroing convention (one for the vRTHS loop, the diagnosis' replay and synthetic
measurements; docs/platform.md, "Timing and zeroing"): the pose commanded at step k is the
target for t_{k+1}; the set-point ramps from c_k to c_{k+1} over the step; every channel is
sampled at t_{k+1} from one state; zero and tare at measured rest after settling.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np

from ..effects.blocks import DelayBlock, LagBlock
from ..errors import ConfigError, SafetyStop
from ..kernels import Block, Chain
from .backend import (
    _MAXVAL,
    StaticState,
    _Ids,
    _ManySims,
    _OneSim,
    assemble,
    static_state,
)
from .kernel_io import KernelArrays, mujoco_group
from .kernels import (
    copy_fts,
    end_ramp,
    fts_distort,
    interface_command,
    leg_lengths_of,
    leg_setpoints,
    measured_over,
    plate_pose,
    quat_rows,
    ramp_ctrl,
    read_interface,
    rotation,
    take_sample,
    world_wrench,
)
from .model import SPOOL_SCALE, PlatformConfig, build_model

__all__ = ["PlatformBatch", "StaticState", "interface_command", "plate_pose", "rotation",
           "static_state"]


def _ff_gains(config: PlatformConfig) -> tuple[float, float]:
    """Velocity feed-forward gains (1/1) on the backward and forward differences of the
    commanded leg lengths: ``kv/(kp ΔT)`` on the backward one (``"backward"``), half of it on
    each (``"central"``: (L_{k+2} − L_k)/(2ΔT)), none (``"none"`` or ``velocity_ff`` off)."""
    a = config.actuator
    if not a.velocity_ff or a.feedforward == "none":
        return 0.0, 0.0
    g = a.kv / a.kp / config.dt
    return (g, 0.0) if a.feedforward == "backward" else (0.5 * g, 0.5 * g)


class PlatformBatch:
    """K platforms (one model structure, per-test parameters) stepped together.

    ``step(poses)`` takes commanded poses (K, 6) (m, rad, relative to home). A test that
    leaves a limit is frozen at its last safe state (its commands no longer change) and
    flagged: ``stopped[k]`` is True and ``reasons[k]`` holds the :class:`SafetyStop`
    message; the other tests go on. Reads are arrays: ``pose`` (K, 6), ``leg_lengths``
    (K, 6), ``leg_forces`` (K, 6), ``wrench`` (K, 6) and ``interface_wrench`` (K, 6); the
    timing and zeroing convention is the module docstring's.

    Per-test models: ``variants`` (one ``(config, payload_xml, world_xml)`` per test) or
    ``models`` (compiled ``MjModel`` per test, e.g. a bench's truth with its hidden effects,
    :class:`rths3d.bench.Bench`); ``nominal`` (one model or one per test) is what the
    controller knows: its gravity compensation is computed there (default: each test's own
    model). ``config`` is the controller's: its geometry drives the inverse kinematics, its
    actuator settings the feed-forward and the set-point lag and delay. ``blocks``: extra
    per-leg set-point blocks over K·6 rows (row ``6k + i``: leg i of test k), applied after
    the lag and delay; ``bias`` (K, 6): per-leg set-point bias (m) that the encoders do not
    see (leg offsets, a true geometry other than the nominal one); ``gravity_scale`` (K,):
    the compensated weight relative to the nominal model's; ``fts_matrix`` (K, 6, 6) and
    ``fts_offset`` (K, 6): a miscalibrated FTS reads ``C w + b``.

    The controller's conventions (``hold``, ``sample``, ``feedforward``) are each test's
    ``config.actuator`` data (:class:`~rths3d.platform.model.ActuatorConfig`). ``replay``: an
    open-loop replay of a known command series; it may set :attr:`poses_next` for a central
    feed-forward (refused in a closed loop) and samples every test at the end of the step.

    After changing masses or inertias of the batch in place (``batch.batch.body(name).mass
    = ...``) call ``reset(set_const=True)``. One test (``nsim = 1``) steps a plain ``MjData``.
    """

    def __init__(self, config: PlatformConfig | None = None, nsim: int = 1, nthread: int = 0,
                 payload_xml: str | None = None, world_xml: str | None = None,
                 settle: float = 0.05, *,
                 variants: Sequence[tuple[PlatformConfig, str | None, str | None]] | None = None,
                 models: Sequence[Any] | None = None, nominal: Any = None,
                 configs: Sequence[PlatformConfig] | None = None,
                 blocks: Sequence[Block] = (), bias: np.ndarray | None = None,
                 gravity_scale: np.ndarray | None = None,
                 fts_matrix: np.ndarray | None = None, fts_offset: np.ndarray | None = None,
                 replay: bool = False):
        if not (isinstance(nsim, int) and nsim >= 1):
            raise ConfigError("nsim", nsim, "must be an integer >= 1")
        cfgs = None
        if variants is not None:
            # per-test (config, payload, world): one model structure, per-test parameters
            if len(variants) != nsim:
                raise ConfigError("variants", len(variants), f"need one per test ({nsim})")
            config = variants[0][0]
            cfgs = [v[0] for v in variants]
            payload_xml, world_xml = variants[0][1], variants[0][2]
        elif configs is not None:
            if len(configs) != nsim:
                raise ConfigError("configs", len(configs), f"need one per test ({nsim})")
            cfgs = list(configs)
            config = cfgs[0]
        if cfgs is not None:
            shared = ("geometry", "dt", "substeps", "stroke", "velocity_limit", "force_limit",
                      "integrator")
            for cfg_k in cfgs:
                for name in shared:
                    if getattr(cfg_k, name) != getattr(config, name):
                        raise ConfigError(f"platform.{name}", getattr(cfg_k, name),
                                          "must be the same for tests stepped together")
        self.config = config = config or PlatformConfig()
        if models is not None:
            if len(models) != nsim:
                raise ConfigError("models", len(models), f"need one per test ({nsim})")
            self.model = models[0]
        else:
            self.model = build_model(config, payload_xml, world_xml)
        self.nsim = nsim
        self.ids = _Ids(self.model)
        self.settle = float(settle)
        self._cfgs = cfgs if cfgs is not None else [config] * nsim
        one = nsim == 1 and variants is None
        self.batch = _OneSim(self.model) if one else _ManySims(self.model, nsim, nthread)
        per_test = None
        if models is not None and nsim > 1:
            per_test = list(models)
        elif variants is not None and len(set(variants)) > 1:
            compiled: dict = {variants[0]: self.model}
            for v in variants:
                if v not in compiled:
                    compiled[v] = build_model(*v)
            per_test = [compiled[v] for v in variants]
        if per_test is not None:
            try:
                self.batch.set_models(per_test)
            except (ValueError, mujoco.FatalError) as exc:
                # FatalError: a payload or world of another structure (bodies, joints, ...)
                raise ConfigError("variants", None, "", message="variants: tests stepped "
                                  "together need one model structure (the same payload and "
                                  f"world bodies, joints and sensors): {exc}") from exc
        if nominal is None or isinstance(nominal, mujoco.MjModel):
            self._nominal = [nominal] * nsim
        else:
            if len(nominal) != nsim:
                raise ConfigError("nominal", len(nominal), f"need one per test ({nsim})")
            self._nominal = list(nominal)
        self._bind_live_views()
        self._controller_arrays(config, replay, bias, gravity_scale)
        self._fts_arrays(fts_matrix, fts_offset)
        self.setpoint_chain = self._setpoint_chain(config, blocks)
        self.poses = np.zeros((nsim, 6))
        """The poses (K, 6) commanded by the last step (m, rad, relative to home)."""
        self.fresh = False
        self.any_stopped = False
        self.running = np.ones(nsim, dtype=np.bool_)
        self.leg_hook = None
        """Per-leg compensation (``transfer.compensate = "legs"``, :mod:`rths3d.transfer.legs`):
        ``hook(L)`` writes the leg lengths (K, 6) m to command for :attr:`poses` before the
        command limits and the set-point blocks (allocation-free); None: their inverse
        kinematics."""
        self._all = np.arange(nsim)
        self._ids = self._all
        self._wrows: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
        self.stopped = np.zeros(nsim, dtype=bool)
        self.reasons = [""] * nsim
        self.stops: list[SafetyStop | None] = [None] * nsim
        """The stop of each frozen test (None while it runs)."""
        self.stop_time = np.full(nsim, np.nan)
        self.rest_pose = np.zeros((nsim, 6))
        """Plate pose at measured rest after settling (K, 6): the zero of ``z_meas``."""
        self.rest_leg_forces = np.zeros((nsim, 6))
        """Leg forces at measured rest (K, 6), N: their tare."""
        self.k = 0
        self.reset()

    def _bind_live_views(self) -> None:
        """Live views of every test's MuJoCo state the steps read and write (K rows)."""
        ids = self.ids
        self._ctrl = self.batch.bind("ctrl")
        self._act = self.batch.bind("act")
        self._qpos = self.batch.bind("qpos")
        self._qvel = self.batch.bind("qvel")
        self._sensor = self.batch.bind("sensordata")
        # the leg force: the servo's actuator, or with a servo lag after the hold
        # (leg{i}_lag actuators) or a valve, every actuator's force on the slide
        self._servo_lag = ids.lag_act.size > 0
        total = ids.slide_total_force
        self._force = self.batch.bind("qfrc_actuator" if total else "actuator_force")
        self._xmat = self.batch.bind("site_xmat")
        self._a0 = int(ids.act[0])
        self._s0 = int(self.model.actuator_actadr[ids.act[0]])
        qs = int(ids.slide_qpos[1] - ids.slide_qpos[0])
        self._q_slice = slice(int(ids.slide_qpos[0]), int(ids.slide_qpos[-1]) + 1, qs)
        vs = int(ids.slide_dof[1] - ids.slide_dof[0])
        self._v_slice = slice(int(ids.slide_dof[0]), int(ids.slide_dof[-1]) + 1, vs)
        self.live_legs_q = self._qpos[:, self._q_slice]
        self.live_legs_v = self._qvel[:, self._v_slice]
        self.live_legs_f = self._force[:, self._v_slice] if total else \
            self._force[:, self._a0:self._a0 + 6]
        pa = ids.plate_qpos
        self.live_qpos = self._qpos[:, pa:pa + 7]
        """Live (K, 7) view of the plate's free-joint qpos (position m, quaternion wxyz)."""
        fa, ta = ids.force_adr, ids.torque_adr
        self._raw_force = self._sensor[:, fa:fa + 3]
        self._raw_torque = self._sensor[:, ta:ta + 3]
        la, qa = ids.legf_adr, ids.quat_adr
        self.leg_force_sensor = self._sensor[:, la:la + 6]
        """Live (K, 6) leg forces from the sensors (N): the start-of-step evaluation."""
        self._fts_quat = self._sensor[:, qa:qa + 4]
        self._live_R = self._xmat[:, ids.fts_site]  # the FTS orientation now

    def _controller_arrays(self, config: PlatformConfig, replay: bool,
                           bias: np.ndarray | None, gravity_scale: np.ndarray | None) -> None:
        """The controller's geometry, limits and conventions per test, as arrays."""
        nsim, g = self.nsim, config.geometry
        self.home_lengths = g.home_leg_lengths()
        self.half_stroke = config.stroke / 2
        self.velocity_limit = float(config.velocity_limit)
        self._vdt = self.velocity_limit * config.dt
        self.force_limit = float(config.force_limit)
        # anchors for the per-step inverse kinematics (the controller's geometry)
        self.ik_base_anchors = np.ascontiguousarray(g.base_anchors(), dtype=float)
        self.ik_top_anchors = np.ascontiguousarray(g.top_anchors(), dtype=float)
        self.home_height = float(g.home_height)
        # the controller's conventions per test, as data: velocity feed-forward gains on the
        # backward (ffg) and forward (ffn) differences of the leg lengths, hold and sampling
        gains = [_ff_gains(c) for c in self._cfgs]
        self._ffg = np.array([g_[0] for g_ in gains])
        self._ffn = np.array([g_[1] for g_ in gains])
        self.needs_next_setpoint = bool(np.any(self._ffn != 0.0))
        if self.needs_next_setpoint and not replay:
            raise ConfigError("controller.feedforward", "central", "needs the next "
                              "set-point: only an open-loop replay of a known command has it, "
                              "not a closed loop; use backward or none")
        self._zoh = np.array([c.actuator.hold == "zoh" for c in self._cfgs], dtype=np.bool_)
        self.any_zoh = bool(self._zoh.any())
        """Whether a test holds its set-points (zero-order hold)."""
        self._start = np.array([c.actuator.sample == "start" and not replay
                                for c in self._cfgs], dtype=np.bool_)
        self._any_start = bool(self._start.any())
        self.sample_start = np.array([c.actuator.sample == "start" for c in self._cfgs])
        """Which tests' controllers sample their channels at the start of the step."""
        self.poses_next = np.zeros((nsim, 6))
        """The poses (K, 6) commanded at the next step (a replay's central feed-forward)."""
        self._Lnext = np.zeros((nsim, 6))
        self.fts_R_start = np.zeros((nsim, 9))
        self._L = np.zeros((nsim, 6))
        self._sp = np.zeros((nsim, 6))
        self._cprev = np.zeros((nsim, 6))
        self._cnew = np.zeros((nsim, 6))
        self._bias = np.zeros((nsim, 6)) if bias is None else \
            np.ascontiguousarray(np.broadcast_to(bias, (nsim, 6)), dtype=float)
        self._gscale = np.ones(nsim) if gravity_scale is None else \
            np.asarray(np.broadcast_to(gravity_scale, (nsim,)), dtype=float)
        self._nsub = int(config.substeps)
        self._inv_dt = 1.0 / config.dt
        # the servo's continuous lag after the hold: its actuators, activations and 1/τ
        taus = np.array([c.actuator.servo_lag for c in self._cfgs])
        if self._servo_lag and not np.all(taus > 0):
            raise ConfigError("controller.lag", "servo", "tests stepped together need the "
                              "same servo structure (a servo lag > 0 s in every test)")
        ids = self.ids
        self._lag = (int(ids.lag_act[0]), int(self.model.actuator_actadr[ids.lag_act[0]]),
                     1.0 / taus) if self._servo_lag else (-1, -1, np.zeros(nsim))

    def _fts_arrays(self, fts_matrix: np.ndarray | None, fts_offset: np.ndarray | None
                    ) -> None:
        """The sensor's reading (a copy of MuJoCo's, or C w + b of a miscalibrated one) and
        the sample buffers of the measured channels."""
        nsim = self.nsim
        self.fts_reading = np.zeros((nsim, 6))
        """Live (K, 6) raw FTS reading of the last sample (N, N·m), sensor frame."""
        self._fts_force = self.fts_reading[:, :3]
        self._fts_torque = self.fts_reading[:, 3:]
        if fts_matrix is not None or fts_offset is not None:
            C = np.tile(np.eye(6), (nsim, 1, 1)) if fts_matrix is None else \
                np.ascontiguousarray(np.broadcast_to(fts_matrix, (nsim, 6, 6)), dtype=float)
            bo = np.zeros((nsim, 6)) if fts_offset is None else \
                np.ascontiguousarray(np.broadcast_to(fts_offset, (nsim, 6)), dtype=float)
            self._fts_C, self._fts_b = C, bo
        else:
            self._fts_C = None
            self._fts_b = np.zeros((nsim, 6))
        self._scratch: list = []  # (model, MjData) per test of a compiled range's batch
        self.plate_qpos = self.live_qpos
        """The measured plate qpos (K, 7) of the last sample (position m, quaternion wxyz):
        the live view when every test samples at the end of the step."""
        self.meas_legs_q = self.live_legs_q
        """Measured leg extensions (K, 6) of the last sample, m (encoders: add
        :meth:`encoder_lengths`)."""
        self.meas_legs_f = self.live_legs_f
        """Measured leg forces (K, 6) of the last sample, N."""
        self._fts_R = self._live_R
        if self._any_start:
            # sample buffers: a start-sampled test keeps the state before its step's
            # set-point acts, an end-sampled one the state after
            self.plate_qpos = np.zeros((nsim, 7))
            self.meas_legs_q = np.zeros((nsim, 6))
            self.meas_legs_f = np.zeros((nsim, 6))
            self._fts_R = np.zeros((nsim, 9))
            if self._fts_C is None:
                self._fts_C = np.tile(np.eye(6), (nsim, 1, 1))

    def _setpoint_chain(self, config: PlatformConfig, blocks: Sequence[Block]) -> Chain:
        """The controller's set-point blocks: lag and transport delay of each test's
        settings, then the bench's per-leg blocks (effects)."""
        chain: list[Block] = []
        tcs = np.repeat([c.actuator.setpoint_lag for c in self._cfgs], 6)
        if np.any(tcs > 0):
            chain.append(LagBlock(self.nsim, 6, tcs, config.dt))
        dls = np.repeat([c.actuator.delay for c in self._cfgs], 6)
        if np.any(dls > 0):
            chain.append(DelayBlock(self.nsim, 6, dls, config.dt))
        chain.extend(blocks)
        return Chain(self.nsim, 6, chain)

    def reset(self, set_const: bool = False) -> None:
        """All tests to home with gravity compensation (of the nominal model), settle, take
        zero and tare at measured rest; clears stop flags; ``t = 0``.

        ``set_const=True`` first recomputes MuJoCo's derived constants per test (needed after
        changing masses or inertias, e.g. ``batch.batch.body("payload").mass = m[:, None]``);
        with per-test models it recomputes them on each test's own model.
        """
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
        offs = np.zeros((self.nsim, 6))
        d = mujoco.MjData(m)
        state_fields = {}
        statics = []
        nominal_static: dict[int, StaticState] = {}
        for k in range(self.nsim):
            mk = self.batch.get_model(k)
            if np.any(self._bias[k]):
                # a set-point bias the encoders do not see (the true geometry differs from
                # the controller's): the static forces where it holds the plate
                assemble(mk, d, self._bias[k], self.ids)
            else:
                mujoco.mj_resetData(mk, d)
            st = static_state(self._cfgs[k], mk, d, self.ids)
            statics.append(st)
            nom = self._nominal[k]
            if self._cfgs[k].actuator.gravity_source == "measured":
                nom = None  # the true bench's own holding forces: its static equilibrium
            if nom is not None and nom is not mk:
                if id(nom) not in nominal_static:
                    dn = mujoco.MjData(nom)
                    nominal_static[id(nom)] = static_state(self._cfgs[k], nom, dn)
                comp = nominal_static[id(nom)]
            else:
                comp = st
            if self._cfgs[k].actuator.gravity_comp:
                offs[k] = comp.offsets * self._gscale[k]
            c0 = offs[k] + self._bias[k]
            # the servos hold the true bench's weight where each slide is its set-point less
            # its leg force over its own gain: start there (sagged where the compensation is
            # not the true bench's), not at home with a transient through the record
            rest = c0 - st.offsets
            if np.max(np.abs(rest - d.qpos[self.ids.slide_qpos])) > 1e-12:
                assemble(mk, d, rest, self.ids)
            d.ctrl[self.ids.act] = 0.0
            d.act[mk.actuator_actadr[self.ids.act]] = c0
            if self.ids.spool_qpos.size:  # the valve at rest: its output is the set-point
                d.qpos[self.ids.spool_qpos] = c0 / SPOOL_SCALE
            mujoco.mj_forward(mk, d)
            for name in ("qpos", "qvel", "act", "ctrl", "history"):
                arr = getattr(d, name)
                if arr.size:
                    state_fields.setdefault(name, np.zeros((self.nsim,) + arr.shape))[k] = arr
        self.statics = statics
        # a reset forgets the past: solver warm starts and every other derived field too
        self.batch.reset()
        self.batch.set_time(0.0)
        for name, arr in state_fields.items():
            self.batch.bind(name)[:] = arr
        self._off = offs
        self._cprev[:] = offs + self._bias
        self._cnew[:] = self._cprev
        self._sp[:] = 0.0
        self.setpoint_chain.reset()
        self._Lprev = np.tile(self.home_lengths, (self.nsim, 1))
        self.poses[:] = 0.0
        self.stopped[:] = False
        self.any_stopped = False
        self._ids = self._all
        self.running[:] = True
        self.reasons = [""] * self.nsim
        self.stops = [None] * self.nsim
        self.stop_time[:] = np.nan
        nset = int(round(self.settle / self.config.timestep))
        self.t0 = nset * self.config.timestep
        if nset:
            self.batch.step(nstep=nset)
        # channels of the settled state (a step leaves them at the start of its last substep)
        self.batch.forward()
        self.read_fts()
        if self._any_start:
            self._sample(True)
            self._sample(False)
        self.k = 0
        self.check_status(settling=True)
        # zero and tare at measured rest, as a bench does
        self.tare_wrench = np.zeros((self.nsim, 6))
        self.rest_pose[:] = 0.0
        world_wrench(self._fts_R, self._fts_force, self._fts_torque, self.tare_wrench,
                     np.arange(6, dtype=np.int64), self.tare_wrench)
        self.rest_pose[:] = plate_pose(self.plate_qpos, self.home_height)
        self.rest_leg_forces[:] = self.live_legs_f
        self.fresh = not self.any_stopped

    def _sample(self, start: bool) -> None:
        """Copy the live channels of the tests sampled at the start (``start``) or at the end
        of the step into the sample buffers (only when a test samples at the start)."""
        take_sample(self._start, start, self.live_qpos, self.live_legs_q, self.live_legs_f,
                    self._live_R, self.plate_qpos, self.meas_legs_q, self.meas_legs_f,
                    self._fts_R, self._raw_force, self._raw_torque, self._fts_C, self._fts_b,
                    self.fts_reading)

    def read_fts(self) -> None:
        if self._fts_C is not None:
            fts_distort(self._raw_force, self._raw_torque, self._fts_C, self._fts_b,
                        self._fts_force, self._fts_torque)
        else:
            copy_fts(self._raw_force, self._raw_torque, self.fts_reading)

    def ensure_reset(self) -> None:
        """:meth:`reset`, unless the platform is still as its last reset left it (not
        stepped, nothing stopped): the same state without settling twice."""
        if not (self.fresh and self.k == 0):
            self.reset()

    @property
    def t(self) -> float:
        """Simulated test time (s) since reset."""
        return self.k * self.config.dt

    def freeze(self, k: int, stop: SafetyStop) -> None:
        if not self.stopped[k]:
            self.any_stopped = True
            self.stops[k] = stop
            self.stopped[k] = True
            self.running[k] = False
            self._ids = self._all[self.running]  # the tests still stepped (once per stop)
            self.reasons[k] = stop.reason
            self.stop_time[k] = stop.t

    def check_status(self, settling: bool = False) -> None:
        """Flag tests whose simulation failed or diverged (MuJoCo resets such a state)."""
        expected = self.t0 + self.k * self.config.dt - 0.5 * self.config.timestep
        failed = self.batch.failed(expected)
        if failed is None:
            return
        bad = failed & ~self.stopped
        if bad.any():
            for k in np.flatnonzero(bad):
                msg = self.batch.error(int(k)).strip()
                what = msg or "MuJoCo bad acceleration, state was reset"
                self.freeze(int(k), SafetyStop(f"divergence ({what}) |qacc|", math.inf,
                                                _MAXVAL, 0.0 if settling else self.t,
                                                test=int(k)))

    def step(self, poses: np.ndarray, translation_only: bool = False) -> None:
        """Command poses (K, 6) (m, rad, relative to home) for one interface step ΔT.

        ``translation_only`` is accepted for compatibility: the compiled inverse kinematics
        costs the same with rotations.
        """
        poses = np.asarray(poses, dtype=float)
        if poses.shape != (self.nsim, 6):
            raise ConfigError("poses", f"array of shape {poses.shape}",
                              f"need ({self.nsim}, 6)")
        self.poses[:] = poses
        self.advance()

    def step_interface(self, u: np.ndarray, idx: np.ndarray, z: np.ndarray,
                       f: np.ndarray) -> None:
        """One interface step commanding the DOFs ``idx`` to ``u`` (K, len(idx); the others
        keep their commanded pose), then the achieved DOFs into ``z`` and their interface
        wrench into ``f`` (the loop's hot path)."""
        interface_command(u, idx, self.poses)
        self.advance()
        self.read(idx, z, f)

    def advance(self, sample: bool = True) -> None:
        """One interface step from the commanded poses in :attr:`poses` (the hot path).

        ``sample=False`` skips the end-of-step ``mj_forward``: the sensors and actuator forces
        then still describe the start of the step. Since the servo's set-point is a state
        (its activation) and the control only its rate, the next step's own evaluation at
        its start gives exactly this step's end-of-step sample: an open-loop replay reads
        them one step later instead of paying a second evaluation per step."""
        self.fresh = False
        sp = self._sp
        ik = self.leg_hook is None
        if not ik:
            # per-leg compensation: the hook writes the lengths to command into _L (from the
            # poses, with this platform's anchors); the call below checks and writes those
            self.leg_hook(self._L)
        if self.needs_next_setpoint:
            leg_lengths_of(self.poses_next, self.ik_base_anchors, self.ik_top_anchors,
                           self.home_height, self._Lnext)
        if self._any_start:  # the state before this step's set-point acts
            self._sample(True)
        if leg_setpoints(self.poses, self.ik_base_anchors, self.ik_top_anchors, self.home_height,
                         self.home_lengths, self._ffg, self._Lprev, self._L, sp,
                         self.half_stroke, self._vdt, self.running, ik, self._ffn, self._Lnext,
                         self.needs_next_setpoint):
            self.command_limits(self._L - self.home_lengths, self._L - self._Lprev)
        y = sp if self.setpoint_chain.empty else self.setpoint_chain(sp)
        run = self.running
        ids = self._ids if self.any_stopped else None
        if ids is not None and not ids.size:
            self.k += 1
            return
        ramp_ctrl(y, self._off, self._bias, self._cprev, self._cnew, self._ctrl, self._a0,
                  self._inv_dt, run, self._zoh, self._act, self._s0, self._lag)
        if ids is None:
            self.batch.step(nstep=self._nsub)
        else:
            # stopped tests hold their last set-point and are not stepped any more
            self.batch.step(nstep=self._nsub, ids=ids)
        end_ramp(self._cnew, self._cprev, self._act, self._s0, run)
        # every channel at t_{k+1} from one state
        if sample:
            self.batch.forward()
            if self._any_start:
                self._sample(False)
            else:
                self.read_fts()
        self.k += 1
        self.check_status()
        self.check_measured()

    def command_limits(self, s: np.ndarray, dL: np.ndarray) -> None:
        """Freeze the running tests whose command leaves stroke or speed (before the step)."""
        dt = self.config.dt
        half, vdt = self.half_stroke, self._vdt
        t_next = (self.k + 1) * dt
        bad = (~(np.abs(s) <= half) | ~(np.abs(dL) <= vdt)) & ~self.stopped[:, None]
        for k in np.flatnonzero(bad.any(axis=1)):
            i = int(np.flatnonzero(bad[k])[0])
            if not abs(s[k, i]) <= half:
                stop = SafetyStop(f"leg {i} commanded stroke", s[k, i], half, t_next,
                                  test=int(k), unit="m")
            else:
                stop = SafetyStop(f"leg {i} commanded velocity", dL[k, i] / dt, self.velocity_limit,
                                  t_next, test=int(k), unit="m/s")
            self.freeze(int(k), stop)

    def measured_limits(self, q: np.ndarray, v: np.ndarray, f: np.ndarray) -> None:
        """Freeze the running tests whose measured stroke, speed or force is out of limits."""
        over = ((np.abs(q) > self.half_stroke) | (np.abs(v) > self.velocity_limit) |
                (np.abs(f) > self.force_limit)) & ~self.stopped[:, None]
        for k in np.flatnonzero(over.any(axis=1)):
            i = int(np.flatnonzero(over[k])[0])
            for name, arr, lim, unit in (("stroke", q, self.half_stroke, "m"),
                                         ("velocity", v, self.velocity_limit, "m/s"),
                                         ("force", f, self.force_limit, "N")):
                if abs(arr[k, i]) > lim:
                    self.freeze(int(k), SafetyStop(f"leg {i} {name}", arr[k, i], lim,
                                                    self.t, test=int(k), unit=unit))
                    break

    # ------------------------------------------------------------------ compiled kernels
    def kernel_arrays(self) -> KernelArrays:
        """The batch's arrays as the compiled kernels take them (views: a kernel steps this
        batch in place); valid until the next :meth:`reset`."""
        K = self.nsim
        geo = (self.ik_base_anchors, self.ik_top_anchors, self.home_height, self.home_lengths,
               self.half_stroke, self._vdt, self.velocity_limit, self.force_limit)
        ctl = (self._ffg, self._ffn, self._Lprev, self._L, np.zeros_like(self._L), self._sp,
               np.zeros_like(self._sp), self._off, self._bias, self._cprev, self._cnew,
               self._zoh, self._inv_dt, self._a0, self._s0, self.needs_next_setpoint,
               self._Lnext, self._lag)
        live = (self._ctrl, self._act, self.live_qpos, self.live_legs_q, self.live_legs_v,
                self.live_legs_f, self.leg_force_sensor, self._fts_quat, self._live_R)
        has_c = self._fts_C is not None
        fts = (has_c, self._fts_C if has_c else np.zeros((1, 6, 6)), self._fts_b,
               self._raw_force, self._raw_torque, self.fts_reading, self._fts_force,
               self._fts_torque)
        meas = (self.plate_qpos, self.meas_legs_q, self.meas_legs_f, self._fts_R)
        targets = meas if self._any_start else (np.zeros((K, 7)), np.zeros((K, 6)),
                                                np.zeros((K, 6)), np.zeros((K, 9)))
        smp = (self._start, self._any_start, *targets, *meas)
        return KernelArrays(geo, ctl, self.setpoint_chain.kernel_group(), live, fts, smp)

    def mujoco_arrays(self, forward: bool) -> tuple:
        """The MuJoCo group of the compiled kernels (:func:`~.kernel_io.mujoco_group`):
        ``forward``, an ``mj_forward`` at the end of each step."""
        cfg = self.config
        group, self._scratch = mujoco_group(self.batch, self.model, self.nsim, self._scratch,
                                            forward, cfg.substeps, self.t0, cfg.dt,
                                            cfg.timestep)
        return group

    def check_measured(self) -> None:
        """Freeze the tests whose measured leg extension, velocity or force is over its limit
        (after a compiled range handed a step back)."""
        q, v, f = self.live_legs_q, self.live_legs_v, self.live_legs_f
        if measured_over(q, v, f, self.half_stroke, self.velocity_limit, self.force_limit,
                         self.running):
            self.measured_limits(q, v, f)

    # ------------------------------------------------------------------ reads
    @property
    def pose(self) -> np.ndarray:
        """Achieved plate poses relative to home (K, 6), m and rad."""
        return plate_pose(self.plate_qpos, self.home_height)

    @property
    def leg_lengths(self) -> np.ndarray:
        """Leg lengths the encoders read (K, 6), m (:meth:`encoder_lengths` of now)."""
        return self.encoder_lengths(self.meas_legs_q)

    def encoder_lengths(self, q: np.ndarray) -> np.ndarray:
        """What the encoders read for piston extensions ``q`` (…, K, 6) of these tests, m:
        home length + extension − the set-point bias the encoders do not see."""
        return q + (self.home_lengths - self._bias)

    @property
    def leg_commands(self) -> np.ndarray:
        """Leg lengths (K, 6), m, commanded by the last step (inverse kinematics)."""
        return self._Lprev.copy()

    @property
    def leg_forces(self) -> np.ndarray:
        """Measured actuator forces (K, 6), N."""
        return self.meas_legs_f.copy()

    @property
    def wrench(self) -> np.ndarray:
        """Raw FTS wrench (K, 6) in the site frame (N, N·m); see :attr:`PlatformSim.wrench`."""
        return self.fts_reading.copy()

    def _rows(self, rows: Sequence[int]) -> tuple[np.ndarray, np.ndarray]:
        key = tuple(int(r) for r in rows)
        if key not in self._wrows:
            self._wrows[key] = (np.array(key, dtype=np.int64), np.zeros((self.nsim, len(key))))
        return self._wrows[key]

    @property
    def interface_wrench(self) -> np.ndarray:
        """Restoring wrench ``f_meas`` (K, 6): world axes, static preload removed (N, N·m)."""
        return self.interface_force(range(6)).copy()

    def read(self, idx: np.ndarray, z: np.ndarray, f: np.ndarray) -> None:
        """Achieved interface DOFs ``idx`` into ``z`` and their measured interface wrench
        into ``f`` ((K, len(idx)) each), in one compiled call."""
        read_interface(self.plate_qpos, self.home_height, idx, self._fts_R, self._fts_force,
                       self._fts_torque, self.tare_wrench, z, f, self.rest_pose)

    def read_start(self, idx: np.ndarray, z: np.ndarray, f: np.ndarray) -> None:
        """After ``advance(sample=False)``: the achieved interface DOFs now, and the
        interface wrench of the previous step's end-of-step sample (from the sensors, which
        the step evaluated at its start)."""
        quat_rows(self._fts_quat, self.fts_R_start)
        read_interface(self.plate_qpos, self.home_height, idx, self.fts_R_start, self._fts_force,
                       self._fts_torque, self.tare_wrench, z, f, self.rest_pose)

    def interface_force(self, rows: Sequence[int]) -> np.ndarray:
        """Rows ``rows`` (0–2 force, 3–5 torque) of :attr:`interface_wrench`, (K, len(rows)),
        in a buffer reused per set of rows."""
        idx, out = self._rows(rows)
        world_wrench(self._fts_R, self._fts_force, self._fts_torque, self.tare_wrench, idx, out)
        return out
