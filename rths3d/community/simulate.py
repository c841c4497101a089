"""Time stepping of the benchmark loop, exactly as the Simulink model behaves (SPEC §7).

At each major step t_k = k·h (h = 1/4096 s): read the specimen displacement x_k and the
numerical floor-1 displacement y_n,k; the force derivative blocks give v_k, a_k by backward
differences; the sensors give x_m = x + n_D and f_meas = k_e x + c_e v + m_e a + n_F; the
controller (A/D → Tustin phase lead → D/A on y_n; A/D → Tustin PI → D/A on y_p − x_m) gives
y_gc,k, held over the step. Then both continuous parts take one RK4 step: the numerical
substructure with ẍ_g linearly interpolated at the stage times and the force of the previous
sample (unit delay), the plant with y_gc held and the CSI derivative block's stage rule. Both
RK4 steps are linear, so they are precomputed as matrices (:func:`numerical_step_matrices`,
:func:`rths3d.community.plant.plant_step_matrices`).

The loop runs the compiled per-step kernels of :mod:`.kernels` (written once; the loop with a
compensator in place of the phase lead, :mod:`.compensated`, calls the same kernels), one
trial or K trials per call. An independent numpy implementation of the same step over K trials
(``run_trials(engine="numpy")``) cross-checks them.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from ..errors import ConfigError, SafetyStop
from ..lti import (
    ContinuousSS,
    DifferenceEquation,
    GroundMotion,
    affine_step_matrices,
    c2d,
    lead_lag,
    lsim_foh,
    pi_controller,
    ss,
)
from ..lti.noise import band_limited_std, normal_sequence, simulink_randn
from ..metrics.criteria import j_criteria
from . import kernels
from .config import BenchmarkConfig, load_excitation
from .plant import PlantParams, plant_step_matrices
from .structure import CaseMatrices, case_matrices

__all__ = ["BenchmarkResult", "numerical_step_matrices", "reference_response", "run_case",
           "run_trials"]


@dataclass(eq=False)
class BenchmarkResult:
    """Logged signals of one run (SI) and its criteria.

    ``t`` (s), ``x_m`` measured specimen displacement (m), ``x_num`` (N, 3) numerical floor
    displacements (m), ``x_ref`` (N, 3) reference displacements (m), ``ag`` scaled ground
    acceleration (m/s²), ``f_act`` actuator force (N), ``y_gc`` command (m), ``f_meas``
    measured force (N). ``status`` is ``ok`` or ``stopped`` with ``reason``; after a stop the
    arrays hold the samples up to and including the stopping one. ``j``: J1 (s), J2–J9 (%).
    A run with a compensator in place of the phase lead also carries ``compensator``,
    ``coefficients``, ``history`` and ``y_p``.
    """

    config: BenchmarkConfig
    t: np.ndarray
    x_m: np.ndarray
    x_num: np.ndarray
    x_ref: np.ndarray
    ag: np.ndarray
    f_act: np.ndarray
    y_gc: np.ndarray
    f_meas: np.ndarray
    status: str = "ok"
    reason: str = ""
    j: dict[str, float] = field(default_factory=dict)
    plant: PlantParams | None = None
    compensator: str = ""
    """The outer compensation: "" for the benchmark's own phase lead (:func:`run_case`), else
    the :mod:`rths3d.compensation` name that replaced it (:func:`.compensated.run_compensated`)."""
    coefficients: dict[str, float] = field(default_factory=dict)
    """The compensator's coefficients at the end of the run (adaptive ones: final values)."""
    history: dict[str, np.ndarray] = field(default_factory=dict)
    """``t`` (s) and the compensator's coefficients over the run, when sampled."""
    y_p: np.ndarray | None = None
    """The compensator's output (m), the PI loop's reference, when run with a compensator."""

    @property
    def peak_force(self) -> float:
        """max |F_act| over the run (N)."""
        return float(np.max(np.abs(self.f_act))) if self.f_act.size else 0.0

    def table_row(self) -> dict[str, float]:
        """Criteria in the benchmark's units: ``J1`` in ms, ``J2``…``J9`` in %."""
        from ..metrics.criteria import benchmark_row

        if not self.j:  # too short to evaluate (fewer than 61 samples)
            return {f"J{i}": math.nan for i in range(1, 10)}
        return benchmark_row(self.j)

    def to_record(self):  # -> rths3d.record.Record
        """The run as an rths3d Record (single DOF ``z`` = the interface, floor 1)."""
        from ..record import Record

        c = self.config
        cols: dict[str, np.ndarray] = {
            "z_cmd.z": self.x_num[:, 0], "z_meas.z": self.x_m, "f_meas.z": self.f_meas,
            "z_ref.z": self.x_ref[:, 0], "f_act": self.f_act, "y_gc": self.y_gc,
            "ag": self.ag,
        }
        for i in range(3):
            cols[f"x_num.{i}"] = self.x_num[:, i]
            cols[f"x_ref.{i}"] = self.x_ref[:, i]
        if self.y_p is not None:
            cols["y_p"] = self.y_p
        m = case_matrices(c.case, c.plant.m_e, c.plant.c_e, c.plant.k_e)
        meta: dict[str, Any] = {
            "scene": f"rthsbench_case{c.case}_{c.excitation}", "transfer": "lti",
            "dt": c.dt, "status": self.status, "reason": self.reason,
            "params": {"case": c.case, "excitation": c.excitation, "intensity": c.intensity,
                       "noise": c.noise, "force_delay": c.force_delay},
            "numerical": {"M": m.Mn.tolist(), "C": m.Cn.tolist(), "K": m.Kn.tolist(),
                          "gamma": m.gamma[:, None].tolist()},
            "experiment": {"m_exp": c.plant.m_e, "k_exp": [[c.plant.k_e]],
                           "c_exp": c.plant.c_e},
            "j_criteria": self.j,
            "compensator": self.compensator or "benchmark phase lead",
            "compensator_coefficients": dict(self.coefficients),
            # fastest eigenfrequency of the numerical substructure (rad/s), for τ-ratios
            "omega_num_max": float(np.sqrt(np.max(np.linalg.eigvals(
                np.linalg.solve(m.Mn, m.Kn)).real))),
        }
        return Record(self.t, cols, meta)


