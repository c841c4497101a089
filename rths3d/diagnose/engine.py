"""The diagnosis engine: replay, compare, screen every candidate effect, refit, rank.

Workflow (one *round*, docs/diagnosis.md):

1. replay the measured pose commands through the bench with the accepted effects
   (:class:`~rths3d.bench.BenchReplay`, the loop's own code); residual r = measured − model
   per channel, in units of each channel's noise floor σ (estimated once from the first
   residual, :func:`~.localise.noise_floor`);
2. split the samples into alternating blocks: training (even) and validation (odd);
3. *screen* every candidate — each effect on each leg and axis it can act on, plus the
   kinematic calibration (42 parameters) and the FTS calibration (6×6 matrix and offset),
   fitted from the measured poses, leg lengths and wrench — by one batched replay at a probe
   value: the linear estimate of its value along its sensitivity Δ;
4. *refit* the best ``refit`` by their predicted error drop, in two batched secant steps;
5. *rank* all evaluated candidates by the held-out criterion
   ΔIC = n_eff · ln(SSE_0 / SSE_1) − k · ln(n_eff) on the validation blocks (SSE pooled over
   channels in noise units), with one effective sample size n_eff for the round (of the
   baseline residual, :func:`~.localise.effective_samples`): the order is that of the
   validation error for candidates of equal k, so an effect that lowers the held-out error
   more always ranks higher. A candidate is *significant* if ΔIC > 0, the validation error
   (squared) falls by at least ``min_gain`` and its 95 % interval excludes the off value;
6. the verdict: ``effect_proposed`` (the best significant candidate leaves a noise-like
   residual), ``partly_explained`` (it, or the accepted effects, leave structure: where is
   reported), ``noise_only`` (nothing significant, noise-like residual) or ``unexplained``.

This module holds :class:`Diagnosis` (the replays, residuals, least-squares fits and the
user's steps); it derives a round's stages (``run``: screen, refit, rank, timed per stage)
from :class:`~.rounds.RoundStages` and the calibrations from
:class:`~.calibrations.Calibrations`; the results are in :mod:`.result`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from ..bench import BenchReplay, ReplayInput
from ..config import Scene
from ..effects import REGISTRY, ProbeData, bench_effects, get_effect, parse_label
from ..errors import ConfigError, RecordError
from ..experiment import make_part
from ..record import Record
from .bench import resolve_bench
from .calibrations import Calibrations
from .candidates import PREFIX, Revision, is_revision
from .candidates.screen import revise, screen_revisions
from .localise import effective_samples, noise_floor
from .measurement import check_measurement
from .result import MULTI, NOISE_LIKE, Candidate, RoundResult, effect_configs
from .rounds import RoundStages

__all__ = ["MULTI", "NOISE_LIKE", "SCREEN_INTEGRATORS", "Candidate", "Diagnosis",
           "RoundResult", "default_candidates"]

SCREEN_INTEGRATORS = ("implicitfast", "RK4")
"""The platform integrators the screening's probes can be replayed with."""


def default_candidates(scene: Scene) -> list[str]:
    """Every candidate label for a bench: each candidate effect on each target, and the two
    calibrations. Part effects a part does not have (a contact gap without a surface) are
    left out."""
    out: list[str] = []
    part = make_part(scene.experiment)
    for name, eff in REGISTRY.items():
        # anchors and the FTS matrix are fitted together by the calibrations (MULTI)
        if not eff.candidate or eff.calibrated or not eff.exists_for(part):
            continue
        for leg, axis in eff.targets():
            out.append(name + (f".leg{leg}" if leg >= 0 else "") + (f".{axis}" if axis else ""))
    return [*out, "fts_gain.fz", "fts_offset.fz", *MULTI]


