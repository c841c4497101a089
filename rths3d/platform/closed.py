"""The closed vRTHS loop with the Stewart platform compiled end to end.

:func:`closed_range` advances a range of interface steps of K tests in one compiled call:
the linear numerical substructure's step (:func:`~rths3d.numerical._kernels.linear_step`)
and the command check, the compensator's kernel (those with ``compiled()``: every shipped
compensator, the adaptive ones with their adaptation and drift stops; per interface DOF, or
per leg in place of the platform's leg hook), the
platform's step as :meth:`PlatformBatch.advance <rths3d.platform.sim.PlatformBatch.advance>`
takes it (inverse kinematics, set-point blocks, the servo's hold, ``mj_step``/``mj_forward``
through MuJoCo's C API, :mod:`rths3d.platform.compiled`), the FTS and sampling, the sensor
chain and the measurement noise (draws taken before the range, in the order the Python
driver draws them), the copies of the record signals, the record row and the force
checks. A step in which the platform stops a test (a command or measured limit, a
divergence) or the compensator raises its drift stop is taken in full and ends the call;
:class:`ClosedRange` then does what needs Python for it (the
:class:`~rths3d.errors.SafetyStop` and its reason, the monitor's stop) with the Python
driver's own methods, and the next call goes on. The Python driver
(:meth:`rths3d.loop._Group._python`) stays the readable reference; both give the same
record (tests/test_closed_stewart.py).
"""

from __future__ import annotations

import math
import os
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import mujoco
import numba
import numpy as np
from numba import literal_unroll, types

from ..kernels import AnyLayout, inline_njit, njit, padded_kernels, run_chain
from ..numerical._kernels import linear_step
from ..safety import check_command, check_measured
from ..stepping import record_row
from .backend import _MAXVAL
from .compiled import (
    _diverged,
    _f64p,
    _mj_forward,
    _mj_getState,
    _mj_setState,
    _mj_step,
    _voidp,
    copy_outputs,
    flat,
    physics,
    read_fts,
)
from .kernels import (
    commands_out,
    interface_command,
    leg_channels,
    leg_setpoints,
    measured_over,
    ramp_ctrl,
    read_interface,
    take_sample,
)

__all__ = ["ClosedRange", "closed_ok", "closed_range"]

_VV = types.void(types.voidptr, types.voidptr)
_check_pos = types.ExternalFunction("mj_checkPos", _VV)
_check_vel = types.ExternalFunction("mj_checkVel", _VV)
_check_acc = types.ExternalFunction("mj_checkAcc", _VV)
_euler = types.ExternalFunction("mj_Euler", _VV)
_implicit = types.ExternalFunction("mj_implicit", _VV)
_rk = types.ExternalFunction("mj_RungeKutta", types.void(types.voidptr, types.voidptr,
                                                         types.int32))
_forward_skip = types.ExternalFunction("mj_forwardSkip", types.void(
    types.voidptr, types.voidptr, types.int32, types.int32))
_fwd_actuation = types.ExternalFunction("mj_fwdActuation", _VV)
_VEL = int(mujoco.mjtStage.mjSTAGE_VEL)
_CTRL = int(mujoco.mjtState.mjSTATE_CTRL)
_ACT = int(mujoco.mjtState.mjSTATE_ACT)
_RK4 = int(mujoco.mjtIntegrator.mjINT_RK4)
_EULER = int(mujoco.mjtIntegrator.mjINT_EULER)


@inline_njit
def _step_warm(m, d, integ, rate_only):
    """``mj_step`` of a state the previous step's end-of-step ``mj_forward`` evaluated, when
    only the control and the servo's set-point changed since: ``mj_step``'s own sequence
    with its first evaluation from the actuation stage on (the position and velocity
    stages are those of the state). ``rate_only``: only the set-point *rate* changed (the
    control of an integrator-dynamics actuator, whose force depends on its activation, not
    on its control), which changes the activation's derivative and nothing else — the
    actuation stage is recomputed (``act_dot``) and the evaluation's accelerations stand
    (the constraint solve it would repeat starts from the same warm start with the same
    inputs and gives the same ``qacc``): bare ``mj_step``'s count of constraint solves. The
    same arithmetic on the same inputs either way."""
    _check_pos(m, d)
    _check_vel(m, d)
    if rate_only:
        _fwd_actuation(m, d)
    else:
        _forward_skip(m, d, _VEL, 1)
    _check_acc(m, d)
    if integ == _RK4:
        _rk(m, d, 4)
    elif integ == _EULER:
        _euler(m, d)
    else:
        _implicit(m, d)


