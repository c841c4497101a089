"""Switched (piecewise-linear) ARX model of the experimental part: two linear regimes split
where a switching variable crosses a threshold.

    F_n = Θ_hi r_n   if w_n = a·z_n − c·F_{n−1} − h > 0,   else Θ_lo r_n

(or with z_{n−1}, the state at the start of the step). This is the class of parts with a gap,
a stop or a contact: a piecewise-linear term max(0, x − h) of an internal displacement x. No
prior knowledge of the part is used: a, c and h are found by a search that, for every
candidate direction, sorts the samples by w and evaluates every threshold at once from
cumulative Gram matrices of the regressors (the least-squares fit of each side, on
differences of the lags), keeping the split of smallest one-step residual; the threshold is
then refined between neighbouring candidates. For one DOF a = 1 and c runs over a grid
(c = 1/k_EXP makes w the internal displacement x = z − F/k of a mass behind a spring); for
several DOFs the direction a and the per-DOF c are searched coordinate-wise, each candidate
direction judged by the free-run output error of the model it gives over the whole record
(one-step residuals of samples 1 ms apart hardly tell directions apart; with the right one,
a bar touching a surface with its tip, the held-out error drops from 0.2–0.6 to 0.04–0.2).
"""

from __future__ import annotations

import numpy as np

from .base import LagModel, Switch, check_signals, column_groups, delta_matrix, lag_matrix

C_GRID: tuple[float, ...] = (0.0, 0.05, 0.1, 0.2, 0.35, 0.5, 0.7, 1.0, 1.5, 2.5,
                             -0.05, -0.1, -0.2, -0.35, -0.5, -0.7, -1.0, -1.5, -2.5)
"""Multipliers of the data scale std(z)/std(F) tried for each component of c."""
GUARD = 1
"""Samples on either side of a change of regime left out of the regimes' fits: the step in
which the part crosses its switch is neither regime (the switch is read at the start of the
step, the contact begins within it). Fitted into the free regime, such steps bias it: on a
2-DOF chain with an undamped contact part they gave the free regime a negative damping
(coupled radius 1.0035) that the true part does not have."""


def settled(hi: np.ndarray, guard: int) -> np.ndarray:
    """Rows whose regime is the same ``guard`` rows before and after (bool, as ``hi``)."""
    keep = np.ones(len(hi), dtype=bool)
    for g in range(1, guard + 1):
        change = hi[g:] != hi[:-g]
        keep[g:] &= ~change
        keep[:-g] &= ~change
    return keep


N_THRESHOLDS = 48
"""Candidate thresholds per direction (equal numbers of samples between them)."""

SSE_TIE = 1e-5
"""Relative margin by which a trial switch's split SSE must undercut the best so far to
replace it. The SSE is the total energy of the targets less the explained part, a difference
of two numbers up to 10⁸ times larger (a contact part fits to a residual of 10⁻⁸ of its
energy), so rounding at the level of the BLAS kernel (SkylakeX vs Haswell OpenBLAS kernels,
or the last bits of the record) moves it by up to ~2·10⁻⁷ of itself: a strict ``<`` between
two such trials is decided by rounding and steered the search to different switches (c
0.04388 vs 0.04458) on the same test. Within this margin the earlier trial is kept (for
several DOFs, where a trial is judged by its free-run error, the same)."""


def _better(sse: float, best: float) -> bool:
    """Whether ``sse`` undercuts ``best`` by more than :data:`SSE_TIE` of it (see there)."""
    return bool(sse < best - SSE_TIE * abs(best)) if np.isfinite(best) else bool(sse < best)


