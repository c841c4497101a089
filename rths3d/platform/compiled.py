"""The platform's interface steps compiled end to end: MuJoCo's C API called from numba.

:func:`run_range` advances K tests through a range of commanded poses in one compiled call:
inverse kinematics and set-points with the controller's conventions (the same kernels as the
Python driver, :mod:`rths3d.platform.kernels`), the set-point blocks (the effects' own
kernels, :func:`rths3d.effects.blocks.run_chain`), the servo's hold, ``mj_step`` and
``mj_forward`` of each test (the symbols of the ``libmujoco`` the ``mujoco`` wheel loaded,
on the tests' own ``mjModel``/``mjData`` pointers; threads over tests: the tests split
over batches, each range call releasing the GIL), the FTS and sampling, the divergence and
limit checks and the record rows. A test of a ``mujoco.batch.Batch`` is loaded from and
saved to its state row around its steps, as the batch itself does, so the Python driver
(:class:`~rths3d.platform.sim.PlatformBatch`) and this path share one state and give the
same records; a step that needs Python (a stop: its :class:`~rths3d.errors.SafetyStop`)
ends the call and the driver takes that step itself.
"""

from __future__ import annotations

import os
from glob import glob

import llvmlite.binding as llvm
import mujoco
import numba
from numba import types
from numba.extending import intrinsic

from ..kernels import njit, run_chain
from .kernels import (
    copy_fts,
    fts_distort,
    leg_lengths_of,
    leg_setpoints,
    measured_over,
    quat_rows,
    ramp_ctrl,
    read_interface,
    take_sample,
)

__all__ = ["STATE_SIG", "run_range"]


def _library() -> str:
    found = sorted(glob(os.path.join(os.path.dirname(mujoco.__file__), "libmujoco.so*")) +
                   glob(os.path.join(os.path.dirname(mujoco.__file__), "libmujoco*.dylib")))
    if not found:  # pragma: no cover - a wheel without its shared library
        raise ImportError("the mujoco wheel's shared library libmujoco was not found")
    return found[0]


# the library the wheel already loaded: its symbols become visible to numba's linker
llvm.load_library_permanently(_library())
_VV = types.void(types.voidptr, types.voidptr)
_mj_step = types.ExternalFunction("mj_step", _VV)
_mj_forward = types.ExternalFunction("mj_forward", _VV)
_STATE = types.void(types.voidptr, types.voidptr, types.CPointer(types.float64), types.int32)
_mj_getState = types.ExternalFunction("mj_getState", _STATE)
_mj_setState = types.ExternalFunction("mj_setState", _STATE)
STATE_SIG = int(mujoco.mjtState.mjSTATE_INTEGRATION)
"""The state components of a ``mujoco.batch.Batch`` row."""
_TIME_SIG = int(mujoco.mjtState.mjSTATE_TIME)


@intrinsic
def _voidp(typingctx, addr):
    """An integer address as a ``void*``."""
    sig = types.voidptr(addr)

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], context.get_value_type(types.voidptr))

    return sig, codegen


@intrinsic
def _f64p(typingctx, addr):
    """An integer address as a ``double*``."""
    sig = types.CPointer(types.float64)(addr)

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], context.get_value_type(types.CPointer(types.float64)))

    return sig, codegen


@numba.njit(cache=True, nogil=True, inline="always")
def flat(a):
    """The rows of a (K, n) float array that is contiguous in memory, as one (K·n,) view.

    The range kernels are compiled for arrays of any layout (:mod:`rths3d.jit`), for which
    numba has no ``reshape``; the arrays flattened here are the loop's own contiguous
    buffers, and a strided one is refused rather than misread."""
    K, n = a.shape
    if (K > 1 and a.strides[0] != n * 8) or (n > 1 and a.strides[1] != 8):
        raise ValueError("flat: a strided array")
    return numba.carray(_f64p(a.ctypes.data), K * n)