@njit
def physics_warm(run, mj, cnew, act, s0, cprev, integ, ctrl, zoh, rate_only):
    """:func:`~rths3d.platform.compiled.physics` of one ``MjData`` per test stepped in
    place, the first substep from the warm state (:func:`_step_warm`): the previous step of
    this range ended with ``mj_forward`` of the same state in the same ``MjData``; with
    ``rate_only`` (every actuator's force independent of its control) a ramped test's first
    substep reuses that evaluation whole (:func:`_step_warm`). A batch's
    tests (state rows) keep their own ``MjData`` live too: the row is not loaded again (the
    range's first step loaded it), only saved after the step with the derived fields the
    driver reads; the servo's set-point (``act`` and ``ctrl``, written into the row by the
    driver) goes into the ``MjData`` before the step."""
    rows = mj[2]
    tb = mj[10]
    for k in range(run.shape[0]):
        if run[k]:
            m = _voidp(mj[0][k])
            d = _voidp(mj[1][k])
            if rows:  # the set-point (held: act; ramped: its rate, ctrl) as the driver wrote it
                _mj_setState(m, d, _f64p(act[k:k + 1].ctypes.data), _ACT)
                _mj_setState(m, d, _f64p(ctrl[k:k + 1].ctypes.data), _CTRL)
            # a held set-point jumps now: its force changes, the step evaluates it
            _step_warm(m, d, integ, rate_only and not zoh[k])
            for _ in range(mj[9] - 1):
                _mj_step(m, d)
            da = numba.carray(_f64p(mj[8][k]), s0 + 6)
            for i in range(6):
                act[k, s0 + i] = cnew[k, i]
                da[s0 + i] = cnew[k, i]
                cprev[k, i] = cnew[k, i]
            _mj_forward(m, d)
            if rows:
                _mj_getState(m, d, _f64p(mj[3][k].ctypes.data), mj[4])
                copy_outputs(k, mj)
                tb[k] = mj[3][k, 0]
            else:
                _mj_getState(m, d, _f64p(tb[k:k + 1].ctypes.data), mj[11])


@njit
def _copy_signals(hist, row):
    for pair in literal_unroll(hist):
        src, h = pair
        for k in range(src.shape[0]):
            for j in range(src.shape[1]):
                h[row, k, j] = src[k, j]


@njit
def _halt(P, s, active, row, n, exact):
    """Tests the monitor stopped at step n rest from now on (load and state zeroed)."""
    for k in range(active.shape[0]):
        if not active[k] and (row[k] == n if exact else row[k] >= n):
            P[:, k, :] = 0.0
            s[k, :] = 0.0


