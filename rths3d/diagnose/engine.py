"""The diagnosis engine: replay, compare, screen every candidate effect, refit, rank.

Workflow (one *round*):

1. replay the measured command through the model with the accepted effects; residual
   r = measured − model per channel, in units of each channel's noise floor σ (estimated
   once from the first residual's differences, see :func:`~.localise.noise_floor`);
2. split the samples into alternating blocks: training (even) and validation (odd);
3. *screen* every candidate: probe it at a typical magnitude, take its sensitivity Δ (the
   change of every output) and the share of the training residual it can explain,
   (r·Δ)² / (|r|²·|Δ|²);
4. *refit* the best few by bounded least squares (scipy) on the training blocks;
5. *rank* by the held-out information criterion
   ΔBIC = Σ_ch n_eff,ch · ln(SSE0_ch / SSE1_ch) − k · ln(n_eff)
   on the validation blocks, with n_eff the effective sample size of the autocorrelated
   1 kHz residual (:func:`~.localise.effective_samples`); an effect is *significant* if
   ΔBIC > 0, the validation error falls by at least ``min_gain`` and its confidence interval
   excludes the off value;
6. report confounded pairs (fitted changes with |cos| ≥ 0.95); when no candidate is
   significant, ``noise_only`` if the residual looks like noise (validation error ≤ 1.5
   noise units, or every channel's residual nearly white: n_eff/n ≥ 0.5), otherwise the
   status ``unexplained``: structure remains that no effect of the library explains (a
   wrong scene or an effect the library lacks) — never reported as noise.

:meth:`Diagnosis.add` accepts an effect (fitted or fixed), refits every free accepted
parameter jointly and appends a step to the waterfall (errors on training and validation).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ..effects.base import REGISTRY, get_effect
from ..errors import ConfigError, RecordError, RthsError
from ..record import Record
from .bench import BenchConfig, BenchModel, resolve_scene
from .localise import effective_samples, noise_floor
from .measurement import COMMAND, check_measurement


@dataclass
class Candidate:
    """One candidate effect after screening (and refitting, if it was among the best).

    ``value`` is the fitted parameter (SI unit of the effect), ``ci`` its 95 % interval;
    ``error_before`` / ``error_after`` are validation errors in noise units (1 = noise only);
    ``score`` is the held-out ΔBIC (higher is better; > 0 favours the effect).
    """

    effect: str
    param: str
    unit: str
    share: float
    value: float = float("nan")
    ci: tuple[float, float] = (float("nan"), float("nan"))
    score: float = float("-inf")
    error_before: float = float("nan")
    error_after: float = float("nan")
    train_before: float = float("nan")
    train_after: float = float("nan")
    fitted: bool = False
    significant: bool = False
    note: str = ""
    channel_share: dict[str, float] = field(default_factory=dict)

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict with the interface keys effect, params, score, error_before,
        error_after."""
        d = asdict(self)
        d["params"] = {self.param: self.value}
        d["ci"] = list(self.ci)
        return d


