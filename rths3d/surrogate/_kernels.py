"""Compiled per-step kernels of the lag models (numba): free-run simulation and the batched
one-step advance used when a surrogate part is coupled to the numerical substructure.

Raw lag regressor of sample n (d interface DOFs, ``nb`` displacement taps, ``na`` force lags):

    r_n = [z_n, z_{n−1}, …, z_{n−nb+1}, F_{n−1}, …, F_{n−na}, 1]      (each z, F a d-vector)

and F_n = Θ r_n with Θ = Θ_hi where the switching variable w > h, else Θ_lo:

    w = a·z_n − c·F_{n−1}      (``lagged = 0``)
    w = a·z_{n−1} − c·F_{n−1}  (``lagged = 1``, the state at the start of the step)
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, nogil=True)
def simulate(z, f, n0, n1, th_lo, th_hi, a, c, h, lagged, nb, na):  # pragma: no cover - jit
    """Free run F_n for n in [n0, n1) driven by the measured ``z`` (N, d); force lags before
    n0 are the measured ``f``. Returns (n1 − n0, d); a run that leaves 1e6× the measured
    force scale stops there and the rest is inf."""
    N, d = z.shape
    out = np.empty((n1 - n0, d))
    p = th_lo.shape[1]
    r = np.empty(p)
    fmax = 0.0
    for i in range(N):
        for j in range(d):
            v = abs(f[i, j])
            if v > fmax:
                fmax = v
    limit = 1e6 * (fmax + 1e-300)
    for n in range(n0, n1):
        k = 0
        for t in range(nb):
            for j in range(d):
                r[k] = z[n - t, j]
                k += 1
        for t in range(1, na + 1):
            m = n - t
            for j in range(d):
                r[k] = out[m - n0, j] if m >= n0 else f[m, j]
                k += 1
        r[k] = 1.0
        w = -h
        zi = n - 1 if lagged else n
        for j in range(d):
            fl = out[n - 1 - n0, j] if n - 1 >= n0 else f[n - 1, j]
            w += a[j] * z[zi, j] - c[j] * fl
        th = th_hi if w > 0.0 else th_lo
        bad = False
        for j in range(d):
            s = 0.0
            for q in range(p):
                s += th[j, q] * r[q]
            out[n - n0, j] = s
            if not abs(s) < limit:
                bad = True
        if bad:
            out[n - n0:, :] = np.inf
            break
    return out


@njit(cache=True, nogil=True)
def advance(zb, fb, z1, th_lo, th_hi, a, c, h, lagged, limit, diverged,
            out):  # pragma: no cover - jit
    """One step of K lag models: ``zb`` (K, nb, d) holds z_n … (newest first), ``fb``
    (K, na, d) F_n …; ``z1`` (K, d) is z_{n+1}. Writes F_{n+1} into ``out`` (K, d) and
    shifts the buffers (no allocation). A test whose force leaves ``limit`` (K,) is flagged
    in ``diverged`` (K,) and gives zero force from then on (so that the interface iteration
    of the others still converges)."""
    K, nb, d = zb.shape
    na = fb.shape[1]
    for k in range(K):
        if diverged[k]:
            for j in range(d):
                out[k, j] = 0.0
            continue
        w = -h[k]
        for j in range(d):
            zz = zb[k, 0, j] if lagged[k] else z1[k, j]
            w += a[k, j] * zz - c[k, j] * fb[k, 0, j]
        th = th_hi if w > 0.0 else th_lo
        for i in range(d):
            s = th[k, i, -1]
            q = 0
            for j in range(d):
                s += th[k, i, q] * z1[k, j]
                q += 1
            for t in range(nb - 1):
                for j in range(d):
                    s += th[k, i, q] * zb[k, t, j]
                    q += 1
            for t in range(na):
                for j in range(d):
                    s += th[k, i, q] * fb[k, t, j]
                    q += 1
            out[k, i] = s
            if not abs(s) <= limit[k]:
                diverged[k] = True
        if diverged[k]:
            for j in range(d):
                out[k, j] = 0.0
            continue
        for t in range(nb - 1, 0, -1):
            for j in range(d):
                zb[k, t, j] = zb[k, t - 1, j]
        for j in range(d):
            zb[k, 0, j] = z1[k, j]
        for t in range(na - 1, 0, -1):
            for j in range(d):
                fb[k, t, j] = fb[k, t - 1, j]
        for j in range(d):
            fb[k, 0, j] = out[k, j]


@njit(cache=True, nogil=True)
def rms_update(buf, sums, out, e, state):  # pragma: no cover - jit
    """Running RMS over a ring buffer of squares: add sample ``e`` (d,); ``state`` = [next
    row, samples so far]. Exact re-sum once per window (no drift)."""
    W, d = buf.shape
    i = state[0]
    for j in range(d):
        sq = e[j] * e[j]
        sums[j] += sq - buf[i, j]
        buf[i, j] = sq
    i += 1
    if i == W:
        i = 0
        for j in range(d):
            s = 0.0
            for r in range(W):
                s += buf[r, j]
            sums[j] = s
    state[0] = i
    if state[1] < W:
        state[1] += 1
    n = state[1]
    for j in range(d):
        v = sums[j] / n
        out[j] = np.sqrt(v) if v > 0.0 else 0.0