@njit
def closed_range(n0, n1, w0, k0, num, mon, rec, comp, io, sens, znz, hist, plat):
    """Steps n0 … n1−1 of the closed loop (module docstring); ``w0``: the step of the noise
    buffers' first row; ``k0``: the platform's step count at n0. Returns (steps done,
    code): code 0 ran through (or every test stopped); 1 the last step done stopped a test
    on the platform's side (``cmd[0]``: by a command limit, its L − L_home and ΔL in
    ``cmd[1]``, ``cmd[2]``) or raised a compensator's safety event, the driver finishes
    it."""
    Ad, Bf, P, s, s_next, Czx, Czv, Cx = num
    (lim_z, lim_v, lim_x, lim_f, g_win, g_fac, g_n, g_floor, g_pk, g_prev, g_base, g_cnt,
     active, code, dof, value, row) = mon
    data, c_zc, c_zm, c_f, c_x = rec
    cf, cp, cs, legs, lrates, ls_des, ls_rate, ls_meas, lu = comp
    z, zd, x, u, zm, fm, fraw, poses, idx, cmd_flag, cmd_s, cmd_dl = io
    sfs, sps, sss, sempty, swb = sens
    zhas, zfs, zps, zss, zwb = znz
    geo, ctl, chain, mj, live, fts, smp, rd = plat
    b, p, hh, home, half, vdt, vmax, fmax = geo
    (ffg, ffn, Lprev, L, Lsave, sp, y, off, bias, cprev, cnew, zoh, inv_dt, a0, s0, ahead,
     Lnext, lag) = ctl
    fs, ps, ss, w, empty = chain
    ctrl, act, qlive, legs_q, legs_v, legs_f, legf_sens, fquat, Rlive = live
    start, any_start, tq, tlq, tlf, tR, qm, lqm, lfm, Rm = smp
    pre, rest = rd
    has_c, C, bo, sf, st, reading, of, ot = fts
    t0, dt, h = mj[14], mj[15], mj[16]
    run, warm, rate_only = mj[17], mj[18], mj[19]
    K = z.shape[0]
    zr, zdr, zmr, ur = flat(z), flat(zd), flat(zm), flat(u)
    fmr, frr = flat(fm), flat(fraw)
    yr = flat(y)
    spr = flat(sp)
    for n in range(n0, n1):
        linear_step(Ad, Bf, P, n, fm, s, s_next, Czx, Czv, Cx, z, zd, x)
        if check_command(z, zd, x, lim_z, lim_v, lim_x, active, code, dof, value, row, n):
            _halt(P, s, active, row, n, True)
            if not active.any():
                return n - n0, 0
        # an adaptive compensator's drift or oscillation stop: the step is taken in full,
        # then handed back (the driver turns the event into the stop)
        if legs:  # per-leg compensation (LegCompensation.command): z on, ż to the legs' rates
            event = False
            for r in range(zr.shape[0]):
                ur[r] = zr[r]
            interface_command(zd, idx, lrates)
        else:
            event = cf[0](cp, cs, zr, zdr, zmr, ur)
        interface_command(u, idx, poses)
        # the platform's step (PlatformBatch.advance, sample=True)
        if any_start:
            take_sample(start, True, qlive, legs_q, legs_f, Rlive, tq, tlq, tlf, tR, sf, st, C,
                        bo, reading)
        cmd_flag[0] = False
        if legs:  # the platform's leg hook (LegCompensation.__call__)
            leg_channels(poses, lrates, b, p, hh, home, legs_q, ls_des, ls_rate, ls_meas)
            if cf[0](cp, cs, flat(ls_des), flat(ls_rate), flat(ls_meas), flat(lu)):
                event = True
            commands_out(lu, home, L)
        if leg_setpoints(poses, b, p, hh, home, ffg, Lprev, L, sp, half, vdt, run, not legs,
                         ffn, Lnext, ahead):
            # the driver stops those tests (PlatformBatch._command_limits); they are not
            # stepped from here on
            event = True
            cmd_flag[0] = True
            for k in range(K):
                for i in range(6):
                    cmd_s[k, i] = L[k, i] - home[i]
                    cmd_dl[k, i] = L[k, i] - Lprev[k, i]
            for k in range(K):
                if run[k]:
                    for i in range(6):
                        if not (abs(cmd_s[k, i]) <= half and abs(cmd_dl[k, i]) <= vdt):
                            run[k] = False
        if not empty:
            run_chain(fs, ps, ss, spr, yr, w)
        any_run = False
        for k in range(K):
            if run[k]:
                any_run = True
        if any_run:
            if empty:
                ramp_ctrl(sp, off, bias, cprev, cnew, ctrl, a0, inv_dt, run, zoh, act, s0,
                         lag)
            else:
                ramp_ctrl(y, off, bias, cprev, cnew, ctrl, a0, inv_dt, run, zoh, act, s0,
                         lag)
            if warm >= 0 and n > n0:
                physics_warm(run, mj, cnew, act, s0, cprev, warm, ctrl, zoh, rate_only)
            else:
                physics(run, mj, cnew, act, s0, cprev)
            if any_start:
                take_sample(start, False, qlive, legs_q, legs_f, Rlive, tq, tlq, tlf, tR, sf,
                            st, C, bo, reading)
            else:
                read_fts(fts)
            if _diverged(run, mj[10], t0 + (k0 + n - n0 + 1) * dt - 0.5 * h):
                event = True
            if measured_over(legs_q, legs_v, legs_f, half, vmax, fmax, run):
                event = True
        # the transfer system's outputs: achieved DOFs, sensor chain, measurement noise
        if sempty:
            read_interface(qm, hh, idx, Rm, of, ot, pre, zm, fm, rest)
        else:
            read_interface(qm, hh, idx, Rm, of, ot, pre, zm, fraw, rest)
            run_chain(sfs, sps, sss, frr, fmr, swb[(n - w0) % swb.shape[0]])
        if zhas:
            run_chain(zfs, zps, zss, zmr, zmr, zwb[(n - w0) % zwb.shape[0]])
        if event:
            return n + 1 - n0, 1
        _copy_signals(hist, n + 1)
        record_row(data, n + 1, z, zm, fm, x, c_zc, c_zm, c_f, c_x)
        if check_measured(fm, lim_f, g_win, g_fac, g_n, g_floor, g_pk, g_prev, g_base, g_cnt,
                          active, code, dof, value, row, n):
            _halt(P, s, active, row, n, False)
            if not active.any():
                return n + 1 - n0, 0
    return n1 - n0, 0