@dataclass
class RoundResult:
    """Outcome of one diagnosis round."""

    candidates: list[Candidate]
    accepted: dict[str, float]
    noise_only: bool
    """True only when nothing is significant *and* the residual looks like noise."""
    proposal: Candidate | None
    confounded: list[tuple[str, str, float]]
    error_train: float
    error_val: float
    channel_rms: dict[str, float]
    noise_sigma: dict[str, float]
    whiteness: dict[str, float] = field(default_factory=dict)
    """n_eff/n of each channel's validation residual (1 = white)."""

    @property
    def status(self) -> str:
        """``"effect_proposed"``, ``"noise_only"`` or ``"unexplained"``."""
        if self.proposal is not None:
            return "effect_proposed"
        return "noise_only" if self.noise_only else "unexplained"

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary (keys ``candidates``, ``accepted``, ``noise_only`` ...)."""
        return {
            "candidates": [c.as_dict() for c in self.candidates],
            "accepted": [{"effect": k, "params": {get_effect(k).param.name: v}}
                         for k, v in self.accepted.items()],
            "noise_only": self.noise_only,
            "status": self.status,
            "whiteness": self.whiteness,
            "proposal": self.proposal.effect if self.proposal else None,
            "confounded": [{"a": a, "b": b, "cos": c} for a, b, c in self.confounded],
            "error_train": self.error_train,
            "error_val": self.error_val,
            "channel_rms": self.channel_rms,
            "noise_sigma": self.noise_sigma,
        }


class Diagnosis:
    """Model-vs-measurement diagnosis of one record.

    Parameters
    ----------
    record:
        The measurement (schema of :mod:`rths3d.record`): ``z_cmd.z`` plus measured channels.
    bench:
        Nominal bench parameters (default: ``record.meta['bench']`` or the built-in bench).
    model:
        ``"bench"`` (1-D heave bench), ``"stewart"`` (six-leg platform) or a ready
        :class:`~rths3d.diagnose.bench.BenchModel`; default from ``record.meta['bench']``.
    candidates:
        Effect names to consider (default: every registered candidate).
    block:
        Length of the alternating training / validation blocks (s).
    top_k:
        How many of the best-screened candidates are refitted each round.
    min_gain:
        Smallest relative fall of the validation error (noise units, squared) that counts.
    """

    def __init__(self, record: Record, bench: BenchConfig | None = None, *,
                 model: str | BenchModel | None = None, candidates: Iterable[str] | None = None,
                 block: float = 0.5, top_k: int = 5,
                 min_gain: float = 0.01, max_nfev: int = 30,
                 progress: Callable[[str], None] | None = None):
        self.channels = check_measurement(record)
        self.record = record
        meta_cfg, kind = resolve_scene(None, record.meta)
        self.bench = bench or meta_cfg
        if isinstance(model, BenchModel):
            self.model = model
        else:
            from .stewart import make_model

            self.model = make_model(self.bench, record.dt, model or kind)
        produced = set(self.model.channels)
        self.ignored = tuple(c for c in self.channels if c not in produced)
        """Measured channels this model does not produce (not compared)."""
        self.channels = tuple(c for c in self.channels if c in produced)
        if not self.channels:
            raise RecordError("the measurement has no channel this bench model produces "
                              f"({', '.join(sorted(produced))})")
        self.dt = record.dt
        self.command = np.ascontiguousarray(record.columns[COMMAND], dtype=float)
        self.measured = {c: np.asarray(record.columns[c], dtype=float) for c in self.channels}
        names = list(candidates) if candidates is not None else \
            [n for n, e in REGISTRY.items() if e.candidate]
        for n in names:
            get_effect(n)
        self.candidate_names = names
        self.top_k = int(top_k)
        self.min_gain = float(min_gain)
        self.max_nfev = int(max_nfev)
        self.progress = progress or (lambda msg: None)
        m = max(1, int(round(block / self.dt)))
        blk = (np.arange(record.n) // m) % 2
        self.train = blk == 0
        self.val = blk == 1
        if self.val.sum() < 10:
            raise ConfigError("block", block, f"too long for a {record.duration:.3g} s record")
        self.accepted: dict[str, float] = {}
        self.fixed: set[str] = set()
        self.cov: dict[str, float] = {}
        base = self.model.replay(self.command, {})
        self.sigma = {}
        for c in self.channels:
            r = self.measured[c] - base[c]
            s = noise_floor(r)
            # floor: a noiseless channel must not get an infinite weight
            self.sigma[c] = max(s, 1e-6 * float(np.std(self.measured[c])), 1e-12)
        self.waterfall: list[dict[str, Any]] = []
        self._log_step("baseline (nominal model)")

    # ------------------------------------------------------------------ residuals
    def predict(self, effects: Mapping[str, float] | None = None) -> dict[str, np.ndarray]:
        """Model outputs for the measured command with ``effects`` (default: accepted)."""
        eff = self.accepted if effects is None else effects
        return self.model.replay(self.command, eff)

    def residuals(self, effects: Mapping[str, float] | None = None) -> dict[str, np.ndarray]:
        """Residual measured − model per channel, in noise units."""
        out = self.predict(effects)
        return {c: (self.measured[c] - out[c]) / self.sigma[c] for c in self.channels}

    def _error(self, res: Mapping[str, np.ndarray], mask: np.ndarray) -> float:
        return math.sqrt(float(np.mean([np.mean(res[c][mask] ** 2) for c in self.channels])))

    def errors(self, effects: Mapping[str, float] | None = None) -> tuple[float, float]:
        """RMS error in noise units (1 = only noise) on (training, validation) samples."""
        res = self.residuals(effects)
        return self._error(res, self.train), self._error(res, self.val)

    def _log_step(self, label: str) -> None:
        tr, va = self.errors()
        self.waterfall.append({"step": label, "effects": dict(self.accepted),
                               "error_train": tr, "error_val": va})

    # ------------------------------------------------------------------ fitting
    def _scale(self, name: str, start: float) -> float:
        p = get_effect(name).param
        if math.isinf(p.off):
            return max(0.2 * abs(start), 1e-9)
        return max(p.scale, 0.05 * abs(start - p.off))

    def fit(self, free: Mapping[str, float], fixed: Mapping[str, float] | None = None
            ) -> tuple[dict[str, float], dict[str, tuple[float, float]], int]:
        """Least-squares fit of the ``free`` effects (name → start value) on the training
        samples, with ``fixed`` effects held. Returns (values, 95 % intervals, evaluations)."""
        from scipy.optimize import least_squares

        fixed = dict(fixed or {})
        names = list(free)
        start = np.array([free[n] for n in names], dtype=float)
        scale = np.array([self._scale(n, s) for n, s in zip(names, start, strict=True)])
        lo = np.array([get_effect(n).param.lo for n in names])
        hi = np.array([get_effect(n).param.hi for n in names])
        start = np.clip(start, lo, hi)
        ulo = (lo - start) / scale
        uhi = (hi - start) / scale
        ulo = np.minimum(ulo, -1e-12)
        uhi = np.maximum(uhi, 1e-12)
        train = self.train
        nfev = 0

        def values(u: np.ndarray) -> dict[str, float]:
            th = np.clip(start + u * scale, lo, hi)
            eff = dict(fixed)
            eff.update({n: float(v) for n, v in zip(names, th, strict=True)})
            return eff

        def fun(u: np.ndarray) -> np.ndarray:
            nonlocal nfev
            nfev += 1
            try:
                res = self.residuals(values(u))
            except RthsError:
                return np.full(int(train.sum()) * len(self.channels), 1e3)
            return np.concatenate([res[c][train] for c in self.channels])

        sol = least_squares(fun, np.zeros(len(names)), bounds=(ulo, uhi), diff_step=1e-2,
                            max_nfev=self.max_nfev, x_scale=1.0)
        eff = values(sol.x)
        out = {n: eff[n] for n in names}
        ci: dict[str, tuple[float, float]] = {}
        r = sol.fun
        n = r.size
        k = len(names)
        res_all = self.residuals(eff)
        neff = sum(effective_samples(res_all[c][train]) for c in self.channels)
        inflation = max(1.0, n / max(neff, 1.0))
        s2 = float(np.dot(r, r)) / max(n - k, 1) * inflation
        try:
            jtj = sol.jac.T @ sol.jac
            cov = np.linalg.inv(jtj) * s2
            sd = np.sqrt(np.maximum(np.diag(cov), 0.0)) * scale
        except np.linalg.LinAlgError:
            sd = np.full(k, np.inf)
        for i, nme in enumerate(names):
            sdi = sd[i] if np.isfinite(sd[i]) else np.inf
            ci[nme] = (out[nme] - 1.96 * sdi, out[nme] + 1.96 * sdi)
        return out, ci, nfev

    # ------------------------------------------------------------------ user steps
    def add(self, name: str, value: float | None = None, *, fix: bool = False) -> dict[str, float]:
        """Accept effect ``name``: start at ``value`` (or its signature-based guess), refit every
        free accepted effect jointly (``fix=True`` holds this one at ``value``), log a
        waterfall step. Returns the accepted effects."""
        eff = get_effect(name)
        if value is not None:
            value = eff.param.check(value, eff.name)
        if fix and value is None:
            raise ConfigError(f"{name}.{eff.param.name}", None, "a fixed effect needs a value")
        if value is None:
            base = self.predict()
            value = eff.probe(self.measured, base, self.command, self.dt)
        self.accepted[eff.name] = float(value)
        if fix:
            self.fixed.add(eff.name)
        free = {n: v for n, v in self.accepted.items() if n not in self.fixed}
        if free:
            held = {n: v for n, v in self.accepted.items() if n in self.fixed}
            vals, ci, _ = self.fit(free, held)
            self.accepted.update(vals)
            self.cov.update({n: ci[n] for n in vals})
        label = f"+ {eff.name} ({eff.param.name} = {self.accepted[eff.name]:.4g} "\
                f"{eff.param.unit})"
        self._log_step(label)
        return dict(self.accepted)

    # ------------------------------------------------------------------ one round
    def _ic(self, r0: Mapping[str, np.ndarray], r1: Mapping[str, np.ndarray], k: int) -> float:
        val = self.val
        total = 0.0
        neff_all = 0.0
        for c in self.channels:
            a = r0[c][val]
            b = r1[c][val]
            s0 = float(np.dot(a, a))
            s1 = float(np.dot(b, b))
            ne = effective_samples(b)
            neff_all += ne
            if s0 > 0 and s1 > 0:
                total += ne * math.log(s0 / s1)
        return total - k * math.log(max(neff_all, 2.0))

    def run(self) -> RoundResult:
        """Screen every candidate, refit the best ``top_k``, rank them (one round)."""
        base = self.predict()
        r0 = {c: (self.measured[c] - base[c]) / self.sigma[c] for c in self.channels}
        train = self.train
        rvec = np.concatenate([r0[c][train] for c in self.channels])
        rr = float(np.dot(rvec, rvec))
        e_tr0 = self._error(r0, train)
        e_va0 = self._error(r0, self.val)
        cands: list[Candidate] = []
        probes = {}
        for name in self.candidate_names:
            if name not in self.accepted:
                probes[name] = get_effect(name).probe(self.measured, base, self.command, self.dt)
        # the physics probes run as one batched rollout; the loop below then hits the cache
        self.model.simulate_many(self.command, [
            {**self.accepted, n: v} for n, v in probes.items() if get_effect(n).needs_sim])
        for name in self.candidate_names:
            if name in self.accepted:
                continue
            eff = get_effect(name)
            self.progress(f"screen {name}")
            probe = probes[name]
            trial = dict(self.accepted)
            trial[name] = probe
            cand = Candidate(name, eff.param.name, eff.param.unit, 0.0)
            try:
                out = self.model.replay(self.command, trial)
            except RthsError as exc:
                cand.note = f"probe failed: {exc}"
                cands.append(cand)
                continue
            d = {c: (out[c] - base[c]) / self.sigma[c] for c in self.channels}
            dvec = np.concatenate([d[c][train] for c in self.channels])
            dd = float(np.dot(dvec, dvec))
            if dd > 0 and rr > 0:
                cand.share = float(np.dot(rvec, dvec)) ** 2 / (rr * dd)
                for c in self.channels:
                    a = r0[c][train]
                    b = d[c][train]
                    den = float(np.dot(a, a) * np.dot(b, b))
                    cand.channel_share[c] = float(np.dot(a, b)) ** 2 / den if den > 0 else 0.0
                alpha = float(np.dot(rvec, dvec)) / dd
                guess = eff.initial_guess(self.measured, base, self.command, self.dt)
                if guess is None:
                    if math.isinf(eff.param.off):
                        guess = probe
                    else:
                        guess = eff.param.off + alpha * (probe - eff.param.off)
                cand.value = float(np.clip(guess, eff.param.lo, eff.param.hi))
            else:
                cand.value = probe
            cands.append(cand)
        order = sorted(cands, key=lambda c: -c.share)
        fitted_changes: dict[str, np.ndarray] = {}
        for cand in order[: self.top_k]:
            if cand.share <= 0:
                continue
            self.progress(f"refit {cand.effect}")
            free = {cand.effect: cand.value}
            try:
                vals, ci, _ = self.fit(free, self.accepted)
            except RthsError as exc:
                cand.note = f"fit failed: {exc}"
                continue
            trial = dict(self.accepted)
            trial.update(vals)
            r1 = self.residuals(trial)
            cand.value = vals[cand.effect]
            cand.ci = ci[cand.effect]
            cand.fitted = True
            cand.train_before, cand.error_before = e_tr0, e_va0
            cand.train_after = self._error(r1, train)
            cand.error_after = self._error(r1, self.val)
            cand.score = self._ic(r0, r1, 1)
            off = get_effect(cand.effect).param.off
            excludes_off = not (cand.ci[0] <= off <= cand.ci[1]) if not math.isinf(off) \
                else cand.ci[1] < get_effect(cand.effect).param.hi
            gain = 1.0 - (cand.error_after / cand.error_before) ** 2 if cand.error_before else 0
            cand.significant = bool(cand.score > 0 and gain >= self.min_gain and excludes_off)
            if not cand.significant:
                cand.note = "; ".join(s for s in (
                    "ΔBIC ≤ 0" if cand.score <= 0 else "",
                    f"validation gain {gain:.2%} < {self.min_gain:.0%}"
                    if gain < self.min_gain else "",
                    "interval includes off" if not excludes_off else "") if s)
            fitted_changes[cand.effect] = np.concatenate(
                [(r0[c] - r1[c])[train] for c in self.channels])
        ranked = sorted(cands, key=lambda c: (-(c.score if c.fitted else -1e300), -c.share))
        confounded = []
        names = [c.effect for c in ranked if c.fitted]
        for i, a in enumerate(names):
            for b in names[i + 1:]:
                va, vb = fitted_changes[a], fitted_changes[b]
                den = math.sqrt(float(np.dot(va, va) * np.dot(vb, vb)))
                if den > 0:
                    cos = float(np.dot(va, vb)) / den
                    if abs(cos) >= 0.95:
                        confounded.append((a, b, cos))
        proposal = next((c for c in ranked if c.significant), None)
        chan_rms = {c: float(np.sqrt(np.mean((r0[c] * self.sigma[c]) ** 2)))
                    for c in self.channels}
        nval = int(self.val.sum())
        white = {c: effective_samples(r0[c][self.val]) / nval for c in self.channels}
        noise_like = e_va0 <= 1.5 or min(white.values()) >= 0.5
        return RoundResult(ranked, dict(self.accepted), proposal is None and noise_like,
                           proposal, confounded, e_tr0, e_va0, chan_rms, dict(self.sigma), white)

    def auto(self, max_rounds: int = 4) -> list[RoundResult]:
        """Rounds of run → accept the proposal, until only noise remains (or ``max_rounds``)."""
        rounds = []
        for _ in range(max_rounds):
            res = self.run()
            rounds.append(res)
            if res.noise_only or res.proposal is None:
                break
            self.add(res.proposal.effect, res.proposal.value)
        return rounds