class Diagnosis(RoundStages, Calibrations):
    """Model-vs-measurement diagnosis of one record through its bench.

    Parameters
    ----------
    record:
        The measurement (schema of :mod:`rths3d.record`): pose commands plus measured
        channels.
    scene:
        The bench (a :class:`~rths3d.config.Scene`); default: the record's own
        (``meta["scene_def"]``), see :func:`~.bench.resolve_bench`. Its ``[[effect]]``
        tables are part of the model.
    candidates:
        Candidate labels (default: :func:`default_candidates`).
    block:
        Length of the alternating training / validation blocks (s).
    refit:
        How many of the best-screened candidates are refitted each round.
    min_gain:
        Smallest relative fall of the validation error (noise units, squared) that counts.
    substeps:
        Physics substeps of the replay.
    nthread:
        Threads of the batched replays: a round's screening and refits are cut into one
        batch per thread (:meth:`outputs`).
    descriptions:
        The description candidates screened beside the effects (names of
        :data:`~.candidates.DESCRIPTIONS`; default all, ``()`` none): revisions of what the
        scene states (the controller's conventions, the payload).
    screen_integrator:
        The platform's integrator for the screening probes of single-parameter candidates
        (``"implicitfast"``, the default, or ``"RK4"``; ``None``: the scene's own). A probe's
        channels are the reference model's at the accepted effects plus the probe's change
        as the cheaper integrator sees it, y_ref(θ₀) + [y_fast(θ) − y_fast(θ₀)]: the
        integrator's error is common to both fast replays and cancels to first order in the
        change, which is all the screening uses (a sensitivity Δ). Refits, calibrations,
        revisions and every figure of the ranking are replayed with the scene's integrator.
        ``"implicitfast"`` costs ≈ 0.4 of an RK4 replay (docs/diagnosis.md).
    baseline:
        A record of the healthy bench running the same command series (what a lab keeps:
        the same test before the change). Its residual against the nominal model — the
        discrepancy common to both records, e.g. what the scene cannot state — is taken out
        of the measurement: the diagnosis ranks what changed, d = y − (y_healthy − ŷ₀), in
        units of the noise of the difference (√2 σ for equal noise).
    """

    def __init__(self, record: Record, scene: Scene | None = None, *,
                 candidates: Iterable[str] | None = None, block: float = 0.5,
                 refit: int = 8, min_gain: float = 0.01, substeps: int = 1, nthread: int = 2,
                 progress: Callable[[str], None] | None = None,
                 descriptions: Iterable[str] | None = None,
                 screen_integrator: str | None = "implicitfast",
                 baseline: Record | None = None):
        chans = check_measurement(record)
        self.record = record
        self.warnings: list[str] = []
        if scene is None:
            scene, self.warnings = resolve_bench(None, record.meta)
        self.scene = scene
        self.base_effects = bench_effects(scene)
        inp = ReplayInput.from_record(record, scene.dofs)
        if inp.source == "z_cmd":
            self.warnings.append("the record has no pose_cmd.*: replaying z_cmd of the "
                                 f"interface DOFs {list(scene.dofs)} (other DOFs held at 0)")
        self._inp, self._substeps, self._nthread = inp, substeps, nthread
        self.descriptions = None if descriptions is None else tuple(descriptions)
        self.revisions: list[dict[str, Any]] = []
        """The parts of the description the diagnosis changed, in order: the revision's
        label and, per dotted scene key, the value stated and the value accepted."""
        self._revs: dict[str, Revision] = {}
        self._evidence: dict[str, str] = {}
        """The last ranking's evidence against the scene's statements, per revision."""
        self.replay = BenchReplay(scene, inp, substeps=substeps, nthread=nthread)
        self.threads = max(1, int(nthread))
        """Threads of a round's batched replays (:meth:`outputs`)."""
        self._pools: dict[BenchReplay, list[BenchReplay]] = {}
        if screen_integrator not in (None, *SCREEN_INTEGRATORS):
            raise ConfigError("screen_integrator", screen_integrator,
                              f"one of {', '.join(SCREEN_INTEGRATORS)}")
        self.screen_integrator = screen_integrator
        self._screen_pair: tuple[BenchReplay, BenchReplay] | None = None
        produced = set(self.replay.channels)
        self.ignored = tuple(c for c in chans if c not in produced)
        self.channels = tuple(c for c in chans if c in produced)
        if not self.channels:
            raise RecordError("the measurement has no channel this bench produces")
        self.dt = record.dt
        self.n = record.n
        self.measured = {c: np.asarray(record.columns[c], dtype=float) for c in self.channels}
        names = list(candidates) if candidates is not None else default_candidates(scene)
        for n in names:
            if n not in MULTI:
                parse_label(n)
        self.candidate_names = names
        self.refit = int(refit)
        self.min_gain = float(min_gain)
        self.progress = progress or (lambda msg: None)
        m = max(1, int(round(block / self.dt)))
        blk = (np.arange(self.n) // m) % 2
        first = np.arange(self.n) >= 1  # row 0: the state before the first step
        self.train = (blk == 0) & first
        self.val = (blk == 1) & first
        if self.val.sum() < 10:
            raise ConfigError("block", block, f"too long for a {record.duration:.3g} s record")
        self.accepted: dict[str, float] = {}
        self._lengths: tuple[Any, np.ndarray] | None = None
        self.fixed: set[str] = set()
        self.cov: dict[str, tuple[float, float]] = {}
        self._cache: dict[tuple, dict[str, np.ndarray]] = {}
        self.nsim = 0
        self.baseline = baseline
        if baseline is not None:
            self._check_baseline(baseline)  # before any replay
        base = self.predict()
        if baseline is not None:  # the discrepancy common to both records taken out
            for c in self.channels:
                self.measured[c] = self.measured[c] - (
                    np.asarray(baseline.columns[c], dtype=float) - base[c])
        self.sigma: dict[str, float] = {}
        for c in self.channels:
            r = (self.measured[c] - base[c])[1:]
            s = noise_floor(r)
            self.sigma[c] = max(s, 1e-6 * float(np.std(self.measured[c])), 1e-12)
        self.waterfall: list[dict[str, Any]] = []
        self._log_step("baseline (nominal model)")

    def _check_baseline(self, healthy: Record) -> None:
        """The healthy record runs the record's commands on its rows and channels."""
        if healthy.n != self.n or abs(healthy.dt - self.dt) > 1e-12 * self.dt:
            raise ConfigError("baseline", f"{healthy.n} rows at {healthy.dt:g} s", "must have "
                              f"the record's rows and sampling ({self.n} at {self.dt:g} s)")
        cmd = ReplayInput.from_record(healthy, self.scene.dofs).poses
        scale = max(float(np.max(np.abs(self._inp.poses))), 1e-12)
        if float(np.max(np.abs(cmd - self._inp.poses))) > 1e-9 * scale:
            raise ConfigError("baseline", "its pose commands", "must repeat the record's "
                              "command series (the same test on the healthy bench)")
        missing = [c for c in self.channels if c not in healthy.columns]
        if missing:
            raise ConfigError("baseline", ", ".join(missing[:3]), "channels the record has "
                              "and the baseline lacks")

    # ------------------------------------------------------------------ model outputs
    def _key(self, effects: Mapping[str, float]) -> tuple:
        return tuple(sorted((k, float(v)) for k, v in effects.items()))

    def outputs(self, effect_sets: list[Mapping[str, float]], *, screen: bool = False
                ) -> list[dict[str, np.ndarray]]:
        """Replays (every channel) for several sets of effects on top of the scene's, in one
        batch; cached. ``screen``: the screening's probes, through
        :attr:`screen_integrator` (anchored on the reference replay of the accepted
        effects)."""
        fast = self._screen_replay() if screen and effect_sets else None
        if fast is None:
            return self._outputs(effect_sets, self.replay, "")
        ref = self.predict()
        base, *raw = self._outputs([self.accepted, *effect_sets], fast, "screen")
        if not all(np.all(np.isfinite(base[c])) for c in self.channels):
            # the cheaper model stopped where the reference did not: no change to anchor
            return self._outputs(effect_sets, self.replay, "")
        return [{**{c: ref[c] + (r[c] - base[c]) for c in self.channels},
                 "_stopped": r["_stopped"]} for r in raw]

    def _outputs(self, effect_sets: list[Mapping[str, float]], replay: BenchReplay,
                 tag: str) -> list[dict[str, np.ndarray]]:
        keys = [(tag, *self._key(e)) for e in effect_sets]
        todo = list({k: i for i, k in enumerate(keys) if k not in self._cache}.values())
        if todo:
            sets = [effect_configs({**self.base_effects, **effect_sets[i]}) for i in todo]
            res = self._replay(sets, replay)
            self.nsim += len(todo)
            if len(self._cache) > 400:
                self._cache.clear()
            for i, r in zip(todo, res, strict=True):
                self._cache[keys[i]] = r
        return [self._cache[k] for k in keys]

    def _screen_replay(self) -> BenchReplay | None:
        """The screening's replay of the current scene with :attr:`screen_integrator`
        (None: the scene's own integrator)."""
        integ = self.screen_integrator
        if integ is None or integ == self.scene.transfer.integrator:
            return None
        if self._screen_pair is None or self._screen_pair[0] is not self.replay:
            import dataclasses

            sc = dataclasses.replace(self.scene, transfer=dataclasses.replace(
                self.scene.transfer, integrator=integ))
            self._screen_pair = (self.replay, BenchReplay(
                sc, self._inp, substeps=self._substeps, nthread=self._nthread))
        return self._screen_pair[1]

    def _thread_replays(self, replay: BenchReplay) -> list[BenchReplay]:
        """One single-threaded replay of ``replay``'s bench per thread (made once)."""
        pool = self._pools.get(replay)
        if pool is None:
            pool = self._pools[replay] = [
                BenchReplay(replay.scene, replay.poses, substeps=replay.substeps, nthread=1)
                for _ in range(self.threads)]
        return pool

    def _replay(self, sets: list, replay: BenchReplay | None = None
                ) -> list[dict[str, np.ndarray]]:
        """Replays of ``sets`` through ``replay`` (default: the reference): one batch, or —
        for a batch of at least two sets per thread — one batch per thread (interleaved
        sets), each stepping its MuJoCo batch on its own core. MuJoCo and the platform's
        kernels release the GIL, so while one thread steps its physics the other runs its
        Python between steps: the round's screening and refits use both cores with no
        thread pool handing single simulations around."""
        replay = self.replay if replay is None else replay
        T = self.threads
        if T < 2 or len(sets) < 2 * T:
            return replay.run(sets)
        chunks = [list(range(i, len(sets), T)) for i in range(T)]
        with ThreadPoolExecutor(T, thread_name_prefix="rths3d-replay") as pool:
            parts = list(pool.map(lambda rc: rc[0].run([sets[i] for i in rc[1]]),
                                  zip(self._thread_replays(replay), chunks, strict=True)))
        out: list[dict[str, np.ndarray]] = [{}] * len(sets)
        for idx, part in zip(chunks, parts, strict=True):
            for i, r in zip(idx, part, strict=True):
                out[i] = r
        return out

    def predict(self, effects: Mapping[str, float] | None = None) -> dict[str, np.ndarray]:
        """Model outputs for the measured command with ``effects`` (default: accepted)."""
        return self.outputs([self.accepted if effects is None else effects])[0]

    def _res(self, out: Mapping[str, np.ndarray]) -> dict[str, np.ndarray]:
        return {c: (self.measured[c] - out[c]) / self.sigma[c] for c in self.channels}

    def residuals(self, effects: Mapping[str, float] | None = None) -> dict[str, np.ndarray]:
        """Residual measured − model per channel, in noise units."""
        return self._res(self.predict(effects))

    def _error(self, res: Mapping[str, np.ndarray], mask: np.ndarray) -> float:
        v = float(np.mean([np.mean(res[c][mask] ** 2) for c in self.channels]))
        return math.sqrt(v) if math.isfinite(v) else math.inf

    def errors(self, effects: Mapping[str, float] | None = None) -> tuple[float, float]:
        """RMS error in noise units (1 = only noise) on (training, validation) samples."""
        res = self.residuals(effects)
        return self._error(res, self.train), self._error(res, self.val)

    def _log_step(self, label: str) -> None:
        tr, va = self.errors()
        self.waterfall.append({"step": label, "effects": dict(self.accepted),
                               "error_train": tr, "error_val": va})

    def _vec(self, res: Mapping[str, np.ndarray], mask: np.ndarray) -> np.ndarray:
        return np.concatenate([res[c][mask] for c in self.channels])

    # ------------------------------------------------------------------ fitting
    def _scale(self, label: str) -> float:
        return get_effect(label.split(".")[0]).param.scale

    def fit(self, free: Mapping[str, float], fixed: Mapping[str, float] | None = None,
            max_nfev: int = 12) -> tuple[dict[str, float], dict[str, tuple[float, float]]]:
        """Least-squares fit of the ``free`` effects (label → start value) on the training
        samples with ``fixed`` effects held; the Jacobian columns are one batched replay.
        Returns (values, 95 % intervals)."""
        from scipy.optimize import least_squares

        fixed = dict(fixed or {})
        names = list(free)
        effs = [get_effect(n.split(".")[0]) for n in names]
        lo = np.array([e.param.lo for e in effs])
        hi = np.array([e.param.hi for e in effs])
        scale = np.array([self._scale(n) for n in names])
        x0 = np.clip(np.array([free[n] for n in names], dtype=float), lo, hi)
        tr = self.train

        def eff(x: np.ndarray) -> dict[str, float]:
            out = dict(fixed)
            out.update({n: float(v) for n, v in zip(names, np.clip(x, lo, hi), strict=True)})
            return out

        def res(out: Mapping[str, np.ndarray]) -> np.ndarray:
            v = self._vec(self._res(out), tr)
            return np.where(np.isfinite(v), v, 1e3)

        def fun(x: np.ndarray) -> np.ndarray:
            return res(self.predict(eff(x)))

        def jac(x: np.ndarray) -> np.ndarray:
            steps = 0.05 * scale
            xs = []
            for i in range(len(x)):
                xi = x.copy()
                xi[i] = x[i] + steps[i] if x[i] + steps[i] <= hi[i] else x[i] - steps[i]
                xs.append(xi)
            outs = self.outputs([eff(xi) for xi in xs])
            f0 = fun(x)
            return np.column_stack([(res(o) - f0) / (xi[i] - x[i])
                                    for i, (o, xi) in enumerate(zip(outs, xs, strict=True))])

        bounds = (lo, hi)
        sol = least_squares(fun, x0, jac=jac, bounds=bounds, x_scale=scale, max_nfev=max_nfev)
        vals = eff(sol.x)
        out = {n: vals[n] for n in names}
        r = sol.fun
        neff = self._neff_fraction * r.size
        s2 = float(np.dot(r, r)) / max(neff - len(names), 1.0)
        try:
            cov = np.linalg.inv(sol.jac.T @ sol.jac) * s2 * r.size / max(neff, 1.0)
            sd = np.sqrt(np.maximum(np.diag(cov), 0.0))
        except np.linalg.LinAlgError:
            sd = np.full(len(names), np.inf)
        ci = {n: (out[n] - 1.96 * s, out[n] + 1.96 * s) for n, s in zip(names, sd, strict=True)}
        return out, ci

    @property
    def _neff_fraction(self) -> float:
        if not hasattr(self, "_nef"):
            res = self.residuals({})
            self._nef = float(np.mean([effective_samples(res[c][self.val]) / self.val.sum()
                                       for c in self.channels]))
        return self._nef

    # ------------------------------------------------------------------ user steps
    def add(self, label: str, value: float | None = None, *, fix: bool = False,
            values: Mapping[str, float] | None = None) -> dict[str, float]:
        """Accept an effect (``label``, start ``value``; ``fix=True`` holds it) — or a
        calibration's fitted ``values`` (held) — refit every free accepted effect jointly,
        log a waterfall step; a revision of the description (``scene:…``) goes to
        :meth:`revise`. Returns the accepted effects."""
        if is_revision(label):
            return self.revise(label)
        if label in MULTI or values is not None:
            vals = dict(values) if values is not None else self._multi(label, self.predict())
            if not vals:
                raise ConfigError(label, None, "nothing to calibrate from this record")
            self.accepted.update(vals)
            self.fixed.update(vals)
            step = f"+ {label} ({len(vals)} parameters)"
        else:
            name, _, _ = parse_label(label)
            eff = get_effect(name)
            if value is not None:
                value = eff.param.check(value, label)
            if fix and value is None:
                raise ConfigError(f"{label}.{eff.param.name}", None,
                                  "a fixed effect needs a value")
            if value is None:
                value = eff.probe_value()
            self.accepted[label] = float(value)
            if fix:
                self.fixed.add(label)
            step = None
        self._refit_free()
        if step is None:
            p = get_effect(parse_label(label)[0]).param
            step = f"+ {label} ({p.name} = {self.accepted[label]:.4g} {p.unit})"
        self._log_step(step)
        return dict(self.accepted)

    def _refit_free(self) -> None:
        free = {n: v for n, v in self.accepted.items() if n not in self.fixed}
        if free:
            held = {n: v for n, v in self.accepted.items() if n in self.fixed}
            vals, ci = self.fit(free, held)
            self.accepted.update(vals)
            self.cov.update(ci)

    def _screen_revisions(self) -> dict[str, tuple[Candidate, dict[str, np.ndarray]]]:
        return {lab: (Candidate(lab, "scene", "", k=rev.k, changes=dict(rev.changes),
                                detail=list(rev.detail)), out)
                for lab, rev, out in screen_revisions(self)}

    def revise(self, label: str) -> dict[str, float]:
        """Accept a revision of the description (``scene:<key>=<value>``, as ranked): the
        scene is rewritten, every free accepted effect refitted on it, a waterfall step
        logged and the change kept in :attr:`revisions`. Returns the accepted effects."""
        revise(self, label)
        self._pools.clear()
        self._refit_free()
        self._log_step(f"~ {label.removeprefix(PREFIX)}")
        return dict(self.accepted)

    # ------------------------------------------------------------------ one round
    def _probe(self, label: str) -> float:
        """The probe value of a candidate: its effect's size for this test (a typical
        magnitude, or one sized from the replayed set-points and measurements)."""
        name, leg, _ = parse_label(label)
        return get_effect(name).probe_value(
            ProbeData(leg, self._setpoint_lengths, self.measured, self.dt))

    def _setpoint_lengths(self) -> np.ndarray:
        """The controller's leg set-points (N, 6) (m) of the replayed poses."""
        if self._lengths is None or self._lengths[0] is not self.replay:
            from ..platform.kinematics import inverse_kinematics

            self._lengths = (self.replay,
                             inverse_kinematics(self.scene_geometry, self.replay.poses))
        return self._lengths[1]

    @property
    def scene_geometry(self):
        return self.replay.bench([]).platform.geometry

    def auto(self, max_rounds: int = 4) -> list[RoundResult]:
        """Rounds of run → accept the proposal, until only noise remains (or ``max_rounds``,
        or nothing significant is left)."""
        rounds = []
        for _ in range(max_rounds):
            res = self.run()
            rounds.append(res)
            if res.proposal is None:
                break
            p = res.proposal
            if is_revision(p.effect):
                self.revise(p.effect)
            elif p.effect in MULTI:
                self.add(p.effect, values=p.values)
            else:
                self.add(p.effect, p.value)
            if res.status == "effect_proposed":
                res2 = self.run()
                rounds.append(res2)
                break
        return rounds

    def calibrated_scene(self) -> Scene:
        """The bench scene with the accepted effects added to its own (``--save-scene``)."""
        import dataclasses

        effects = {e.label: e for e in self.scene.effects}
        for e in effect_configs(self.accepted):
            effects[e.label] = e
        return dataclasses.replace(self.scene, effects=tuple(effects.values()))

