"""Ranges of interface steps of a :class:`~rths3d.platform.sim.PlatformBatch` through a
known command series: the open-loop replay's and the tracking benchmarks' stepping.

:func:`track_batch` steps K tests through commanded poses and returns every measured
channel per row, either one Python-driven step at a time (the readable reference:
:meth:`PlatformBatch._advance` and its reads) or in compiled ranges
(:func:`rths3d.platform.compiled.run_range`), which hand the steps that need Python (a stop)
back to the same reference step. Both give the same records (tests/test_platform_compiled.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import mujoco
import numpy as np

if TYPE_CHECKING:
    from .sim import PlatformBatch

__all__ = ["TrackRecord", "compiled_ok", "track_batch"]


@dataclass
class TrackRecord:
    """Per-row channels (N, K, ·) of a tracked command series; row 0 is the state before the
    first step. ``q``: plate qpos (m, quaternion); ``legs_q``: piston extensions (m);
    ``legs_f``: leg forces (N, not tared); ``fts``: the raw FTS reading (N, N·m); ``z``/``f``:
    interface DOFs from the rest pose and their wrench (tared; m, rad, N, N·m); ``stop``:
    the row from which each test is stopped (N: it ran through)."""

    q: np.ndarray
    legs_q: np.ndarray
    legs_f: np.ndarray
    fts: np.ndarray
    z: np.ndarray
    f: np.ndarray
    stop: np.ndarray


def compiled_ok(sim: PlatformBatch) -> bool:
    """Whether the compiled range can step this batch: inverse kinematics of the poses (no
    per-leg hook), no noise in the set-point blocks, no per-test model fields expanded inside
    a ``mujoco.batch.Batch`` (its own model copies)."""
    if sim.leg_hook is not None or sim.setpoint_chain.noise is not None:
        return False
    inner = sim.batch.batch
    return inner is None or not getattr(inner, "_expanded", {})


def _mj_tuple(sim: PlatformBatch, forward: bool) -> tuple:
    """The MuJoCo tuple of :func:`~rths3d.platform.compiled.run_range` (see there)."""
    from .compiled import _TIME_SIG, STATE_SIG

    K = sim.nsim
    cfg = sim.config
    inner = sim.batch.batch
    if inner is None:  # one MjData: stepped in place
        d = sim.batch.d
        models, datas, rows = [sim.model], [d], False
        state = np.zeros((1, 1))
        oaddr = np.zeros((1, 0), dtype=np.int64)
        daddr_out = np.zeros((1, 0), dtype=np.int64)
        osize = np.zeros(0, dtype=np.int64)
    else:
        ms = inner.models
        models = list(ms) if isinstance(ms, list | tuple) else [ms or sim.model] * K
        if len(sim._scratch) != K or any(
                s[0] is not m for s, m in zip(sim._scratch, models, strict=True)):
            sim._scratch = [(m, mujoco.MjData(m)) for m in models]
        datas = [s[1] for s in sim._scratch]
        rows = True
        state = inner.state
        assert state.shape[1] == mujoco.mj_stateSize(models[0], STATE_SIG)
        names = list(inner._bound)
        oaddr = np.zeros((K, len(names)), dtype=np.int64)
        daddr_out = np.zeros((K, len(names)), dtype=np.int64)
        osize = np.zeros(len(names), dtype=np.int64)
        for j, name in enumerate(names):
            out = inner._bound[name]
            assert out.flags.c_contiguous and out.dtype == np.float64
            osize[j] = out[0].size
            for k in range(K):
                oaddr[k, j] = out.ctypes.data + k * out.strides[0]
                daddr_out[k, j] = getattr(datas[k], name).ctypes.data
    maddr = np.array([m._address for m in models], dtype=np.int64)
    daddr = np.array([d._address for d in datas], dtype=np.int64)
    dact = np.array([d.act.ctypes.data for d in datas], dtype=np.int64)
    return (maddr, daddr, rows, state, STATE_SIG, oaddr, daddr_out, osize, dact,
            int(cfg.substeps), np.zeros(K), _TIME_SIG, False, forward, float(sim._t0),
            float(cfg.dt), float(cfg.timestep))


def _python_row(sim: PlatformBatch, r: int, lazy: bool, idx: np.ndarray, rec: TrackRecord,
                z: np.ndarray, f: np.ndarray) -> None:
    """Row r through the Python driver (the reference step)."""
    if lazy:
        # the forces of step r are read after step r + 1 (its start is step r's end:
        # PlatformBatch._advance(sample=False)), the pose right after step r
        sim._advance(sample=False)
        sim._read_fts()
        sim.read_start(idx, z, f)
        if r >= 2:
            rec.f[r - 1] = f
            rec.legs_f[r - 1] = sim.leg_force_sensor
            rec.fts[r - 1] = sim.fts_reading
        rec.q[r] = sim.live_qpos
        rec.legs_q[r] = sim._legs_q
    else:
        sim._advance()
        sim.read(idx, z, f)
        rec.f[r] = f
        rec.legs_f[r] = sim.meas_legs_f
        rec.fts[r] = sim.fts_reading
        rec.q[r] = sim.plate_qpos
        rec.legs_q[r] = sim.meas_legs_q
    rec.z[r] = z


def track_batch(sim: PlatformBatch, poses: np.ndarray, idx: np.ndarray, *,
                lazy: bool = False, compiled: bool = True) -> TrackRecord:
    """Step the (reset) batch through ``poses`` (N, 6) or (N, K, 6): row r ≥ 1 commanded at
    step r − 1, next poses from row r + 1 (a central feed-forward). ``idx``: the interface
    DOFs of ``z``/``f``. ``lazy``: skip the end-of-step ``mj_forward`` and read each step's
    forces at its successor's start (exact for a ramped set-point; one evaluation per step
    less). ``compiled``: compiled ranges where :func:`compiled_ok` (else Python)."""
    from ..jit import AnyLayout
    from .compiled import run_range

    P = np.asarray(poses, dtype=float)
    N, K = P.shape[0], sim.nsim
    if P.ndim == 2:
        P = np.broadcast_to(P[:, None, :], (N, K, 6))
    P = np.ascontiguousarray(P)
    Pn = np.ascontiguousarray(np.concatenate([P[1:], P[-1:]]))
    idx = np.ascontiguousarray(idx, dtype=np.int64)
    n = len(idx)
    rec = TrackRecord(np.zeros((N, K, 7)), np.zeros((N, K, 6)), np.zeros((N, K, 6)),
                      np.zeros((N, K, 6)), np.zeros((N, K, n)), np.zeros((N, K, n)),
                      np.full(K, N))
    z, f = np.zeros((K, n)), np.zeros((K, n))
    rec.q[0] = sim.live_qpos if lazy else sim.plate_qpos
    rec.legs_q[0] = sim._legs_q if lazy else sim.meas_legs_q
    rec.legs_f[0] = sim._legs_f if lazy else sim.meas_legs_f
    rec.fts[0] = sim.fts_reading
    args = None
    if compiled and compiled_ok(sim):
        args = _range_args(sim, P, Pn, idx, rec, z, f, lazy)
        # one specialisation per structure of the arguments (rths3d.jit), typed once here
        run = AnyLayout(run_range).entry(0, N - 1, sim.k, *args)
    if N > 1:
        rec.stop[sim.stopped] = 1  # stopped before the first step (e.g. while settling)
    r = 1
    while r < N:
        if sim._any_stopped and sim.stopped.all():
            break
        if args is None:
            sim.poses[:] = P[r]
            sim.poses_next[:] = Pn[r]
            _python_row(sim, r, lazy, idx, rec, z, f)
            r += 1
        else:
            done, code = run(r - 1, N - 1, sim.k, *args)
            sim.k += done
            r += done
            if code == 1:  # a command out of limits: the reference step freezes the test
                sim.poses[:] = P[r]
                sim.poses_next[:] = Pn[r]
                _python_row(sim, r, lazy, idx, rec, z, f)
                r += 1
            elif code:
                sim._check_status()
                from .kernels import measured_over

                if measured_over(sim._legs_q, sim._legs_v, sim._legs_f, sim._half, sim._vmax,
                                 sim._fmax, sim._run):
                    sim._measured_limits(sim._legs_q, sim._legs_v, sim._legs_f)
            sim.poses[:] = P[r - 1]
        if sim._any_stopped:
            for k in np.flatnonzero(sim.stopped & (rec.stop == N)):
                rec.stop[k] = r - 1
    if lazy:
        sim.batch.forward()
        sim._read_fts()
        sim.read(idx, z, f)
        rec.f[N - 1] = f
        rec.legs_f[N - 1] = sim._legs_f
        rec.fts[N - 1] = sim.fts_reading
    return rec


def platform_args(sim: PlatformBatch) -> tuple:
    """The platform's argument groups of the compiled kernels (views of ``sim``'s arrays):
    (geometry, controller, set-point chain, live MuJoCo views, FTS, sampling); the MuJoCo
    group is the caller's (:func:`_mj_tuple` and what its kernel adds)."""
    from ..effects.blocks import padded_kernels

    ch = sim.setpoint_chain
    chain = (*padded_kernels(ch.fns, ch.params, ch.states), ch._w, ch.empty)
    geo = (sim._b, sim._p, sim._hh, sim._home, sim._half, sim._vdt, sim._vmax, sim._fmax)
    ctl = (sim._ffg, sim._ffn, sim._Lprev, sim._L, np.zeros_like(sim._L), sim._sp,
           np.zeros_like(sim._sp), sim._off, sim._bias, sim._cprev, sim._cnew, sim._zoh,
           sim._inv_dt, sim._a0, sim._s0, sim._ahead, sim._Lnext, sim._lag)
    live = (sim._ctrl, sim._act, sim.live_qpos, sim._legs_q, sim._legs_v, sim._legs_f,
            sim.leg_force_sensor, sim._fts_quat, sim._live_R)
    has_c = sim._fts_C is not None
    C = sim._fts_C if has_c else np.zeros((1, 6, 6))
    fts = (has_c, C, sim._fts_b, sim._raw_force, sim._raw_torque, sim.fts_reading,
           sim._fts_force, sim._fts_torque)
    meas = (sim.plate_qpos, sim.meas_legs_q, sim.meas_legs_f, sim._fts_R)
    K = sim.nsim
    targets = meas if sim._any_start else (np.zeros((K, 7)), np.zeros((K, 6)),
                                            np.zeros((K, 6)), np.zeros((K, 9)))
    smp = (sim._start, sim._any_start, *targets, *meas)
    return geo, ctl, chain, live, fts, smp


def _range_args(sim: PlatformBatch, P, Pn, idx, rec: TrackRecord, z, f,
                lazy: bool) -> tuple:
    """The arguments of :func:`~rths3d.platform.compiled.run_range` after its step range."""
    geo, ctl, chain, live, fts, smp = platform_args(sim)
    mj = _mj_tuple(sim, not lazy)
    recs = (lazy, idx, sim._pre, sim.rest_pose, sim._R_start, z, f, rec.q, rec.legs_q,
            rec.legs_f, rec.fts, rec.z, rec.f, True)
    return (P[1:], Pn[1:], sim._run, geo, ctl, chain, mj, live, fts, smp, recs)
