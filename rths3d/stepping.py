"""The compiled loop: K tests stepped together at the interface rate, in numba.

One step n → n+1 of every test (paper Fig. 1): the linear numerical substructure advances
with the measured force held over the step and gives the command z_{n+1} = Γᵀ x_{n+1}; the
safety monitor checks the command; the transfer system's stages (compensator → actuator
chain → part model → sensor chain, :class:`~rths3d.transfer.base.CompiledTransfer`) give
z'_{n+1} and F'_m(t_{n+1}); the record row n+1 is written; the monitor checks the force.

The stages are the components' own kernels, called as first-class functions, so this loop
never knows which transfer system, part or effect it runs. :func:`run_steps` advances a
range of steps and returns to Python (for a live viewer, pause/stop and progress); the
Python loop (:mod:`rths3d.loop`) calls the same kernels one step at a time when a stage has
no kernel (MuJoCo), so both paths compute the same physics.
"""

from __future__ import annotations

import numba
import numpy as np

from .kernels import inline_njit, njit, run_chain
from .numerical._kernels import linear_step
from .safety import check_command, check_measured

# The per-step kernels the range loop calls, inlined into it (the same source, compiled
# once more with inlining), and the loop compiled without numba's reference counting
# (``_nrt=False``: it allocates nothing; every array it touches is held by the caller for
# the call): each array handed to a helper took a reference and gave it back, two atomic
# operations, and a one-DOF test's step hands on about fifty — 600 → 400 ns per step of
# a one-DOF test (0.075 µs per test and step of a 512-test batch either way).
_linear_step = inline_njit(linear_step.py_func)
_run_chain = inline_njit(run_chain.py_func)
_check_command = inline_njit(check_command.py_func)
_check_measured = inline_njit(check_measured.py_func)

__all__ = ["copy_signals", "fill_known", "linear_step", "noise_buffer", "post_step", "pre_step",
           "record_row", "run_steps", "transfer_step"]


@inline_njit
def record_row(data, row, z, zm, f, x, c_zc, c_zm, c_f, c_x):
    """Write z, z', F'_m and x of every test into row ``row`` of the record array."""
    for k in range(z.shape[0]):
        for j in range(z.shape[1]):
            data[row, k, c_zc + j] = z[k, j]
            data[row, k, c_zm + j] = zm[k, j]
            data[row, k, c_f + j] = f[k, j]
        for i in range(x.shape[1]):
            data[row, k, c_x + i] = x[k, i]


@inline_njit
def transfer_step(comp_f, comp_p, comp_s, act_fs, act_ps, act_ss, part_f, part_p, part_s,
                  sens_fs, sens_ps, sens_ss, z, zd, zm, zprev, ftrue, fmeas, u, w_act, w_sens):
    """One step of a compiled transfer system over R rows (1-D views of (K, n_if) arrays):
    u = compensate(z, ż, z'_prev), z' = actuators(u), F = part(z'_prev → z'), F' = sensor(F).
    The compensator and the part kernel come as 1-tuples (a tuple of kernels of one
    signature is typed as first-class functions, which numba can cache). Returns whether
    the compensator raised a new safety event."""
    event = comp_f[0](comp_p, comp_s, z, zd, zm, u)
    _run_chain(act_fs, act_ps, act_ss, u, zm, w_act)
    part_f[0](part_p, part_s, zprev, zm, ftrue)
    _run_chain(sens_fs, sens_ps, sens_ss, ftrue, fmeas, w_sens)
    for r in range(zm.shape[0]):
        zprev[r] = zm[r]
    return event


@inline_njit
def copy_signals(src, h, row):
    """Row ``row`` of a record signal's history ``h`` (N+1, K, w) from its source (K, w)
    (w = 0: no signal)."""
    for k in range(src.shape[0]):
        for j in range(src.shape[1]):
            h[row, k, j] = src[k, j]


@njit
def pre_step(num, f, n, z, zd, x, mon):
    """The Python loop's step n before the transfer system, in one compiled call: the linear
    substructure's step and the command check (returns the new stops)."""
    Ad, Bf, P, s, s_next, Czx, Czv, Cx = num
    (lim_z, lim_v, lim_x, lim_f, g_win, g_fac, g_n, g_floor, g_pk, g_prev, g_base, g_cnt,
     active, code, dof, value, row) = mon
    linear_step(Ad, Bf, P, n, f, s, s_next, Czx, Czv, Cx, z, zd, x)
    return check_command(z, zd, x, lim_z, lim_v, lim_x, active, code, dof, value, row, n)


@njit
def post_step(rec, n, z, zm, f, x, mon):
    """The Python loop's step n after the transfer system, in one compiled call: the record
    row n+1 and the measured-force checks (returns the new stops)."""
    data, c_zc, c_zm, c_f, c_x = rec
    (lim_z, lim_v, lim_x, lim_f, g_win, g_fac, g_n, g_floor, g_pk, g_prev, g_base, g_cnt,
     active, code, dof, value, row) = mon
    record_row(data, n + 1, z, zm, f, x, c_zc, c_zm, c_f, c_x)
    return check_measured(f, lim_f, g_win, g_fac, g_n, g_floor, g_pk, g_prev, g_base, g_cnt,
                          active, code, dof, value, row, n)