def numerical_step_matrices(m: CaseMatrices, h: float, ground_interp: str = "linear"
                            ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One RK4 step of ``M_n ẍ + C_n ẋ + K_n x = −M ι ẍ_g − γ f`` as
    ``z_{k+1} = Φ z_k + G [ẍ_g(t_k), ẍ_g(t_k + h/2), ẍ_g(t_k + h)] + g_f f``; z = [x; ẋ].

    ``ground_interp="hold"`` uses ẍ_g(t_k) at all stages (the result of G then sums into its
    first column). Returns ``(Φ (6×6), G (6×3), g_f (6,))``.
    """
    Mi = np.linalg.inv(m.Mn)
    A = np.block([[np.zeros((3, 3)), np.eye(3)], [-Mi @ m.Kn, -Mi @ m.Cn]])
    b_ag = np.concatenate([np.zeros(3), -Mi @ m.M @ m.iota])
    b_f = np.concatenate([np.zeros(3), -Mi @ m.gamma])
    hold = ground_interp == "hold"

    def step(z: np.ndarray, u: np.ndarray) -> np.ndarray:
        a0, am, a1, f = u
        if hold:
            am = a1 = a0
        k1 = A @ z + b_ag * a0 + b_f * f
        k2 = A @ (z + 0.5 * h * k1) + b_ag * am + b_f * f
        k3 = A @ (z + 0.5 * h * k2) + b_ag * am + b_f * f
        k4 = A @ (z + h * k3) + b_ag * a1 + b_f * f
        return z + (h / 6.0) * (k1 + 2.0 * k2 + 2.0 * k3 + k4)

    Phi, G = affine_step_matrices(step, 6, 4)
    return Phi, G[:, :3].copy(), G[:, 3].copy()


def reference_system(m: CaseMatrices) -> ContinuousSS:
    """``M ẍ + C ẋ + K x = −M ι ẍ_g`` as state space, input ẍ_g (m/s²), outputs x (m)."""
    Mi = np.linalg.inv(m.M)
    A = np.block([[np.zeros((3, 3)), np.eye(3)], [-Mi @ m.K, -Mi @ m.C]])
    B = np.concatenate([np.zeros(3), -m.iota])[:, None]
    return ss(A, B, np.hstack([np.eye(3), np.zeros((3, 3))]))


def reference_response(m: CaseMatrices, ag: np.ndarray, dt: float, method: str = "foh"
                       ) -> np.ndarray:
    """Exact reference floor displacements (N, 3) for ground-acceleration samples ``ag``.

    ``foh``: input linear between samples (MATLAB lsim on the logged samples); ``zoh``: held.
    """
    sysr = reference_system(m)
    if method == "foh":
        return lsim_foh(sysr, ag, dt)
    d = c2d(sysr, dt, "zoh")
    from ..lti import recur

    X = np.zeros((ag.size, 6))
    if ag.size > 1:
        X[1:] = recur(d.Ad, np.zeros(6), ag[:-1, None] @ d.Bd.T)
    return X @ d.Cd.T


def _noise(cfg: BenchmarkConfig, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Displacement (m) and force (N) noise sequences, held per sample."""
    if not cfg.noise:
        z = np.zeros(n)
        return z, z
    if cfg.noise_generator == "simulink":
        w = simulink_randn(n, cfg.noise_seed)
        w_f = w if cfg.noise_shared else simulink_randn(n, cfg.noise_seed + 1)
    else:
        w = normal_sequence(n, cfg.noise_seed)
        w_f = w if cfg.noise_shared else normal_sequence(n, cfg.noise_seed + 1)
    return (band_limited_std(cfg.noise_cov_d, cfg.dt) * w,
            band_limited_std(cfg.noise_cov_f, cfg.dt) * w_f)


def _first_order(de: DifferenceEquation, field: str) -> tuple[float, float, float]:
    """``(b0, b1, a1)`` of a controller of order ≤ 1 (the generated loop's form)."""
    if len(de.a) > 2 or len(de.b) > 2:
        raise ConfigError(field, (de.b, de.a), "the benchmark loop takes controllers of "
                          "order ≤ 1 (two b and two a coefficients)")
    b = (*de.b, 0.0, 0.0)
    a = (*de.a, 0.0, 0.0)
    return float(b[0]), float(b[1]), float(a[1])


def _controller_coeffs(cfg: BenchmarkConfig) -> tuple[float, ...]:
    """``(lb0, lb1, la1, pb0, pb1, pg)``: phase lead ``y = lb0 u + lb1 u⁻ − la1 y⁻`` and
    tracking controller ``y = pg y⁻ + pb0 e + pb1 e⁻`` (pg = 1 for a PI)."""
    c = cfg.controller
    track = c.tracking or pi_controller(c.kp, c.ki, cfg.dt)
    if c.lead is not None:
        lead = c.lead
    elif c.phase_lead:
        lead = lead_lag(c.lead_num, c.lead_den, cfg.dt)
    else:
        lead = DifferenceEquation((1.0,), (1.0,), cfg.dt)
    lb0, lb1, la1 = _first_order(lead, "controller.lead")
    pb0, pb1, pa1 = _first_order(track, "controller.tracking")
    return lb0, lb1, la1, pb0, pb1, -pa1


def _grid(cfg: BenchmarkConfig, gm: GroundMotion) -> tuple[int, np.ndarray]:
    t_end = gm.t_end if cfg.t_end is None else min(cfg.t_end, gm.t_end)
    n = int(math.floor(t_end / cfg.dt + 1e-9)) + 1
    return n, cfg.dt * np.arange(n)


def _ground_stages(cfg: BenchmarkConfig, gm: GroundMotion, t: np.ndarray) -> np.ndarray:
    """ẍ_g at t_k, t_k + h/2, t_k + h for every step, shape (N, 3) (m/s²)."""
    if cfg.ground_interp == "record_hold":
        return np.stack([gm.held(t), gm.held(t + 0.5 * cfg.dt), gm.held(t + cfg.dt)], axis=1)
    a0 = gm(t)
    if cfg.ground_interp == "hold":
        return np.stack([a0, a0, a0], axis=1)
    return np.stack([a0, gm(t + 0.5 * cfg.dt), gm(t + cfg.dt)], axis=1)


def _prepare(cfg: BenchmarkConfig, plant: PlantParams):
    m = case_matrices(cfg.case, plant.m_e, plant.c_e, plant.k_e)
    Phi_n, G_ag, gf = numerical_step_matrices(m, cfg.dt, cfg.ground_interp)
    Phi_p, gy, gx = plant_step_matrices(plant, cfg.dt, cfg.derivative)
    return m, Phi_n, G_ag, gf, Phi_p, gy, gx


class _Loop:
    """One run of K plants on a common grid: the step matrices, noise, controller
    coefficients, loop states and logs that the kernels of :mod:`.kernels` work on."""

    def __init__(self, cfg: BenchmarkConfig, plants: Sequence[PlantParams], gm: GroundMotion):
        K = len(plants)
        self.cfg, self.plants = cfg, list(plants)
        self.N, self.t = _grid(cfg, gm)
        self.stages = np.ascontiguousarray(_ground_stages(cfg, gm, self.t))
        prep = [_prepare(cfg, p) for p in plants]
        # Φ_n, G_ag, g_f, Φ_p, g_y, g_x stacked over plants
        self.mats = tuple(np.ascontiguousarray(np.stack([p[j] for p in prep]))
                          for j in range(1, 7))
        self.spec = np.array([[p.k_e, p.c_e, p.m_e] for p in plants])
        nD, nF = _noise(cfg, self.N)
        self.nD = np.ascontiguousarray(nD, dtype=float)
        self.nF = np.ascontiguousarray(nF, dtype=float)
        lb0, lb1, la1, pb0, pb1, pg = (float(v) for v in _controller_coeffs(cfg))
        self.lead = np.array([lb0, lb1, la1])
        self.ctrl = np.array([pb0, pb1, pg])
        q, sat = (float(cfg.q), float(cfg.sat)) if cfg.quantize else (0.0, math.inf)
        self.conv = np.array([1.0 / cfg.dt, q, sat])
        self.limit = float(cfg.force_limit)
        self.force_delay = bool(cfg.force_delay)
        self.Z, self.P = np.zeros((K, 6)), np.zeros((K, 5))
        self.mem, self.hist = np.zeros((K, kernels.MEM)), np.zeros((K, 2))
        self.zc, self.zdc, self.zmc, self.yp = (np.zeros((K, 1)) for _ in range(4))
        self.work = np.zeros(11)
        N = self.N
        self.XM, self.XN, self.FM = np.zeros((N, K)), np.zeros((N, K, 3)), np.zeros((N, K))
        self.FA, self.YG, self.YP = np.zeros((N, K)), np.zeros((N, K)), np.zeros((N, K))
        self.alive = np.ones(K, dtype=bool)
        self.stop_at = np.full(K, -1, dtype=np.int64)
        # the kernels with everything but the step (and the command) bound once
        self.measure: Callable[[int], None] = functools.partial(
            kernels.measure, self.alive, self.Z, self.P, self.mem, self.spec, self.nD,
            self.nF, self.conv, self.zc, self.zdc, self.zmc, self.XM, self.XN, self.FM)
        """``measure(k)``: sensors at t_k; the compensator's inputs in ``zc``, ``zdc``,
        ``zmc``."""
        self.advance: Callable[[int, np.ndarray], int] = functools.partial(
            kernels.advance, self.alive, self.stop_at, self.Z, self.P, self.mem, self.ctrl,
            self.conv, self.limit, self.force_delay, self.stages, *self.mats, self.FA,
            self.YG, self.YP, self.work)
        """``advance(k, yp)``: tracking controller from ``yp`` (K, 1), force check, RK4
        step; the number of trials stopped at the force limit."""

    def run_fixed(self) -> int:
        """The whole loop with the benchmark's phase lead, compiled; steps run."""
        return kernels.run_fixed(self.lead, self.hist, self.alive, self.stop_at, self.Z,
                                 self.P, self.mem, self.spec, self.nD, self.nF, self.conv,
                                 self.ctrl, self.limit, self.force_delay, self.stages,
                                 *self.mats, self.zc, self.zdc, self.zmc, self.yp, self.work,
                                 self.XM, self.XN, self.FM, self.FA, self.YG, self.YP)

    def force_stop(self, i: int) -> SafetyStop | None:
        """The force-limit stop of trial ``i``, if it stopped."""
        if self.stop_at[i] < 0:
            return None
        k = int(self.stop_at[i])
        return SafetyStop("actuator force |F_act|", abs(float(self.FA[k, i])), self.limit,
                          float(self.t[k]), i, "N")

    def result(self, i: int, stop: SafetyStop | None, x_ref: np.ndarray, copy: bool = False
               ) -> BenchmarkResult:
        """Trial ``i`` as a :class:`BenchmarkResult` up to its stop (``copy``: contiguous
        copies, so that the result does not keep the (N, K) logs alive)."""
        n = self.N if self.stop_at[i] < 0 else int(self.stop_at[i]) + 1
        cols = [self.XM[:n, i], self.XN[:n, i, :], self.FA[:n, i], self.YG[:n, i],
                self.FM[:n, i]]
        if copy:
            cols = [c.copy() for c in cols]
        p = self.plants[i]
        return _finish(replace(self.cfg, plant=p), p, self.t, self.stages[:, 0], *cols, stop,
                       n, x_ref)


def _finish(cfg: BenchmarkConfig, plant: PlantParams, t: np.ndarray, ag: np.ndarray,
            xm: np.ndarray, xnum: np.ndarray, F: np.ndarray, ygc: np.ndarray, fm: np.ndarray,
            stop: SafetyStop | None, n: int, x_ref_full: np.ndarray) -> BenchmarkResult:
    xr = x_ref_full[:n]
    res = BenchmarkResult(cfg, t[:n], xm[:n], xnum[:n], xr, ag[:n], F[:n], ygc[:n], fm[:n],
                          plant=plant)
    if stop is not None:
        res.status, res.reason = "stopped", stop.reason
    if n > 60:
        res.j = j_criteria(res.x_num[:, 0], res.x_m, res.x_num, res.x_ref, dt=cfg.dt,
                           convention=cfg.convention)
    return res


def run_case(cfg: BenchmarkConfig | None = None, data_path: str | None = None,
             gm: GroundMotion | None = None, raise_on_stop: bool = False,
             x_ref: np.ndarray | None = None) -> BenchmarkResult:
    """Run one benchmark test (single trial, plant ``cfg.plant``) and evaluate J1–J9.

    The record is ``cfg.excitation`` from the benchmark data, or ``gm`` if given (its scale
    is replaced by ``cfg.intensity``). ``x_ref`` may pass a precomputed reference response
    (N, 3) of the same record and grid (it depends on neither plant nor controller).

    If |F_act| reaches ``cfg.force_limit`` the test stops at that sample: the result has
    ``status="stopped"``, the reason, and the samples so far (or, with ``raise_on_stop``, a
    :class:`~rths3d.errors.SafetyStop` is raised).
    """
    cfg = cfg or BenchmarkConfig()
    if gm is None:
        gm = load_excitation(cfg.excitation, cfg.intensity, data_path)
    else:
        gm = gm.scaled(cfg.intensity)
    loop = _Loop(cfg, [cfg.plant], gm)
    n = loop.run_fixed()
    if x_ref is None or x_ref.shape[0] < n:
        m = case_matrices(cfg.case, cfg.plant.m_e, cfg.plant.c_e, cfg.plant.k_e)
        x_ref = reference_response(m, loop.stages[:n, 0], cfg.dt, cfg.reference)
    stop = loop.force_stop(0)
    res = loop.result(0, stop, x_ref)
    if stop is not None and raise_on_stop:
        raise stop
    return res


def run_trials(cfg: BenchmarkConfig | None = None, n_trials: int = 20, seed: int = 123,
               plants: list[PlantParams] | None = None, data_path: str | None = None,
               gm: GroundMotion | None = None, engine: str = "python",
               progress: Callable[[int], None] | None = None) -> list[BenchmarkResult]:
    """Run ``n_trials`` perturbed-plant trials of the case in ``cfg``.

    Plants are drawn with :meth:`PlantParams.perturbed` from ``numpy.random.default_rng(seed)``
    (or given as ``plants``). The numerical substructure of each trial uses its own perturbed
    k_e and c_e so that numerical + experimental always add up to the reference structure.
    All trials share the sensor-noise realisation of ``cfg``. A trial reaching the force
    limit stops (its result is ``stopped``, truncated); the others go on.

    ``engine="python"`` runs each trial through the compiled loop of :mod:`.kernels` (the
    one :func:`run_case` runs); ``engine="numpy"`` steps all trials together with numpy
    arrays over trials (an independent implementation of the same step, used to cross-check
    the kernels). ``progress(i)`` is called after each finished trial (python engine).
    """
    cfg = cfg or BenchmarkConfig()
    if plants is None:
        rng = np.random.default_rng(seed)
        plants = [cfg.plant.perturbed(rng) for _ in range(int(n_trials))]
    if engine not in ("python", "numpy"):
        raise ConfigError("engine", engine, "must be 'python' or 'numpy'")
    if gm is None:
        gm = load_excitation(cfg.excitation, cfg.intensity, data_path)
    if engine == "python":
        out = []
        # the reference structure is the same for every trial (the partition adds up)
        gs = gm.scaled(cfg.intensity)
        _, t = _grid(cfg, gs)
        m = case_matrices(cfg.case, cfg.plant.m_e, cfg.plant.c_e, cfg.plant.k_e)
        x_ref = reference_response(m, _ground_stages(cfg, gs, t)[:, 0], cfg.dt, cfg.reference)
        for i, p in enumerate(plants):
            out.append(run_case(replace(cfg, plant=p), gm=gm, x_ref=x_ref))
            if progress is not None:
                progress(i)
        return out
    return _run_batched(cfg, plants, gm.scaled(cfg.intensity))


def _run_batched(cfg: BenchmarkConfig, plants: list[PlantParams], gm: GroundMotion
                 ) -> list[BenchmarkResult]:
    """All trials stepped together with numpy arrays over trials (see :func:`run_trials`)."""
    K = len(plants)
    N, t = _grid(cfg, gm)
    stages = _ground_stages(cfg, gm, t)
    prep = [_prepare(cfg, p) for p in plants]
    m_ref = prep[0][0]
    PhiN = np.stack([p[1] for p in prep])        # (K, 6, 6)
    Gag = np.stack([p[2] for p in prep])         # (K, 6, 3)
    GF = np.stack([p[3] for p in prep])          # (K, 6)
    PhiP = np.stack([p[4] for p in prep])        # (K, 5, 5)
    GY = np.stack([p[5] for p in prep])          # (K, 5)
    GX = np.stack([p[6] for p in prep])          # (K, 5)
    ke = np.array([p.k_e for p in plants])
    ce = np.array([p.c_e for p in plants])
    me = np.array([p.m_e for p in plants])
    nD, nF = _noise(cfg, N)
    lb0, lb1, la1, pb0, pb1, pa1 = _controller_coeffs(cfg)
    q, sat, conv = cfg.q, cfg.sat, cfg.quantize
    h_inv = 1.0 / cfg.dt
    limit = cfg.force_limit

    def ad(u: np.ndarray) -> np.ndarray:
        if not conv:
            return u
        u = np.clip(u, -sat, sat)
        return q * np.sign(u) * np.floor(np.abs(u) / q + 0.5) if q > 0 else u

    def da(u: np.ndarray) -> np.ndarray:
        if not conv:
            return u
        u = q * np.sign(u) * np.floor(np.abs(u) / q + 0.5) if q > 0 else u
        return np.clip(u, -sat, sat)

    Z = np.zeros((K, 6, 1))
    P = np.zeros((K, 5, 1))
    xprev = np.zeros(K)
    vprev = np.zeros(K)
    fdel = np.zeros(K)
    u1p = np.zeros(K)
    yplp = np.zeros(K)
    ep = np.zeros(K)
    ypip = np.zeros(K)
    XM = np.empty((N, K))
    XN = np.empty((N, K, 3))
    FA = np.empty((N, K))
    YG = np.empty((N, K))
    FM = np.empty((N, K))
    stop_at = np.full(K, -1)
    alive = np.ones(K, dtype=bool)
    chunk = 2048
    for c0 in range(0, N, chunk):
        c1 = min(N, c0 + chunk)
        forcing = np.einsum("kij,nj->nki", Gag, stages[c0:c1])  # (n, K, 6)
        for k in range(c0, c1):
            x = P[:, 3, 0].copy()
            v = (x - xprev) * h_inv
            a = (v - vprev) * h_inv
            xm = x + nD[k]
            fm = ke * x + ce * v + me * a + nF[k]
            u1 = ad(Z[:, 0, 0])
            ypl = lb0 * u1 + lb1 * u1p - la1 * yplp
            e = ad(da(ypl) - xm)
            ypi = pa1 * ypip + pb0 * e + pb1 * ep
            ygc = da(ypi)
            F = P[:, 2, 0]
            XM[k] = xm
            XN[k] = Z[:, :3, 0]
            FA[k] = F
            YG[k] = ygc
            FM[k] = fm
            bad = alive & ~(np.abs(F) < limit)
            if bad.any():
                stop_at[bad] = k
                alive &= ~bad
                if not alive.any():
                    break
            ff = fdel if cfg.force_delay else fm
            Z = PhiN @ Z
            Z[:, :, 0] += forcing[k - c0] + GF * ff[:, None]
            P = PhiP @ P
            P[:, :, 0] += GY * ygc[:, None] + GX * xprev[:, None]
            xprev, vprev, fdel = x, v, fm
            u1p, yplp, ep, ypip = u1, ypl, e, ypi
        if not alive.any():
            break
    ag = stages[:, 0]
    results = []
    for i, p in enumerate(plants):
        n = N if stop_at[i] < 0 else int(stop_at[i]) + 1
        stop = None
        if stop_at[i] >= 0:
            stop = SafetyStop("actuator force |F_act|", abs(FA[n - 1, i]), limit,
                              float(t[n - 1]), i, "N")
        x_ref = reference_response(m_ref, ag[:n], cfg.dt, cfg.reference)
        results.append(_finish(replace(cfg, plant=p), p, t, ag, XM[:, i], XN[:, i, :],
                               FA[:, i], YG[:, i], FM[:, i], stop, n, x_ref))
    return results
