"""Compiled per-step kernels of the maRTHS loop, in Simulink's order (SPEC §8), for K trials
stepped together (same structure and record, one plant per trial):

:func:`measure` (steps 1–6 at t_k): plant output y = C x_p, measurement y + n_k (the same
n_k on both channels); actuator→frame (x̂, θ̂); the specimen's feedback force from
q = [x̂, θ̂, G[x̂, θ̂]] with backward differences (0 at k = 0); the numerical substructure's
Newmark step with ẍ_g(t_k) and the force; frame→actuator targets. Then the compensator
(from Python) gives u_k; :func:`advance` (step 9) logs it and takes the plant's RK4 step.
"""

from __future__ import annotations

from numba import njit

from .model import _a2f, _f2a, newmark_step

__all__ = ["advance", "feedback", "measure", "targets"]

IX, ITH, ITH2, IX2, IR2, IX3, IR3 = 26, 20, 28, 25, 21, 12, 2
"""0-based rows of equations 27, 21, 29, 26, 22, 13, 3."""


@njit(cache=True, nogil=True)
def measure(k, alive, stop_at, stop_val, Xp, Cp, U, V, A, R, Fv, Kinv, RU, RV, RA, Ml, a,
            ag, noise, kin, K5, C5, M5, G, qm, inv_dt, limit, zt, zm, XAT, XAM, XH, NUM, FF,
            Fi, u6):
    """Steps 1–6 of sample k for every live trial: :func:`feedback` (steps 1–4), the
    numerical substructure's Newmark step with ẍ_g(t_k) and the specimen's force, and
    :func:`targets` (steps 5–6); a trial whose measured actuator displacement is not finite
    or beyond ``limit`` (mm) is logged and stopped (``alive`` cleared, ``stop_at`` = k,
    ``stop_val`` the value). ``qm`` (K, 10) holds q_{k−1} and q̇_{k−1}; ``Fv`` (29,),
    ``R`` (29,), ``Fi`` (3,), ``u6`` (6,) scratch. Returns the number of trials stopped."""
    n_stop = 0
    agk = ag[k]
    for i in range(Xp.shape[0]):
        if not alive[i]:
            continue
        feedback(k, i, Xp, Cp, noise, kin, K5, C5, M5, G, qm, inv_dt, zm, XH, FF, Fi)
        Fv[IX] = Fi[0]
        Fv[ITH] = Fi[1]
        Fv[ITH2] = Fi[2]
        newmark_step(U[i], V[i], A[i], Kinv, RU, RV, RA, Ml, a, agk, Fv, R)
        u6[0] = U[i, IX]
        u6[1] = U[i, ITH]
        u6[2] = U[i, IX2]
        u6[3] = U[i, IR2]
        u6[4] = U[i, IX3]
        u6[5] = U[i, IR3]
        n_stop += targets(k, i, u6, kin, limit, alive, stop_at, stop_val, zt, zm, XAT, XAM,
                          NUM)
    return n_stop


@njit(cache=True, nogil=True)
def feedback(k, i, Xp, Cp, noise, kin, K5, C5, M5, G, qm, inv_dt, zm, XH, FF, Fi):
    """Steps 1–4 of :func:`measure` for trial ``i`` (also alone, when the numerical
    substructure is stepped outside: an OpenSees model): the measurement into ``zm[i]``
    (mm), x̂, θ̂ into ``XH[k, i]``, the specimen's force into ``FF[k, i]`` and the
    benchmark's F at equations 27, 21, 29 into ``Fi`` (3,)."""
    nk = noise[k]
    y1 = 0.0
    y2 = 0.0
    for c in range(Xp.shape[1]):
        y1 += Cp[i, 0, c] * Xp[i, c]
        y2 += Cp[i, 1, c] * Xp[i, c]
    xm1 = y1 + nk
    xm2 = y2 + nk
    xh, th = _a2f(xm1, xm2, kin)
    q = (xh, th, G[0, 0] * xh + G[0, 1] * th, G[1, 0] * xh + G[1, 1] * th,
         G[2, 0] * xh + G[2, 1] * th)
    for r in range(3):
        s = 0.0
        for c in range(5):
            if k > 0:
                qd = (q[c] - qm[i, c]) * inv_dt
                qdd = (qd - qm[i, 5 + c]) * inv_dt
            else:
                qd = 0.0
                qdd = 0.0
            s += K5[r, c] * q[c] + C5[r, c] * qd + M5[r, c] * qdd
        FF[k, i, r] = s
    for c in range(5):
        qd = (q[c] - qm[i, c]) * inv_dt if k > 0 else 0.0
        qm[i, 5 + c] = qd
        qm[i, c] = q[c]
    Fi[0] = FF[k, i, 0]
    Fi[1] = -FF[k, i, 1]
    Fi[2] = -FF[k, i, 2]
    zm[i, 0] = xm1
    zm[i, 1] = xm2
    XH[k, i, 0] = 1000.0 * xh
    XH[k, i, 1] = th


@njit(cache=True, nogil=True)
def targets(k, i, u, kin, limit, alive, stop_at, stop_val, zt, zm, XAT, XAM, NUM):
    """Steps 5–6 of :func:`measure` for trial ``i`` from the numerical substructure's U at
    equations 27, 21, 26, 22, 13, 3 (``u``, m and rad): the actuator targets, the logs and
    the stroke check (returns 1 when the trial stops, else 0)."""
    xa1, xa2 = _f2a(u[0], -u[1], kin)
    zt[i, 0] = xa1
    zt[i, 1] = xa2
    xm1, xm2 = zm[i, 0], zm[i, 1]
    XAT[k, i, 0] = xa1
    XAT[k, i, 1] = xa2
    XAM[k, i, 0] = xm1
    XAM[k, i, 1] = xm2
    NUM[k, i, 0] = 1000.0 * u[0]
    NUM[k, i, 1] = -u[1]
    NUM[k, i, 2] = u[2]
    NUM[k, i, 3] = u[3]
    NUM[k, i, 4] = u[4]
    NUM[k, i, 5] = u[5]
    worst = max(abs(xm1), abs(xm2))
    if not (worst <= limit):  # also catches NaN
        alive[i] = False
        stop_at[i] = k
        stop_val[i] = worst
        return 1
    return 0


@njit(cache=True, nogil=True)
def advance(k, alive, Xp, Phi, Gam, u, UL, work):
    """Step 9: log the commands ``u`` (K, 2) (mm) and advance each live trial's plant one
    RK4 step with them held."""
    for i in range(Xp.shape[0]):
        if not alive[i]:
            continue
        u1, u2 = u[i, 0], u[i, 1]
        UL[k, i, 0] = u1
        UL[k, i, 1] = u2
        n = Xp.shape[1]
        for r in range(n):
            s = Gam[i, r, 0] * u1 + Gam[i, r, 1] * u2
            for c in range(n):
                s += Phi[i, r, c] * Xp[i, c]
            work[r] = s
        for r in range(n):
            Xp[i, r] = work[r]
