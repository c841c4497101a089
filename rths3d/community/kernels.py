"""Compiled per-step kernels of the benchmark loop (SPEC §7), written once and used by every
driver: :func:`~.simulate.run_case` / :func:`~.simulate.run_trials` (the whole loop in one
compiled call, :func:`run_fixed`) and :func:`~.compensated.run_compensated` (a compensator
from Python between :func:`measure` and :func:`advance`).

One step at t_k for each of K trials (arrays indexed by trial ``i``):

1. :func:`measure` — sensors: ``v = (x − x₋)/h``, ``a = (v − v₋)/h``, ``x_m = x + n_D``,
   ``f_m = k_e x + c_e v + m_e a + n_F``; the compensator's inputs ``AD(y_n)``, ``ẏ_n``,
   ``AD(x_m)``.
2. the outer compensation gives ``y_p`` before its D/A: the benchmark's phase lead
   (:func:`phase_lead`, ``y = b₀ u + b₁ u₋ − a₁ y₋``) or a compensator.
3. :func:`advance` — ``e = AD(DA(y_p) − x_m)``, tracking controller ``y_pi = g y_pi₋ + b₀ e +
   b₁ e₋``, ``y_gc = DA(y_pi)``; the force check ``|F| < limit``; one RK4 step of the
   numerical substructure ``z ← Φ_n z + G [ẍ_g(t_k), ẍ_g(t_k + h/2), ẍ_g(t_k + h)] + g_f f``
   (f the measured force, of the previous sample with ``force_delay``) and of the plant
   ``p ← Φ_p p + g_y y_gc + g_x x₋`` (matrices from :func:`~.simulate.numerical_step_matrices`
   and :func:`~.plant.plant_step_matrices`).

Converters (A/D: saturate then quantise; D/A: quantise then saturate; halves away from zero)
take ``conv = [1/h, q, sat]``; ``q = 0``, ``sat = inf`` turn them off. A trial whose force
leaves the limit is logged at that sample and not stepped again.
"""

from __future__ import annotations

import math

from numba import njit

__all__ = ["MEM", "advance", "measure", "phase_lead", "run_fixed"]

MEM = 9
"""Columns of the per-trial memory ``mem``: x_{k−1}, v_{k−1}, f_{k−1}, e_{k−1}, y_pi,k−1,
then x, v, x_m, f_m at t_k."""


@njit(cache=True, nogil=True, inline="always")
def _ad(v: float, q: float, sat: float) -> float:
    if v > sat:
        v = sat
    elif v < -sat:
        v = -sat
    if q > 0.0:
        if v >= 0.0:
            v = q * math.floor(v / q + 0.5)
        else:
            v = -q * math.floor(-v / q + 0.5)
    return v


@njit(cache=True, nogil=True, inline="always")
def _da(v: float, q: float, sat: float) -> float:
    if q > 0.0:
        if v >= 0.0:
            v = q * math.floor(v / q + 0.5)
        else:
            v = -q * math.floor(-v / q + 0.5)
    if v > sat:
        v = sat
    elif v < -sat:
        v = -sat
    return v


@njit(cache=True, nogil=True)
def measure(alive, Z, P, mem, spec, nD, nF, conv, zc, zdc, zmc, XM, XN, FM, k):
    """Sensors at t_k and the compensator's inputs ``zc = AD(y_n)``, ``zdc = ẏ_n``,
    ``zmc = AD(x_m)`` (K, 1). ``Z`` (K, 6), ``P`` (K, 5) states; ``mem`` (K, :data:`MEM`);
    ``spec`` (K, 3): k_e, c_e, m_e; ``nD``, ``nF`` noise per sample; logs ``XM``, ``XN``,
    ``FM`` at row k. (The step index comes last so that a driver binds the rest once.)"""
    inv_h, q, sat = conv[0], conv[1], conv[2]
    for i in range(Z.shape[0]):
        if not alive[i]:
            continue
        x = P[i, 3]
        v = (x - mem[i, 0]) * inv_h
        a = (v - mem[i, 1]) * inv_h
        xm = x + nD[k]
        fm = spec[i, 0] * x + spec[i, 1] * v + spec[i, 2] * a + nF[k]
        mem[i, 5] = x
        mem[i, 6] = v
        mem[i, 7] = xm
        mem[i, 8] = fm
        XM[k, i] = xm
        XN[k, i, 0] = Z[i, 0]
        XN[k, i, 1] = Z[i, 1]
        XN[k, i, 2] = Z[i, 2]
        FM[k, i] = fm
        zc[i, 0] = _ad(Z[i, 0], q, sat)
        zdc[i, 0] = Z[i, 3]
        zmc[i, 0] = _ad(xm, q, sat)


