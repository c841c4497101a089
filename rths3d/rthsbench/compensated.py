"""The benchmark loop with a compensator from :mod:`rths3d.compensation` as the outer
compensation.

The benchmark's sample controller is a feedback PI on the tracking error and, outside that
loop, a phase lead G_T on the desired displacement y_n (SPEC §8: "the phase lead acts on the
reference, outside the feedback loop"). That phase lead is the outer (delay) compensation;
here a compensator takes its place and the PI loop stays:

    u₁ = AD(y_n),  v₁ = ẏ_n,  m = AD(x_m)              (numerical outputs and measurement)
    y_p = DA(compensator.command(u₁, v₁, m))            (was DA(G_T u₁))
    e = AD(y_p − x_m),  y_gc = DA(PI e)                 (unchanged)

so the compensator's "transfer system" is the PI-controlled servo loop y_p → x_m. The
compensator sees the signals the benchmark controller sees plus the numerical substructure's
floor-1 velocity ẏ_n (an output of the numerical model) and the measured displacement.
Everything else (plant, RK4 steps, converters, noise, force delay, the 8900 N limit) is the
benchmark's (:mod:`.simulate`). With the ``lead`` compensator (the benchmark's G_T) this loop
reproduces :func:`~.simulate.run_case` (tested).

All trials step together (K tests × 1 channel for the compensator); each step is one numba
call for the plant and one ``command`` call. A trial stops at the 8900 N force limit or when
its compensator stops (drift safety), with the reason, keeping the samples up to the stop.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np
from numba import njit

from ..errors import ConfigError, SafetyStop
from ..lti import GroundMotion
from .config import BenchmarkConfig, load_excitation
from .plant import PlantParams
from .simulate import (
    BenchmarkResult,
    _controller_coeffs,
    _finish,
    _grid,
    _ground_stages,
    _noise,
    _prepare,
    reference_response,
)
from .structure import case_matrices

__all__ = ["calibrated_config", "calibration_record", "run_compensated"]


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
def _measure(k, alive, Z, P, mem, spec, nD, nF, conv, zc, zdc, zmc, XM, XN, FM):
    """Sensors at t_k and the compensator's inputs. ``mem`` (K, 9): x_{k−1}, v_{k−1},
    f_{k−1}, e_{k−1}, y_pi,k−1, then x, v, x_m, f_meas at t_k; ``spec`` (K, 3): k_e, c_e,
    m_e; ``conv`` = [inv_h, q, sat]."""
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
def _advance(k, yp_raw, alive, stop_at, Z, P, mem, ctrl, conv, limit, force_delay, stage,
             PhiN, Gag, GF, PhiP, GY, GX, FA, YG, YP):
    """Controller from the compensator's output, force check, one RK4 step of both parts.
    ``ctrl`` = [pb0, pb1, pg] (PI), ``stage`` = ẍ_g at t_k, t_k + h/2, t_k + h. Returns the
    number of trials stopped at the force limit in this step."""
    q, sat = conv[1], conv[2]
    pb0, pb1, pg = ctrl[0], ctrl[1], ctrl[2]
    a0, am, a1 = stage[0], stage[1], stage[2]
    stopped = 0
    zn = np.empty(6)
    pn = np.empty(5)
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
            zn[r] = s + GF[i, r] * ff + (Gag[i, r, 0] * a0 + Gag[i, r, 1] * am
                                         + Gag[i, r, 2] * a1)
        xprev = mem[i, 0]
        for r in range(5):
            s = 0.0
            for c in range(5):
                s += PhiP[i, r, c] * P[i, c]
            pn[r] = s + GY[i, r] * ygc + GX[i, r] * xprev
        for r in range(6):
            Z[i, r] = zn[r]
        for r in range(5):
            P[i, r] = pn[r]
        mem[i, 0] = mem[i, 5]
        mem[i, 1] = mem[i, 6]
        mem[i, 2] = mem[i, 8]
        mem[i, 3] = e
        mem[i, 4] = ypi
    return stopped


def _plants(cfg: BenchmarkConfig, plants: Sequence[PlantParams] | None, n_trials: int,
            seed: int) -> list[PlantParams]:
    if plants is not None:
        return list(plants)
    rng = np.random.default_rng(seed)
    return [cfg.plant] + [cfg.plant.perturbed(rng) for _ in range(int(n_trials))]


def run_compensated(cfg: BenchmarkConfig | None = None, compensator: str | Any = "ats",
                    params: Mapping[str, Any] | Any = None,
                    plants: Sequence[PlantParams] | None = None, n_trials: int = 0,
                    seed: int = 123, data_path: str | None = None,
                    gm: GroundMotion | None = None, x_ref: np.ndarray | None = None,
                    history_every: int = 0,
                    progress: Callable[[int, int], None] | None = None
                    ) -> list[BenchmarkResult]:
    """Run the benchmark with ``compensator`` (a name in
    :data:`rths3d.compensation.COMPENSATORS`, configured by ``params``: its Config or a
    mapping of its fields) in place of the phase lead, for several plants at once.

    ``compensator`` may also be a compensator object already built for these K plants and
    1 channel at ``cfg.dt``. ``plants``: the plants to run (default: ``cfg.plant`` followed
    by ``n_trials`` perturbed draws from ``numpy.random.default_rng(seed)``, the draws of
    :func:`~.simulate.run_trials` with the same seed). Returns one :class:`BenchmarkResult`
    per plant with ``compensator``, the final ``coefficients``, ``y_p`` and, with
    ``history_every`` > 0, ``history``: the coefficients every ``history_every`` steps.
    ``progress(k, N)`` is called every 4096 steps.
    """
    from ..compensation import build

    cfg = cfg or BenchmarkConfig()
    plant_list = _plants(cfg, plants, n_trials, seed)
    if not plant_list:
        raise ConfigError("plants", 0, "need at least one plant")
    if gm is None:
        gm = load_excitation(cfg.excitation, cfg.intensity, data_path)
    else:
        gm = gm.scaled(cfg.intensity)
    K = len(plant_list)
    N, t = _grid(cfg, gm)
    stages = np.ascontiguousarray(_ground_stages(cfg, gm, t))
    prep = [_prepare(cfg, p) for p in plant_list]
    PhiN = np.ascontiguousarray(np.stack([p[1] for p in prep]))
    Gag = np.ascontiguousarray(np.stack([p[2] for p in prep]))
    GF = np.ascontiguousarray(np.stack([p[3] for p in prep]))
    PhiP = np.ascontiguousarray(np.stack([p[4] for p in prep]))
    GY = np.ascontiguousarray(np.stack([p[5] for p in prep]))
    GX = np.ascontiguousarray(np.stack([p[6] for p in prep]))
    spec = np.array([[p.k_e, p.c_e, p.m_e] for p in plant_list])
    nD, nF = _noise(cfg, N)
    nD = np.ascontiguousarray(nD, dtype=float)
    nF = np.ascontiguousarray(nF, dtype=float)
    _, _, _, pb0, pb1, pg = (float(v) for v in _controller_coeffs(cfg))
    ctrl = np.array([pb0, pb1, pg])
    q, sat = (float(cfg.q), float(cfg.sat)) if cfg.quantize else (0.0, math.inf)
    conv = np.array([1.0 / cfg.dt, q, sat])

    if isinstance(compensator, str):
        comp = build(compensator, K, 1, cfg.dt, params)
    else:
        comp = compensator
        compensator = getattr(comp, "name", type(comp).__name__)
    Z = np.zeros((K, 6))
    P = np.zeros((K, 5))
    mem = np.zeros((K, 9))
    zc = np.zeros((K, 1))
    zdc = np.zeros((K, 1))
    zmc = np.zeros((K, 1))
    XM = np.zeros((N, K))
    XN = np.zeros((N, K, 3))
    FM = np.zeros((N, K))
    FA = np.zeros((N, K))
    YG = np.zeros((N, K))
    YP = np.zeros((N, K))
    alive = np.ones(K, dtype=bool)
    stop_at = np.full(K, -1, dtype=np.int64)
    comp_stop_at = np.full(K, -1, dtype=np.int64)
    history: list[tuple[float, dict[str, np.ndarray]]] = []
    limit = float(cfg.force_limit)
    fdelay = bool(cfg.force_delay)
    cstopped = comp.stopped
    n_alive = K
    for k in range(N):
        _measure(k, alive, Z, P, mem, spec, nD, nF, conv, zc, zdc, zmc, XM, XN, FM)
        yp = comp.command(zc, zdc, zmc)
        if cstopped.any():
            new = cstopped & alive
            if new.any():
                for i in np.flatnonzero(new):
                    comp_stop_at[i] = k
                    stop_at[i] = k
                    # the stopping sample keeps its measurements; no command is applied
                    FA[k, i] = P[i, 2]
                alive &= ~new
                n_alive = int(alive.sum())
        if n_alive:
            n_alive -= _advance(k, yp, alive, stop_at, Z, P, mem, ctrl, conv, limit, fdelay,
                                stages[k], PhiN, Gag, GF, PhiP, GY, GX, FA, YG, YP)
        if history_every and k % history_every == 0:
            history.append((float(t[k]), {n: v[:, 0].copy()
                                          for n, v in comp.coefficients().items()}))
        if progress is not None and k % 4096 == 0:
            progress(k, N)
        if n_alive == 0:
            break
    ag = stages[:, 0]
    if x_ref is None or x_ref.shape[0] < N:
        m = case_matrices(cfg.case, cfg.plant.m_e, cfg.plant.c_e, cfg.plant.k_e)
        n_ref = N if (stop_at < 0).any() else int(stop_at.max()) + 1
        x_ref = reference_response(m, ag[:n_ref], cfg.dt, cfg.reference)
    coefs = comp.coefficients()
    results = []
    for i, p in enumerate(plant_list):
        n = N if stop_at[i] < 0 else int(stop_at[i]) + 1
        stop = None
        if comp_stop_at[i] >= 0:
            stop = comp.stops[i]
        elif stop_at[i] >= 0:
            stop = SafetyStop("actuator force |F_act|", abs(FA[n - 1, i]), limit,
                              float(t[n - 1]), i, "N")
        # contiguous copies: a trial's result does not keep the (N, K) logs alive
        res = _finish(replace(cfg, plant=p), p, t, ag, XM[:n, i].copy(), XN[:n, i, :].copy(),
                      FA[:n, i].copy(), YG[:n, i].copy(), FM[:n, i].copy(), stop, n, x_ref)
        res.compensator = compensator
        res.y_p = YP[:n, i].copy()
        res.coefficients = {name: float(v[i, 0]) for name, v in coefs.items()}
        if history_every:
            res.history = {"t": np.array([h[0] for h in history])}
            for name in coefs:
                res.history[name] = np.array([h[1][name][i] for h in history])
        results.append(res)
    return results


class _Prescribed:
    """A command given in advance (a predefined displacement test); keeps what it saw."""

    name = "prescribed"

    def __init__(self, signal: np.ndarray):
        self.signal = np.asarray(signal, dtype=float)
        self.u = np.zeros((1, 1))
        self.z_meas = np.zeros(self.signal.size)
        self.stopped = np.zeros(1, dtype=bool)
        self.stops = [None]
        self.k = 0

    def command(self, z: np.ndarray, zdot: np.ndarray, z_meas: np.ndarray) -> np.ndarray:
        k = self.k
        self.z_meas[k] = z_meas[0, 0]
        self.u[0, 0] = self.signal[k] if k < self.signal.size else 0.0
        self.k = k + 1
        return self.u

    def coefficients(self) -> dict[str, np.ndarray]:
        return {}


CALIBRATION_SIGNAL = {"f_min": 0.2, "f_max": 30.0, "n_lines": 40, "period": 10.0,
                      "amplitude": 3e-4, "velocity": 5e-3}
"""The predefined displacement test: a Schroeder multisine (``rths3d.platform.identify.
multisine``), lines 0.2–30 Hz, 0.3 mm each (less above 2.7 Hz: 5 mm/s per line)."""


def calibration_record(cfg: BenchmarkConfig | None = None, periods: int = 2,
                       plant: PlantParams | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The commands y_p (m) and measurements x_m (m, through the A/D, at the same calls) of a
    predefined displacement test of the PI-controlled actuator with the specimen: the
    multisine :data:`CALIBRATION_SIGNAL` (faded in over its first second) sent as y_p for
    ``periods`` periods, no ground motion; sensor noise and converters as in ``cfg``."""
    from ..platform.identify import multisine

    cfg = cfg or BenchmarkConfig()
    _, one = multisine(dt=cfg.dt, **CALIBRATION_SIGNAL)
    sig = np.tile(one, periods)
    nf = int(round(1.0 / cfg.dt))
    sig[:nf] *= 0.5 - 0.5 * np.cos(np.pi * np.arange(1, nf + 1) / nf)
    T = sig.size * cfg.dt
    quiet = GroundMotion(np.array([0.0, T + 1.0]), np.zeros(2), name="none")
    comp = _Prescribed(sig)
    run_compensated(replace(cfg, t_end=(sig.size - 1) * cfg.dt, intensity=1.0), comp,
                    plants=[plant or cfg.plant], gm=quiet,
                    x_ref=np.zeros((sig.size, 3)))
    return sig, comp.z_meas


def calibrated_config(name: str, cfg: BenchmarkConfig | None = None,
                      params: Mapping[str, Any] | None = None,
                      record: tuple[np.ndarray, np.ndarray] | None = None) -> Any:
    """Compensator ``name``'s config for the benchmark: its defaults with ``params``, then —
    for the compensators with an offline calibration (:data:`rths3d.compensation.
    CALIBRATIONS`) — calibrated on :func:`calibration_record` of the nominal plant (initial
    ATS/RLS coefficients, the identified PI-loop model of ``inverse``/``model_based``).
    Keys given in ``params`` are kept over the calibrated ones."""
    from ..compensation import CALIBRATIONS, config_from_dict

    cfg = cfg or BenchmarkConfig()
    params = dict(params or {})
    config = config_from_dict(name, params)
    cal = CALIBRATIONS.get(name)
    if cal is None:
        return config
    u, zm = record if record is not None else calibration_record(cfg)
    calibrated = cal(u, zm, cfg.dt, config)
    keep = {k: getattr(config, k) for k in params}
    return replace(calibrated, **keep)