def _split_sse(groups: list[tuple], w: np.ndarray, min_rows: int, n_cand: int
               ) -> tuple[float, float]:
    """Smallest summed SSE of the two-regime least squares over thresholds of ``w``.

    ``groups``: per output group (O (rows, p, p) outer products of the scaled regressors,
    B (rows, p, k) regressor × target, yy (rows,) |y|², totals, ridge λ (p,), the regimes it
    serves ``("lo", "hi")``). The regimes share the threshold; the SSE adds up over groups.
    Returns (SSE, threshold)."""
    n = len(w)
    order = np.argsort(w, kind="stable")
    ws = w[order]
    pos = np.unique(np.linspace(min_rows, n - min_rows, n_cand).astype(int))
    if len(pos) == 0:
        return np.inf, np.inf
    cuts = np.concatenate([[0], pos])
    sse = np.zeros(len(pos))
    for O, B, yy, totals, lam, sides in groups:
        Gc = np.cumsum(np.add.reduceat(O[order], cuts, axis=0), axis=0)[:len(pos)]
        Bc = np.cumsum(np.add.reduceat(B[order], cuts, axis=0), axis=0)[:len(pos)]
        yc = np.cumsum(np.add.reduceat(yy[order], cuts))[:len(pos)]
        Gt, Bt, yt = totals
        eye = np.diag(lam)
        both = ((Gc, Bc, yc, "lo"), (Gt - Gc, Bt - Bc, yt - yc, "hi"))
        for G, Bs, ys, side in both:
            if side not in sides:
                continue
            th = np.linalg.solve(G + eye, Bs)
            sse += ys - np.einsum("kpd,kpd->k", Bs, th)
    j = int(np.argmin(sse))
    if not np.isfinite(sse[j]):
        return np.inf, np.inf
    k = pos[j]
    return float(sse[j]), 0.5 * (ws[k - 1] + ws[k])


