"""The vRTHS co-simulation loop: K tests stepped together at the interface rate ΔT.

Per step n (paper Fig. 1): the numerical substructure advances t_n → t_{n+1} with the
measured force F'_m(t_n) held over the step and outputs the command z_{n+1} = Γᵀ x_{n+1};
the transfer system moves the experimental part towards it during the next ΔT and returns
the achieved z'_{n+1} and the measured force F'_m(t_{n+1}); the safety monitor checks both.
With the ideal transfer system the only error left is this partitioned exchange (force held
over a step), which converges to the reference at first order in ΔT with the ``exact``
integrator and at about second order with ``central_difference``; the partitioned exchange is
only conditionally stable (a part stiff against the numerical mass diverges with either
integrator, and the safety limits stop it).

Two drivers run the same components: when the numerical substructure and every stage of the
transfer system have compiled kernels (:mod:`rths3d.stepping`), whole ranges of steps run in
numba; otherwise (MuJoCo, a plugged-in numerical substructure) the loop steps them from
Python and calls the same kernels. The record's ``loop`` metadata says which ran. The loop
never asks which transfer system or part it drives (:class:`~rths3d.transfer.base.
TransferSystem`). A stopped test (:class:`~rths3d.safety.SafetyMonitor`) keeps its record up
to the last safe sample with ``status = "stopped"`` and the reason; the other tests of a batch
go on. Every test writes a :class:`~rths3d.record.RecordBuffer` that a live viewer may read
from another thread; :class:`LoopControl` gives pause/stop and real-time pacing.

Public API: :func:`run` (one test), :func:`run_batch` (many parameter sets, K at once),
:func:`batch_key`, :class:`RunResult`, :class:`LoopControl`. See docs/loop.md.
"""

from __future__ import annotations

import contextlib
import math
import os
import threading
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np
from tqdm import tqdm

from .config import Scene
from .errors import ConfigError, NumericalFailure
from .kernels import kernel_tuple
from .metadata import record_metas
from .numerical import NumericalFactory, max_batch, numerical_factory
from .record import Record, RecordBuffer
from .reference import reference_solution
from .safety import USER, SafetyMonitor
from .scene import scene_to_dict, scene_with
from .stepping import fill_known, noise_buffer, post_step, pre_step, run_steps
from .surrogate.monitor import FidelityMonitor
from .transfer import TransferSystem, batch_key, build_transfer, transfer_class

__all__ = ["LoopControl", "RunResult", "batch_key", "run", "run_batch"]


@dataclass
class RunResult:
    """Outcome of one test: its record, status and speed.

    ``rtf``: simulated seconds per wall second of the loop that ran this test (for a batch,
    per test; the aggregate is ``K·rtf``). ``out``: file written, if any.
    """

    record: Record
    status: str
    reason: str
    rtf: float
    wall: float
    params: dict[str, Any] = field(default_factory=dict)
    out: str | None = None
    measures: dict[str, float] = field(default_factory=dict)


class LoopControl:
    """Pause / stop and real-time pacing of a running loop (checked every ``every`` steps).

    Thread-safe: a viewer calls :meth:`pause`, :meth:`resume` or :meth:`stop` from its own
    thread. ``realtime=True`` sleeps so that simulated time does not run ahead of wall time;
    a ``pacer`` paces every step to its deadline instead (``rths3d run --realtime``).
    """

    def __init__(self, realtime: bool = False, every: int = 20, pacer: Any = None):
        self.realtime = realtime or pacer is not None
        self.every = 1 if pacer is not None else int(every)
        self.pacer = pacer
        """A :class:`~rths3d.network.pacing.Pacer`: every step paced on the wall clock (its
        jitter, latency and overruns go to the record's ``pacing`` metadata); None: with
        ``realtime``, a sleep every ``every`` steps."""
        self._run = threading.Event()
        self._run.set()
        self._stop = threading.Event()

    def pause(self) -> None:
        self._run.clear()

    def resume(self) -> None:
        self._run.set()

    def stop(self) -> None:
        self._stop.set()
        self._run.set()

    @property
    def stopped(self) -> bool:
        return self._stop.is_set()

    def wait(self) -> None:
        """Block while paused."""
        self._run.wait()