# one specialisation per structure of the arguments, whatever the views' layouts (rths3d.jit)
_CLOSED = AnyLayout(closed_range)


def closed_ok(transfer: Any) -> bool:
    """Whether the compiled closed loop can step this Stewart transfer system: a compensator
    with a kernel (every shipped one; per interface DOF, or per leg in place of the
    platform's hook), no noise in the set-point blocks, no per-test model fields expanded
    inside a ``mujoco.batch.Batch``, at most one noise block in the sensor chain."""
    from .ranges import compiled_ok

    sim = transfer.sim
    comp = transfer.compensator
    hook = sim.leg_hook
    if comp.compiled() is None or (hook is not None and hook is not comp) \
            or not compiled_ok(sim, hook=hook is not None):
        return False
    if sim.needs_next_setpoint:
        return False
    for sig in transfer.signals:
        src = sig.source
        if src.ndim < 2 or not np.shares_memory(src.reshape(src.shape[0], -1), src):
            return False
    return True


def _chain_args(chain: Any) -> tuple:
    return chain.fns, chain.params, chain.states


_POOL: list[ThreadPoolExecutor] = []


def _pool() -> ThreadPoolExecutor:
    """The threads that step the chunks of a batch (one per core, shared by every batch)."""
    if not _POOL:
        _POOL.append(ThreadPoolExecutor(os.cpu_count() or 1, thread_name_prefix="closed"))
    return _POOL[0]


def _rows(arrs: tuple, a: int, b: int, n: int) -> tuple:
    """Rows a·n … b·n of per-row arrays (K·n rows: tests a … b−1)."""
    return tuple(x[a * n:b * n] for x in arrs)


