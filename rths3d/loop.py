"""The vRTHS co-simulation loop: K tests stepped together at the interface rate ΔT.

Per step n (paper Fig. 1): the numerical substructure advances t_n → t_{n+1} with the
measured force F'_m(t_n) held over the step and outputs the command z_{n+1} = Γᵀ x_{n+1};
the transfer system moves the experimental part towards it during the next ΔT and returns
the achieved z'_{n+1} and the measured force F'_m(t_{n+1}); safety limits are checked. With
the ideal transfer system the only error left is this partitioned exchange (force held
over a step), which converges to the reference at first order in ΔT with the ``exact``
integrator and at about second order with ``central_difference``. The partitioned exchange is
only conditionally stable (a part stiff against the numerical mass diverges with either
integrator, and the safety limits stop it).

Safety limits (stroke, command velocity, FTS range, divergence) stop a test as a real bench
would: the test's record ends at the last safe sample, ``status = "stopped"`` and ``reason``
says which limit and when (:class:`~rths3d.errors.SafetyStop`); the other tests of a batch
go on. Every test writes a :class:`~rths3d.record.RecordBuffer` (``buffers``) that a live
viewer may read from another thread; :class:`LoopControl` gives pause/stop and real-time
pacing without per-step callbacks.

Public API: :func:`run` (one test), :func:`run_batch` (many parameter sets, K at once),
:class:`RunResult`. See docs/loop.md.
"""

from __future__ import annotations

import functools
import math
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import asdict, dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from .errors import ConfigError, SafetyStop
from .record import DOFS, Record, RecordBuffer
from .scene import (
    ACTUATOR_PER_TEST,
    PER_TEST_COMPENSATION,
    STEWART_PER_TEST_SERVO,
    Scene,
    apply_overrides,
    scene_from_dict,
)

if TYPE_CHECKING:
    from .numerical import NumericalFactory

