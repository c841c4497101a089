"""The online fidelity monitor: warn or stop a running test whose estimated error grows.

A scene asks for it in ``[safety]``: ``fidelity_limit`` (m or rad, > 0; 0 switches it off),
``fidelity_action`` (``"warn"`` or ``"stop"``) and ``fidelity_warmup`` (s). During the first
``fidelity_warmup`` seconds the test runs unwatched; at their end the experimental part is
identified from those samples of the test's own record (z', F'_m; :func:`.identify`, the
model classes of the surrogate reference), and from then on the surrogate reference ẑ^r is
stepped beside the test (:class:`.OnlineReference`: the identified part coupled exactly to
the numerical substructure, started at rest and caught up over the warm-up samples once).
The running RMS of ê = z' − ẑ^r over the surrogate's window (0.25 s) is compared with the
limit on every interface DOF.

The loop calls :meth:`FidelityMonitor.update` after every block of steps (50 ms of test
time when the monitor is on), so a crossing is acted on at the end of the block it happened
in: with ``"stop"`` the test stops there, as any safety stop, with its partial record and the
reason (the time of the crossing, the DOF, the estimate and the limit); with ``"warn"`` it
runs on and its record's metadata ``fidelity`` names the first crossing. The part model is
identified from the warm-up only: a part whose behaviour changes later (a contact first
reached after the warm-up) is extrapolated, which the estimate then reports as error —
choose a warm-up that excites the part.

**An estimate the monitor does not act on.** A warm-up that holds only part of the part's
behaviour can leave a model that validates well and still couples wrongly: from the 1 s
warm-up of ``paper_contact`` (one entry into contact, no separation) the switch of the
identified part is not pinned down, and the surrogate reference stays in contact when the
test separates, pulling with −22 N where the part never pulled (ê's running RMS 2.2 mm on a
test whose true error peaks at 0.066 mm). So at the end of every block the part force of ẑ^r
is compared with the range of F'_m the model's regime held in the warm-up, widened by
:data:`ENVELOPE` times the warm-up's peak |F'_m|; outside it the estimate is *unreliable*
from there on. The first time this happens in a test group, the monitor identifies the part
again from the record so far (which now holds the behaviour the warm-up lacked), replaces
the model and recomputes ẑ^r and the running RMS from the start (metadata
``reidentified``: the time and the reason); a model that is flagged again makes the
estimate unreliable for the rest of the test: no crossing is acted on (no false stop), the
metadata names the time and the reason under ``unreliable``, and ``rths3d run`` says so.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..config import Scene
from .estimator import identify
from .online import OnlineReference
from .running import WINDOW, window_samples

ACTIONS = ("warn", "stop")
"""What the monitor does when the running estimate crosses ``safety.fidelity_limit``."""

BLOCK = 0.05
"""Test time (s) between two monitor updates: the latency of a warning or stop."""

ENVELOPE = 0.2
"""Widening of each regime's warm-up force range, in multiples of the warm-up's peak |F'_m|,
beyond which ẑ^r extrapolates the part model and the estimate is unreliable."""


class FidelityMonitor:
    """Online fidelity monitor of K tests stepped together (see the module docstring).

    ``FidelityMonitor(scenes, num)``: ``num`` the loop's
    :class:`~rths3d.numerical.LinearSubstructure` (its M, C, K, Γ and load p of every
    test). ``update(data, ci, n, stop)`` after the loop recorded rows 0…n of ``data``
    (N+1, K, columns; ``ci`` the column index); ``stop(k, reason, row)`` stops test k.
    ``summary(k)``: what the record's metadata ``fidelity`` holds.
    """

    def __init__(self, scenes: Sequence[Scene], num: Any):
        self.scenes = list(scenes)
        base = self.scenes[0]
        self.dt, self.dofs = base.dt, tuple(base.dofs)
        self.limit = np.array([s.safety.fidelity_limit for s in self.scenes], dtype=float)
        self.watch = np.flatnonzero(self.limit > 0)
        self.enabled = self.watch.size > 0
        self.warmup_rows = max(int(round(base.safety.fidelity_warmup / self.dt)), 1)
        self.window_rows = window_samples(WINDOW, self.dt)
        self.every = max(int(round(BLOCK / self.dt)), 1)
        self.num = num
        self.online: OnlineReference | None = None
        self.done = 0  # rows the online reference has reached
        self.models: list[str] = [""] * len(self.scenes)
        self.validation = np.full(len(self.scenes), np.nan)
        self.first: list[dict[str, float | str] | None] = [None] * len(self.scenes)
        self.peak = np.zeros((len(self.scenes), len(self.dofs)))
        self.failed: list[str] = [""] * len(self.scenes)
        self.unreliable: list[dict[str, float | str] | None] = [None] * len(self.scenes)
        self.reidentified: list[dict[str, float | str] | None] = [None] * len(self.scenes)
        self.reidentified_at = 0.0  # s: when the group was identified again (0: never)
        self.identify_s = 0.0
        """Wall time of the identification after the warm-up (s; once per test group)."""
        self.identify_cpu_s = 0.0
        """Its processor time (s): what it costs whatever else the machine runs."""
        self._rms = np.empty((0, 0, 0))
        self.cpu_s = 0.0
        """Processor time (s) spent in :meth:`update`, the identification included."""
        from ..numerical import LinearSubstructure

        if self.enabled and type(num) is not LinearSubstructure:
            # ẑ^r needs the substructure's exact discretisation: M, C, K and the load
            for k in self.watch:
                self.failed[k] = "the monitor needs a linear numerical substructure"
            self.enabled = False

    # ------------------------------------------------------------------ stepping
    def check(self, data: np.ndarray, ci: dict[str, int], n: int, safety: Any,
              num: Any) -> None:
        """:meth:`update` with the loop's :class:`~rths3d.safety.SafetyMonitor`: a test the
        monitor stops stops there (row n kept) and its numerical substructure rests."""
        from ..safety import EXTERNAL

        def stop(k: int, reason: str, row: int) -> None:
            if safety.active[k]:
                safety.stop(k, reason, row, EXTERNAL)
                num.halt(k)

        self.update(data, ci, n, stop)

    def update(self, data: np.ndarray, ci: dict[str, int], n: int, stop) -> None:
        """Rows 0…n of ``data`` are recorded: identify after the warm-up, then step ẑ^r to
        row n and act on any crossing."""
        if not self.enabled or n < self.warmup_rows:
            return
        c0 = time.process_time()
        try:
            self._update(data, ci, n, stop)
        finally:
            self.cpu_s += time.process_time() - c0

    def _update(self, data: np.ndarray, ci: dict[str, int], n: int, stop) -> None:
        c_z, c_f = ci[f"z_meas.{self.dofs[0]}"], ci[f"f_meas.{self.dofs[0]}"]
        d = len(self.dofs)
        if self.online is None:
            t0, c0 = time.perf_counter(), time.process_time()
            self._identify(data[: n + 1, :, c_z:c_z + d], data[: n + 1, :, c_f:c_f + d])
            self.identify_s += time.perf_counter() - t0  # the re-identification added
            self.identify_cpu_s += time.process_time() - c0
            if self.online is None:
                return
        rows = self.watch
        zm = data[self.done + 1:n + 1, :, c_z:c_z + d]
        if rows.size != zm.shape[1]:
            zm = zm[:, rows]
        m = n - self.done
        if self._rms.shape[0] < m:  # the catch-up over the warm-up, then blocks reuse it
            self._rms = np.empty((m, rows.size, d))
        rms = self._rms[:m]
        crossed = self.online.update_block(
            self.done, n, np.ascontiguousarray(zm), self.warmup_rows, self._peak, self._lim,
            self._first, self._first_dof, self._first_val, rms)
        # the online estimate into the record (``e_hat_rms.<dof>``: the live view draws it)
        c_r = ci.get(f"e_hat_rms.{self.dofs[0]}")
        if c_r is not None:
            block = data[self.done + 1:n + 1]
            for r, k in enumerate(rows):
                block[:, k, c_r:c_r + d] = rms[:, r]
        if self._envelope(n) and not self.reidentified_at:
            # once per test group: identify again from the record so far (it now holds the
            # behaviour the warm-up lacked) and catch ẑ^r up with the new model
            self.reidentified_at = n * self.dt
            for k in self.watch:
                if self.unreliable[k] is not None:
                    self.reidentified[k] = self.unreliable[k]
                    self.unreliable[k] = None
            self.online = None
            self._update(data, ci, n, stop)
            return
        if crossed:
            self._cross(n, stop)
        self.done = n

    def _envelope(self, n: int) -> bool:
        """Flag the tests whose ẑ^r, at the end of the block ending at row n, drives the part
        model outside the force range its regime held in the warm-up (:data:`ENVELOPE`).
        Returns whether a test was newly flagged."""
        new = False
        on = self.online
        w = np.einsum("kd,kd->k", on.z_ref, self._sw_a) - \
            np.einsum("kd,kd->k", on.f_ref, self._sw_c) - self._sw_h
        hi = w > 0.0
        lo_b = np.where(hi[:, None], self._env[:, 1, 0], self._env[:, 0, 0])
        hi_b = np.where(hi[:, None], self._env[:, 1, 1], self._env[:, 0, 1])
        with np.errstate(invalid="ignore"):
            out = ~((on.f_ref >= lo_b) & (on.f_ref <= hi_b))  # NaN (diverged) is out too
        for r in np.flatnonzero(out.any(axis=1)):
            k = int(self.watch[r])
            if self.unreliable[k] is not None:
                continue
            new = True
            j = int(np.argmax(out[r]))
            regime = "contact (high)" if hi[r] and np.isfinite(self._sw_h[r]) else "free (low)"
            if not np.isfinite(self._sw_h[r]):
                regime = "only"
            unit = "N·m" if self.dofs[j].startswith("r") else "N"
            self.unreliable[k] = {
                "t": n * self.dt, "dof": self.dofs[j],
                "reason": f"estimate unreliable: ẑ^r drives the part model ({self.models[k]}) "
                          f"to a force of {on.f_ref[r, j]:.4g} {unit} in its {regime} regime, "
                          f"outside the {lo_b[r, j]:.4g} … {hi_b[r, j]:.4g} {unit} that regime "
                          f"held in the warm-up (widened by {ENVELOPE:g}× the peak |F'_m|): "
                          "the warm-up did not show this behaviour of the part"}
        return new

    def _identify(self, z: np.ndarray, f: np.ndarray) -> None:
        """The part of every watched test from its warm-up samples; the online reference."""
        from ..numerical import LinearSubstructure

        models, env = [], []
        for k in self.watch:
            ident = identify(z[:, k, :], f[:, k, :])
            # the online coupling needs a switch fixed at the start of the step: the best
            # candidate that has one (a linear model always does)
            pick = next((ident.candidates[i] for i in ident.order
                         if ident.candidates[i].switch_.lagged
                         or not np.isfinite(ident.candidates[i].switch_.h)), None)
            if pick is None:
                self.failed[k] = "no identified part model can be stepped online"
                models.append(None)
                continue
            self.models[k] = pick.label
            self.validation[k] = float(ident.scores[ident.candidates.index(pick)])
            models.append(pick)
            env.append(self._warmup_envelope(pick, z[:, k, :], f[:, k, :]))
        keep = [i for i, m in enumerate(models) if m is not None]
        if not keep:
            self.enabled = False
            return
        self.watch = self.watch[keep]
        num = self.num
        rows = self.watch

        def sel(a: np.ndarray) -> np.ndarray:
            a = np.asarray(a)
            return a[rows] if a.ndim == 3 and a.shape[0] == len(self.scenes) else \
                np.broadcast_to(a, (len(rows),) + a.shape[-2:]).copy()

        sub = LinearSubstructure(sel(num.M), sel(num.C), sel(num.Kmat), num.gamma,
                                 np.asarray(num.p)[rows], self.dt, "exact")
        picked = [models[i] for i in keep]
        self.online = OnlineReference(sub, picked, self.window_rows)
        # the switch of each picked model and its regimes' warm-up force ranges
        self._env = np.stack(env)                               # (K, regime, bound, d)
        self._sw_a = np.array([np.asarray(m.switch_.a, float) for m in picked])
        self._sw_c = np.array([np.asarray(m.switch_.c, float) for m in picked])
        self._sw_h = np.array([float(m.switch_.h) for m in picked])
        self.done = 0
        # per-step buffers of the watched tests: no allocation per step
        self._peak = np.zeros((len(rows), len(self.dofs)))
        self._lim = np.ascontiguousarray(
            np.repeat(self.limit[rows, None], len(self.dofs), axis=1))
        self._first = np.full(len(rows), -1, dtype=np.int64)
        self._first_dof = np.zeros(len(rows), dtype=np.int64)
        self._first_val = np.zeros(len(rows))

    @staticmethod
    def _warmup_envelope(model, z: np.ndarray, f: np.ndarray) -> np.ndarray:
        """(regime, bound, d): the range of F'_m in each regime of ``model`` over the warm-up
        (regime read at the start of the step, as the coupling does), widened by
        :data:`ENVELOPE` × peak |F'_m|; a regime the warm-up never held has an empty range."""
        sw = model.switch_
        f1 = f[1:]
        if np.isfinite(sw.h):
            hi = z[:-1] @ np.asarray(sw.a, float) - f[:-1] @ np.asarray(sw.c, float) > sw.h
        else:
            hi = np.zeros(len(f1), dtype=bool)
        pad = ENVELOPE * float(np.max(np.abs(f))) if len(f) else 0.0
        out = np.empty((2, 2, f.shape[1]))
        for q, rows in enumerate((~hi, hi)):
            if rows.any():
                out[q, 0] = f1[rows].min(axis=0) - pad
                out[q, 1] = f1[rows].max(axis=0) + pad
            else:
                out[q, 0], out[q, 1] = np.inf, -np.inf
        return out

    def _cross(self, n: int, stop) -> None:
        """Tests whose first crossing was found in the block ending at row n."""
        for r, k in enumerate(self.watch):
            row = int(self._first[r])
            if row < 0 or self.first[k] is not None or self.unreliable[k] is not None:
                continue
            j = int(self._first_dof[r])
            v = float(self._first_val[r])
            unit = "rad" if self.dofs[j].startswith("r") else "m"
            self.first[k] = {"t": row * self.dt, "dof": self.dofs[j], "estimate": v}
            if self.scenes[k].safety.fidelity_action == "stop":
                stop(int(k), f"fidelity estimate: running RMS of ê ({self.dofs[j]}) "
                     f"{v:.4g} {unit} exceeded safety.fidelity_limit = {self.limit[k]:g} "
                     f"{unit} at t = {row * self.dt:.3f} s", n)

    # ------------------------------------------------------------------ results
    def columns(self) -> list[str]:
        """Record columns the monitor fills: the running RMS of ê per interface DOF
        (``e_hat_rms.<dof>``, NaN until the warm-up is identified; none when it is off)."""
        return [f"e_hat_rms.{d}" for d in self.dofs] if self.enabled else []

    def blank(self, data: np.ndarray, ci: dict[str, int]) -> None:
        """The monitor's columns of the loop's record array start unknown (NaN)."""
        for c in self.columns():
            data[:, :, ci[c]] = np.nan

    def meta(self, k: int) -> dict[str, Any]:
        """``{"fidelity": summary}`` for a watched test, else ``{}`` (record metadata)."""
        s = self.summary(k)
        return {} if s is None else {"fidelity": s}

    def summary(self, k: int) -> dict[str, Any] | None:
        """The record's metadata ``fidelity`` of test k (None: not watched)."""
        if self.limit[k] <= 0:
            return None
        if self.online is not None and k in self.watch:
            self.peak[k] = self._peak[int(np.flatnonzero(self.watch == k)[0])]
        s = self.scenes[k].safety
        out: dict[str, Any] = {"limit": float(self.limit[k]), "action": s.fidelity_action,
                               "warmup": float(s.fidelity_warmup), "window": WINDOW,
                               "model": self.models[k] or None,
                               "validation": float(self.validation[k]),
                               "identify_s": float(self.identify_s),
                               "identify_cpu_s": float(self.identify_cpu_s),
                               "cpu_s": float(self.cpu_s),
                               "peak": [float(v) for v in self.peak[k]],
                               "peak_after": float(s.fidelity_warmup),
                               "crossed": self.first[k],
                               "unreliable": self.unreliable[k],
                               "reidentified": self.reidentified[k]}
        if self.failed[k] or self.online is None:
            out["error"] = self.failed[k] or (
                "the test ended before the warm-up" if self.online is None else "")
        return out


__all__ = ["ACTIONS", "BLOCK", "ENVELOPE", "FidelityMonitor"]

