"""What every surrogate model class of the experimental part shares.

A model of the part maps the measured interface displacement z' (N, d) to the measured
restoring force F'_m (N, d), sampled at the record's ΔT, with no prior knowledge of the part.
The model classes here are discrete-time *lag models*: F_n is a function of the regressor

    r_n = [z_n, z_{n−1}, …, z_{n−nb+1}, F_{n−1}, …, F_{n−na}, 1]

(``nb`` displacement taps, ``na`` force lags, each a d-vector), linear in r_n within each of
at most two regimes split by a switching variable w (see :mod:`._kernels`). The linear ARX
model is the one-regime case. A part that is a linear mass–spring–damper driven through its
mount on a linear path per step (the loop's specimen, any integrator with fixed substeps) is
exactly an ARX model with nb = 4, na = 2.

Estimator API (scikit-learn style): ``fit(z, F)`` returns the model, fitted attributes end in
``_`` (``theta_lo_``, ``theta_hi_``, ``switch_``); ``predict(z, F)`` runs the model freely
from the measured initial lags; :meth:`LagModel.validate` scores it on held-out blocks. Every
fitted model becomes a part that :func:`rths3d.reference.couple_exact` can couple to the
numerical substructure (:class:`LagPart`, K tests stepped together).
"""

from __future__ import annotations

from dataclasses import dataclass
from math import comb

import numpy as np
from scipy.linalg import solve_triangular

from ..errors import RecordError
from . import _kernels


@dataclass(frozen=True)
class Switch:
    """Regime switch of a lag model: Θ_hi where w = a·z − c·F_{n−1} − h > 0.

    ``a``, ``c``: (d,) weights (1/m and 1/N scaled as the data); ``h``: threshold; ``lagged``:
    take z_{n−1} (the state at the start of the step) instead of z_n.
    """

    a: tuple[float, ...]
    c: tuple[float, ...]
    h: float
    lagged: bool = False

    def w(self, z_now: np.ndarray, z_prev: np.ndarray, f_prev: np.ndarray) -> np.ndarray:
        zz = z_prev if self.lagged else z_now
        return zz @ np.asarray(self.a) - f_prev @ np.asarray(self.c) - self.h


NO_SWITCH = Switch((0.0,), (0.0,), np.inf)
ERROR_CAP = 10.0
"""Largest relative output error counted (a run that diverges counts as this)."""


def difference_transform(m: int) -> np.ndarray:
    """T with (T x)_j = Δ^j x_n, the j-th backward difference of the taps x_n, x_{n−1}, …
    (m × m, lower triangular binomial). Least squares on differences is much better
    conditioned than on raw taps sampled at 1 kHz (which are nearly equal)."""
    T = np.zeros((m, m))
    for j in range(m):
        for i in range(j + 1):
            T[j, i] = (-1) ** i * comb(j, i)
    return T


def first_sample(nb: int, na: int) -> int:
    """The first sample a model of orders (nb, na) predicts: all its lags, and the state at
    the start of the step a switch reads (n ≥ 1)."""
    return max(nb - 1, na, 1)


def lag_matrix(z: np.ndarray, f: np.ndarray, nb: int, na: int, start: int | None = None
               ) -> tuple[np.ndarray, np.ndarray, int]:
    """Raw regressors R (rows, p) and targets Y (rows, d) for samples n = start … N−1.

    ``start`` defaults to :func:`first_sample`.
    """
    N, d = z.shape
    L = first_sample(nb, na)
    s = L if start is None else max(int(start), L)
    rows = N - s
    p = (nb + na) * d + 1
    R = np.empty((rows, p))
    k = 0
    for t in range(nb):
        R[:, k:k + d] = z[s - t:N - t]
        k += d
    for t in range(1, na + 1):
        R[:, k:k + d] = f[s - t:N - t]
        k += d
    R[:, -1] = 1.0
    return R, f[s:], s


def delta_matrix(nb: int, na: int, d: int) -> np.ndarray:
    """The p × p map raw lags → differences (per DOF, per block), constant kept."""
    p = (nb + na) * d + 1
    T = np.zeros((p, p))
    for off, m in ((0, nb), (nb * d, na)):
        Tm = difference_transform(m)
        for j in range(d):
            idx = off + np.arange(m) * d + j
            T[np.ix_(idx, idx)] = Tm
    T[-1, -1] = 1.0
    return T


