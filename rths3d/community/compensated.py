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

All trials step together (K tests × 1 channel for the compensator); each step is the
compiled :func:`~.kernels.measure` (sensors), one ``command`` call and the compiled
:func:`~.kernels.advance` (PI, force check, plant and numerical RK4 steps) — the kernels that
:func:`~.simulate.run_case` runs with the phase lead between them. A trial stops at the
8900 N force limit or when its compensator stops (drift safety), with the reason, keeping the
samples up to the stop.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import replace
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..lti import GroundMotion
from .config import BenchmarkConfig, load_excitation
from .plant import PlantParams
from .simulate import BenchmarkResult, _Loop, reference_response
from .structure import case_matrices

__all__ = ["calibrated_config", "calibration_record", "run_compensated"]


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
    loop = _Loop(cfg, plant_list, gm)
    N, t = loop.N, loop.t
    if isinstance(compensator, str):
        comp = build(compensator, K, 1, cfg.dt, params)
    else:
        comp = compensator
        compensator = getattr(comp, "name", type(comp).__name__)
    alive, stop_at = loop.alive, loop.stop_at
    comp_stop_at = np.full(K, -1, dtype=np.int64)
    history: list[tuple[float, dict[str, np.ndarray]]] = []
    cstopped = comp.stopped
    n_alive = K
    for k in range(N):
        loop.measure(k)
        yp = comp.command(loop.zc, loop.zdc, loop.zmc)
        if cstopped.any():
            new = cstopped & alive
            if new.any():
                for i in np.flatnonzero(new):
                    comp_stop_at[i] = k
                    stop_at[i] = k
                    # the stopping sample keeps its measurements; no command is applied
                    loop.FA[k, i] = loop.P[i, 2]
                alive &= ~new
                n_alive = int(alive.sum())
        if n_alive:
            n_alive -= loop.advance(k, yp)
        if history_every and k % history_every == 0:
            history.append((float(t[k]), {n: v[:, 0].copy()
                                          for n, v in comp.coefficients().items()}))
        if progress is not None and k % 4096 == 0:
            progress(k, N)
        if n_alive == 0:
            break
    if x_ref is None or x_ref.shape[0] < N:
        m = case_matrices(cfg.case, cfg.plant.m_e, cfg.plant.c_e, cfg.plant.k_e)
        n_ref = N if (stop_at < 0).any() else int(stop_at.max()) + 1
        x_ref = reference_response(m, loop.stages[:n_ref, 0], cfg.dt, cfg.reference)
    coefs = comp.coefficients()
    results = []
    for i in range(K):
        n = N if stop_at[i] < 0 else int(stop_at[i]) + 1
        stop = comp.stops[i] if comp_stop_at[i] >= 0 else loop.force_stop(i)
        res = loop.result(i, stop, x_ref, copy=True)
        res.compensator = compensator
        res.y_p = loop.YP[:n, i].copy()
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
"""The predefined displacement test: a Schroeder multisine (``rths3d.lti.identify.
multisine``), lines 0.2–30 Hz, 0.3 mm each (less above 2.7 Hz: 5 mm/s per line)."""


def calibration_record(cfg: BenchmarkConfig | None = None, periods: int = 2,
                       plant: PlantParams | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The commands y_p (m) and measurements x_m (m, through the A/D, at the same calls) of a
    predefined displacement test of the PI-controlled actuator with the specimen: the
    multisine :data:`CALIBRATION_SIGNAL` (faded in over its first second) sent as y_p for
    ``periods`` periods, no ground motion; sensor noise and converters as in ``cfg``."""
    from ..lti.identify import multisine

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
