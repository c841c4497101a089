"""The bench's safety limits, checked every step by one monitor on every path of the loop.

A real bench stops a test that leaves its limits and keeps what it recorded up to then. The
:class:`SafetyMonitor` holds each test's limits (from its scene's ``[safety]`` table) and
checks, per interface step n → n+1:

1. the command: every numerical displacement |x| ≤ ``divergence`` (NaN counts as out),
   |z| ≤ ``stroke`` (``rotation`` for rotational DOFs) and |ż| ≤ ``velocity``; a stop keeps
   rows 0…n (the out-of-limit sample is not recorded);
2. the measured force: |F'_m| ≤ ``force`` (``torque``), the FTS range; a stop keeps the
   offending sample when it is finite;
3. divergence by growth: the peak |F'_m| of each DOF over windows of ``growth_window`` grew
   by more than ``growth`` in ``growth_windows`` consecutive windows (each peak above 2 % of
   the FTS range);
4. stops the transfer system itself reports (leg limits of the platform) and a user's stop.

The checks are numba kernels called by the compiled loop (:mod:`rths3d.stepping`) and, step
by step, by the Python loop through this class, so both paths stop alike. A stop is a code
per test; :meth:`SafetyMonitor.reasons` turns codes into the
:class:`~rths3d.errors.SafetyStop` sentences of the records.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from .config import Scene
from .errors import SafetyStop
from .kernels import inline_njit, njit

__all__ = ["SafetyMonitor"]

RUNNING, CMD_X, CMD_Z, CMD_V, FORCE, GROWTH, EXTERNAL, USER = range(8)
"""Stop codes: running, numerical divergence, stroke, velocity, FTS range, growth,
reported by the transfer system, stopped by the user."""


@njit
def check_command(z, zd, x, lim_z, lim_v, lim_x, active, code, dof, value, row, n):
    """Stop the active tests whose command left its limits (row n kept); returns how many."""
    stops = 0
    for k in range(z.shape[0]):
        if not active[k]:
            continue
        bad = False
        for i in range(x.shape[1]):
            if not abs(x[k, i]) <= lim_x[k]:
                bad = True
        if bad:
            # the largest |x| (NaN when every offending entry is NaN)
            m = -1.0
            for i in range(x.shape[1]):
                a = abs(x[k, i])
                if a == a and a > m:
                    m = a
            code[k] = CMD_X
            dof[k] = 0
            value[k] = m if m >= 0.0 else math.nan
        else:
            for j in range(z.shape[1]):
                if abs(z[k, j]) > lim_z[k, j]:
                    code[k] = CMD_Z
                    dof[k] = j
                    value[k] = z[k, j]
                    break
                if abs(zd[k, j]) > lim_v[k, j]:
                    code[k] = CMD_V
                    dof[k] = j
                    value[k] = zd[k, j]
                    break
        if code[k] != RUNNING:
            active[k] = False
            row[k] = n
            stops += 1
    return stops


@inline_njit
def check_force(f, lim_f, active, code, dof, value, row, n):
    """Stop the active tests whose measured force left the FTS range (NaN counts as out)."""
    stops = 0
    for k in range(f.shape[0]):
        if not active[k]:
            continue
        for j in range(f.shape[1]):
            v = f[k, j]
            if not abs(v) <= lim_f[k, j]:
                code[k] = FORCE
                dof[k] = j
                value[k] = v
                # a non-finite sample is not kept (the record stays loadable)
                row[k] = n + 1 if math.isfinite(v) else n
                active[k] = False
                stops += 1
                break
    return stops


@inline_njit
def check_growth(f, win, fac, nwin, floor, pk, prev, base, cnt, active, code, dof, value,
                 row, n):
    """Watch the windowed peak |F'_m| for a growing oscillation (see the module docstring)."""
    stops = 0
    for k in range(f.shape[0]):
        if nwin[k] <= 0:
            continue
        for j in range(f.shape[1]):
            a = abs(f[k, j])
            if a > pk[k, j]:
                pk[k, j] = a
        if (n + 1) % win[k] != 0:
            continue
        for j in range(f.shape[1]):
            grew = pk[k, j] > fac[k] * prev[k, j] and pk[k, j] > floor[k, j]
            if grew:
                if cnt[k, j] == 0:
                    base[k, j] = prev[k, j]
                cnt[k, j] += 1
            else:
                cnt[k, j] = 0
        for j in range(f.shape[1]):
            if cnt[k, j] >= nwin[k] and active[k]:
                code[k] = GROWTH
                dof[k] = j
                value[k] = pk[k, j] / base[k, j]
                row[k] = n + 1
                active[k] = False
                stops += 1
        for j in range(f.shape[1]):
            prev[k, j] = pk[k, j]
            pk[k, j] = 0.0
    return stops


@njit
def check_measured(f, lim_f, win, fac, nwin, floor, pk, prev, base, cnt, active, code, dof,
                   value, row, n):
    """:func:`check_force`, then :func:`check_growth`, for step n; returns the new stops."""
    stops = 0
    for k in range(f.shape[0]):
        for j in range(f.shape[1]):
            if not abs(f[k, j]) <= lim_f[k, j]:
                stops += check_force(f, lim_f, active, code, dof, value, row, n)
                break
        if stops:
            break
    return stops + check_growth(f, win, fac, nwin, floor, pk, prev, base, cnt, active, code,
                                dof, value, row, n)


