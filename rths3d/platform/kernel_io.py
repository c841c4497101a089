"""What the compiled stepping kernels take from a :class:`~rths3d.platform.sim.PlatformBatch`.

The batch hands its arrays to the kernels (:mod:`rths3d.platform.compiled` for a known command
series, :mod:`rths3d.platform.closed` for the closed loop) through one object,
:meth:`PlatformBatch.kernel_arrays`, and its MuJoCo addresses through
:meth:`PlatformBatch.mujoco_arrays`; nothing outside the batch reads its private fields. The
groups are tuples in the order the kernels unpack them (numba takes tuples, not objects), each
a view of the batch's own arrays: a kernel writes the batch's state in place. They are valid
until the next :meth:`~PlatformBatch.reset` (which replaces the hold's and gravity
compensation's arrays): build them after it.
"""

from __future__ import annotations

from typing import NamedTuple

import mujoco
import numpy as np

__all__ = ["KernelArrays", "mujoco_group"]


class KernelArrays(NamedTuple):
    """The platform's argument groups of the compiled kernels (SI units; K tests).

    ``geometry``: (base anchors b (6, 3) m, top anchors p (6, 3) m in the plate frame — the
    controller's inverse kinematics —, home height m, home leg lengths (6,) m, half stroke m,
    v_max·ΔT m, v_max m/s, f_max N).
    ``controller``: (feed-forward gains on the backward and forward differences (K,), previous
    and current leg lengths L (K, 6) m and a scratch, set-points and a scratch (K, 6) m,
    gravity offsets (K, 6) m, encoder bias (K, 6) m, held set-points c_k and c_{k+1} (K, 6) m,
    zero-order hold per test (K,), 1/ΔT 1/s, first servo actuator id, its activation address,
    whether the central feed-forward needs the next pose, next lengths (K, 6) m, the servo
    lag after the hold (actuator id, activation address, 1/τ (K,) 1/s)).
    ``chain``: the set-point blocks' kernels, parameters, states, work array and empty flag.
    ``live``: MuJoCo's live views (ctrl, act, plate qpos (K, 7), leg extensions, velocities
    and forces (K, 6), leg force sensors (K, 6), FTS quaternion (K, 4), FTS rotation (K, 9)).
    ``fts``: (miscalibrated?, C (K, 6, 6), b (K, 6), raw force and torque (K, 3), reading
    (K, 6), its force and torque views).
    ``sampling``: (start-sampled per test (K,), any of them, the four sample targets, the four
    measured channels: plate qpos, leg extensions, leg forces, FTS rotation).
    """

    geometry: tuple
    controller: tuple
    chain: tuple
    live: tuple
    fts: tuple
    sampling: tuple


def mujoco_group(batch, model, nsim: int, scratch: list, forward: bool, substeps: int,
                 t0: float, dt: float, timestep: float) -> tuple[tuple, list]:
    """The MuJoCo tuple of :func:`~rths3d.platform.compiled.run_range` for the batch wrapper
    ``batch`` (:mod:`rths3d.platform.backend`): model and data addresses per test, the state
    and bound outputs of a ``mujoco.batch.Batch`` (stepped through one ``MjData`` per test,
    ``scratch``, kept by the caller across calls), substeps, ``forward`` (end-of-step
    ``mj_forward``), the time after settling ``t0`` s, ΔT s and the physics step s. Returns
    the tuple and the scratch list to keep."""
    from .compiled import _TIME_SIG, STATE_SIG

    K = nsim
    inner = batch.batch
    if inner is None:  # one MjData: stepped in place
        d = batch.d
        models, datas, rows = [model], [d], False
        state = np.zeros((1, 1))
        oaddr = np.zeros((1, 0), dtype=np.int64)
        daddr_out = np.zeros((1, 0), dtype=np.int64)
        osize = np.zeros(0, dtype=np.int64)
    else:
        ms = inner.models
        models = list(ms) if isinstance(ms, list | tuple) else [ms or model] * K
        if len(scratch) != K or any(
                s[0] is not m for s, m in zip(scratch, models, strict=True)):
            scratch = [(m, mujoco.MjData(m)) for m in models]
        datas = [s[1] for s in scratch]
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
    group = (maddr, daddr, rows, state, STATE_SIG, oaddr, daddr_out, osize, dact,
             int(substeps), np.zeros(K), _TIME_SIG, False, forward, float(t0), float(dt),
             float(timestep))
    return group, scratch