Progress = bool | Callable[[float], None]
"""A progress bar (True) or a callable told the tests' work done since its last call."""


class _Group:
    """K compatible tests (one :func:`batch_key`) stepped together into one record array."""

    def __init__(self, scenes: list[Scene], *, nthread: int, specimen: str,
                 numerical: NumericalFactory | None, test_ids: Sequence[int] | None,
                 reference: bool | str = True):
        base = scenes[0]
        self.with_reference = bool(reference)
        self.scenes, self.base = scenes, base
        self.K, self.N, self.dt, self.nd = len(scenes), base.n_steps, base.dt, len(base.dofs)
        self.test_ids = list(test_ids) if test_ids is not None else list(range(self.K))
        self.num = (numerical or numerical_factory(base))(scenes)
        self.transfer: TransferSystem = build_transfer(base, self.K, nthread=nthread,
                                                       specimen=specimen, scenes=scenes)
        self.monitor = SafetyMonitor(scenes)
        self.fidelity = FidelityMonitor(scenes, self.num)
        # record signals: the transfer system's, then the numerical substructure's own
        # (an OpenSees model's element forces and deformations)
        self.signals = tuple(self.transfer.signals) + tuple(getattr(self.num, "signals", ()))
        self._layout()

    def _layout(self) -> None:
        """Columns of the record (contiguous per signal) and their array over all tests."""
        num, nd, dofs = self.num, self.nd, self.base.dofs
        cols = ["t"]
        for sig in ("z_cmd", "z_meas", "f_meas"):
            cols += [f"{sig}.{d}" for d in dofs]
        cols += [f"x_num.{i}" for i in range(num.n)]
        for sig in self.signals:
            cols += sig.columns
        cols += [f"f_ext.{d}" for d in dofs] + [f"p_num.{i}" for i in range(num.n)]
        cols += self.fidelity.columns()
        if self.with_reference:  # no columns (nor memory) for a reference not asked for
            cols += [f"z_ref.{d}" for d in dofs] + [f"x_ref.{i}" for i in range(num.n)]
        self.cols = cols
        self.ci = {c: i for i, c in enumerate(cols)}
        c0 = self.ci[f"z_cmd.{dofs[0]}"]
        self.c_zc, self.c_zm, self.c_f = c0, c0 + nd, c0 + 2 * nd
        self.c_x = self.ci["x_num.0"]
        data = np.zeros((self.N + 1, self.K, len(cols)))
        # t; f_ext per interface DOF: Γᵀ p (the external load seen at the interface); p_num
        # per numerical DOF: p(t) itself (Γᵀ p loses it when Γ is not square; the energy
        # needs it) — one pass over the record array
        fill_known(data, float(self.dt), np.ascontiguousarray(num.p, dtype=float),
                   np.ascontiguousarray(num.gamma, dtype=float), 0,
                   self.ci[f"f_ext.{dofs[0]}"], self.ci["p_num.0"])
        self.fidelity.blank(data, self.ci)
        self.data = data
        # the transfer system's extra signals: copies per step, converted when flushed
        self.hist = []
        for sig in self.signals:
            h = np.zeros((self.N + 1,) + sig.source.shape)
            if sig.initial is not None:
                h[:] = sig.initial
            self.hist.append(h)
        self.flushed = 0

    def buffers(self) -> list[RecordBuffer]:
        out = []
        metas = record_metas(self.scenes, self.num, self.transfer.metas)
        for k in range(self.K):
            b = RecordBuffer(self.cols, 1, metas[k])
            b.data = self.data[:, k, :]
            b.n = 1
            out.append(b)
        return out

    def flush(self, upto: int) -> None:
        """Write the transfer system's signals of rows flushed … upto−1 into the records."""
        a = self.flushed
        for sig, h in zip(self.signals, self.hist, strict=True):
            c = self.ci[sig.columns[0]]
            block = h[a:upto] if sig.convert is None else sig.convert(h[a:upto])
            self.data[a:upto, :, c:c + len(sig.labels)] = block
        self.flushed = upto

    # ------------------------------------------------------------------ stepping
    def run(self, control: LoopControl | None, buffers: list[RecordBuffer],
            progress: Progress) -> tuple[int, float, str]:
        """Step all tests to the end (or until all stopped); returns (steps, wall s, path).

        ``progress``: a bar (True), or a callable told the tests' worth of work done since
        its last call (a sweep's bar within a batch), every 500 steps."""
        self.transfer.reset()
        self.monitor.reset()
        num_c, tr_c = self.num.compiled(), self.transfer.compiled()
        # a transfer system without a 1-D kernel may step its own compiled ranges
        closed = self.transfer.closed_range(self) if num_c is not None and tr_c is None \
            else None
        path = "compiled" if num_c is not None and (tr_c is not None or closed) else "python"
        if control is not None and control.pacer is not None:
            # paced: one step per call, and one call of a compiled range costs ≈ 0.2 ms of
            # argument handling against ≈ 10 µs for the same step from Python
            path, closed = "python", None
        report = progress if callable(progress) else None
        every = control.every if control is not None else (500 if progress else self.N)
        fid = self.fidelity if self.fidelity.enabled else None
        every = every if fid is None or control else min(every, fid.every)  # monitor blocks
        # disable=None: shown on a terminal only (a piped stderr keeps one-line errors)
        pbar = tqdm(total=self.N, desc=f"{self.base.transfer.kind} ×{self.K}", unit="step",
                    mininterval=0.5, disable=True if (not progress or report) else None)
        self._f = np.zeros((self.K, self.nd))  # F'_m held over the next step
        t0 = time.perf_counter()
        n = 0
        # a transfer system holding a connection (the remote one) releases it however the
        # loop ends: its last step, a stop, Ctrl-C or an error
        close = getattr(self.transfer, "close", None)
        pacer = control.pacer if control is not None else None
        with pbar, contextlib.closing(self.transfer) if close is not None \
                else contextlib.nullcontext(), contextlib.ExitStack() as paced:
            if pacer is not None:  # its scheduling policy restored however the loop ends
                paced.callback(pacer.finish)
                pacer.start()
            while n < self.N:
                # with a control: back to Python after every step n with n % every == 0
                n1 = min(self.N, -(-n // every) * every + 1 if control is not None
                         else n + every)
                done = closed(n, n1) if closed is not None else \
                    self._compiled(n, n1, num_c, tr_c) if path == "compiled" else \
                    self._python(n, n1)
                pbar.update(done)
                if report is not None:
                    report(done * self.K / self.N)
                n += done
                if fid is not None and self.monitor.any_active:
                    fid.check(self.data, self.ci, n, self.monitor, self.num)
                if not self.monitor.any_active:
                    break
                if control is not None and self._control(control, n, buffers, t0):
                    break
        self.flush(self.N + 1)
        return n, time.perf_counter() - t0, path

    def _control(self, control: LoopControl, n: int, buffers: list[RecordBuffer],
                 t0: float) -> bool:
        """After step n−1: publish the rows to the live buffers, obey pause/stop/real time."""
        self.flush(n + 1)
        for b in buffers:
            b.n = n + 1
        if control.stopped:
            for k in np.flatnonzero(self.monitor.active):
                self.monitor.stop(int(k), f"stopped by the user at t = {n * self.dt:.3f} s",
                                  n, USER)
            return True
        control.wait()
        pacer = control.pacer
        if pacer is not None:
            if not pacer.wait(n):  # the overrun policy stops the test, as a bench would
                for k in np.flatnonzero(self.monitor.active):
                    self.monitor.stop(int(k), f"stopped at t = {n * self.dt:.6g} s: real time "
                                      f"lost ({pacer.overruns} steps overran their "
                                      f"{self.dt * 1e3:g} ms, limit {pacer.max_overruns})", n)
                return True
        elif control.realtime:
            ahead = n * self.dt - (time.perf_counter() - t0)
            if ahead > 0:
                time.sleep(ahead)
        return False

    def _compiled(self, n0: int, n1: int, num_c: tuple, tr_c: Any) -> int:
        tr = self.transfer
        R = self.K * self.nd
        # each stage's kernels typed once (kernel_tuple), not inspected on every call
        stages = tuple(x for fns, params, state in (tr_c.comp, tr_c.act, tr_c.part, tr_c.sens)
                       for x in (kernel_tuple(fns), params, state))
        io = (self.num.z, self.num.zdot, self.num.x, tr.z_meas, tr.z_prev, tr.f_true,
              tr.f_meas, tr.u)
        mon = self._monitor_arrays()
        rec = (self.data, self.c_zc, self.c_zm, self.c_f, self.c_x)
        hist = self.__dict__.get("_hist2d")
        if hist is None:  # the signal's source and history as (K, w), (N+1, K, w) views
            if len(self.signals) > 1:  # a programming error: a 1-D chain records one
                raise ValueError(f"{len(self.signals)} record signals in the 1-D range loop")
            hist = self._hist2d = next(
                ((sig.source.reshape(self.K, -1), h.reshape(h.shape[0], self.K, -1))
                 for sig, h in zip(self.signals, self.hist, strict=True)),
                (np.zeros((self.K, 0)), np.zeros((1, self.K, 0))))
        done, code = run_steps(n0, n1, num_c, stages, io, mon, rec,
                               noise_buffer(tr_c.act_noise, n1 - n0, R),
                               noise_buffer(tr_c.sens_noise, n1 - n0, R), hist)
        done = int(done)
        if code:  # the compensator's safety event in step n0 + done: finish that step
            self._finish_event(n0 + done, mon, rec)
            done += 1
        return done

    def _finish_event(self, n: int, mon_c: tuple, rec: tuple) -> None:
        """Step n after the compiled transfer step whose compensator raised a safety event,
        as :meth:`_python` finishes a step: the stops (ChainTransfer.step's), the signals'
        row, the record row and the force checks."""
        num, tr, mon = self.num, self.transfer, self.monitor
        comp = tr.compensator
        comp.events(n)
        if comp.any_stopped:
            tr.stopped[:] = comp.stopped
            tr.reasons = list(comp.reasons)
        for k in np.flatnonzero(tr.stopped & mon.active):
            mon.stop(int(k), tr.reasons[k], n)
            num.halt(int(k))
        for sig, h in zip(self.signals, self.hist, strict=True):
            h[n + 1] = sig.source
        if post_step(rec, n, num.z, tr.z_meas, tr.f_meas, num.x, mon_c):
            self._halt(n)

    def _python(self, n0: int, n1: int) -> int:
        num, tr, mon = self.num, self.transfer, self.monitor
        f = self._f
        ctx = self.__dict__.get("_py_ctx")
        if ctx is None:  # built once: a paced loop comes here for every single step
            ctx = self._py_ctx = (
                num.compiled(),  # a linear substructure: its step and the checks in one call
                self._monitor_arrays(),
                (self.data, self.c_zc, self.c_zm, self.c_f, self.c_x),
                list(zip(self.signals, self.hist, strict=True)))
        num_c, mon_c, rec, sigs = ctx
        for n in range(n0, n1):
            if num_c is not None:
                new = pre_step(num_c, f, n, num.z, num.zdot, num.x, mon_c)
            else:
                try:
                    num.step(n, f)
                except NumericalFailure as exc:  # the test stops here, its record kept
                    mon.stop(exc.test, exc.reason, n)
                    self._halt(n)
                    if not mon.any_active:
                        return n - n0
                    continue
                new = mon.command(n, num.z, num.zdot, num.x)
            if new:
                self._halt(n)
                if not mon.any_active:
                    return n - n0
            tr.step(num.z, num.zdot)
            if tr.stopped.any():
                for k in np.flatnonzero(tr.stopped & mon.active):
                    mon.stop(int(k), tr.reasons[k], n)
                    num.halt(int(k))
            f = self._f = tr.f_meas
            for sig, h in sigs:
                h[n + 1] = sig.source
            if post_step(rec, n, num.z, tr.z_meas, f, num.x, mon_c):
                self._halt(n)
                if not mon.any_active:
                    return n + 1 - n0
        return n1 - n0

    def _monitor_arrays(self) -> tuple:
        m = self.monitor
        return (m.lim_z, m.lim_v, m.lim_x, m.lim_f, m.g_win, m.g_fac, m.g_n, m.g_floor, m.g_pk,
                m.g_prev, m.g_base, m.g_cnt, m.active, m.code, m.dof, m.value, m.row)

    def _halt(self, n: int) -> None:
        """Tests stopped at step n rest from now on (load and state zeroed)."""
        for k in np.flatnonzero(~self.monitor.active & (self.monitor.row >= n)):
            self.num.halt(int(k))

    # ------------------------------------------------------------------ results
    def results(self, buffers: list[RecordBuffer], steps: int, wall: float, path: str,
                reference: bool | str, progress: Progress, numerical: NumericalFactory | None,
                nthread: int) -> list[RunResult]:
        K, N, mon = self.K, self.N, self.monitor
        rtf = steps * self.dt / wall if wall > 0 else math.inf
        if reference is True:
            # the reference uses the same model of the part as the test; when every test
            # stopped, only over the rows recorded (it is causal: the same samples)
            rows = N + 1 if mon.any_active else int(mon.row.max()) + 1
            rscenes = self.scenes if rows == N + 1 else \
                [replace(s, duration=(rows - 1) * self.dt) for s in self.scenes]
            zr, xr = self.ci[f"z_ref.{self.base.dofs[0]}"], self.ci["x_ref.0"]
            try:
                ref = reference_solution(rscenes, nthread=nthread, progress=progress,
                                         specimen=_reference_model(self.transfer),
                                         numerical=numerical)
                self.data[:rows, :, zr:zr + self.nd] = ref["z_ref"].transpose(1, 0, 2)
                self.data[:rows, :, xr:xr + self.num.n] = ref["x_ref"].transpose(1, 0, 2)
            except NumericalFailure as exc:  # no reference: NaN, and the record says why
                self.data[:rows, :, zr:zr + self.nd] = np.nan
                self.data[:rows, :, xr:xr + self.num.n] = np.nan
                for b in buffers:
                    b.meta["reference"] = f"failed: {exc.reason}"
        out = []
        for k in range(K):
            b = buffers[k]
            b.n = int(mon.row[k]) + 1
            if not mon.active[k]:
                b.meta["status"] = "stopped"
                b.meta["reason"] = mon.reason(k, self.test_ids[k])
            b.meta["rtf"] = rtf
            b.meta.update(self.fidelity.meta(k))
            b.meta["loop"] = path
            d = b.data[: b.n]  # views of the loop's array (no copy of K × N × columns)
            rec = Record(d[:, 0], {c: d[:, i] for i, c in enumerate(b.columns) if i},
                         dict(b.meta))
            out.append(RunResult(rec, b.meta["status"], b.meta["reason"], rtf, wall,
                                 b.meta["params"]))
        return out


def _reference_model(transfer: TransferSystem) -> str:
    """The reference's part model: the one the test moved (``numpy`` only where the part
    has a compiled numpy model, MuJoCo otherwise)."""
    return transfer.part_model


def _run_group(scenes: list[Scene], *, reference: bool | str, nthread: int,
               control: LoopControl | None, buffers_out: list | None, progress: Progress,
               specimen: str, numerical: NumericalFactory | None = None,
               test_ids: Sequence[int] | None = None) -> tuple[list[RunResult], str]:
    """Step K compatible tests together; returns their results and the reference model."""
    group = _Group(scenes, nthread=nthread, specimen=specimen, numerical=numerical,
                   test_ids=test_ids, reference=reference)
    buffers = group.buffers()
    if buffers_out is not None:
        buffers_out.extend(buffers)
    steps, wall, path = group.run(control, buffers, progress)
    results = group.results(buffers, steps, wall, path, reference, progress, numerical,
                            nthread)
    return results, _reference_model(group.transfer)


def run(scene: Scene, transfer: str | None = None, *, reference: bool = True,
        control: LoopControl | None = None, buffers: list | None = None,
        progress: bool = False, specimen: str = "auto", out: str | None = None,
        numerical: NumericalFactory | None = None) -> RunResult:
    """Run one test of ``scene`` (optionally with another ``transfer`` kind).

    ``buffers``: a list that receives the test's :class:`RecordBuffer` as soon as the loop
    starts (for a live viewer). ``out``: write the record (``.parquet`` or ``.csv``).
    ``numerical``: a factory ``scenes -> NumericalSubstructure`` to plug in a nonlinear
    numerical substructure (used for the test and for its reference), e.g.
    ``lambda s: CubicSpringSubstructure.from_scenes(s, k3=1e8)``; default: the scene's linear
    ``M, C, K``. ``specimen``: the part model of the 1-D transfer systems, ``numpy``,
    ``mujoco`` or ``auto``.
    """
    if transfer is not None:
        transfer_class(transfer)
        scene = scene.with_transfer(transfer)
    res = _run_group([scene], reference=reference, nthread=1, control=control,
                     buffers_out=buffers, progress=progress, specimen=specimen,
                     numerical=numerical)[0][0]
    if control is not None and control.pacer is not None:
        res.record.meta["pacing"] = control.pacer.stats()
    if out:
        res.out = str(res.record.save(out))
    return res


def run_batch(scene: Scene, param_sets: Sequence[Mapping[str, Any]], transfer: str | None = None,
              *, reference: bool = True, max_k: int = 256, nthread: int = 0,
              progress: Progress = False, specimen: str = "auto") -> list[RunResult]:
    """Run one test per parameter set, stepping compatible tests together (K at a time).

    ``param_sets``: dotted-key overrides per test, e.g. ``[{"numerical.k": 5e3,
    "experiment.h0": 0.002}, ...]``. Tests with the same :func:`batch_key` (the transfer
    system's rule: time grid, interface, integrator and Γ, and what changes the structure of
    its model) are stepped together in groups of up to ``max_k``; every other setting may
    differ test by test. Results come back in the order of ``param_sets``; the references
    are computed afterwards in bigger batches. A bad parameter raises
    :class:`~rths3d.errors.ConfigError` naming the set's index. ``progress``: a bar per
    group, or a callable told the tests' worth of work done since its last call (a sweep's
    progress within a batch).
    """
    if callable(progress) and reference:  # the loop and the reference pass: half each
        report = progress
        progress = lambda tests: report(0.5 * tests)  # noqa: E731
    if transfer is not None:
        transfer_class(transfer)
        scene = scene.with_transfer(transfer)
    scenes = []
    raw = scene_to_dict(scene)
    for i, ps in enumerate(param_sets):
        try:
            scenes.append(scene_with(scene, ps, raw))
        except ConfigError as exc:
            raise ConfigError(exc.field, exc.value, exc.limit,
                              message=f"parameter set {i}: {exc}") from None
    groups: dict[tuple, list[int]] = {}
    for i, s in enumerate(scenes):
        groups.setdefault(batch_key(s), []).append(i)
    # a numerical substructure may bound its group (OpenSees: one domain, one test)
    max_k = min(max_k, max_batch(scene) or max_k)
    results: list[RunResult | None] = [None] * len(scenes)
    models = [""] * len(scenes)
    threads = nthread if nthread > 0 else min(2, os.cpu_count() or 1)

    def one(part: list[int], report: Progress) -> None:
        res, model = _run_group([scenes[i] for i in part],
                                reference="defer" if reference else False,
                                nthread=nthread, control=None, buffers_out=None,
                                progress=report, specimen=specimen, test_ids=part)
        for i, r in zip(part, res, strict=True):
            results[i] = r
            models[i] = model

    for idx in groups.values():
        for start in range(0, len(idx), max_k):
            part = idx[start:start + max_k]
            slices = _thread_slices(scenes[part[0]], part, threads, specimen)
            if len(slices) == 1:
                one(part, progress)
                continue
            # each slice built and stepped on its own thread: the compiled steps and the
            # record's fill release the GIL, the set-up in Python takes turns
            with _slice_progress(progress, len(part)) as report, \
                    ThreadPoolExecutor(len(slices), thread_name_prefix="batch") as pool:
                for fut in [pool.submit(one, sl, report) for sl in slices]:
                    fut.result()
    if reference:
        _fill_references(scenes, results, models, max_k=max_k, nthread=nthread,
                         progress=progress)
    return results  # type: ignore[return-value]


SLICE_MIN = 64
"""Fewest tests of a slice stepped on its own thread (smaller slices: one group)."""


def _thread_slices(scene: Scene, part: list[int], threads: int, specimen: str
                   ) -> list[list[int]]:
    """``part`` cut into up to ``threads`` slices of ≥ :data:`SLICE_MIN` tests when its
    transfer system allows it (``threads_over_tests``), else one slice."""
    n = min(threads, len(part) // SLICE_MIN)
    allowed = getattr(transfer_class(scene.transfer.kind), "threads_over_tests", None)
    if n < 2 or allowed is None or not allowed(scene, specimen):
        return [part]
    cuts = np.linspace(0, len(part), n + 1).round().astype(int)
    return [part[a:b] for a, b in zip(cuts[:-1], cuts[1:], strict=True)]


@contextmanager
def _slice_progress(progress: Progress, tests: int) -> Iterator[Progress]:
    """One progress report for the slices of a batch: the caller's callable (made safe to
    call from the slices' threads), one bar over the batch's tests, or none (the slices
    then step their tests in one compiled call each, as a group without progress does)."""
    lock = threading.Lock()
    if not progress:
        yield False
        return
    if callable(progress):
        def report(done: float) -> None:
            with lock:
                progress(done)
        yield report
        return
    # disable=None: shown on a terminal only (a piped stderr keeps one-line errors)
    with tqdm(total=tests, desc="tests", unit="test", mininterval=0.5, disable=None) as bar:
        def report_bar(done: float) -> None:
            with lock:
                bar.update(done)
        yield report_bar


def _fill_references(scenes: list[Scene], results: list, models: list[str], *, max_k: int,
                     nthread: int, progress: Progress) -> None:
    """Compute z^r for the tests of :func:`run_batch` and write it into their records (the
    ``z_ref.*``/``x_ref.*`` columns, truncated like the record for stopped tests), in groups
    of one time grid, interface, part kind, part model and numerical size."""
    groups: dict[tuple, list[int]] = {}
    for i, s in enumerate(scenes):
        key = (s.dt, s.duration, s.dofs, s.experiment.kind, s.experiment.substeps, models[i],
               len(s.numerical.M), np.array(s.numerical.gamma).tobytes(), s.numerical.kind)
        groups.setdefault(key, []).append(i)
    for key, idx in groups.items():
        for start in range(0, len(idx), max_k):
            part = idx[start:start + max_k]
            try:
                ref = reference_solution([scenes[i] for i in part], nthread=nthread,
                                         specimen=key[5], progress=progress)
            except NumericalFailure as exc:  # no reference for these tests (NaN)
                for i in part:
                    results[i].record.meta["reference"] = f"failed: {exc.reason}"
                    for c, col in results[i].record.columns.items():
                        if c.startswith(("z_ref.", "x_ref.")):
                            col[:] = np.nan
                continue
            for k, i in enumerate(part):
                rec = results[i].record
                n = len(rec.t)
                for j, d in enumerate(scenes[i].dofs):
                    rec.columns[f"z_ref.{d}"][:] = ref["z_ref"][k, :n, j]
                for j in range(ref["x_ref"].shape[2]):
                    rec.columns[f"x_ref.{j}"][:] = ref["x_ref"][k, :n, j]
