"""The maRTHS benchmark loop (Condori Uribe et al. 2023) with any compensator per actuator.

One call runs K plants (the nominal and/or perturbed ones) through the same record, stepped
together in Simulink's order (:mod:`.kernels`): measurement, actuator→frame kinematics,
specimen feedback force, the numerical substructure's Newmark step, frame→actuator targets,
then the compensator (from Python, in SI: the targets and measurements in m) and the plant's
RK4 step. The reference structure's response is computed once per record (Newmark, no
feedback). Each trial gets its 24 criteria (:func:`.criteria.marths_criteria`).

A trial stops safely — logged up to the stopping sample, with the reason — when a measured
actuator displacement leaves ``stroke_limit`` (mm) or is not finite, or when its compensator
stops (bounds, oscillation, non-finite command); the others go on.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import ConfigError, SafetyStop
from ...lti import GroundMotion
from . import kernels
from .criteria import marths_criteria
from .data import data_dir, load_record, load_reference_matrices, record_name
from .model import COUPLER, Partition, newmark_matrices, newmark_response, partition, specimen
from .plant import NOMINAL, PlantZPK

__all__ = ["INITIALS", "MarthsConfig", "MarthsResult", "default_config", "rodeac_initial",
           "run_marths", "stored_initial", "structure"]

INITIAL_FILE = Path(__file__).with_name("rodeac_initial.json")


@dataclass(frozen=True)
class MarthsConfig:
    """One maRTHS run.

    Attributes
    ----------
    record: ``ElCentro | Kobe | Morgan``; intensity: the record's scale (0.4).
    fs: sample rate of every discrete block and of the plant's RK4 step (Hz), 1024.
    noise: sensor noise on/off; noise_cov: the band-limited white noise's power (mm²·s),
      1.5e-7 (std √(cov·fs) = 0.0124 mm at 1024 Hz); noise_seed: numpy seed of the one
      sequence both channels (and all trials of a call) share.
    t_end: stop time (s); None: the record's end.
    stroke_limit: |measured actuator displacement| (mm) at which a trial stops, 100 mm.
    """

    record: str = "ElCentro"
    intensity: float = 0.4
    fs: float = 1024.0
    noise: bool = True
    noise_cov: float = 1.5e-7
    noise_seed: int = 123
    t_end: float | None = None
    stroke_limit: float = 100.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "record", record_name(self.record))
        if not (math.isfinite(self.intensity) and 0.0 < self.intensity <= 10.0):
            raise ConfigError("intensity", self.intensity, "must be in (0, 10]")
        if not (math.isfinite(self.fs) and 64.0 <= self.fs <= 65536.0):
            raise ConfigError("fs", self.fs, "must be in [64, 65536] Hz")
        if not (math.isfinite(self.noise_cov) and self.noise_cov >= 0.0):
            raise ConfigError("noise_cov", self.noise_cov, "must be ≥ 0 mm²·s")
        if self.t_end is not None and not (self.t_end > 0.0):
            raise ConfigError("t_end", self.t_end, "must be > 0 s")
        if not (self.stroke_limit > 0.0):
            raise ConfigError("stroke_limit", self.stroke_limit, "must be > 0 mm")

    @property
    def dt(self) -> float:
        return 1.0 / self.fs


@dataclass(eq=False)
class MarthsResult:
    """Logged signals of one trial and its criteria.

    ``t`` (s); ``ag`` (m/s²); ``xa_t``, ``xa_m``, ``u`` (N, 2): target, measured and commanded
    actuator displacements (mm); ``x_hat`` (N, 2): x̂ (mm), θ̂ (rad) from the measurements;
    ``num``, ``ref`` (N, 6): numerical and reference [x (mm), θ (rad), x 2nd (m), θ 2nd,
    x 3rd (m), θ 3rd]; ``force`` (N, 3): F27 (N), M(node 1), M(node 2) (N·m) of the specimen.
    ``j``: J1–J10 (:func:`.criteria.marths_criteria`); empty when stopped.
    """

    config: MarthsConfig
    t: np.ndarray
    ag: np.ndarray
    xa_t: np.ndarray
    xa_m: np.ndarray
    u: np.ndarray
    x_hat: np.ndarray
    num: np.ndarray
    ref: np.ndarray
    force: np.ndarray
    plant: PlantZPK
    compensator: str = ""
    status: str = "ok"
    reason: str = ""
    j: dict[str, list[float]] = field(default_factory=dict)
    coefficients: dict[str, list[float]] = field(default_factory=dict)

    @property
    def command_volts(self) -> np.ndarray:
        """The logged command in volts (N, 2): u/(c g) − o/g (SPEC §6.4)."""
        g = np.array([7.4921, 7.3907])
        o = np.array([0.0092, -0.0059])
        c = np.array([1.053, 1.055])
        return self.u / (c * g) - o / g


@lru_cache(maxsize=4)
def structure(data_path: str | None = None) -> Partition:
    """The reference and numerical matrices (cached per data folder)."""
    K, M = load_reference_matrices(data_path)
    return partition(K, M)


def rodeac_initial() -> tuple[tuple[float, ...], tuple[float, ...]]:
    """θ₀ (2 × 4) and P₀ (2 × 16) per actuator from the project's own offline calibration
    (``rodeac_initial.json``, written by ``python -m rths3d.community.marths.calibration``)."""
    d = json.loads(INITIAL_FILE.read_text())
    th = tuple(float(v) for a in ("act1", "act2") for v in d["theta0"][a])
    p0 = tuple(float(v) for a in ("act1", "act2") for row in d["P0"][a] for v in row)
    return th, p0


def stored_initial(data_path: str | None = None
                   ) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """θ₀ (2 × 4) and P₀ (2 × 16) as the benchmark stores them (``Initial_parameters.mat``,
    read from the benchmark folder's ``data/controller_rodeac.json``)."""
    d = json.loads((data_dir(data_path) / "data" / "controller_rodeac.json").read_text())
    th = tuple(float(v) for a in ("act1", "act2") for v in d[f"theta0_{a}"])
    p0 = tuple(float(v) for a in ("act1", "act2") for row in d[f"P0_{a}"] for v in row)
    return th, p0


INITIALS = ("stored", "calibrated")


def default_config(name: str, params: Mapping[str, Any] | None = None,
                   initial: str = "stored", data_path: str | None = None) -> Any:
    """Compensator ``name``'s config with ``params``; for ``rodeac`` θ₀ and P₀ not given in
    ``params`` come from ``initial``: ``stored`` (the benchmark's own, :func:`stored_initial`)
    or ``calibrated`` (the project's calibration, :func:`rodeac_initial`)."""
    from ...compensation import config_from_dict

    p = {k: (list(v) if isinstance(v, tuple) else v) for k, v in dict(params or {}).items()}
    if name == "rodeac" and ("theta0" not in p or "p0" not in p):
        if initial not in INITIALS:
            raise ConfigError("initial", initial, "must be stored or calibrated")
        th, p0 = stored_initial(data_path) if initial == "stored" else rodeac_initial()
        p.setdefault("theta0", list(th))
        p.setdefault("p0", list(p0))
    return config_from_dict(name, p)


def _grid(cfg: MarthsConfig, gm: GroundMotion) -> tuple[int, np.ndarray]:
    t_end = gm.t_end if cfg.t_end is None else min(cfg.t_end, gm.t_end)
    n = int(math.floor(t_end * cfg.fs + 1e-9)) + 1
    return n, np.arange(n) / cfg.fs


def reference_signals(part: Partition, ag: np.ndarray, dt: float) -> np.ndarray:
    """The reference's logged signals (N, 6) for ground-acceleration samples ``ag``."""
    nm = newmark_matrices(part.M, part.C, part.K, part.l, dt)
    U = newmark_response(nm, ag)
    return np.stack([1000.0 * U[:, 26], -U[:, 20], U[:, 25], U[:, 21], U[:, 12], U[:, 2]],
                    axis=1)


class _Comps:
    """The compensator(s) of a run: one for both channels, or one per actuator."""

    def __init__(self, compensator: Any, params: Any, K: int, dt: float, initial: str,
                 data_path: str | None):
        from ...compensation import BaseCompensator, build

        if isinstance(compensator, str):
            name = compensator
            if isinstance(params, (tuple, list)) and len(params) == 2 and not isinstance(
                    params[0], (int, float)):
                cfgs = [p if not (p is None or isinstance(p, Mapping))
                        else default_config(name, p, initial, data_path) for p in params]
                self.comps = [build(name, K, 1, dt, c) for c in cfgs]
            else:
                c = params if not (params is None or isinstance(params, Mapping)) \
                    else default_config(name, params, initial, data_path)
                self.comps = [build(name, K, 2, dt, c)]
        else:
            comps = list(compensator) if isinstance(compensator, (list, tuple)) \
                else [compensator]
            for c in comps:
                if not isinstance(c, BaseCompensator) and not hasattr(c, "command"):
                    raise ConfigError("compensator", type(c).__name__, "must be a name or "
                                      "compensator object(s)")
            self.comps = comps
            name = getattr(comps[0], "name", type(comps[0]).__name__)
        self.name = name
        per = len(self.comps) == 2
        self.per_actuator = per
        self.u = np.zeros((K, 2))
        self._stopped = np.zeros(K, dtype=bool)
        if per:  # (K, 1) inputs per actuator and their 1-D views, made once
            self.cols = [[np.zeros((K, 1)) for _ in range(3)] for _ in range(2)]
            self.flat = [[c[:, 0] for c in cols] for cols in self.cols]
            self.ucol = [self.u[:, 0], self.u[:, 1]]

    def bind(self, z: np.ndarray, zd: np.ndarray, zm: np.ndarray) -> None:
        """The loop's (K, 2) input buffers, so that the per-actuator columns are views made
        once (the per-step path allocates no arrays)."""
        self.src = [(z[:, j], zd[:, j], zm[:, j]) for j in range(2)]
        self.inputs = (z, zd, zm)

    def command(self) -> np.ndarray:
        """The commands (K, 2) in m from the bound inputs (m, m/s, m)."""
        if self.per_actuator:
            for j in range(2):
                for dst, src in zip(self.flat[j], self.src[j], strict=True):
                    np.copyto(dst, src)
                out = self.comps[j].command(*self.cols[j])
                np.copyto(self.ucol[j], out.reshape(-1))
            return self.u
        return self.comps[0].command(*self.inputs)

    def stopped(self) -> np.ndarray:
        if not self.per_actuator:
            return self.comps[0].stopped
        return np.logical_or(self.comps[0].stopped, self.comps[1].stopped, out=self._stopped)

    def stop(self, i: int) -> SafetyStop | None:
        for j, c in enumerate(self.comps):
            if c.stopped[i]:
                stop = c.stops[i]
                if stop is not None and self.per_actuator:
                    stop = SafetyStop(f"actuator {j + 1}: {stop.quantity}", stop.value,
                                      stop.limit, stop.t, i, stop.unit)
                return stop
        return None

    def coefficients(self, i: int) -> dict[str, list[float]]:
        """Each coefficient's final value per channel (actuator 1, then 2) of trial ``i``."""
        out: dict[str, list[float]] = {}
        for c in self.comps:
            for name, v in c.coefficients().items():
                out.setdefault(name, []).extend(float(x) for x in np.atleast_2d(v)[i])
        return out


def run_marths(cfg: MarthsConfig | None = None, compensator: Any = "rodeac",
               params: Any = None, plants: Sequence[PlantZPK] | None = None,
               data_path: str | None = None, gm: GroundMotion | None = None,
               initial: str = "stored",
               progress: Callable[[int, int], None] | None = None,
               numerical: Any = None) -> list[MarthsResult]:
    """Run the benchmark for ``plants`` (default: the nominal plant) with ``compensator``.

    ``compensator``: a name of :data:`rths3d.compensation.COMPENSATORS` configured by
    ``params`` (its Config or a mapping of its fields, for both actuators as one K × 2
    compensator; or a pair of them, one K × 1 compensator per actuator), or compensator
    object(s) already built for K plants at ``cfg.dt`` (one with 2 channels, or two with 1).
    ``rodeac`` without θ₀/P₀ starts from ``initial`` (:func:`default_config`). ``gm`` replaces the
    record (its scale becomes ``cfg.intensity``). Returns one :class:`MarthsResult` per plant.
    ``progress(k, N)`` is called every 4096 steps. ``numerical``: the numerical substructure
    stepped outside the compiled loop instead of the benchmark's Newmark step of K_N, C_N,
    M_N — an :class:`~.opensees_frame.OpenSeesFrame` (its ``reset()``, ``step(ag, F)``
    returning False when it fails, ``u`` at :data:`~.opensees_frame.OUTPUTS`, ``dt`` and
    ``reason``); one plant then. A failed step stops the trial with the record up to the
    sample before.
    """
    cfg = cfg or MarthsConfig()
    plant_list = list(plants) if plants is not None else [NOMINAL]
    if not plant_list:
        raise ConfigError("plants", 0, "need at least one plant")
    gm = load_record(cfg.record, cfg.intensity, data_path) if gm is None \
        else gm.scaled(cfg.intensity)
    part = structure(str(data_path) if data_path else None)
    K, dt = len(plant_list), cfg.dt
    if numerical is not None:
        if K != 1:
            raise ConfigError("plants", K, "an outside numerical substructure (OpenSees: one "
                              "domain per process) steps one plant per run")
        if abs(numerical.dt - dt) > 1e-12 * dt:
            raise ConfigError("numerical.dt", numerical.dt, f"must equal the benchmark's "
                              f"1/fs = {dt:g} s")
        numerical.reset()
    N, t = _grid(cfg, gm)
    ag = np.ascontiguousarray(gm(t))
    ref = reference_signals(part, ag, dt)
    nmN = newmark_matrices(part.MN, part.CN, part.KN, part.l, dt)
    sp = specimen()
    mats = [p.step_matrices(dt) for p in plant_list]
    Phi = np.ascontiguousarray(np.stack([m[0] for m in mats]))
    Gam = np.ascontiguousarray(np.stack([m[1] for m in mats]))
    Cp = np.ascontiguousarray(np.stack([m[2] for m in mats]))
    ns = Phi.shape[1]
    if cfg.noise and cfg.noise_cov > 0.0:
        noise = math.sqrt(cfg.noise_cov * cfg.fs) * \
            np.random.default_rng(cfg.noise_seed).standard_normal(N)
    else:
        noise = np.zeros(N)
    comps = _Comps(compensator, params, K, dt, initial,
                   str(data_path) if data_path else None)
    Xp = np.zeros((K, ns))
    U, V, A = np.zeros((K, 29)), np.zeros((K, 29)), np.zeros((K, 29))
    R, Fv = np.zeros(29), np.zeros(29)
    qm = np.zeros((K, 10))
    kin = COUPLER.params()
    K5, C5, M5 = (np.ascontiguousarray(m[:3]) for m in (sp.K5, sp.C5, sp.M5))
    G = np.ascontiguousarray(sp.G)
    zt, zm = np.zeros((K, 2)), np.zeros((K, 2))
    zt_si, zm_si, zd_si, zprev = (np.zeros((K, 2)) for _ in range(4))
    u_mm = np.zeros((K, 2))
    comps.bind(zt_si, zd_si, zm_si)
    work = np.zeros(ns)
    XAT, XAM, XH = np.zeros((N, K, 2)), np.zeros((N, K, 2)), np.zeros((N, K, 2))
    NUM, FF, UL = np.zeros((N, K, 6)), np.zeros((N, K, 3)), np.zeros((N, K, 2))
    alive = np.ones(K, dtype=bool)
    stop_at = np.full(K, -1, dtype=np.int64)
    stop_val = np.zeros(K)
    comp_stop = np.zeros(K, dtype=bool)
    inv_dt = 1.0 / dt
    n_alive = K
    Fi, u6 = np.zeros(3), np.zeros(6)  # the kernels' scratch (force in, U at the logs)
    failed = ""
    for k in range(N):
        if numerical is None:
            n_alive -= kernels.measure(k, alive, stop_at, stop_val, Xp, Cp, U, V, A, R, Fv,
                                       nmN.Kinv, nmN.RU, nmN.RV, nmN.RA, nmN.Ml, nmN.a, ag,
                                       noise, kin, K5, C5, M5, G, qm, inv_dt,
                                       cfg.stroke_limit, zt, zm, XAT, XAM, XH, NUM, FF,
                                       Fi, u6)
        else:
            kernels.feedback(k, 0, Xp, Cp, noise, kin, K5, C5, M5, G, qm, inv_dt, zm, XH, FF,
                             Fi)
            if not numerical.step(float(ag[k]), Fi):
                failed = numerical.reason
                stop_at[0] = k
                alive[0] = False
                break
            n_alive -= kernels.targets(k, 0, numerical.u, kin, cfg.stroke_limit, alive,
                                       stop_at, stop_val, zt, zm, XAT, XAM, NUM)
        np.multiply(zt, 1e-3, out=zt_si)
        np.multiply(zm, 1e-3, out=zm_si)
        np.subtract(zt_si, zprev, out=zd_si)
        zd_si *= inv_dt if k else 0.0
        zprev[:] = zt_si
        u = comps.command()
        st = comps.stopped()
        if st.any():
            new = st & alive
            for i in np.flatnonzero(new):
                comp_stop[i] = True
                stop_at[i] = k
                alive[i] = False
                n_alive -= 1
        np.multiply(u, 1e3, out=u_mm)
        kernels.advance(k, alive, Xp, Phi, Gam, u_mm, UL, work)
        if progress is not None and k % 4096 == 0:
            progress(k, N)
        if n_alive == 0:
            break
    results = []
    for i, p in enumerate(plant_list):
        n = N if stop_at[i] < 0 else int(stop_at[i]) + (0 if failed else 1)
        res = MarthsResult(cfg, t[:n].copy(), ag[:n].copy(), XAT[:n, i].copy(),
                           XAM[:n, i].copy(), UL[:n, i].copy(), XH[:n, i].copy(),
                           NUM[:n, i].copy(), ref[:n].copy(), FF[:n, i].copy(), p,
                           compensator=comps.name, coefficients=comps.coefficients(i))
        if stop_at[i] >= 0:
            res.status = "stopped"
            stop = comps.stop(i) if comp_stop[i] else SafetyStop(
                "measured actuator displacement |x_a,m|", float(stop_val[i]),
                cfg.stroke_limit, float(t[n - 1]), i, "mm")
            res.reason = failed or (stop.reason if stop is not None else
                                    "compensator stopped")
        else:
            res.j = marths_criteria(res.xa_t, res.xa_m, res.x_hat, res.num, res.ref, cfg.fs)
        results.append(res)
    return results