def lstsq_fit(R: np.ndarray, Y: np.ndarray, T: np.ndarray, ridge: float = 1e-12) -> np.ndarray:
    """Θ (d, p) on raw lags minimising |R Θᵀ − Y|², solved on differences with columns
    scaled to unit RMS and a relative ridge ``ridge`` (a guard against a regressor that the
    data never excite, e.g. an empty regime)."""
    D = R @ T.T
    scale = np.sqrt(np.mean(D * D, axis=0))
    scale[scale == 0] = 1.0
    Ds = D / scale
    p = Ds.shape[1]
    if ridge > 0:
        Ds = np.vstack([Ds, np.sqrt(ridge * len(Ds)) * np.eye(p)])
        Y = np.vstack([Y, np.zeros((p, Y.shape[1]))])
    # QR (Householder) rather than an SVD: ~10× faster on these tall, thin problems, and
    # the differences and the ridge keep R well conditioned
    # of the augmented [Ds Y] only R is formed: its top right block is Qᵀ Y (no Q built,
    # half the work)
    k = Y.shape[1]
    r = np.linalg.qr(np.hstack([Ds, Y]), mode="r")
    th = solve_triangular(r[:p, :p], r[:p, p:p + k])
    return ((th / scale[:, None]).T @ T)  # Θ_raw = Θ_δ T


COUPLINGS = ("full", "diagonal", "mixed")
"""How the force components depend on the DOFs: every component on every DOF's lags
(``full``), or each component on its own DOF's lags only (``diagonal``; DOFs that do not
interact); ``mixed`` (two-regime models): diagonal in the low regime, full in the high one (a
part whose DOFs interact only through a contact, e.g. a bar touching a surface with its
tip)."""


def column_groups(nb: int, na: int, d: int, coupling: str = "full", regime: str = "lo"
                  ) -> list[tuple[np.ndarray, list[int]]]:
    """(regressor columns, force components) fitted together in ``regime`` (``lo``/``hi``):
    one group for full coupling, one per DOF for diagonal coupling (its own lags and the
    constant)."""
    p = (nb + na) * d + 1
    if coupling not in COUPLINGS:
        raise ValueError(f"coupling must be one of {COUPLINGS}")
    if coupling == "mixed":
        coupling = "diagonal" if regime == "lo" else "full"
    if coupling == "full" or d == 1:
        return [(np.arange(p), list(range(d)))]
    return [(np.concatenate([np.arange(nb + na) * d + j, [p - 1]]), [j]) for j in range(d)]


def fit_groups(R: np.ndarray, Y: np.ndarray, T: np.ndarray, groups, nb: int, na: int
               ) -> np.ndarray:
    """Θ (d, p) from one least-squares fit per column group (zeros outside the groups), each
    with its force-lag (autoregressive) part made stable (:func:`stabilise`)."""
    d = Y.shape[1]
    th = np.zeros((d, R.shape[1]))
    for cols, outs in groups:
        sub = lstsq_fit(R[:, cols], Y[:, outs], T[np.ix_(cols, cols)])
        th[np.ix_(outs, cols)] = stabilise(sub, R[:, cols], Y[:, outs],
                                          T[np.ix_(cols, cols)], nb, na, len(outs))
    return th


def ar_radius(th: np.ndarray, nb: int, na: int, k: int) -> float:
    """Largest |root| of the force-lag polynomial of a group's Θ (k outputs, columns ordered
    z taps, force lags, constant; k DOFs per tap): the decay of the part's force with its
    mount held still."""
    if na == 0:
        return 0.0
    A = [th[:, nb * k + (i - 1) * k: nb * k + i * k] for i in range(1, na + 1)]
    comp = np.zeros((na * k, na * k))
    comp[:k] = np.hstack(A)
    comp[k:, :-k] = np.eye((na - 1) * k)
    return float(np.max(np.abs(np.linalg.eigvals(comp))))


def stabilise(th: np.ndarray, R: np.ndarray, Y: np.ndarray, T: np.ndarray, nb: int, na: int,
              k: int) -> np.ndarray:
    """Θ with its force-lag polynomial's roots inside the unit circle.

    With the mount held still the force of a passive part dies out (or rings on, undamped):
    the roots of its force-lag polynomial lie in the closed unit disc. Least squares on
    sampled data can put a lightly damped mode's pair just outside it (|λ| = 1.0001 is a
    growth of 10 % per second at 1 kHz), and coupled to a stiff numerical substructure over
    a whole test that mode then grows where the real part's decays. Such a fit is scaled
    radially, A_i → A_i s^i with s = 1/|λ|_max (every root by s), and the displacement
    coefficients refitted with the force lags fixed.
    """
    rho = ar_radius(th, nb, na, k)
    if rho <= 1.0 or not np.isfinite(rho):
        return th
    s = 1.0 / rho
    th = th.copy()
    ar = np.arange(nb * k, (nb + na) * k)
    for i in range(1, na + 1):
        th[:, nb * k + (i - 1) * k: nb * k + i * k] *= s ** i
    rest = np.setdiff1d(np.arange(th.shape[1]), ar)
    th[:, rest] = lstsq_fit(R[:, rest], Y - R[:, ar] @ th[:, ar].T, T[np.ix_(rest, rest)])
    return th