# the MuJoCo tuple ``mj`` of run_range (built by rths3d.platform.sim.PlatformBatch):
# 0 model addresses (K,), 1 data addresses (K,), 2 whether tests live in batch state rows,
# 3 the state rows (K, nstate), 4 their signature, 5 output addresses (K, F) of the bound
# derived fields and 6 the data's (K, F), 7 their sizes (F,), 8 the data's act addresses
# (K,), 9 substeps, 10 each test's time after its step (K,), 11 the time signature,
# 12 (unused), 13 mj_forward after the step (every channel at its end), 14 the
# time at k = 0 (s), 15 ΔT (s), 16 the physics step (s)


@numba.njit(cache=True, nogil=True, inline="always")
def _physics_one(k, mj, cnew, act, s0):
    """Test k's physics: (load its state row) substeps × mj_step, the set-point exactly
    c_{k+1} (end of the ramp), mj_forward, (save the row and copy the outputs); its time
    afterwards."""
    m = _voidp(mj[0][k])
    d = _voidp(mj[1][k])
    rows = mj[2]
    if rows:
        _mj_setState(m, d, _f64p(mj[3][k].ctypes.data), mj[4])
    for _ in range(mj[9]):
        _mj_step(m, d)
    if rows:
        _mj_getState(m, d, _f64p(mj[3][k].ctypes.data), mj[4])
    da = numba.carray(_f64p(mj[8][k]), s0 + 6)
    for i in range(6):
        act[k, s0 + i] = cnew[k, i]
        da[s0 + i] = cnew[k, i]
    if mj[13]:
        _mj_forward(m, d)
    tb = mj[10]
    if rows:
        copy_outputs(k, mj)
        tb[k] = mj[3][k, 0]
    else:
        _mj_getState(m, d, _f64p(tb[k:k + 1].ctypes.data), mj[11])


@numba.njit(cache=True, nogil=True, inline="always")
def copy_outputs(k, mj):
    """Test k's derived fields the driver reads (a batch's bound outputs), from its
    ``MjData`` into the batch's arrays."""
    osize = mj[7]
    for j in range(osize.shape[0]):
        n = osize[j]
        src = numba.carray(_f64p(mj[6][k, j]), n)
        dst = numba.carray(_f64p(mj[5][k, j]), n)
        for i in range(n):
            dst[i] = src[i]


@njit
def physics(run, mj, cnew, act, s0, cprev):
    """Every running test's physics for one interface step, one after the other (threads
    over tests: split the tests over several batches, each stepped by its own call, which
    releases the GIL); ``cprev = cnew`` after."""
    for k in range(run.shape[0]):
        if run[k]:
            _physics_one(k, mj, cnew, act, s0)
            for i in range(6):
                cprev[k, i] = cnew[k, i]


@njit
def _diverged(run, tbuf, expected):
    """A running test whose time is behind: MuJoCo reset its state (a bad acceleration)."""
    for k in range(run.shape[0]):
        if run[k] and not tbuf[k] >= expected:
            return True
    return False


@njit
def read_fts(fts):
    """The FTS reading of the last evaluation: MuJoCo's, or ``C w + b``."""
    has_c, C, bo, sf, st, reading, of, ot = fts
    if has_c:
        fts_distort(sf, st, C, bo, of, ot)
    else:
        copy_fts(sf, st, reading)


@numba.njit(cache=True, nogil=True, inline="always")
def _rows_now(row, K, q, lq, lf, reading, z, f, q_rec, lq_rec, lf_rec, ft_rec, z_rec, f_rec):
    for k in range(K):
        for c in range(7):
            q_rec[row, k, c] = q[k, c]
        for i in range(6):
            lq_rec[row, k, i] = lq[k, i]
            lf_rec[row, k, i] = lf[k, i]
            ft_rec[row, k, i] = reading[k, i]
        for j in range(z.shape[1]):
            z_rec[row, k, j] = z[k, j]
            f_rec[row, k, j] = f[k, j]