class SwitchedARX(LagModel):
    """Two-regime ARX part model with a searched switch (see the module docstring).

    Parameters: ``nb``, ``na`` as :class:`~rths3d.surrogate.arx.ARX`; ``switch``: a fixed
    :class:`~rths3d.surrogate.base.Switch` (skips the search, e.g. to refit on other rows);
    ``timings``: which switching variables the search tries, ``True`` the state at the start
    of the step (z_{n−1}, F_{n−1}; default), ``False`` with z_n. A switch fixed at the start
    of the step keeps the force affine in z_n within every step, so that the exact coupling
    has exactly one solution per step (with z_n the regime can flip with the unknown z_n:
    two solutions or none).
    ``guard``: rows on either side of a change of regime left out of the regimes' fits
    (:data:`GUARD`; 0 fits every row).
    Fitted: ``theta_lo_``, ``theta_hi_`` (d, p), ``switch_``, ``residual_``.
    """

    name = "switched"

    def __init__(self, nb: int = 4, na: int = 2, coupling: str = "full",
                 switch: Switch | None = None, timings: tuple[bool, ...] = (True,),
                 guard: int = 0):
        super().__init__(nb, na, coupling)
        self.switch = switch
        self.timings = tuple(bool(t) for t in timings)
        self.guard = int(guard)

    @property
    def label(self) -> str:
        """As :attr:`LagModel.label`, with ``,g<guard>`` when transition rows are left out."""
        base = super().label
        return base if self.guard == 0 else f"{base[:-1]},g{self.guard})"

    def refit(self, z, f, rows=None) -> SwitchedARX:
        return SwitchedARX(self.nb, self.na, self.coupling, self.switch_,
                           self.timings, self.guard).fit(z, f, rows)

    def fit(self, z: np.ndarray, f: np.ndarray, rows: np.ndarray | None = None
            ) -> SwitchedARX:
        z, f = check_signals(z, f)
        d = z.shape[1]
        R, Y, s = lag_matrix(z, f, self.nb, self.na)
        zn, zl, fl = z[s:], z[s - 1:-1], f[s - 1:-1]
        zn_all, zl_all, fl_all = zn, zl, fl
        if rows is not None:
            R, Y, zn, zl, fl = R[rows], Y[rows], zn[rows], zl[rows], fl[rows]
        T = delta_matrix(self.nb, self.na, d)
        sw = (self.switch if self.switch is not None else
              self._search(R, Y, zn, zl, fl, T, z, f))
        self.switch_ = sw
        hi = sw.w(zn_all, zl_all, fl_all) > 0
        keep = settled(hi, self.guard)
        if rows is not None:
            hi, keep = hi[rows], keep[rows]
        if keep.sum() < 0.5 * len(keep) or hi[keep].all() or not hi[keep].any():
            keep = np.ones(len(hi), dtype=bool)  # too few settled rows: all of them
        self._fit_regimes(R[keep], Y[keep], hi[keep], T)
        return self

    def _search(self, R, Y, zn, zl, fl, T, z, f) -> Switch:
        d = zn.shape[1]
        D = R @ T.T
        scale = np.sqrt(np.mean(D * D, axis=0))
        scale[scale == 0] = 1.0
        Ds = D / scale
        ysc = np.sqrt(np.mean(Y * Y, axis=0))
        ysc[ysc == 0] = 1.0
        Ys = Y / ysc
        groups = []
        p_max = 0
        lo = column_groups(self.nb, self.na, d, self.coupling, "lo")
        hi = column_groups(self.nb, self.na, d, self.coupling, "hi")
        keyed: dict[tuple, list[str]] = {}
        for side, gs in (("lo", lo), ("hi", hi)):
            for cols, outs in gs:
                keyed.setdefault((tuple(cols), tuple(outs)), []).append(side)
        for (cols, outs), sides in keyed.items():
            Dg, Yg = Ds[:, list(cols)], Ys[:, list(outs)]
            O = Dg[:, :, None] * Dg[:, None, :]
            B = Dg[:, :, None] * Yg[:, None, :]
            yy = np.einsum("ij,ij->i", Yg, Yg)
            groups.append((O, B, yy, (O.sum(0), B.sum(0), yy.sum()),
                           np.full(len(cols), 1e-9 * len(Ds)), tuple(sides)))
            p_max = max(p_max, len(cols))
        min_rows = max(4 * p_max, len(Ds) // 200)
        sz = np.std(zn, axis=0)
        sz[sz == 0] = 1.0
        sf = np.std(fl, axis=0)
        sf[sf == 0] = 1.0

        def score(a, c, lagged, n_cand=N_THRESHOLDS):
            w = (zl if lagged else zn) @ a - fl @ c
            sse, h = _split_sse(groups, w, min_rows, n_cand)
            if d == 1 or not np.isfinite(h):
                return sse, h
            # several DOFs: the one-step residual hardly tells directions apart (the
            # samples are 1 ms apart); the threshold comes from it, the direction is judged
            # by the free run of the model it gives
            sw = Switch(tuple(map(float, a)), tuple(map(float, c)), float(h), bool(lagged))
            m = SwitchedARX(self.nb, self.na, self.coupling, sw).fit(z, f)
            return m.simulation_error(z, f), h

        def direction(phi):
            if d == 1:
                return np.array([1.0 / sz[0]])
            a = np.zeros(d)
            a[0], a[1] = np.cos(phi), np.sin(phi)  # the first two DOFs span the search
            return a / sz

        # 1. direction (several DOFs) on a grid, c = 0, either timing of the switch
        angles = [0.0] if d == 1 else list(np.linspace(0.0, np.pi, 12, endpoint=False))
        best = (np.inf, 0.0, np.zeros(d), np.inf, False)   # sse, φ, c, h, lagged
        for lagged in self.timings:
            for ph in angles:
                sse, h = score(direction(ph), np.zeros(d), lagged)
                if _better(sse, best[0]):
                    best = (sse, ph, np.zeros(d), h, lagged)
        if not np.isfinite(best[0]):
            return Switch(tuple([0.0] * d), tuple([0.0] * d), np.inf)
        # 2. each component of c on a grid (multiples of the data scale), both timings
        for lagged in self.timings:
            c = np.zeros(d)
            for j in range(d):
                for m in C_GRID:
                    cj = c.copy()
                    cj[j] = m / sf[j]  # w in units of std(z): c·F = m·F/std(F)
                    sse, h = score(direction(best[1]), cj, lagged)
                    if _better(sse, best[0]):
                        best = (sse, best[1], cj, h, lagged)
                        c = cj
        # 3. pattern search on (φ, c) around the best: the timing of the switch depends on
        # c·F when the force oscillates (a free mass ringing behind its spring)
        _, phi, c, h, lagged = best
        step, dphi = 0.25, 0.1
        for _ in range(16):
            moved = False
            trials = []
            for j in range(d):
                for sgn in (1.0, -1.0):
                    cj = c.copy()
                    cj[j] = c[j] * (1.0 + sgn * step) if c[j] != 0 else sgn * step * 0.05 / sf[j]
                    trials.append((phi, cj))
            if d > 1:
                trials += [(phi + dphi, c), (phi - dphi, c)]
            for ph, cj in trials:
                sse, hj = score(direction(ph), cj, lagged)
                if _better(sse, best[0]):
                    best = (sse, ph, cj, hj, lagged)
                    phi, c, h, moved = ph, cj, hj, True
            if not moved:
                step *= 0.5
                dphi *= 0.5
                if step < 0.01:
                    break
        a = direction(phi)
        # refine the threshold: many more candidates in the chosen direction
        sse_f, h_f = score(a, c, lagged, n_cand=8 * N_THRESHOLDS)
        if _better(sse_f, best[0]):
            h = h_f
        return Switch(tuple(float(v) for v in a), tuple(float(v) for v in c), float(h),
                      bool(lagged))