@njit(cache=True, nogil=True)
def phase_lead(alive, u, lead, hist, y):
    """The benchmark's phase lead ``y = b₀ u + b₁ u₋ − a₁ y₋`` (``lead = [b₀, b₁, a₁]``) on
    ``u`` (K, 1) into ``y`` (K, 1); ``hist`` (K, 2) holds u₋, y₋."""
    b0, b1, a1 = lead[0], lead[1], lead[2]
    for i in range(u.shape[0]):
        if not alive[i]:
            continue
        ui = u[i, 0]
        yi = b0 * ui + b1 * hist[i, 0] - a1 * hist[i, 1]
        hist[i, 0] = ui
        hist[i, 1] = yi
        y[i, 0] = yi


@njit(cache=True, nogil=True)
def advance(alive, stop_at, Z, P, mem, ctrl, conv, limit, force_delay, stages, PhiN, Gag, GF,
            PhiP, GY, GX, FA, YG, YP, work, k, yp_raw):
    """Tracking controller from the outer compensation's ``yp_raw`` (K, 1), force check, one
    RK4 step of both parts. ``ctrl = [b₀, b₁, g]``, ``stages[k]`` = ẍ_g at t_k, t_k + h/2,
    t_k + h; ``work`` (11,) scratch. Returns the number of trials stopped at the force limit
    in this step (their ``alive`` cleared, ``stop_at`` = k)."""
    q, sat = conv[1], conv[2]
    pb0, pb1, pg = ctrl[0], ctrl[1], ctrl[2]
    a0, am, a1 = stages[k, 0], stages[k, 1], stages[k, 2]
    stopped = 0
    for i in range(Z.shape[0]):
        if not alive[i]:
            continue
        xm = mem[i, 7]
        yp = _da(yp_raw[i, 0], q, sat)
        e = _ad(yp - xm, q, sat)
        ypi = pg * mem[i, 4] + pb0 * e + pb1 * mem[i, 3]
        ygc = _da(ypi, q, sat)
        F = P[i, 2]
        FA[k, i] = F
        YG[k, i] = ygc
        YP[k, i] = yp
        if not (-limit < F < limit):
            alive[i] = False
            stop_at[i] = k
            stopped += 1
            continue
        ff = mem[i, 2] if force_delay else mem[i, 8]
        for r in range(6):
            s = 0.0
            for c in range(6):
                s += PhiN[i, r, c] * Z[i, c]
            work[r] = s + GF[i, r] * ff + (Gag[i, r, 0] * a0 + Gag[i, r, 1] * am
                                           + Gag[i, r, 2] * a1)
        xprev = mem[i, 0]
        for r in range(5):
            s = 0.0
            for c in range(5):
                s += PhiP[i, r, c] * P[i, c]
            work[6 + r] = s + GY[i, r] * ygc + GX[i, r] * xprev
        for r in range(6):
            Z[i, r] = work[r]
        for r in range(5):
            P[i, r] = work[6 + r]
        mem[i, 0] = mem[i, 5]
        mem[i, 1] = mem[i, 6]
        mem[i, 2] = mem[i, 8]
        mem[i, 3] = e
        mem[i, 4] = ypi
    return stopped


@njit(cache=True, nogil=True)
def run_fixed(lead, hist, alive, stop_at, Z, P, mem, spec, nD, nF, conv, ctrl, limit,
              force_delay, stages, PhiN, Gag, GF, PhiP, GY, GX, zc, zdc, zmc, yp, work,
              XM, XN, FM, FA, YG, YP):
    """The whole loop with the benchmark's phase lead (:func:`phase_lead`) as the outer
    compensation, over the rows of ``stages`` (N, 3); returns the number of steps run (the
    last one stops the last live trial)."""
    n_alive = 0
    for i in range(alive.size):
        if alive[i]:
            n_alive += 1
    for k in range(stages.shape[0]):
        measure(alive, Z, P, mem, spec, nD, nF, conv, zc, zdc, zmc, XM, XN, FM, k)
        phase_lead(alive, zc, lead, hist, yp)
        n_alive -= advance(alive, stop_at, Z, P, mem, ctrl, conv, limit, force_delay, stages,
                           PhiN, Gag, GF, PhiP, GY, GX, FA, YG, YP, work, k, yp)
        if n_alive == 0:
            return k + 1
    return stages.shape[0]