__all__ = ["LoopControl", "RunResult", "build_numerical", "run", "run_batch", "scene_to_dict",
           "scene_with"]


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
    thread. ``realtime=True`` sleeps so that simulated time does not run ahead of wall time.
    """

    def __init__(self, realtime: bool = False, every: int = 20):
        self.realtime = realtime
        self.every = int(every)
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


# ---------------------------------------------------------------------------- scenes
def scene_to_dict(scene: Scene) -> dict[str, Any]:
    """The raw TOML-shaped mapping of a scene (inverse of ``scene_from_dict``)."""
    out: dict[str, Any] = {"name": scene.name, "dofs": list(scene.dofs), "dt": scene.dt,
                           "duration": scene.duration}
    nm = scene.numerical
    if nm.n == 1:
        out["numerical"] = {"m": nm.M[0][0], "c": nm.C[0][0], "k": nm.K[0][0],
                            "gamma": [list(r) for r in nm.gamma],
                            "integrator": nm.integrator}
    else:
        out["numerical"] = {"M": [list(r) for r in nm.M], "C": [list(r) for r in nm.C],
                            "K": [list(r) for r in nm.K], "gamma": [list(r) for r in nm.gamma],
                            "integrator": nm.integrator}
    for sec in ("experiment", "excitation", "transfer", "sensor", "safety"):
        d = asdict(getattr(scene, sec))
        out[sec] = {k: (list(v) if isinstance(v, tuple) else v) for k, v in d.items()
                    if not (isinstance(v, float) and math.isnan(v))}
    return out


def scene_with(scene: Scene, overrides: Mapping[str, Any] | Sequence[str],
               _raw: dict | None = None) -> Scene:
    """A validated copy of ``scene`` with dotted-key overrides (e.g. ``{"numerical.k": 5e3}``)."""
    if not overrides:
        return scene
    raw = dict(_raw) if _raw is not None else scene_to_dict(scene)
    nm = raw["numerical"] = dict(raw["numerical"])
    items = overrides.items() if isinstance(overrides, Mapping) else \
        [tuple(s.split("=", 1)) for s in overrides]
    for key, _ in items:
        # single-DOF scenes accept both m/M, c/C, k/K
        base, _, leaf = str(key).partition(".")
        if base == "numerical" and leaf in ("M", "C", "K") and leaf.lower() in nm:
            nm.pop(leaf.lower())
        if base == "numerical" and leaf in ("m", "c", "k") and leaf.upper() in nm:
            nm.pop(leaf.upper())
    raw = apply_overrides(raw, overrides)
    return scene_from_dict(raw, name=scene.name, source=scene.source)


# ---------------------------------------------------------------------------- builders
def build_numerical(scenes: Sequence[Scene], method: str | None = None):
    """The :class:`~rths3d.numerical.LinearSubstructure` of K scenes (their loads included)."""
    from .numerical import LinearSubstructure, load_history

    base = scenes[0]
    t = np.arange(base.n_steps + 1) * base.dt
    M = np.array([s.numerical.M for s in scenes])
    C = np.array([s.numerical.C for s in scenes])
    K = np.array([s.numerical.K for s in scenes])
    p = np.stack([load_history(s.excitation, M[i], C[i], K[i], t, s.experiment.h0)
                  for i, s in enumerate(scenes)])
    return LinearSubstructure(M, C, K, np.array(base.numerical.gamma), p, base.dt,
                              method or base.numerical.integrator)


@functools.lru_cache(maxsize=1)
def _versions() -> dict[str, str]:
    from importlib.metadata import version

    out = {}
    for pkg in ("rths3d", "mujoco", "numpy", "scipy"):
        try:
            out[pkg] = version(pkg)
        except Exception:
            out[pkg] = "unknown"
    return out


def _meta(scene: Scene, num, k: int, transfer_meta: dict) -> dict[str, Any]:
    from .experiment.mjcf import interface_matrices
    from .numerical import coupled_fastest_eigenfrequency, fastest_eigenfrequency
    from .numerical.modal import interface_delay_margin

    e = scene.experiment
    k_exp, m_exp = interface_matrices(e, scene.dofs)
    c_exp = [[e.d, 0.0], [0.0, e.d_rot]] if len(k_exp) == 2 else [[e.d]]
    M, K = num.M[k], num.Kmat[k]
    # delay margin of the delayed interface loop with the part as it is built (a mass behind
    # its spring, contact open); recorded only when a delay can destabilise the test
    margin = {}
    try:
        tau_cr, wc, pm = interface_delay_margin(M, num.C[k], K, num.gamma, m_exp, c_exp, k_exp)
    except (ValueError, np.linalg.LinAlgError):
        tau_cr = math.inf
    if math.isfinite(tau_cr):
        margin = {"phase_margin": pm, "crossover": wc, "delay_margin": tau_cr}
    return {
        "scene": scene.name, "params": scene.params(), "transfer": scene.transfer.kind,
        "dt": scene.dt, "dofs": list(scene.dofs), "versions": dict(_versions()),
        "numerical": num.meta(k),
        "experiment": {"kind": e.kind, "m_exp": e.m, "k_exp": k_exp, "m_exp_matrix": m_exp,
                       "d_exp": e.d, "c_exp": c_exp, "h0": e.h0 if e.kind != "linear" else None,
                       "k_contact": e.k_contact, "d_contact": e.d_contact},
        "omega_num_max": fastest_eigenfrequency(M, K),
        "omega_dyn_max": coupled_fastest_eigenfrequency(M, K, num.gamma, m_exp, k_exp),
        "transfer_meta": transfer_meta, **margin,
        "status": "ok", "reason": "",
    }


def _columns(dofs: Sequence[str], n: int, stewart: bool) -> list[str]:
    # everything written per step is contiguous (one row assignment in the fast kernel)
    cols = ["t"]
    for sig in ("z_cmd", "z_meas", "f_meas"):
        cols += [f"{sig}.{d}" for d in dofs]
    cols += [f"x_num.{i}" for i in range(n)]
    if stewart:
        cols += [f"pose_cmd.{d}" for d in DOFS] + [f"pose_meas.{d}" for d in DOFS]
    cols += [f"f_ext.{d}" for d in dofs]
    cols += [f"p_num.{i}" for i in range(n)]
    cols += [f"z_ref.{d}" for d in dofs]
    cols += [f"x_ref.{i}" for i in range(n)]
    return cols


# ---------------------------------------------------------------------------- the loop
def _run_group(scenes: list[Scene], *, reference: bool | str, nthread: int,
               control: LoopControl | None, buffers_out: list | None,
               progress: bool, specimen: str, numerical=None,
               test_ids: Sequence[int] | None = None) -> list[RunResult]:
    """Step K compatible tests together. ``test_ids``: the tests' indices in the caller's
    list (``run_batch``'s parameter sets), named in stop reasons (default 0…K−1)."""
    from .transfer import build_transfer

    base = scenes[0]
    K = len(scenes)
    N = base.n_steps
    dt = base.dt
    nd = len(base.dofs)
    num = numerical(scenes) if numerical is not None else build_numerical(scenes)
    transfer = build_transfer(base, K, [s.experiment for s in scenes], nthread=nthread,
                              specimen=specimen, scenes=scenes)
    stewart = base.transfer.kind == "stewart"
    cols = _columns(base.dofs, num.n, stewart)
    ci = {c: i for i, c in enumerate(cols)}
    data = np.zeros((N + 1, K, len(cols)))
    buffers = []
    for k in range(K):
        tmeta = transfer.metas[k] if hasattr(transfer, "metas") else getattr(transfer, "meta", {})
        b = RecordBuffer(cols, 1, _meta(scenes[k], num, k, tmeta))
        b.data = data[:, k, :]
        b.n = 1
        buffers.append(b)
    if buffers_out is not None:
        buffers_out.extend(buffers)
    # column slices (contiguous per signal group)
    s_zc = slice(ci[f"z_cmd.{base.dofs[0]}"], ci[f"z_cmd.{base.dofs[0]}"] + nd)
    s_zm = slice(s_zc.start + nd, s_zc.start + 2 * nd)
    s_fm = slice(s_zc.start + 2 * nd, s_zc.start + 3 * nd)
    s_fe = slice(ci[f"f_ext.{base.dofs[0]}"], ci[f"f_ext.{base.dofs[0]}"] + nd)
    s_x = slice(ci["x_num.0"], ci["x_num.0"] + num.n)
    if stewart:
        s_pc = slice(ci["pose_cmd.x"], ci["pose_cmd.x"] + 6)
        s_pm = slice(ci["pose_meas.x"], ci["pose_meas.x"] + 6)
    data[:, :, 0] = (np.arange(N + 1) * dt)[:, None]
    # f_ext per interface DOF: Γᵀ p (the external load seen at the interface)
    data[:, :, s_fe] = np.matmul(num.p, num.gamma).transpose(1, 0, 2)
    # p_num per numerical DOF: the external force p(t) itself (Γᵀ p loses it when Γ is not
    # square; the energy balance needs it)
    s_pn = slice(ci["p_num.0"], ci["p_num.0"] + num.n)
    data[:, :, s_pn] = np.asarray(num.p).transpose(1, 0, 2)
    # safety limits per interface DOF
    saf = base.safety
    is_rot = np.array([d.startswith("r") for d in base.dofs])
    lim_z = np.where(is_rot, saf.rotation, saf.stroke)
    lim_v = np.where(is_rot, np.inf, saf.velocity)
    lim_f = np.where(is_rot, saf.torque, saf.force)
    lim_x = saf.divergence
    stop_row = np.full(K, N, dtype=int)
    reasons = [""] * K
    active = np.ones(K, dtype=bool)
    transfer.reset()
    f = np.zeros((K, nd))
    every = control.every if control is not None else 0
    from .numerical import LinearSubstructure

    kernel = _fast_kernel(num, transfer, base, ci) \
        if K == 1 and isinstance(num, LinearSubstructure) else None
    if kernel is not None:
        steps_done, wall = _run_kernel(kernel, num, transfer, base, data, buffers, control,
                                       every, halt_info := {})
        if halt_info:
            active[0] = False
            stop_row[0] = halt_info["row"]
            reasons[0] = halt_info["reason"]
        return _finish(scenes, num, data, buffers, ci, cols, s_zc, nd, stop_row, reasons,
                       active, steps_done, wall, reference, stewart, specimen, nthread, progress,
                       numerical, test_ids)
    t0 = time.perf_counter()
    pbar = None
    # a callable: called every 500 steps with the tests' worth of work done since (K·500/N)
    report = progress if callable(progress) else None
    if progress and report is None:
        from tqdm import tqdm

        pbar = tqdm(total=N, desc=f"{base.transfer.kind} ×{K}", unit="step", mininterval=0.5)

    def halt(k: int, stop: SafetyStop, row: int) -> None:
        if active[k]:
            active[k] = False
            stop_row[k] = row
            reasons[k] = stop.reason
            if hasattr(num, "halt"):
                num.halt(k)
            else:  # a stopped test rests (its load and state zeroed), the others go on
                num.P[k] = 0.0
                num.s[k] = 0.0

    n = 0
    # per-signal histories: contiguous (K, ·) block writes per step, copied into the record
    # array at the end (and every few steps when someone watches the live buffers)
    h_zc = np.zeros((N + 1, K, nd))
    h_zm = np.zeros((N + 1, K, nd))
    h_f = np.zeros((N + 1, K, nd))
    h_x = np.zeros((N + 1, K, num.n))
    if stewart:
        from .platform.sim import plate_pose

        h_pc = np.zeros((N + 1, K, 6))
        # raw plate qpos per step (a copy of 7 floats per test), converted to poses at flush
        h_pq = np.zeros((N + 1, K, 7))
        h_pq[:, :, 2] = transfer.home_height
        h_pq[:, :, 3] = 1.0
    # divergence by growth: peak |F'_m| per window, consecutive windows growing (see
    # SafetyLimits); gw = 0 switches it off
    gw = int(saf.growth_windows)
    g_win = max(1, int(round(saf.growth_window / dt)))
    g_fac = float(saf.growth)
    g_floor = 0.02 * lim_f
    g_pk = np.zeros((K, nd))
    g_prev = np.full((K, nd), np.inf)
    g_base = np.zeros((K, nd))
    g_cnt = np.zeros((K, nd), dtype=int)
    f_abs = np.zeros((K, nd))  # |F'_m| of the step, for the FTS range and the growth watch
    az = np.zeros((K, nd))  # |z|, |ż|, |x| of the step (no allocation per step)
    azd = np.zeros((K, nd))
    ax = np.zeros((K, num.n))
    zlim_min = float(lim_z.min())
    vlim_min = float(lim_v.min())
    flim_min = float(lim_f.min())
    watched = control is not None

    flushed = [0]

    def flush(upto: int) -> None:
        a = flushed[0]
        data[a:upto, :, s_zc] = h_zc[a:upto]
        data[a:upto, :, s_zm] = h_zm[a:upto]
        data[a:upto, :, s_fm] = h_f[a:upto]
        data[a:upto, :, s_x] = h_x[a:upto]
        if stewart:
            data[a:upto, :, s_pc] = h_pc[a:upto]
            data[a:upto, :, s_pm] = plate_pose(h_pq[a:upto], transfer.home_height)
        flushed[0] = upto

    for n in range(N):
        num.step(n, f)
        z = num.z
        zd = num.zdot
        np.abs(z, out=az)
        np.abs(zd, out=azd)
        np.abs(num.x, out=ax)
        # cheap pre-checks (NaN fails `<=`); the per-test search runs only when one trips
        if (not (az.max() <= zlim_min) or not (azd.max() <= vlim_min)
                or not (ax.max() <= lim_x)) and \
                ((az > lim_z).any() or (azd > lim_v).any()
                 or not (ax <= lim_x).all()):
            _check_command(num, z, zd, az, active, base, is_rot, lim_z, lim_v, lim_x, dt, n,
                           halt)
            if not active.any():
                break
        try:
            transfer.step(z, zd)
        except SafetyStop as stop:  # a single platform raises; a batch flags
            halt(0, SafetyStop(stop.quantity, stop.value, stop.limit, (n + 1) * dt, 0,
                               stop.unit), n)
            break
        if transfer.stopped.any():
            for k in np.flatnonzero(transfer.stopped & active):
                halt(int(k), SafetyStop(transfer.reasons[k] or "transfer system", math.nan,
                                        math.nan, (n + 1) * dt, int(k)), n)
                reasons[k] = transfer.reasons[k]
        f = transfer.f_meas
        h_zc[n + 1] = z
        h_zm[n + 1] = transfer.z_meas
        h_f[n + 1] = f
        h_x[n + 1] = num.x
        if stewart:
            h_pc[n + 1] = transfer.pose_cmd
            h_pq[n + 1] = transfer.plate_qpos
        np.abs(f, out=f_abs)
        if not (f_abs.max() <= flim_min):
            # only the active tests over the range (a stopped test may keep diverging);
            # NaN fails `<=`, so a non-finite force counts as out of range
            for k in np.flatnonzero(active & ~(f_abs <= lim_f).all(axis=1)):
                for j in range(nd):
                    if not f_abs[k, j] <= lim_f[j]:
                        v = float(f[k, j])
                        # a non-finite sample is not kept (the record stays loadable)
                        halt(k, _fts_stop(base, j, v, (n + 1) * dt, int(k)),
                             n + 1 if math.isfinite(v) else n)
                        break
            if not active.any():
                break
        if gw:
            np.maximum(g_pk, f_abs, out=g_pk)
            if (n + 1) % g_win == 0:
                grew = (g_pk > g_fac * g_prev) & (g_pk > g_floor)
                g_base[grew & (g_cnt == 0)] = g_prev[grew & (g_cnt == 0)]
                g_cnt = np.where(grew, g_cnt + 1, 0)
                if (g_cnt >= gw).any():
                    for k, j in zip(*np.nonzero(g_cnt >= gw), strict=True):
                        if active[k]:
                            halt(int(k), _growth_stop(base, int(j), g_pk[k, j] / g_base[k, j],
                                                      (n + 1) * dt, int(k)), n + 1)
                    if not active.any():
                        break
                g_prev[:] = g_pk
                g_pk[:] = 0.0
        if every and (n % every == 0):
            if watched:
                flush(n + 2)
            for b in buffers:
                b.n = n + 2
            if control.stopped:
                for k in np.flatnonzero(active):
                    halt(k, SafetyStop("user stop", 0.0, 0.0, (n + 1) * dt, k), n + 1)
                    reasons[k] = f"stopped by the user at t = {(n + 1) * dt:.3f} s"
                break
            control.wait()
            if control.realtime:
                ahead = (n + 1) * dt - (time.perf_counter() - t0)
                if ahead > 0:
                    time.sleep(ahead)
        if pbar is not None and n % 500 == 0:
            pbar.update(min(500, N - pbar.n))
        elif report is not None and (n + 1) % 500 == 0:
            report(500 * K / N)
    wall = time.perf_counter() - t0
    flush(N + 1)
    if pbar is not None:
        pbar.close()
    return _finish(scenes, num, data, buffers, ci, cols, s_zc, nd, stop_row, reasons, active,
                   n + 1, wall, reference, stewart, specimen, nthread, progress, numerical,
                   test_ids)


def _fts_stop(base: Scene, j: int, value: float, t: float, k: int) -> SafetyStop:
    """The stop of a measured force/torque out of the FTS range, or not finite."""
    d = base.dofs[j]
    rot = d.startswith("r")
    what = "torque" if rot else "force"
    unit = "N·m" if rot else "N"
    stop = SafetyStop(f"FTS range: measured {what} {d}", value,
                      base.safety.torque if rot else base.safety.force, t, k, unit)
    if not math.isfinite(value):  # NaN exceeds no limit: say what it is
        stop.args = (f"stopped at t = {t:.3f} s: FTS range: measured {what} {d} = {value} "
                     f"is not finite" + (f" (test {k})" if k else ""),)
    return stop


def _growth_stop(base: Scene, j: int, ratio: float, t: float, k: int) -> SafetyStop:
    """The divergence stop of a growing interface oscillation (see SafetyLimits)."""
    saf = base.safety
    d = base.dofs[j]
    what = "torque" if d.startswith("r") else "force"
    return SafetyStop(f"divergence: growth of the peak measured {what} {d} over "
                      f"{saf.growth_windows} windows of {saf.growth_window:g} s", ratio,
                      saf.growth ** saf.growth_windows, t, k)


def _check_command(num, z, zd, az, active, base, is_rot, lim_z, lim_v, lim_x, dt, n, halt):
    """Find which test left which command limit and stop it (see :func:`_run_group`).

    Vectorised over the batch: a stopped test whose transfer state went non-finite keeps
    tripping the cheap pre-check, so this runs every step then and must not loop over K.
    """
    x = num.x
    # NaN fails `<=`, so a non-finite state counts as out of limits
    bad_x = ~(np.abs(x) <= lim_x).all(axis=1)
    bad_z = (az > lim_z).any(axis=1)
    bad_v = (np.abs(zd) > lim_v).any(axis=1)
    tk = (n + 1) * dt
    for k in np.flatnonzero(active & (bad_x | bad_z | bad_v)):
        if bad_x[k]:
            halt(k, SafetyStop("divergence: numerical displacement |x|",
                               float(np.nanmax(np.abs(x[k]))), lim_x, tk, k, "m"), n)
            continue
        for j, d in enumerate(base.dofs):
            u = "rad" if is_rot[j] else "m"
            if az[k, j] > lim_z[j]:
                halt(k, SafetyStop(f"stroke: commanded {d}", z[k, j], lim_z[j], tk, k, u), n)
                break
            if abs(zd[k, j]) > lim_v[j]:
                halt(k, SafetyStop(f"velocity: commanded {d} rate", zd[k, j], lim_v[j], tk,
                                   k, "m/s"), n)
                break


def _run_kernel(kernel, num, transfer, base: Scene, data, buffers, control, every, halt_info):
    """Run the generated single-test kernel; fill ``halt_info`` on a stop."""
    N = base.n_steps
    dt = base.dt
    P = num.P[0].tolist()
    D = data[:, 0, :]
    t0 = time.perf_counter()

    def ctl(n: int) -> bool:
        if control.stopped:
            return True
        control.wait()
        if control.realtime:
            ahead = (n + 1) * dt - (time.perf_counter() - t0)
            if ahead > 0:
                time.sleep(ahead)
        return False

    sim = getattr(transfer, "sim", None)
    dl = [0.0] * (transfer.delay_line.size if getattr(transfer, "delay_line", None) else 1)
    try:
        n_done, code, j, val = kernel(N, P, D, sim, ctl, every, buffers, dl)
    except SafetyStop as stop:
        n_done = int(round(stop.t / dt)) if math.isfinite(stop.t) else 0
        n_done = max(0, min(n_done, N) - 1)
        halt_info.update(row=n_done, reason=SafetyStop(stop.quantity, stop.value, stop.limit,
                                                       (n_done + 1) * dt, 0, stop.unit).reason)
        return n_done + 1, time.perf_counter() - t0
    wall = time.perf_counter() - t0
    if code is not None:
        d = base.dofs[j] if code != "x" else str(j)
        rot = d.startswith("r")
        saf = base.safety
        t = (n_done + 1) * dt if code != "f" else n_done * dt
        if code == "x":
            stop = SafetyStop("divergence: numerical displacement |x|", abs(val),
                              saf.divergence, t, 0, "m")
            row = n_done
        elif code == "z":
            stop = SafetyStop(f"stroke: commanded {d}", val, saf.rotation if rot else saf.stroke,
                              t, 0, "rad" if rot else "m")
            row = n_done
        elif code == "v":
            stop = SafetyStop(f"velocity: commanded {d} rate", val, saf.velocity, t, 0, "m/s")
            row = n_done
        elif code == "g":
            stop = _growth_stop(base, j, val, n_done * dt, 0)
            row = n_done
        elif code == "f":
            stop = _fts_stop(base, j, val, t, 0)
            # a non-finite sample is not kept (the record stays loadable), as batched
            row = n_done if math.isfinite(val) else n_done - 1
        else:
            halt_info.update(row=n_done, reason=f"stopped by the user at t = {n_done * dt:.3f} s")
            return n_done, wall
        halt_info.update(row=row, reason=stop.reason)
    return n_done, wall


def _finish(scenes, num, data, buffers, ci, cols, s_zc, nd, stop_row, reasons, active,
            steps_done, wall, reference, stewart, specimen, nthread,
            progress=False, numerical=None, test_ids=None) -> list[RunResult]:
    base = scenes[0]
    K = len(scenes)
    dt = base.dt
    N = base.n_steps
    for b in buffers:
        b.n = N + 1
    rtf = steps_done * dt / wall if wall > 0 else math.inf
    if reference and reference != "defer":
        from .reference import reference_solution

        # the reference uses the same model of the part as the test: on the platform the
        # MuJoCo part, on the fast path the numpy one (documented in docs/loop.md); when
        # every test stopped, only over the rows recorded (the reference is causal: the same
        # samples as over the whole duration, without the wait)
        rows = N + 1 if active.any() else int(stop_row.max()) + 1
        rscenes = scenes if rows == N + 1 else \
            [replace(s, duration=(rows - 1) * dt) for s in scenes]
        rspec = "mujoco" if (stewart or specimen == "mujoco") else "auto"
        ref = reference_solution(rscenes, nthread=nthread, specimen=rspec, progress=progress,
                                 numerical=numerical)
        s_zr = slice(ci[f"z_ref.{base.dofs[0]}"], ci[f"z_ref.{base.dofs[0]}"] + nd)
        s_xr = slice(ci["x_ref.0"], ci["x_ref.0"] + num.n)
        data[:rows, :, s_zr] = ref["z_ref"].transpose(1, 0, 2)
        data[:rows, :, s_xr] = ref["x_ref"].transpose(1, 0, 2)
    results = []
    for k in range(K):
        b = buffers[k]
        b.n = int(stop_row[k]) + 1
        if not active[k]:
            b.meta["status"] = "stopped"
            b.meta["reason"] = _renumber(reasons[k], k, k if test_ids is None else test_ids[k])
        b.meta["rtf"] = rtf
        # the record's columns are views of the loop's array (no copy of K × N × columns)
        d = b.data[: b.n]
        rec = Record(d[:, 0], {c: d[:, i] for i, c in enumerate(b.columns) if i},
                     dict(b.meta))
        if not reference:  # "defer": the columns stay, filled in by run_batch
            for d in base.dofs:
                rec.columns.pop(f"z_ref.{d}", None)
            for i in range(num.n):
                rec.columns.pop(f"x_ref.{i}", None)
        results.append(RunResult(rec, b.meta["status"], b.meta["reason"], rtf, wall,
                                 b.meta["params"]))
    return results


def _renumber(reason: str, k: int, test: int) -> str:
    """``reason`` naming test ``test`` instead of the group-local index ``k`` (SafetyStop
    appends " (test k)" for k > 0)."""
    local = f" (test {k})"
    if k and reason.endswith(local):
        reason = reason[: -len(local)]
    return reason + (f" (test {test})" if test else "")


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
    ``M, C, K``.
    """
    if transfer is not None:
        scene = scene.with_transfer(transfer)
    res = _run_group([scene], reference=reference, nthread=1, control=control,
                     buffers_out=buffers, progress=progress, specimen=specimen,
                     numerical=numerical)[0]
    if out:
        res.out = str(res.record.save(out))
    return res


def _group_key(s: Scene) -> tuple:
    # tests stepped together must share the time grid, DOFs, transfer and (for MuJoCo
    # specimens) the part's model; numerical parameters may differ freely. On the Stewart
    # platform the parts' parameters and the leg-servo settings may differ too (per-test
    # models of one structure): only the part kind, the actuator delay and whether the servo
    # has a lag change the model's structure. On the delay and LTI paths the actuator model, its
    # delay and a velocity compensation (or none) are per test as well; so is the sensor's
    # noise seed (one generator per test).
    tr = s.transfer
    if tr.kind in ("delay", "lti") and tr.compensation in PER_TEST_COMPENSATION:
        tr = replace(tr, compensation="", **{k: None for k in ACTUATOR_PER_TEST})
    if tr.kind == "stewart":
        tr = replace(tr, timeconst=float(tr.timeconst > 0),
                     **dict.fromkeys(STEWART_PER_TEST_SERVO, 0.0))
        exp = (s.experiment.kind, s.experiment.substeps)
    elif s.experiment.kind == "multidof":
        exp = s.experiment
    else:
        exp = (s.experiment.kind, s.experiment.substeps)
    return (s.dt, s.duration, s.dofs, tr, replace(s.sensor, seed=0), s.safety, exp,
            s.numerical.integrator, np.array(s.numerical.gamma).tobytes())


def run_batch(scene: Scene, param_sets: Sequence[Mapping[str, Any]], transfer: str | None = None,
              *, reference: bool = True, max_k: int = 256, nthread: int = 0,
              progress: bool | Callable[[float], None] = False, specimen: str = "auto"
              ) -> list[RunResult]:
    """Run one test per parameter set, stepping compatible tests together (K at a time).

    ``param_sets``: dotted-key overrides per test, e.g. ``[{"numerical.k": 5e3,
    "experiment.h0": 0.002}, ...]``. Tests that share the time grid, transfer system and
    (for MuJoCo parts) the part's model are stepped together in groups of up to ``max_k``:
    numerical substructures as arrays over tests, the Stewart platform through
    ``PlatformBatch`` (``mujoco.batch``, ``nthread`` threads, 0 = 2; servo settings and part
    parameters per test), the 1-D LTI path with the vectorised numpy specimen (actuator
    delay, model and compensation none/velocity per test, see docs/loop.md). Results come
    back in the order of ``param_sets``. A bad parameter raises
    :class:`~rths3d.errors.ConfigError` naming the set's index. ``progress``: a bar per
    group, or a callable called now and then with the tests' worth of work done since its
    last call (a sweep's progress within a batch).
    """
    if transfer is not None:
        scene = scene.with_transfer(transfer)
    if callable(progress) and reference:  # the loop and the reference pass: half each
        report = progress
        progress = lambda tests: report(0.5 * tests)  # noqa: E731
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
        groups.setdefault(_group_key(s), []).append(i)
    results: list[RunResult | None] = [None] * len(scenes)
    for idx in groups.values():
        for start in range(0, len(idx), max_k):
            part = idx[start:start + max_k]
            # the reference does not depend on the transfer system: it is computed once for
            # all groups below (bigger batches, one pass)
            res = _run_group([scenes[i] for i in part],
                             reference="defer" if reference else False, nthread=nthread,
                             control=None, buffers_out=None, progress=progress,
                             specimen=specimen, test_ids=part)
            for i, r in zip(part, res, strict=True):
                results[i] = r
    if reference:
        _fill_references(scenes, results, max_k=max_k, nthread=nthread, specimen=specimen,
                         progress=progress)
    return results  # type: ignore[return-value]


def _reference_key(s: Scene, specimen: str) -> tuple:
    # tests whose references can be computed together: same time grid and DOFs, same kind of
    # part model (MuJoCo models of one structure, or the numpy specimen), same numerical size
    rspec = "mujoco" if (s.transfer.kind == "stewart" or specimen == "mujoco") else "auto"
    return (s.dt, s.duration, s.dofs, s.experiment.kind, s.experiment.substeps, rspec,
            len(s.numerical.M), np.array(s.numerical.gamma).tobytes())


def _fill_references(scenes: list[Scene], results: list, *, max_k: int, nthread: int,
                     specimen: str, progress: bool) -> None:
    """Compute z^r for the deferred tests of :func:`run_batch` and write it into their records
    (the ``z_ref.*``/``x_ref.*`` columns, truncated like the record for stopped tests)."""
    from .reference import reference_solution

    groups: dict[tuple, list[int]] = {}
    for i, s in enumerate(scenes):
        groups.setdefault(_reference_key(s, specimen), []).append(i)
    for key, idx in groups.items():
        rspec = key[5]
        for start in range(0, len(idx), max_k):
            part = idx[start:start + max_k]
            ref = reference_solution([scenes[i] for i in part], nthread=nthread,
                                     specimen=rspec, progress=progress)
            for k, i in enumerate(part):
                rec = results[i].record
                n = len(rec.t)
                for j, d in enumerate(scenes[i].dofs):
                    rec.columns[f"z_ref.{d}"][:] = ref["z_ref"][k, :n, j]
                for j in range(ref["x_ref"].shape[2]):
                    rec.columns[f"x_ref.{j}"][:] = ref["x_ref"][k, :n, j]


# ---------------------------------------------------------------------------- one test, fast
def _f(x: float) -> str:
    return repr(float(x))


def _fast_kernel(num, transfer, base: Scene, ci: dict[str, int]):
    """A generated, fully unrolled single-test loop over Python floats, or None.

    The hot path of one test (K = 1) is dominated by per-call overhead, not arithmetic:
    small-array numpy costs ~1 µs per operation. This kernel unrolls the numerical
    recurrence, the compensation, the delay line, the LTI actuator and the numpy specimen
    (or calls the single :class:`~rths3d.platform.sim.PlatformSim`) into straight-line float
    code with every matrix entry a literal. It is the same algorithm as the batched path
    (checked bit-for-bit-close in tests/test_loop.py).
    """
    from .experiment.specimen import Specimen1D
    from .transfer.systems import ActuatorTransfer, StewartTransfer

    tr = base.transfer
    nd = len(base.dofs)
    S = num.s.shape[1]
    n = num.n
    if num.K_tests != 1 or tr.compensation not in ("none", "velocity"):
        return None
    stewart = isinstance(transfer, StewartTransfer)
    if stewart:
        if not transfer.single or not transfer.sensor.ideal:
            return None
    elif not (isinstance(transfer, ActuatorTransfer) and isinstance(transfer.specimen, Specimen1D)
              and transfer.sensor.ideal and nd == 1):
        return None
    Ad = num.Ad[0]
    Bf = num.Bf_hold[0]
    Czx, Czv = num.Czx, num.Czv
    saf = base.safety
    L: list[str] = []
    a = L.append
    a("def kernel(N, P, D, sim, ctl, every, buffers, dl):")
    a("    " + "; ".join(f"s{i} = 0.0" for i in range(S)))
    a("    " + "; ".join(f"f{j} = 0.0" for j in range(nd)))
    lti = None if stewart else transfer.lti
    dline = None if stewart else transfer.delay_line
    if lti is not None:
        ns_a = lti.ns
        if ns_a:
            a("    " + "; ".join(f"xa{i} = 0.0" for i in range(ns_a)))
    if dline is not None:
        a("    bi = 0")
    if not stewart:
        sp = transfer.specimen
        a("    xe = 0.0; ve = 0.0; zp = 0.0")
    if stewart:
        a("    sim_step = sim.step")
        a("    Sim = type(sim)")
        a("    pose_get = Sim.pose.fget; wrench_get = Sim.interface_wrench.fget")
    gw = int(saf.growth_windows)
    if gw:
        a("    " + "; ".join(f"gp{j} = 0.0; gv{j} = 1e308; gb{j} = 0.0; gc{j} = 0"
                          for j in range(nd)))
    a("    for n in range(N):")
    a("        p = P[n]")
    for i in range(S):
        terms = [f"{_f(Ad[i, j])} * s{j}" for j in range(S) if Ad[i, j] != 0.0]
        terms += [f"p[{i}]"]
        terms += [f"{_f(-Bf[i, j])} * f{j}" for j in range(nd) if Bf[i, j] != 0.0]
        a(f"        n{i} = " + " + ".join(terms))
    a("        " + "; ".join(f"s{i} = n{i}" for i in range(S)))
    for j in range(nd):
        tz = [f"{_f(Czx[j, i])} * s{i}" for i in range(S) if Czx[j, i] != 0.0] or ["0.0"]
        tv = [f"{_f(Czv[j, i])} * s{i}" for i in range(S) if Czv[j, i] != 0.0] or ["0.0"]
        a(f"        z{j} = " + " + ".join(tz))
        a(f"        v{j} = " + " + ".join(tv))
    is_rot = [d.startswith("r") for d in base.dofs]
    # x = C_x s = s[:n] for both integrators
    for i in range(n):
        a(f"        if not (-{_f(saf.divergence)} <= s{i} <= {_f(saf.divergence)}): "
          f"return n, 'x', {i}, s{i}")
    for j in range(nd):
        lz = saf.rotation if is_rot[j] else saf.stroke
        a(f"        if not (-{_f(lz)} <= z{j} <= {_f(lz)}): return n, 'z', {j}, z{j}")
        if not is_rot[j]:
            a(f"        if not (-{_f(saf.velocity)} <= v{j} <= {_f(saf.velocity)}): "
              f"return n, 'v', {j}, v{j}")
    for j in range(nd):
        if tr.compensation == "velocity" and tr.comp_time:
            a(f"        u{j} = z{j} + {_f(tr.comp_time)} * v{j}")
        else:
            a(f"        u{j} = z{j}")
    if stewart:
        cmd = ["0.0"] * 6
        for j, d in enumerate(base.dofs):
            cmd[DOFS.index(d)] = f"u{j}"
        a(f"        sim_step({', '.join(cmd)})")
        a("        pm = pose_get(sim); w = wrench_get(sim)")
        for j, d in enumerate(base.dofs):
            k = DOFS.index(d)
            a(f"        m{j} = pm[{k}]; f{j} = w[{k}]")
    else:
        if dline is not None:
            d0, fr, sz = dline.d0, dline.frac, dline.size
            a("        dl[bi] = u0")
            if fr:
                a(f"        u0 = dl[(bi - {d0}) % {sz}] * {_f(1 - fr)} + "
                  f"dl[(bi - {d0 + 1}) % {sz}] * {_f(fr)}")
            else:
                a(f"        u0 = dl[(bi - {d0}) % {sz}]")
            a(f"        bi = (bi + 1) % {sz}")
        if lti is not None:
            A_ = lti.AdT.T
            for i in range(lti.ns):
                terms = [f"{_f(A_[i, j])} * xa{j}" for j in range(lti.ns) if A_[i, j] != 0.0]
                terms.append(f"{_f(lti.Bd[i])} * u0")
                a(f"        y{i} = " + " + ".join(terms))
            if lti.ns:
                a("        " + "; ".join(f"xa{i} = y{i}" for i in range(lti.ns)))
            out = [f"{_f(lti.Cd[i])} * xa{i}" for i in range(lti.ns)]
            if lti.Dd:
                out.append(f"{_f(lti.Dd)} * u0")
            a("        m0 = " + (" + ".join(out) if out else "0.0"))
        else:
            a("        m0 = u0")
        m, k, dd = float(sp.m[0]), float(sp.k[0]), float(sp.d[0])
        h0, kc, dc = float(sp.h0[0]), float(sp.kc[0]), float(sp.dc[0])
        nsub = sp.substeps
        h = sp.dt / nsub
        a(f"        vm = (m0 - zp) * {_f(1.0 / sp.dt)}; dz = (m0 - zp) * {_f(1.0 / nsub)}")
        a(f"        for j in range({nsub}):")
        a("            zm = zp + j * dz")
        if np.isfinite(h0):
            a(f"            if xe > {_f(h0)}:")
            a(f"                fc = {_f(kc)} * (xe - {_f(h0)}) + {_f(dc)} * ve")
            a("                if fc < 0.0: fc = 0.0")
            a("            else:")
            a("                fc = 0.0")
            fc = " - fc"
        else:
            fc = ""
        a(f"            ve += ({_f(k)} * (zm - xe) + {_f(dd)} * (vm - ve){fc}) * {_f(h / m)}")
        a(f"            xe += ve * {_f(h)}")
        a("        zp = m0")
        a(f"        f0 = {_f(k)} * (m0 - xe) + {_f(dd)} * (vm - ve)")
    zc0 = ci[f"z_cmd.{base.dofs[0]}"]
    vals = [f"z{j}" for j in range(nd)] + [f"m{j}" for j in range(nd)] + \
        [f"f{j}" for j in range(nd)] + [f"s{i}" for i in range(n)]
    end = zc0 + 3 * nd + n
    if stewart:
        vals += cmd
        end += 12
        a(f"        D[n + 1, {zc0}:{end}] = ({', '.join(vals)},) + pm")
    else:
        a(f"        D[n + 1, {zc0}:{end}] = ({', '.join(vals)},)")
    for j in range(nd):
        lf = saf.torque if is_rot[j] else saf.force
        a(f"        if not (-{_f(lf)} <= f{j} <= {_f(lf)}): return n + 1, 'f', {j}, f{j}")
    if gw:
        # divergence by growth of the windowed peak |F'_m| (same rule as the batched path)
        for j in range(nd):
            a(f"        a{j} = abs(f{j})")
            a(f"        if a{j} > gp{j}: gp{j} = a{j}")
        a(f"        if (n + 1) % {max(1, int(round(saf.growth_window / base.dt)))} == 0:")
        for j in range(nd):
            floor = 0.02 * (saf.torque if is_rot[j] else saf.force)
            a(f"            if gp{j} > {_f(saf.growth)} * gv{j} and gp{j} > {_f(floor)}:")
            a(f"                if gc{j} == 0: gb{j} = gv{j}")
            a(f"                gc{j} += 1")
            a(f"                if gc{j} >= {gw}: return n + 1, 'g', {j}, gp{j} / gb{j}")
            a("            else:")
            a(f"                gc{j} = 0")
            a(f"            gv{j} = gp{j}; gp{j} = 0.0")
    a("        if every and n % every == 0:")
    a("            for b in buffers: b.n = n + 2")
    a("            if ctl(n): return n + 1, 'user', 0, 0.0")
    a("    return N, None, 0, 0.0")
    env: dict[str, Any] = {}
    exec(compile("\n".join(L), "<rths3d.loop single-test kernel>", "exec"), env)
    return env["kernel"]