def blocks(n: int, start: int, n_blocks: int) -> list[tuple[int, int]]:
    """``n_blocks`` contiguous, nearly equal sample ranges covering [start, n)."""
    edges = np.linspace(start, n, n_blocks + 1).round().astype(int)
    return [(int(edges[i]), int(edges[i + 1])) for i in range(n_blocks)]


def check_signals(z: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """z, F as float (N, d) arrays of one shape, finite (RecordError naming the problem)."""
    z = np.asarray(z, dtype=float)
    f = np.asarray(f, dtype=float)
    z = z[:, None] if z.ndim == 1 else z
    f = f[:, None] if f.ndim == 1 else f
    if z.shape != f.shape or z.ndim != 2:
        raise RecordError(f"z' and F'_m differ in shape ({z.shape} vs {f.shape}): a part "
                          "model needs both for every interface DOF")
    if not (np.isfinite(z).all() and np.isfinite(f).all()):
        raise RecordError("z' or F'_m holds NaN/inf: a part model needs finite data")
    return z, f


class LagModel:
    """Base of the lag-model classes (see the module docstring).

    Subclasses implement :meth:`fit`. Fitted attributes: ``theta_lo_``, ``theta_hi_`` (d, p)
    raw lag coefficients (equal for a one-regime model), ``switch_`` (:class:`Switch`),
    ``residual_`` (relative RMS one-step residual on the fit rows).
    """

    name = "lag"

    def __init__(self, nb: int = 4, na: int = 2, coupling: str = "full"):
        self.nb = int(nb)
        self.na = int(na)
        if coupling not in COUPLINGS:
            raise ValueError(f"coupling must be one of {COUPLINGS}, got {coupling!r}")
        self.coupling = coupling

    def __repr__(self) -> str:
        return f"{type(self).__name__}(nb={self.nb}, na={self.na}, coupling={self.coupling!r})"

    @property
    def label(self) -> str:
        """Short name of the class and its orders, e.g. ``arx(4,2)`` (``arx(4,2,diag)`` for
        diagonal coupling of several DOFs)."""
        tail = ",diag" if self.coupling == "diagonal" else ""
        return f"{self.name}({self.nb},{self.na}{tail})"

    def fit(self, z: np.ndarray, f: np.ndarray, rows: np.ndarray | None = None) -> LagModel:
        raise NotImplementedError

    def refit(self, z: np.ndarray, f: np.ndarray, rows: np.ndarray | None = None) -> LagModel:
        """A new model of this class and structure (same switch) fitted on ``rows``."""
        return type(self)(self.nb, self.na, self.coupling).fit(z, f, rows)

    # ------------------------------------------------------------------ use
    def predict(self, z: np.ndarray, f: np.ndarray, start: int | None = None,
                stop: int | None = None) -> np.ndarray:
        """Free run of F over samples [start, stop) driven by ``z``, its lags before
        ``start`` the measured ``f`` (N, d). Diverged samples are inf."""
        z, f = check_signals(z, f)
        L = first_sample(self.nb, self.na)
        n0 = L if start is None else max(int(start), L)
        n1 = len(z) if stop is None else int(stop)
        sw = self.switch_
        d = z.shape[1]
        a = np.broadcast_to(np.asarray(sw.a, float), (d,)).copy()
        c = np.broadcast_to(np.asarray(sw.c, float), (d,)).copy()
        return _kernels.simulate(np.ascontiguousarray(z), np.ascontiguousarray(f), n0, n1,
                                 self.theta_lo_, self.theta_hi_, a, c, float(sw.h),
                                 bool(sw.lagged), self.nb, self.na)

    def validate(self, z: np.ndarray, f: np.ndarray, n_blocks: int = 4) -> float:
        """Output error on held-out blocks: for each of ``n_blocks`` contiguous blocks, refit
        on the others (same structure) and run freely over the block from its measured
        initial lags; the mean over blocks of RMS(F_sim − F)/RMS(F), each block's error
        capped at :data:`ERROR_CAP` (a run that diverges counts as the cap)."""
        z, f = check_signals(z, f)
        L = first_sample(self.nb, self.na)
        scale = np.sqrt(np.mean(f * f)) or 1.0
        errs = []
        for b0, b1 in blocks(len(z), L, n_blocks):
            rows = np.ones(len(z) - L, dtype=bool)
            rows[b0 - L:b1 - L] = False
            m = self.refit(z, f, rows)
            errs.append(self._error(m.predict(z, f, b0, b1), f[b0:b1], scale))
        return float(np.mean(errs))

    def simulation_error(self, z: np.ndarray, f: np.ndarray) -> float:
        """In-sample output error: this model run freely over the whole record,
        RMS(F_sim − F)/RMS(F) (capped at :data:`ERROR_CAP`)."""
        z, f = check_signals(z, f)
        L = first_sample(self.nb, self.na)
        return self._error(self.predict(z, f, L), f[L:], np.sqrt(np.mean(f * f)) or 1.0)

    @staticmethod
    def _error(sim: np.ndarray, f: np.ndarray, scale: float) -> float:
        if not np.isfinite(sim).all():
            return ERROR_CAP
        return min(float(np.sqrt(np.mean((sim - f) ** 2))) / scale, ERROR_CAP)

    def _fit_regimes(self, R: np.ndarray, Y: np.ndarray, hi: np.ndarray | None, T: np.ndarray
                     ) -> None:
        d = Y.shape[1]
        g_lo = column_groups(self.nb, self.na, d, self.coupling, "lo")
        g_hi = column_groups(self.nb, self.na, d, self.coupling, "hi")
        o = (self.nb, self.na)
        if hi is None or hi.all() or not hi.any():
            th = fit_groups(R, Y, T, g_lo, *o)
            self.theta_lo_ = self.theta_hi_ = np.ascontiguousarray(th)
            res = R @ th.T - Y
        else:
            self.theta_lo_ = np.ascontiguousarray(fit_groups(R[~hi], Y[~hi], T, g_lo, *o))
            self.theta_hi_ = np.ascontiguousarray(fit_groups(R[hi], Y[hi], T, g_hi, *o))
            res = np.where(hi[:, None], R @ self.theta_hi_.T, R @ self.theta_lo_.T) - Y
        self.residual_ = float(np.sqrt(np.mean(res ** 2) / max(np.mean(Y ** 2), 1e-300)))


class LagPart:
    """K fitted lag models as one experimental part for :func:`rths3d.reference.couple_exact`.

    ``advance(z_from, z_to)`` (K, d): the mount moves to z_to over one step; returns the
    restoring force F at its end (K, d). ``get_state``/``set_state``: the lag buffers. The
    models may differ in class and orders: they are padded to the largest orders with zero
    coefficients. Starts at rest (all lags zero), as the reference does. ``limit`` (K,):
    a test whose force exceeds it is flagged in ``diverged`` and gives zero force from then
    on (the others' interface iteration still converges); default no limit.
    """

    def __init__(self, models: list[LagModel], limit: np.ndarray | None = None):
        d = models[0].theta_lo_.shape[0]
        nb = max(m.nb for m in models)
        na = max(m.na for m in models)
        K = len(models)
        p = (nb + na) * d + 1
        self.K, self.d, self.nb, self.na = K, d, nb, na
        self.th_lo = np.zeros((K, d, p))
        self.th_hi = np.zeros((K, d, p))
        self.a = np.zeros((K, d))
        self.c = np.zeros((K, d))
        self.h = np.zeros(K)
        self.lagged = np.zeros(K, dtype=np.bool_)
        for k, m in enumerate(models):
            if m.theta_lo_.shape[0] != d:
                raise ValueError("all models of a part must have the same interface DOFs")
            for dst, src in ((self.th_lo, m.theta_lo_), (self.th_hi, m.theta_hi_)):
                dst[k][:, :m.nb * d] = src[:, :m.nb * d]
                dst[k][:, nb * d:nb * d + m.na * d] = src[:, m.nb * d:(m.nb + m.na) * d]
                dst[k][:, -1] = src[:, -1]
            sw = m.switch_
            self.a[k] = sw.a
            self.c[k] = sw.c
            self.h[k] = sw.h
            self.lagged[k] = sw.lagged
        self.zb = np.zeros((K, nb, d))
        self.fb = np.zeros((K, na, d))
        self.f = np.zeros((K, d))
        self.limit = (np.full(K, np.inf) if limit is None else
                      np.ascontiguousarray(np.broadcast_to(np.asarray(limit, float), (K,))))
        self.diverged = np.zeros(K, dtype=np.bool_)

    def reset(self) -> None:
        self.zb[:] = 0.0
        self.fb[:] = 0.0
        self.f[:] = 0.0

    def get_state(self) -> tuple[np.ndarray, np.ndarray]:
        return self.zb.copy(), self.fb.copy()

    def set_state(self, state: tuple[np.ndarray, np.ndarray]) -> None:
        self.zb[:] = state[0]
        self.fb[:] = state[1]

    def advance(self, z_from: np.ndarray, z_to: np.ndarray) -> np.ndarray:
        _kernels.advance(self.zb, self.fb, np.ascontiguousarray(z_to, dtype=float),
                         self.th_lo, self.th_hi, self.a, self.c, self.h, self.lagged,
                         self.limit, self.diverged, self.f)
        return self.f
