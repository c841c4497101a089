"""The surrogate reference one step at a time, for an online fidelity monitor.

:class:`OnlineReference` steps the surrogate reference ẑ^r alongside a running test: an
identified part model (a lag model fitted beforehand, e.g. on an earlier run or on the first
seconds of this one) coupled exactly to the numerical substructure. Its switch is fixed at
the start of each step (:class:`~rths3d.surrogate.base.Switch` with ``lagged``), so within a
step the part's force is affine in the interface displacement, F_{n+1} = α z_{n+1} + β, and
the exact discretisation of the numerical substructure with the force interpolated over the
step is affine too, z_{n+1} = g − C F_{n+1}: each step is one d × d solve,

    (I + C α) z_{n+1} = g − C β,

the same fixed point the interface iteration of :func:`rths3d.reference.couple_exact` reaches
(tested against it). ``update(n, z_meas)`` advances ẑ^r from t_n to t_{n+1} and returns the
running RMS of ê = z'_{n+1} − ẑ^r_{n+1} (:class:`~rths3d.surrogate.running.RunningRMS`).
Everything works in preallocated buffers through a compiled kernel: no allocation per step.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ._kernels import rms_update
from .base import LagModel, LagPart


@njit(cache=True, nogil=True)
def _step(n, s, f_n, zb, fb, Ad, Bf0, Bf1, P, Czx, th_lo, th_hi, a, c, h,
          tmp_s, g, A, rhs, z_out, f_out, limit, diverged):  # pragma: no cover - jit
    K, S = s.shape
    d = zb.shape[2]
    nb = zb.shape[1]
    na = fb.shape[1]
    for k in range(K):
        if diverged[k]:
            for j in range(d):
                z_out[k, j] = np.nan
                f_out[k, j] = np.nan
            continue
        km = k if Ad.shape[0] > 1 else 0
        kp = k if P.shape[1] > 1 else 0  # load terms (N, K, S): one step's tests together
        # free part of the numerical step: Ad s + P[n] − Bf0 f_n
        for i in range(S):
            v = P[n, kp, i]
            for j in range(S):
                v += Ad[km, i, j] * s[k, j]
            for j in range(d):
                v -= Bf0[km, i, j] * f_n[k, j]
            tmp_s[i] = v
        for i in range(d):
            v = 0.0
            for j in range(S):
                v += Czx[i, j] * tmp_s[j]
            g[i] = v
        # regime from the state at the start of the step
        w = -h[k]
        for j in range(d):
            w += a[k, j] * zb[k, 0, j] - c[k, j] * fb[k, 0, j]
        th = th_hi if w > 0.0 else th_lo
        # β: everything but z_{n+1}
        for i in range(d):
            b = th[k, i, -1]
            q = d
            for t in range(nb - 1):
                for j in range(d):
                    b += th[k, i, q] * zb[k, t, j]
                    q += 1
            for t in range(na):
                for j in range(d):
                    b += th[k, i, q] * fb[k, t, j]
                    q += 1
            f_out[k, i] = b  # β for now
        # C = Czx Bf1 (d × d); A = I + C α, rhs = g − C β
        for i in range(d):
            for j in range(d):
                cij = 0.0
                for m in range(S):
                    cij += Czx[i, m] * Bf1[km, m, j]
                tmp_s[j] = cij  # row i of C
            r = g[i]
            for j in range(d):
                r -= tmp_s[j] * f_out[k, j]
            rhs[i] = r
            for j in range(d):
                v = 1.0 if i == j else 0.0
                for m in range(d):
                    v += tmp_s[m] * th[k, m, j]
                A[i, j] = v
        # Gaussian elimination with partial pivoting (d is 1 … 6)
        for col in range(d):
            piv = col
            for r in range(col + 1, d):
                if abs(A[r, col]) > abs(A[piv, col]):
                    piv = r
            if piv != col:
                for j in range(d):
                    A[col, j], A[piv, j] = A[piv, j], A[col, j]
                rhs[col], rhs[piv] = rhs[piv], rhs[col]
            for r in range(col + 1, d):
                fac = A[r, col] / A[col, col]
                for j in range(col, d):
                    A[r, j] -= fac * A[col, j]
                rhs[r] -= fac * rhs[col]
        for i in range(d - 1, -1, -1):
            v = rhs[i]
            for j in range(i + 1, d):
                v -= A[i, j] * z_out[k, j]
            z_out[k, i] = v / A[i, i]
        # F_{n+1} = α z + β
        bad = False
        for i in range(d):
            v = f_out[k, i]
            for j in range(d):
                v += th[k, i, j] * z_out[k, j]
            f_out[k, i] = v
            if not abs(v) <= limit[k]:
                bad = True
        if bad:  # this model's coupled run diverges: it stops here (NaN from now on)
            diverged[k] = True
            for j in range(d):
                z_out[k, j] = np.nan
                f_out[k, j] = np.nan
            continue
        # numerical state s_{n+1} = Ad s + P − Bf0 f_n − Bf1 f_{n+1}
        for i in range(S):
            v = P[n, kp, i]
            for j in range(S):
                v += Ad[km, i, j] * s[k, j]
            for j in range(d):
                v -= Bf0[km, i, j] * f_n[k, j] + Bf1[km, i, j] * f_out[k, j]
            tmp_s[i] = v
        for i in range(S):
            s[k, i] = tmp_s[i]
        for j in range(d):
            f_n[k, j] = f_out[k, j]
        # lag buffers
        for t in range(nb - 1, 0, -1):
            for j in range(d):
                zb[k, t, j] = zb[k, t - 1, j]
        for j in range(d):
            zb[k, 0, j] = z_out[k, j]
        for t in range(na - 1, 0, -1):
            for j in range(d):
                fb[k, t, j] = fb[k, t - 1, j]
        for j in range(d):
            fb[k, 0, j] = f_out[k, j]


_NO_ROWS = np.zeros((0, 0, 0))


@njit(cache=True, nogil=True)
def _rms_rows(buf, sums, out, e, state):  # pragma: no cover - jit
    """The running RMS of K tests (:func:`~rths3d.surrogate._kernels.rms_update` each)."""
    for k in range(e.shape[0]):
        rms_update(buf[k], sums[k], out[k], e[k], state[k])


@njit(cache=True, nogil=True)
def _block(n0, n1, zm, s, f_n, zb, fb, Ad, Bf0, Bf1, P, Czx, th_lo, th_hi, a, c, h, tmp_s, g,
           A, rhs, z_out, f_out, limit, diverged, e, buf, sums, out, state, judge, peak,
           lim, first, first_dof, first_val, rms_rows):  # pragma: no cover - jit
    """Steps n0 … n1−1 with the measured z'_{m+1} = ``zm[m − n0]`` (K, d): ẑ^r, ê, the
    running RMS; from row ``judge`` on, its peak (in place) and, per test not yet crossed
    (``first[k] < 0``), the first row, DOF and value where it exceeds ``lim``. Returns how
    many tests crossed in this block. ``rms_rows`` (n1 − n0, K, d), unless empty, receives
    the running RMS of every step."""
    new = 0
    keep = rms_rows.shape[0] > 0
    K, d = e.shape
    for m in range(n0, n1):
        _step(m, s, f_n, zb, fb, Ad, Bf0, Bf1, P, Czx, th_lo, th_hi, a, c, h, tmp_s, g, A,
              rhs, z_out, f_out, limit, diverged)
        for k in range(K):
            for j in range(d):
                e[k, j] = zm[m - n0, k, j] - z_out[k, j]
        _rms_rows(buf, sums, out, e, state)
        if keep:
            for k in range(K):
                for j in range(d):
                    rms_rows[m - n0, k, j] = out[k, j]
        if m + 1 >= judge:
            for k in range(K):
                for j in range(d):
                    v = out[k, j]
                    if v > peak[k, j]:
                        peak[k, j] = v
                    if first[k] < 0 and v > lim[k, j]:
                        first[k] = m + 1
                        first_dof[k] = j
                        first_val[k] = v
                        new += 1
    return new


@njit(cache=True, nogil=True)
def _run(N, s, f_n, zb, fb, Ad, Bf0, Bf1, P, Czx, th_lo, th_hi, a, c, h, limit, diverged,
         z_ref, f_ref):  # pragma: no cover - jit
    K, S = s.shape
    d = zb.shape[2]
    tmp_s = np.zeros(S)
    g = np.zeros(d)
    A = np.zeros((d, d))
    rhs = np.zeros(d)
    z1 = np.zeros((K, d))
    f1 = np.zeros((K, d))
    for n in range(N):
        _step(n, s, f_n, zb, fb, Ad, Bf0, Bf1, P, Czx, th_lo, th_hi, a, c, h, tmp_s, g, A,
              rhs, z1, f1, limit, diverged)
        z_ref[:, n + 1] = z1
        f_ref[:, n + 1] = f1


def couple_closed_form(num, part: LagPart, n_steps: int) -> dict[str, np.ndarray]:
    """ẑ^r of K lag models (switches fixed at the start of the step) coupled exactly to
    ``num`` (a :class:`~rths3d.numerical.LinearSubstructure`, exact discretisation): one
    closed-form solve per step and test, the fixed point the interface iteration of
    :func:`rths3d.reference.couple_exact` converges to (tested). Returns ``z_ref``, ``f_ref``
    (K, N+1, d); a test whose force leaves ``part.limit`` is NaN from there on and flagged in
    ``part.diverged``."""
    if np.any(~part.lagged & np.isfinite(part.h)):
        raise ValueError("closed-form coupling needs switches fixed at the start of the step")
    K, d, N = part.K, part.d, int(n_steps)
    z_ref = np.zeros((K, N + 1, d))
    f_ref = np.zeros((K, N + 1, d))
    s = np.zeros((K, num.s.shape[1]))
    part.reset()
    _run(N, s, np.zeros((K, d)), part.zb, part.fb, num.Ad, num.Bf0, num.Bf1, num.P, num.Czx,
         part.th_lo, part.th_hi, part.a, part.c, part.h, part.limit, part.diverged, z_ref,
         f_ref)
    return {"z_ref": z_ref, "f_ref": f_ref}


def coupled_radius(Ad: np.ndarray, Bf0: np.ndarray, Bf1: np.ndarray, Czx: np.ndarray,
                   model: LagModel) -> float:
    """The larger of :func:`coupled_radii` (see there)."""
    return max(coupled_radii(Ad, Bf0, Bf1, Czx, model))


def coupled_radii(Ad: np.ndarray, Bf0: np.ndarray, Bf1: np.ndarray, Czx: np.ndarray,
                  model: LagModel) -> tuple[float, float]:
    """Largest |eigenvalue| of the exactly coupled one-step map (numerical state, lag
    buffers) of ``model`` in each of its regimes: (low, high).

    With a passive part on a damped numerical substructure the reference decays in every
    regime (the exchange's delay alone destabilises a test, and the reference has none), so
    a radius above 1 says the identified model would make the surrogate reference grow
    where the true one does not: its dynamics, unexcited in the record, are wrong.
    ``Ad`` (S, S), ``Bf0``, ``Bf1`` (S, d), ``Czx`` (d, S): the exact discretisation.
    """
    d = model.theta_lo_.shape[0]
    nb, na, S = model.nb, model.na, Ad.shape[0]
    n_x = S + (nb + na) * d
    C = Czx @ Bf1
    radii = []
    for th in (model.theta_lo_, model.theta_hi_):
        alpha = th[:, :d]
        rest_z = th[:, d:nb * d]                  # z_n … z_{n−nb+2}
        rest_f = th[:, nb * d:(nb + na) * d]      # F_n … F_{n−na+1}
        X = np.eye(n_x)
        s0 = X[:S]
        zb = X[S:S + nb * d].reshape(nb, d, n_x)
        fb = X[S + nb * d:].reshape(na, d, n_x)
        beta = (rest_z @ zb[:nb - 1].reshape((nb - 1) * d, n_x) if nb > 1 else 0.0) + \
            (rest_f @ fb.reshape(na * d, n_x) if na else 0.0)
        f_n = fb[0] if na else np.zeros((d, n_x))
        free = Ad @ s0 - Bf0 @ f_n
        z1 = np.linalg.solve(np.eye(d) + C @ alpha, Czx @ free - C @ beta)
        f1 = alpha @ z1 + beta
        s1 = free - Bf1 @ f1
        rows = [s1, z1] + [zb[t] for t in range(nb - 1)] + [f1] + [fb[t] for t in range(na - 1)]
        T = np.vstack(rows)
        radii.append(float(np.max(np.abs(np.linalg.eigvals(T)))))
    return radii[0], radii[1]


class OnlineReference:
    """ẑ^r and the running RMS of ê one step at a time (see the module docstring).

    ``OnlineReference(num, models, window_samples)``: ``num`` a
    :class:`~rths3d.numerical.LinearSubstructure` built with ``method="exact"`` (its load
    p(t) included, K tests), ``models`` K fitted lag models whose switches are fixed at the
    start of the step. ``update(n, z_meas)`` with the measured z'_{n+1} (K, d) advances
    t_n → t_{n+1} and returns the running RMS (K, d) view; ``z_ref`` (K, d) is ẑ^r_{n+1},
    ``f_ref`` the part's force. Starts at rest, as the test and the reference do.
    """

    def __init__(self, num, models: list[LagModel], window_samples: int):
        if getattr(num, "method", "exact") != "exact":
            raise ValueError("the online reference needs the exact discretisation "
                             "(LinearSubstructure(..., method='exact'))")
        if any(not m.switch_.lagged and np.isfinite(m.switch_.h) for m in models):
            raise ValueError("online coupling needs switches fixed at the start of the step")
        part = LagPart(models)
        self.K, self.d = part.K, part.d
        if num.z.shape != (self.K, self.d):
            raise ValueError(f"numerical substructure has {num.z.shape} interface values, "
                             f"the models {(self.K, self.d)}")
        self.num = num
        self._part = part
        S = num.s.shape[1]
        self.s = np.zeros((self.K, S))
        self.f_n = np.zeros((self.K, self.d))
        self.z_ref = np.zeros((self.K, self.d))
        self.f_ref = np.zeros((self.K, self.d))
        self._tmp = np.zeros(S)
        self._g = np.zeros(self.d)
        self._A = np.zeros((self.d, self.d))
        self._rhs = np.zeros(self.d)
        self._e = np.zeros((self.K, self.d))
        # one ring buffer of squares per test (RunningRMS's, stacked for the compiled loops)
        W = int(window_samples)
        if W < 1:
            raise ValueError("OnlineReference needs window_samples >= 1")
        self._buf = np.zeros((self.K, W, self.d))
        self._sum = np.zeros((self.K, self.d))
        self._state = np.zeros((self.K, 2), dtype=np.int64)
        self.value = np.zeros((self.K, self.d))

    def reset(self) -> None:
        self.s[:] = 0.0
        self.f_n[:] = 0.0
        self.z_ref[:] = 0.0
        self.f_ref[:] = 0.0
        self._part.reset()
        self._part.diverged[:] = False
        self._buf[:] = 0.0
        self._sum[:] = 0.0
        self._state[:] = 0
        self.value[:] = 0.0

    def update(self, n: int, z_meas: np.ndarray) -> np.ndarray:
        """Advance ẑ^r from t_n to t_{n+1}; ``z_meas`` is z'_{n+1} (K, d). Returns the running
        RMS of ê (K, d), updated in place."""
        p, num = self._part, self.num
        _step(n, self.s, self.f_n, p.zb, p.fb, num.Ad, num.Bf0, num.Bf1, num.P, num.Czx,
              p.th_lo, p.th_hi, p.a, p.c, p.h, self._tmp, self._g, self._A, self._rhs,
              self.z_ref, self.f_ref, p.limit, p.diverged)
        np.subtract(z_meas, self.z_ref, out=self._e)
        _rms_rows(self._buf, self._sum, self.value, self._e, self._state)
        return self.value

    def update_block(self, n0: int, n1: int, z_meas: np.ndarray, judge: int,
                     peak: np.ndarray, limit: np.ndarray, first: np.ndarray,
                     first_dof: np.ndarray, first_val: np.ndarray,
                     rms_rows: np.ndarray | None = None) -> int:
        """:meth:`update` for steps n0 … n1−1 in one compiled call (``z_meas`` (n1 − n0, K, d):
        z'_{n0+1} … z'_{n1}). From row ``judge`` on, ``peak`` (K, d) keeps the largest running
        RMS and, for each test k with ``first[k] < 0``, the first row whose running RMS exceeds
        ``limit`` (K, d) goes to ``first[k]`` (int), its DOF to ``first_dof[k]`` (int) and
        the value to ``first_val[k]``, all in place. ``rms_rows`` (n1 − n0, K, d), if given,
        receives the running RMS after every step. Returns how many tests crossed."""
        p, num = self._part, self.num
        if rms_rows is None:
            rms_rows = _NO_ROWS
        return int(_block(n0, n1, z_meas, self.s, self.f_n, p.zb, p.fb, num.Ad, num.Bf0,
                          num.Bf1, num.P, num.Czx, p.th_lo, p.th_hi, p.a, p.c, p.h, self._tmp,
                          self._g, self._A, self._rhs, self.z_ref, self.f_ref, p.limit,
                          p.diverged, self._e, self._buf, self._sum, self.value, self._state,
                          judge, peak, limit, first, first_dof, first_val, rms_rows))