class SafetyMonitor:
    """Each test's limits and stop state (see the module docstring).

    Arrays over K tests: ``active`` (still running), ``code``, ``dof``, ``value``, ``row``
    (last kept row) of its stop. ``scenes``: one per test (same DOFs).
    """

    def __init__(self, scenes: Sequence[Scene]):
        self.scenes = list(scenes)
        base = self.scenes[0]
        self.dofs = base.dofs
        K, nd = len(self.scenes), len(base.dofs)
        self.K, self.nd = K, nd
        self.dt = base.dt
        self.n_steps = base.n_steps
        rot = np.array([d.startswith("r") for d in base.dofs])
        saf = [s.safety for s in self.scenes]
        col = lambda a, b: np.array([[getattr(x, a) if not r else getattr(x, b)  # noqa: E731
                                      for r in rot] for x in saf], dtype=float)
        self.lim_z = col("stroke", "rotation")
        self.lim_v = np.where(rot[None, :], np.inf, col("velocity", "velocity"))
        self.lim_f = col("force", "torque")
        self.lim_x = np.array([x.divergence for x in saf], dtype=float)
        self.g_win = np.array([max(1, int(round(x.growth_window / base.dt))) for x in saf],
                              dtype=np.int64)
        self.g_fac = np.array([x.growth for x in saf], dtype=float)
        self.g_n = np.array([int(x.growth_windows) for x in saf], dtype=np.int64)
        self.g_floor = 0.02 * self.lim_f
        self.active = np.ones(K, dtype=np.bool_)
        self.code = np.zeros(K, dtype=np.int64)
        self.dof = np.zeros(K, dtype=np.int64)
        self.value = np.zeros(K)
        self.row = np.full(K, self.n_steps, dtype=np.int64)
        self.external = [""] * K
        self.g_pk = np.zeros((K, nd))
        self.g_prev = np.full((K, nd), np.inf)
        self.g_base = np.zeros((K, nd))
        self.g_cnt = np.zeros((K, nd), dtype=np.int64)

    def reset(self) -> None:
        self.active[:] = True
        self.code[:] = RUNNING
        self.row[:] = self.n_steps
        self.external = [""] * self.K
        self.g_pk[:] = 0.0
        self.g_prev[:] = np.inf
        self.g_base[:] = 0.0
        self.g_cnt[:] = 0

    @property
    def any_active(self) -> bool:
        return bool(self.active.any())

    # ------------------------------------------------------------------ Python loop
    def command(self, n: int, z: np.ndarray, zd: np.ndarray, x: np.ndarray) -> int:
        """Check the command of step n (see :func:`check_command`); returns the new stops."""
        return check_command(z, zd, x, self.lim_z, self.lim_v, self.lim_x, self.active,
                             self.code, self.dof, self.value, self.row, n)

    def stop(self, k: int, reason: str, row: int, code: int = EXTERNAL) -> None:
        """Stop test k from outside the checks (the transfer system, the user)."""
        if self.active[k]:
            self.active[k] = False
            self.code[k] = code
            self.row[k] = row
            self.external[k] = reason

    # ------------------------------------------------------------------ reasons
    def stop_of(self, k: int) -> SafetyStop | None:
        """The :class:`SafetyStop` of test k (None while it runs)."""
        c = int(self.code[k])
        if c == RUNNING:
            return None
        saf = self.scenes[k].safety
        j = int(self.dof[k])
        d = self.dofs[j]
        rot = d.startswith("r")
        v = float(self.value[k])
        r = int(self.row[k])
        t_cmd = (r + 1) * self.dt
        if c == CMD_X:
            return SafetyStop("divergence: numerical displacement |x|", v, saf.divergence,
                              t_cmd, k, "m")
        if c == CMD_Z:
            return SafetyStop(f"stroke: commanded {d}", v, saf.rotation if rot else saf.stroke,
                              t_cmd, k, "rad" if rot else "m")
        if c == CMD_V:
            return SafetyStop(f"velocity: commanded {d} rate", v, saf.velocity, t_cmd, k,
                              "m/s")
        if c == FORCE:
            t = (r if math.isfinite(v) else r + 1) * self.dt
            what, unit = ("torque", "N·m") if rot else ("force", "N")
            stop = SafetyStop(f"FTS range: measured {what} {d}", v,
                              saf.torque if rot else saf.force, t, k, unit)
            if not math.isfinite(v):  # NaN exceeds no limit: say what it is
                stop.args = (f"stopped at t = {t:.3f} s: FTS range: measured {what} {d} = "
                             f"{v} is not finite" + (f" (test {k})" if k else ""),)
            return stop
        if c == GROWTH:
            what = "torque" if rot else "force"
            return SafetyStop(f"divergence: growth of the peak measured {what} {d} over "
                              f"{saf.growth_windows} windows of {saf.growth_window:g} s", v,
                              saf.growth ** saf.growth_windows, r * self.dt, k)
        stop = SafetyStop(self.external[k] or "stopped", math.nan, math.nan, r * self.dt, k)
        stop.args = (self.external[k] or f"stopped at t = {r * self.dt:.3f} s",)
        return stop

    def reason(self, k: int, test: int | None = None) -> str:
        """The stop sentence of test k ("" while it runs), naming it as ``test`` (default
        k; SafetyStop appends " (test k)" for k > 0)."""
        stop = self.stop_of(k)
        if stop is None:
            return ""
        text = stop.reason
        local = f" (test {k})"
        if k and text.endswith(local):
            text = text[: -len(local)]
        t = k if test is None else test
        return text + (f" (test {t})" if t else "")
