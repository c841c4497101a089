"""Ranges of interface steps of a :class:`~rths3d.platform.sim.PlatformBatch` through a
known command series: the open-loop replay's and the tracking benchmarks' stepping.

:func:`track_batch` steps K tests through commanded poses and returns every measured
channel per row, either one Python-driven step at a time (the readable reference:
:meth:`PlatformBatch.advance` and its reads) or in compiled ranges
(:func:`rths3d.platform.compiled.run_range`), which hand the steps that need Python (a stop)
back to the same reference step. Both give the same records (tests/test_platform_compiled.py).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

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


def compiled_ok(sim: PlatformBatch, hook: bool = False) -> bool:
    """Whether the compiled range can step this batch: inverse kinematics of the poses (no
    per-leg hook; ``hook``: the caller steps the hook itself), no noise in the set-point
    blocks, no per-test model fields expanded inside a ``mujoco.batch.Batch`` (its own model
    copies)."""
    if (sim.leg_hook is not None and not hook) or sim.setpoint_chain.noise is not None:
        return False
    inner = sim.batch.batch
    return inner is None or not getattr(inner, "_expanded", {})


def _python_row(sim: PlatformBatch, r: int, lazy: bool, idx: np.ndarray, rec: TrackRecord,
                z: np.ndarray, f: np.ndarray) -> None:
    """Row r through the Python driver (the reference step)."""
    if lazy:
        # the forces of step r are read after step r + 1 (its start is step r's end:
        # PlatformBatch.advance(sample=False)), the pose right after step r
        sim.advance(sample=False)
        sim.read_fts()
        sim.read_start(idx, z, f)
        if r >= 2:
            rec.f[r - 1] = f
            rec.legs_f[r - 1] = sim.leg_force_sensor
            rec.fts[r - 1] = sim.fts_reading
        rec.q[r] = sim.live_qpos
        rec.legs_q[r] = sim.live_legs_q
    else:
        sim.advance()
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
    from ..kernels import AnyLayout
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
    rec.legs_q[0] = sim.live_legs_q if lazy else sim.meas_legs_q
    rec.legs_f[0] = sim.live_legs_f if lazy else sim.meas_legs_f
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
        if sim.any_stopped and sim.stopped.all():
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
                sim.check_status()
                sim.check_measured()
            sim.poses[:] = P[r - 1]
        if sim.any_stopped:
            for k in np.flatnonzero(sim.stopped & (rec.stop == N)):
                rec.stop[k] = r - 1
    if lazy:
        sim.batch.forward()
        sim.read_fts()
        sim.read(idx, z, f)
        rec.f[N - 1] = f
        rec.legs_f[N - 1] = sim.live_legs_f
        rec.fts[N - 1] = sim.fts_reading
    return rec


def _range_args(sim: PlatformBatch, P, Pn, idx, rec: TrackRecord, z, f,
                lazy: bool) -> tuple:
    """The arguments of :func:`~rths3d.platform.compiled.run_range` after its step range."""
    geo, ctl, chain, live, fts, smp = sim.kernel_arrays()
    mj = sim.mujoco_arrays(not lazy)
    recs = (lazy, idx, sim.tare_wrench, sim.rest_pose, sim.fts_R_start, z, f, rec.q, rec.legs_q,
            rec.legs_f, rec.fts, rec.z, rec.f, True)
    return (P[1:], Pn[1:], sim.running, geo, ctl, chain, mj, live, fts, smp, recs)