class ClosedRange:
    """The compiled closed loop of one loop group (``group``: :class:`rths3d.loop._Group`
    with a linear numerical substructure and a Stewart transfer system): ``self(n0, n1)``
    steps n0 … n1−1 like the group's Python driver and returns the steps done.

    A batch of tests in a ``mujoco.batch.Batch`` is split into chunks of tests (one per
    core), each chunk's range one call on a thread (the calls release the GIL; every test
    has its own ``MjData``); a chunk whose step stops a test on the platform is finished by
    the driver and goes on, independently of the others."""

    def __init__(self, group: Any, chunks: int | None = None):
        self.g = g = group
        tr = self.tr = g.transfer
        self.sim = tr.sim
        K, nd = g.K, g.nd
        self.num_c = g.num.compiled()
        self.comp = tr.compensator.compiled()
        comp = tr.compensator
        self.legs = sim_hook = self.sim.leg_hook is not None
        # per-leg compensation steps the hook's own arrays (the Python driver's too)
        self.leg_arrays = (comp.rates, comp.s_des, comp.s_rate, comp.s_meas, comp.comp.u) \
            if sim_hook else tuple(np.zeros((K, 6)) for _ in range(5))
        self.u = np.zeros((K, nd))
        self.fraw = tr._f
        self.hist = tuple((sig.source.reshape(sig.source.shape[0], -1),
                           h.reshape(h.shape[0], h.shape[1], -1))
                          for sig, h in zip(tr.signals, g.hist, strict=True))
        self.plat = self._plat()
        rows = bool(self.plat[3][2])
        c = chunks if chunks is not None else (min(K, os.cpu_count() or 1) if rows else 1)
        c = max(1, min(int(c), K))
        bounds = np.linspace(0, K, c + 1).round().astype(int)
        self.parts = [(int(bounds[i]), int(bounds[i + 1])) for i in range(c)]
        self.static = [self._static(a, b) for a, b in self.parts]
        self.pool = _pool() if c > 1 else None
        self._entries: list[Any] = [None] * c  # the compiled closed_range per chunk

    def _plat(self) -> tuple:
        sim = self.sim
        geo, ctl, chain, live, fts, smp = sim.kernel_arrays()
        mt = sim.mujoco_arrays(True)
        # the warm first substep: one MjData per test stepped in place (a batch's state
        # rows are loaded by a range's first step only)
        m = sim.model
        warm = int(m.opt.integrator) if not (
            m.opt.enableflags & int(mujoco.mjtEnableBit.mjENBL_FWDINV)) else -1
        # an integrator-dynamics servo's force depends on its activation only: a ramped step's
        # control (the set-point rate) leaves the end-of-step evaluation valid but its act_dot
        # (a servo lag's filter likewise: its force is its activation's)
        rate_only = bool(m.nu) and bool(np.all(np.isin(
            m.actuator_dyntype, (int(mujoco.mjtDyn.mjDYN_INTEGRATOR),
                                 int(mujoco.mjtDyn.mjDYN_FILTER))))) and not bool(
            np.any(m.actuator_actearly))
        mj = (*mt, sim.running, warm, rate_only)
        return (geo, ctl, chain, mj, live, fts, smp, (sim.tare_wrench, sim.rest_pose))

    def _static(self, a: int, b: int) -> tuple:
        """The arguments of tests a … b−1 that do not change between calls (views)."""
        g, tr, sim = self.g, self.tr, self.sim
        nd = g.nd
        sl = slice(a, b)
        Ad, Bf, P, s, s_next, Czx, Czv, Cx = self.num_c
        num = (Ad if Ad.shape[0] == 1 else Ad[sl], Bf if Bf.shape[0] == 1 else Bf[sl],
               P[:, sl], s[sl], s_next[sl], Czx, Czv, Cx)
        mon = tuple(x[sl] for x in g._monitor_arrays())
        rec = (g.data[:, sl], g.c_zc, g.c_zm, g.c_f, g.c_x)
        cf, cp, cs = self.comp
        w = 6 if self.legs else nd  # the compensator's channels per test
        comp = (cf, cp[a * w:b * w], cs[a * w:b * w], self.legs,
                *(x[sl] for x in self.leg_arrays))
        cmd = (np.zeros(1, dtype=np.bool_), np.zeros((b - a, 6)), np.zeros((b - a, 6)))
        io = (g.num.z[sl], g.num.zdot[sl], g.num.x[sl], self.u[sl], tr.z_meas[sl],
              tr.f_meas[sl], self.fraw[sl], sim.poses[sl], tr.idx, *cmd)
        hist = tuple((src[sl], h[:, sl]) for src, h in self.hist)
        geo, ctl, chain, mj, live, fts, smp, rd = self.plat
        ctl = tuple(x[sl] if i in (0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 16) else x
                    for i, x in enumerate(ctl))
        fs, ps, ss, w, empty = chain
        chain = (fs, _rows(ps, a, b, 6), _rows(ss, a, b, 6), w[a * 6:b * 6], empty)
        mj = tuple(x[sl] if i in (0, 1, 3, 5, 6, 8, 10, 17) else x for i, x in enumerate(mj))
        live = tuple(x[sl] for x in live)
        fts = (fts[0], fts[1][sl] if fts[0] else fts[1], *(x[sl] for x in fts[2:]))
        smp = (smp[0][sl], smp[1], *(x[sl] for x in smp[2:]))
        rd = tuple(x[sl] for x in rd)
        sen = tr.sensor
        fns, ps, ss = padded_kernels(sen.fns, sen.params, sen.states)
        sens = (fns, _rows(ps, a, b, nd), _rows(ss, a, b, nd), sen.empty)
        zn = tr._znoise
        znz = (True, (type(zn).kernel,), (zn.params[a * nd:b * nd],),
               (zn.state[a * nd:b * nd],)) if zn is not None else \
            (False, sens[0][:1], sens[1][:1], sens[2][:1])
        return (num, mon, rec, comp, io, sens, znz, hist,
                (geo, ctl, chain, mj, live, fts, smp, rd), cmd)

    def __call__(self, n0: int, n1: int) -> int:
        from ..stepping import noise_buffer

        g, tr, sim = self.g, self.tr, self.sim
        R = g.K * g.nd
        steps = n1 - n0
        sw = noise_buffer(tr.sensor, steps, R)
        zn = tr._znoise
        zw = np.zeros((1, R))
        if zn is not None:
            zw = np.empty((steps, R))
            zn.draw(zw)
        nd = g.nd
        calls = []
        for (a, b), st in zip(self.parts, self.static, strict=True):
            num, mon, rec, comp, io, sens, znz, hist, plat, cmd = st
            sens = (*sens, np.ascontiguousarray(sw[:, a * nd:b * nd]))
            znz = (*znz, np.ascontiguousarray(zw[:, a * nd:b * nd]))
            calls.append([n0, (num, mon, rec, comp, io, sens, znz, hist, plat), cmd, a, b])
        sim.fresh = False
        k0 = sim.k
        pos = [n0] * len(calls)
        todo = list(range(len(calls)))
        while todo:
            def one(i: int) -> tuple[int, int]:
                n = pos[i]
                args = (n, n1, n0, k0 + n - n0, *calls[i][1])
                run = self._entries[i]
                if run is None:  # typed once: the arguments keep their types between calls
                    run = self._entries[i] = _CLOSED.entry(*args)
                return run(*args)

            res = list(self.pool.map(one, todo)) if self.pool is not None and len(todo) > 1 \
                else [one(i) for i in todo]
            nxt = []
            for i, (done, code) in zip(todo, res, strict=True):
                pos[i] += done
                if code:  # the step that stopped a test on the platform: finish it
                    self._finish(pos[i] - 1, k0 + pos[i] - n0, *calls[i][2:])
                a, b = calls[i][3], calls[i][4]
                if pos[i] < n1 and g.monitor.active[a:b].any():
                    nxt.append(i)
            todo = nxt
        done = max(pos) - n0
        tr.compensator.calls += done
        sim.k = k0 + done
        return done

    def _finish(self, n: int, k: int, cmd: tuple, a: int, b: int) -> None:
        """Step n of tests a … b−1 after the platform's part, as PlatformBatch.advance
        and StewartTransfer.step finish it (``k``: the platform's step count after it): its
        stops, the signals' row, the record row and the checks."""
        from ..stepping import post_step
        from .kernels import measured_over as over

        g, tr, sim, mon = self.g, self.tr, self.sim, self.g.monitor
        sl = slice(a, b)
        whole = a == 0 and b == g.K
        keep = sim.k
        if cmd[0][0]:
            sim.k = k - 1
            s, dl = np.zeros((g.K, 6)), np.zeros((g.K, 6))
            s[sl], dl[sl] = cmd[1], cmd[2]
            sim.command_limits(s, dl)
        sim.k = k
        if whole:
            sim.check_status()
        else:
            self._diverged(sl)
        q, v, f = sim.live_legs_q, sim.live_legs_v, sim.live_legs_f
        if over(q[sl], v[sl], f[sl], sim.half_stroke, sim.velocity_limit, sim.force_limit,
                sim.running[sl]):
            if whole:
                sim.measured_limits(q, v, f)
            else:
                mask = np.zeros((g.K, 1))
                mask[sl] = 1.0
                sim.measured_limits(q * mask, v * mask, f * mask)
        sim.k = keep
        if sim.any_stopped:
            tr.stopped[:] = sim.stopped
            tr.reasons = list(sim.reasons)
        comp = tr.compensator
        if comp.adaptive:  # its kernel's new events (StewartTransfer.step's order)
            comp.events(n, sl)
            if comp.any_stopped:
                for kk in np.flatnonzero(comp.stopped[sl] & ~tr.stopped[sl]):
                    kk = a + int(kk)
                    tr.stopped[kk] = True
                    tr.reasons[kk] = comp.reasons[kk]
        for j in np.flatnonzero(tr.stopped[sl] & mon.active[sl]):
            kk = a + int(j)
            mon.stop(kk, tr.reasons[kk], n)
            g.num.halt(kk)
        for sig, h in zip(tr.signals, g.hist, strict=True):
            h[n + 1, sl] = sig.source[sl]
        st = self.static[[p[0] for p in self.parts].index(a)]
        if post_step(st[2], n, g.num.z[sl], tr.z_meas[sl], tr.f_meas[sl], g.num.x[sl],
                     st[1]):
            g._halt(n)

    def _diverged(self, sl: slice) -> None:
        """PlatformBatch._check_status for tests ``sl`` only (the others may be at other
        steps)."""
        from ..errors import SafetyStop

        sim = self.sim
        expected = sim.t0 + sim.k * sim.config.dt - 0.5 * sim.config.timestep
        failed = sim.batch.failed(expected)
        if failed is None:
            return
        for j in np.flatnonzero(failed[sl] & ~sim.stopped[sl]):
            k = sl.start + int(j)
            msg = sim.batch.error(k).strip()
            what = msg or "MuJoCo bad acceleration, state was reset"
            sim.freeze(k, SafetyStop(f"divergence ({what}) |qacc|", math.inf, _MAXVAL,
                                      sim.t, test=k))