@njit
def run_range(n0, n1, k0, P, Pn, run, geo, ctl, chain, mj, live, fts, smp, rec):
    """Interface steps n0 … n1−1 (poses ``P[n]``, next poses ``Pn[n]``) of K tests, see the
    module docstring; ``k0``: the driver's step count at n0. Returns (steps done, code):
    code 0 all done; 1 step n0 + done has a command out of limits (not taken: the driver
    takes it); 2 a test diverged and 3 a measured limit was crossed in the last step done
    (the driver freezes those tests)."""
    b, p, hh, home, half, vdt, vmax, fmax = geo
    (ffg, ffn, Lprev, L, Lsave, sp, y, off, bias, cprev, cnew, zoh, inv_dt, a0, s0, ahead,
     Lnext, lag) = ctl
    fs, ps, ss, w, empty = chain
    ctrl, act, qlive, legs_q, legs_v, legs_f, legf_sens, fquat, Rlive = live
    # sample buffers a start-sampling test writes (writable), and the measured channels
    start, any_start, tq, tlq, tlf, tR, qm, lqm, lfm, Rm = smp
    (lazy, idx, pre, rest, R_start, z, f, q_rec, lq_rec, lf_rec, ft_rec, z_rec, f_rec,
     record) = rec
    has_c, C, bo, sf, st, reading, of, ot = fts
    t0, dt, h = mj[14], mj[15], mj[16]
    K = P.shape[1]
    yr = flat(y)
    spr = flat(sp)
    for n in range(n0, n1):
        if ahead:
            leg_lengths_of(Pn[n], b, p, hh, Lnext)
        if any_start:
            take_sample(start, True, qlive, legs_q, legs_f, Rlive, tq, tlq, tlf, tR, sf, st, C,
                        bo, reading)
        for k in range(K):
            for i in range(6):
                Lsave[k, i] = Lprev[k, i]
        if leg_setpoints(P[n], b, p, hh, home, ffg, Lprev, L, sp, half, vdt, run, True,
                         ffn, Lnext, ahead):
            for k in range(K):
                for i in range(6):
                    Lprev[k, i] = Lsave[k, i]
            return n - n0, 1
        if empty:
            ramp_ctrl(sp, off, bias, cprev, cnew, ctrl, a0, inv_dt, run, zoh, act, s0,
                         lag)
        else:
            run_chain(fs, ps, ss, spr, yr, w)
            ramp_ctrl(y, off, bias, cprev, cnew, ctrl, a0, inv_dt, run, zoh, act, s0,
                         lag)
        physics(run, mj, cnew, act, s0, cprev)
        row = n + 1
        if not lazy:  # every channel at t_{k+1} from one state
            if any_start:
                take_sample(start, False, qlive, legs_q, legs_f, Rlive, tq, tlq, tlf, tR, sf,
                            st, C, bo, reading)
            else:
                read_fts(fts)
            if record:
                read_interface(qm, hh, idx, Rm, of, ot, pre, z, f, rest)
                _rows_now(row, K, qm, lqm, lfm, reading, z, f, q_rec, lq_rec, lf_rec, ft_rec,
                          z_rec, f_rec)
        else:  # the forces of step r are its successor's start-of-step evaluation
            read_fts(fts)
            quat_rows(fquat, R_start)
            read_interface(qlive, hh, idx, R_start, of, ot, pre, z, f, rest)
            for k in range(K):
                for j in range(z.shape[1]):
                    z_rec[row, k, j] = z[k, j]
                for c in range(7):
                    q_rec[row, k, c] = qlive[k, c]
                for i in range(6):
                    lq_rec[row, k, i] = legs_q[k, i]
                if row >= 2:
                    for j in range(f.shape[1]):
                        f_rec[row - 1, k, j] = f[k, j]
                    for i in range(6):
                        lf_rec[row - 1, k, i] = legf_sens[k, i]
                        ft_rec[row - 1, k, i] = reading[k, i]
        if _diverged(run, mj[10], t0 + (k0 + n - n0 + 1) * dt - 0.5 * h):
            return n + 1 - n0, 2
        if measured_over(legs_q, legs_v, legs_f, half, vmax, fmax, run):
            return n + 1 - n0, 3
    return n1 - n0, 0