@numba.njit(cache=True, nogil=True, _nrt=False)
def run_steps(n0, n1, num, tr, io, mon, rec, noise_act, noise_sens, hist):
    """Steps n0 … n1−1 of K tests (see the module docstring). Returns (steps done, code):
    done < n1 − n0 when every test has stopped; code 1: the compensator raised a safety
    event in step n0 + done, which is done up to the transfer system's outputs — the
    driver finishes it (the stop, the signals' row, the record row and the force checks)
    and counts it.

    ``num``: (A_d, B_f, P, s, s_next, C_zx, C_zv, C_x) of the linear substructure;
    ``tr``: the transfer stages (comp kernel, params, state, act kernels, params, states,
    part kernel, params, state, sensor kernels, params, states); ``io``: the loop's (K, ·)
    buffers (z, ż, x, z', z'_prev, F, F', u); ``mon``: the monitor's limits and state;
    ``rec``: (record array (N+1, K, C), column of z_cmd, z_meas, f_meas, x_num);
    ``noise_*``: the chains' standard-normal draws for these steps ((n1 − n0, R));
    ``hist``: the record signal to copy after each step, (source (K, w), history (N+1, K,
    w)) (:func:`copy_signals`; w = 0 for none).
    """
    Ad, Bf, P, s, s_next, Czx, Czv, Cx = num
    z, zd, x, zm, zprev, ftrue, fmeas, u = io
    (lim_z, lim_v, lim_x, lim_f, g_win, g_fac, g_n, g_floor, g_pk, g_prev, g_base, g_cnt,
     active, code, dof, value, row) = mon
    data, c_zc, c_zm, c_f, c_x = rec
    K, nd = z.shape
    zr, zdr, zmr, zpr = z.reshape(-1), zd.reshape(-1), zm.reshape(-1), zprev.reshape(-1)
    ftr, fmr, ur = ftrue.reshape(-1), fmeas.reshape(-1), u.reshape(-1)
    for n in range(n0, n1):
        _linear_step(Ad, Bf, P, n, fmeas, s, s_next, Czx, Czv, Cx, z, zd, x)
        if _check_command(z, zd, x, lim_z, lim_v, lim_x, active, code, dof, value, row, n):
            for k in range(K):
                if not active[k] and row[k] == n:
                    # a stopped test rests (its load and state zeroed), the others go on
                    P[:, k, :] = 0.0
                    s[k, :] = 0.0
            if not active.any():
                return n - n0, 0
        wa = noise_act[(n - n0) % noise_act.shape[0]]
        ws = noise_sens[(n - n0) % noise_sens.shape[0]]
        if transfer_step(tr[0], tr[1], tr[2], tr[3], tr[4], tr[5], tr[6], tr[7], tr[8],
                         tr[9], tr[10], tr[11], zr, zdr, zmr, zpr, ftr, fmr, ur, wa, ws):
            return n - n0, 1
        copy_signals(hist[0], hist[1], n + 1)
        record_row(data, n + 1, z, zm, fmeas, x, c_zc, c_zm, c_f, c_x)
        if _check_measured(fmeas, lim_f, g_win, g_fac, g_n, g_floor, g_pk, g_prev, g_base, g_cnt,
                          active, code, dof, value, row, n):
            for k in range(K):
                if not active[k] and row[k] >= n:
                    P[:, k, :] = 0.0
                    s[k, :] = 0.0
            if not active.any():
                return n + 1 - n0, 0
    return n1 - n0, 0


@njit
def fill_known(data, dt, p, gamma, c_t, c_fe, c_pn):
    """The record columns known before the run, in one pass over the record array (N+1, K,
    C): the time t (s), f_ext = Γᵀ p and p_num = p for the loads p (K, N+1, n). Blocks of
    rows, so that both the loads (read along time) and the record (written across tests)
    stay in cache."""
    K, N1, n = p.shape
    nd = gamma.shape[1]
    B = 64
    for r0 in range(0, N1, B):
        r1 = min(N1, r0 + B)
        for k in range(K):
            for r in range(r0, r1):
                data[r, k, c_t] = r * dt
                for j in range(nd):
                    acc = 0.0
                    for i in range(n):
                        acc += p[k, r, i] * gamma[i, j]
                    data[r, k, c_fe + j] = acc
                for i in range(n):
                    data[r, k, c_pn + i] = p[k, r, i]


def noise_buffer(chain, steps: int, rows: int) -> np.ndarray:
    """The standard-normal draws of a chain for the next ``steps`` (one zero row stands for
    a chain without noise: its kernels never read it)."""
    if chain is None or chain.noise is None:
        return np.zeros((1, rows))
    out = np.empty((steps, rows))
    chain.draw(out)
    return out
