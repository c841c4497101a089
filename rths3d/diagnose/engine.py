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
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

from ..bench import BenchReplay, ReplayInput
from ..config import EffectConfig, Scene
from ..effects import REGISTRY, WRENCH, get_effect, parse_label
from ..errors import ConfigError, RecordError
from ..record import DOFS, Record
from .bench import resolve_bench
from .candidates import PREFIX, Revision, is_revision
from .candidates.screen import revise, screen_revisions
from .localise import effective_samples, noise_floor, remaining_structure
from .measurement import check_measurement

__all__ = ["Candidate", "Diagnosis", "RoundResult", "default_candidates"]

MULTI = ("kinematic_calibration", "fts_calibration")
"""Multi-parameter candidates (fitted from the measured channels, not from a probe)."""

NOISE_LIKE = 1.2
"""Validation error (noise units) at or below which a residual counts as noise."""


def default_candidates(scene: Scene) -> list[str]:
    """Every candidate label for a bench: each candidate effect on each target, and the two
    calibrations. Part effects a part does not have (a contact gap without a surface) are
    left out."""
    out: list[str] = []
    contact = scene.experiment.kind in ("contact", "multidof")
    spring = scene.experiment.kind in ("contact", "linear", "multidof")
    for name, eff in REGISTRY.items():
        if not eff.candidate or eff.stage == "geometry" and name != "leg_offset":
            continue
        if eff.stage == "fts" or (name == "contact_gap" and not contact):
            continue
        if name in ("specimen_stiffness", "specimen_damping") and not spring:
            continue
        for leg, axis in eff.targets():
            out.append(name + (f".leg{leg}" if leg >= 0 else "") + (f".{axis}" if axis else ""))
    return [*out, "fts_gain.fz", "fts_offset.fz", *MULTI]


@dataclass
class Candidate:
    """One candidate after screening (and refitting, if it was among the best).

    ``value`` is the fitted parameter (SI unit of the effect; NaN for a calibration, whose
    fitted effects are ``values``), ``ci`` its 95 % interval; ``error_before`` /
    ``error_after`` are validation errors in noise units (1 = only noise); ``score`` the
    held-out ΔIC (higher is better; > 0 favours the effect).
    """

    effect: str
    param: str
    unit: str
    share: float = 0.0
    value: float = float("nan")
    values: dict[str, float] = field(default_factory=dict)
    k: int = 1
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
    detail: list[str] = field(default_factory=list)
    """Further facts (e.g. the kinematic calibration's identifiability report)."""
    changes: dict[str, Any] = field(default_factory=dict)
    """A description revision's changes of the scene (dotted key → new value)."""

    @property
    def leg(self) -> int:
        """The leg the candidate acts on (−1: none or all)."""
        if self.effect in MULTI or is_revision(self.effect):
            return -1
        return parse_label(self.effect)[1]

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict with the interface keys effect, params, score, error_before,
        error_after."""
        d = asdict(self)
        d["params"] = dict(self.changes) if is_revision(self.effect) else \
            {self.param: self.value} if self.effect not in MULTI else dict(self.values)
        d["ci"] = list(self.ci)
        return d


@dataclass
class RoundResult:
    """Outcome of one diagnosis round."""

    candidates: list[Candidate]
    accepted: dict[str, float]
    noise_only: bool
    proposal: Candidate | None
    confounded: list[tuple[str, str, float]]
    error_train: float
    error_val: float
    channel_rms: dict[str, float]
    noise_sigma: dict[str, float]
    whiteness: dict[str, float] = field(default_factory=dict)
    partly: bool = False
    """Structure remains after the best candidate (or the accepted effects)."""
    remaining: dict[str, Any] = field(default_factory=dict)
    """Where the residual left by the proposal (or the current model) sits."""

    @property
    def status(self) -> str:
        """``effect_proposed``, ``partly_explained``, ``noise_only`` or ``unexplained``."""
        if self.partly:
            return "partly_explained"
        if self.proposal is not None:
            return "effect_proposed"
        return "noise_only" if self.noise_only else "unexplained"

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary (keys ``candidates``, ``accepted``, ``noise_only`` ...)."""
        return {
            "candidates": [c.as_dict() for c in self.candidates],
            "accepted": [{"effect": k, "params": {_param(k): v}}
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
            "remaining": self.remaining,
        }


def _param(label: str) -> str:
    return get_effect(label.split(".")[0]).param.name


def _configs(effects: Mapping[str, float]) -> list[EffectConfig]:
    out = []
    for label, v in effects.items():
        name, leg, axis = parse_label(label)
        out.append(EffectConfig(name, float(v), leg, axis))
    return out


class Diagnosis:
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
    descriptions:
        The description candidates screened beside the effects (names of
        :data:`~.candidates.DESCRIPTIONS`; default all, ``()`` none): revisions of what the
        scene states (the controller's conventions, the payload).
    """

    def __init__(self, record: Record, scene: Scene | None = None, *,
                 candidates: Iterable[str] | None = None, block: float = 0.5,
                 refit: int = 8, min_gain: float = 0.01, substeps: int = 1, nthread: int = 2,
                 progress: Callable[[str], None] | None = None,
                 descriptions: Iterable[str] | None = None):
        chans = check_measurement(record)
        self.record = record
        self.warnings: list[str] = []
        if scene is None:
            scene, self.warnings = resolve_bench(None, record.meta)
        self.scene = scene
        self.base_effects = {e.label: e.value for e in scene.effects
                             if e.name != "sensor_noise"}
        inp = ReplayInput.from_record(record, scene.dofs)
        if inp.source == "z_cmd":
            self.warnings.append("the record has no pose_cmd.*: replaying z_cmd of the "
                                 f"interface DOFs {list(scene.dofs)} (other DOFs held at 0)")
        self._inp, self._substeps, self._nthread = inp, substeps, nthread
        self.descriptions = None if descriptions is None else tuple(descriptions)
        self.revisions: list[dict[str, Any]] = []
        """The parts of the description the diagnosis changed, in order: label and, per
        dotted scene key, the value stated and the value accepted."""
        self._revs: dict[str, Revision] = {}
        self.replay = BenchReplay(scene, inp, substeps=substeps, nthread=nthread)
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
        self.fixed: set[str] = set()
        self.cov: dict[str, tuple[float, float]] = {}
        self._cache: dict[tuple, dict[str, np.ndarray]] = {}
        self.nsim = 0
        base = self.predict()
        self.sigma: dict[str, float] = {}
        for c in self.channels:
            r = (self.measured[c] - base[c])[1:]
            s = noise_floor(r)
            self.sigma[c] = max(s, 1e-6 * float(np.std(self.measured[c])), 1e-12)
        self.waterfall: list[dict[str, Any]] = []
        self._log_step("baseline (nominal model)")

    # ------------------------------------------------------------------ model outputs
    def _key(self, effects: Mapping[str, float]) -> tuple:
        return tuple(sorted((k, float(v)) for k, v in effects.items()))

    def outputs(self, effect_sets: list[Mapping[str, float]]) -> list[dict[str, np.ndarray]]:
        """Replays (every channel) for several sets of effects on top of the scene's, in one
        batch; cached."""
        keys = [self._key(e) for e in effect_sets]
        todo = list({k: i for i, k in enumerate(keys) if k not in self._cache}.values())
        if todo:
            sets = [_configs({**self.base_effects, **effect_sets[i]}) for i in todo]
            res = self.replay.run(sets)
            self.nsim += len(todo)
            if len(self._cache) > 400:
                self._cache.clear()
            for i, r in zip(todo, res, strict=True):
                self._cache[keys[i]] = r
        return [self._cache[k] for k in keys]

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

    # ------------------------------------------------------------------ calibrations
    def _kinematic(self, base: Mapping[str, np.ndarray]) -> dict[str, float] | None:
        """Kinematic calibration (42 parameters) from the measured absolute poses and leg
        encoders of the training samples: the identified deviations as geometry effects."""
        from ..platform.calibration import KinematicCalibration, parameter_names

        need = [f"pose_meas.{d}" for d in DOFS] + [f"leg_len.{i}" for i in range(6)]
        if not all(c in self.measured for c in need):
            return None
        bench = self.replay.bench(_configs({**self.base_effects, **self.accepted}))
        nominal = bench.true_geometry()
        rows = np.flatnonzero(self.train)[:: max(1, int(0.005 / self.dt))]
        q = np.column_stack([self.measured[f"pose_meas.{d}"][rows] for d in DOFS])
        L = np.column_stack([self.measured[f"leg_len.{i}"][rows] for i in range(6)])
        sig = float(np.median([self.sigma[f"leg_len.{i}"] for i in range(6)]))
        try:
            # a prior of 2 mm (manufacturing tolerance) keeps what the poses cannot see near
            # the drawing; the identifiability report says which parameters those are
            cal = KinematicCalibration(nominal, sigma=max(sig, 1e-7), prior_sigma=2e-3,
                                       tolerance=1e-4).fit(q, L)
        except ConfigError:
            return None
        self.kinematic_ = cal
        out: dict[str, float] = {}
        for name, dev in zip(parameter_names(), cal.deviation_, strict=True):
            if abs(dev) <= 1e-7:
                continue
            kind, rest = name.split("[")  # base_anchor[i].x, top_anchor[i].z, leg_offset[i]
            leg = int(rest[0])
            axis = rest.split(".")[-1] if "." in rest else ""
            lab = f"{kind}.leg{leg}" + (f".{axis}" if axis else "")
            out[lab] = self.accepted.get(lab, 0.0) + float(dev)
        return out or None

    def _fts(self, base: Mapping[str, np.ndarray]) -> dict[str, float] | None:
        """FTS calibration: the 6×6 matrix and offset that map the model's wrench onto the
        measured one (least squares on the training samples), as gain, cross-talk and
        offset effects."""
        cols = [f"fts.{c}" for c in WRENCH]
        if not all(c in self.measured for c in cols):
            return None
        tr = self.train
        W = np.column_stack([base[c][tr] for c in cols] + [np.ones(int(tr.sum()))])
        Y = np.column_stack([self.measured[c][tr] for c in cols])
        X, *_ = np.linalg.lstsq(W, Y, rcond=None)
        C = X[:6].T
        b = X[6]
        out: dict[str, float] = {}
        sw = np.sqrt(np.mean(W[:, :6] ** 2, axis=0)) + 1e-12
        for r, rn in enumerate(WRENCH):
            sr = self.sigma[f"fts.{rn}"]
            for c, cn in enumerate(WRENCH):
                v = C[r, c] - (1.0 if r == c else 0.0)
                # keep entries that move the channel by more than a tenth of its noise
                if abs(v) * sw[c] > 0.1 * sr:
                    lab = f"fts_gain.{rn}" if r == c else f"fts_crosstalk.{rn}.{cn}"
                    out[lab] = self.accepted.get(lab, 0.0) + float(v)
            if abs(b[r]) > 0.1 * sr:
                lab = f"fts_offset.{rn}"
                out[lab] = self.accepted.get(lab, 0.0) + float(b[r])
        return out or None

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
        log a waterfall step. Returns the accepted effects."""
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
        self._refit_free()
        self._log_step(f"~ {label.removeprefix(PREFIX)}")
        return dict(self.accepted)

    def _multi(self, label: str, base: Mapping[str, np.ndarray]) -> dict[str, float] | None:
        return self._kinematic(base) if label == "kinematic_calibration" else self._fts(base)

    # ------------------------------------------------------------------ one round
    def run(self) -> RoundResult:
        """Screen every candidate, refit the best ``refit``, rank them (one round)."""
        base = self.predict()
        r0 = self._res(base)
        tr, va = self.train, self.val
        rvec = self._vec(r0, tr)
        rr = float(np.dot(rvec, rvec))
        e_tr0, e_va0 = self._error(r0, tr), self._error(r0, va)
        nval = int(va.sum())
        white = {c: effective_samples(r0[c][va]) / nval for c in self.channels}
        neff = max(2.0, float(np.mean(list(white.values()))) * nval * len(self.channels))
        sse0 = float(np.dot(self._vec(r0, va), self._vec(r0, va)))

        cands: dict[str, Candidate] = {}
        trials: dict[str, dict[str, float]] = {}
        probes: dict[str, float] = {}
        for lab in self.candidate_names:
            if lab in self.accepted:
                continue
            if lab in MULTI:
                vals = self._multi(lab, base)
                if vals:
                    cands[lab] = Candidate(lab, "θ", "m" if lab[0] == "k" else "1",
                                           values=vals, k=len(vals))
                    trials[lab] = {**self.accepted, **vals}
                    if lab == "kinematic_calibration":
                        cands[lab].detail = self.kinematic_.report_.lines()
                continue
            name = lab.split(".")[0]
            eff = get_effect(name)
            p = self._probe(lab)
            probes[lab] = p
            cands[lab] = Candidate(lab, eff.param.name, eff.param.unit)
            trials[lab] = {**self.accepted, lab: p}
        revs = self._screen_revisions()
        self.progress(f"screen {len(trials)} candidates and {len(revs)} revisions")
        outs = dict(zip(trials, self.outputs(list(trials.values())), strict=True))
        # linear estimate along each probe's sensitivity
        est: dict[str, float] = {}
        gain: dict[str, float] = {}
        deltas: dict[str, np.ndarray] = {}
        for lab, cand in cands.items():
            rp = self._res(outs[lab])
            d = self._vec(rp, tr)
            dvec = rvec - d  # the change the trial makes, in noise units
            ok = np.isfinite(dvec)
            if not ok.all() or not np.any(dvec):
                cand.note = "probe failed (the platform stopped)" if not ok.all() else \
                    "no effect on the measured channels"
                continue
            dd = float(np.dot(dvec, dvec))
            rd = float(np.dot(rvec, dvec))
            cand.share = rd * rd / (rr * dd) if rr > 0 and dd > 0 else 0.0
            for c in self.channels:
                a = r0[c][tr]
                b = (r0[c] - rp[c])[tr]
                den = float(np.dot(a, a) * np.dot(b, b))
                cand.channel_share[c] = float(np.dot(a, b)) ** 2 / den if den > 0 else 0.0
            deltas[lab] = dvec
            if lab in MULTI:
                est[lab] = 1.0
                gain[lab] = rr - float(np.dot(d, d))
                continue
            eff = get_effect(lab.split(".")[0])
            off, p = eff.param.off, probes[lab]
            alpha = rd / dd
            if math.isinf(off):
                # no linear scale from an infinite off value: a second point beside the
                # probe, so that the secant refit has a slope
                v = 0.95 * p if alpha > 0.5 else eff.param.hi
            else:
                v = off + alpha * (p - off)
            est[lab] = float(np.clip(v, eff.param.lo, eff.param.hi))
            gain[lab] = rd * rd / dd
        order = sorted(gain, key=lambda k: -gain[k])
        top = [k for k in order if k not in MULTI][: self.refit]
        # the best single-parameter candidates: simulated at the linear estimate, then one
        # batched secant step; the better of the two (training error) is kept
        self.progress(f"refit {len(top)} candidates")
        first = dict(zip(top, self.outputs([{**self.accepted, k: est[k]} for k in top]),
                         strict=True))
        second_v: dict[str, float] = {}
        for k in top:
            eff = get_effect(k.split(".")[0])
            p, v = probes[k], est[k]
            rv = self._vec(self._res(first[k]), tr)
            if v == p or not np.all(np.isfinite(rv)):
                continue
            J = (rv - self._vec(self._res(outs[k]), tr)) / (v - p)  # secant d(residual)/dθ
            jj = float(np.dot(J, J))
            if jj > 0:
                second_v[k] = float(np.clip(v - float(np.dot(J, rv)) / jj, eff.param.lo,
                                            eff.param.hi))
        second = dict(zip(second_v, self.outputs(
            [{**self.accepted, k: v} for k, v in second_v.items()]), strict=True))
        self.progress("rank")
        fin: dict[str, dict[str, np.ndarray]] = {}
        final_sets: dict[str, dict[str, float]] = {}
        for k in top:
            o1, o2 = first[k], second.get(k)
            e1 = self._vec(self._res(o1), tr)
            use2 = o2 is not None and np.all(np.isfinite(self._vec(self._res(o2), tr))) and \
                float(np.dot(*(2 * [self._vec(self._res(o2), tr)]))) < float(np.dot(e1, e1))
            fin[k] = o2 if use2 else o1
            final_sets[k] = {**self.accepted, k: second_v[k] if use2 else est[k]}
        for k in cands:
            if k in MULTI and k in trials and k in deltas:
                fin[k], final_sets[k] = outs[k], trials[k]
        for k, (cand, out) in revs.items():  # revisions of the description: replayed once
            cands[k], fin[k], final_sets[k] = cand, out, dict(self.accepted)
        lin: dict[str, dict[str, np.ndarray]] = {}
        for k in cands:
            if k in fin or k not in est or k in MULTI:
                continue
            # not refitted: the linear prediction along the probe's sensitivity, on every
            # sample (the validation blocks included)
            eff = get_effect(k.split(".")[0])
            p, off = probes[k], eff.param.off
            a = 1.0 if math.isinf(off) else (est[k] - off) / (p - off)
            rp = self._res(outs[k])
            lin[k] = {c: r0[c] - a * (r0[c] - rp[c]) for c in self.channels}
            final_sets[k] = {**self.accepted, k: est[k]}
        fitted_changes: dict[str, np.ndarray] = {}
        for k in list(fin) + list(lin):
            cand = cands[k]
            r1 = self._res(fin[k]) if k in fin else lin[k]
            v1 = self._vec(r1, va)
            if not np.all(np.isfinite(v1)):
                cand.note = "the platform stopped at the fitted value"
                continue
            cand.fitted = k in fin
            cand.train_before, cand.error_before = e_tr0, e_va0
            cand.train_after = self._error(r1, tr)
            cand.error_after = self._error(r1, va)
            sse1 = float(np.dot(v1, v1))
            cand.score = neff * math.log(sse0 / sse1) - cand.k * math.log(neff) \
                if sse1 > 0 and sse0 > 0 else -math.inf
            g = 1.0 - (cand.error_after / cand.error_before) ** 2 if cand.error_before else 0.0
            if is_revision(k):
                excludes = self._revs[k].excludes_current(self.scene)
            elif k in MULTI:
                cand.values = {lab: final_sets[k][lab] for lab in trials[k]
                               if lab not in self.accepted}
                excludes = True
            else:
                cand.value = final_sets[k][k]
                eff = get_effect(k.split(".")[0])
                J = (self._vec(r1, tr) - rvec) / (cand.value - eff.param.off) \
                    if not math.isinf(eff.param.off) and cand.value != eff.param.off else None
                if J is not None and np.dot(J, J) > 0:
                    rt = self._vec(r1, tr)
                    s2 = float(np.dot(rt, rt)) / max(rt.size - 1, 1) / max(
                        float(np.mean(list(white.values()))), 1e-3)
                    sd = math.sqrt(s2 / float(np.dot(J, J)))
                    cand.ci = (cand.value - 1.96 * sd, cand.value + 1.96 * sd)
                    excludes = not (cand.ci[0] <= eff.param.off <= cand.ci[1])
                else:
                    cand.ci = (cand.value, cand.value)
                    excludes = math.isinf(eff.param.off) and cand.value < eff.param.hi
            cand.significant = bool(cand.fitted and cand.score > 0 and g >= self.min_gain
                                    and excludes)
            if not cand.significant:
                cand.note = "; ".join(s for s in (
                    "not refitted (linear estimate)" if not cand.fitted else "",
                    "ΔIC ≤ 0" if cand.score <= 0 else "",
                    f"validation gain {g:.2%} < {self.min_gain:.0%}" if g < self.min_gain
                    else "", "interval includes off" if not excludes else "") if s)
            fitted_changes[k] = self._vec(r0, tr) - self._vec(r1, tr)
        ranked = sorted(cands.values(), key=lambda c: (
            -(c.score if math.isfinite(c.score) else -1e300), -c.share))
        confounded = []
        names = [c.effect for c in ranked if c.fitted and c.significant][:8]
        for i, a in enumerate(names):
            for b in names[i + 1:]:
                x, y = fitted_changes[a], fitted_changes[b]
                den = math.sqrt(float(np.dot(x, x) * np.dot(y, y)))
                if den > 0 and abs(float(np.dot(x, y)) / den) >= 0.95:
                    confounded.append((a, b, float(np.dot(x, y)) / den))
        proposal = next((c for c in ranked if c.significant), None)
        chan_rms = {c: float(np.sqrt(np.mean((r0[c][1:] * self.sigma[c]) ** 2)))
                    for c in self.channels}
        noise_like = e_va0 <= NOISE_LIKE
        partly = False
        remaining: dict[str, Any] = {}
        if proposal is not None:
            after = self._res(fin[proposal.effect])
            if proposal.error_after > NOISE_LIKE:
                partly = True
                remaining = remaining_structure(after, self, self.channels)
        elif not noise_like:
            remaining = remaining_structure(r0, self, self.channels)
            partly = bool(self.accepted)
        return RoundResult(ranked, dict(self.accepted), proposal is None and noise_like,
                           proposal, confounded, e_tr0, e_va0, chan_rms, dict(self.sigma),
                           white, partly, remaining)

    def _probe(self, label: str) -> float:
        """The probe value of a candidate: a typical magnitude; a speed limit at 80 % of the
        peak set-point speed of its leg."""
        name, leg, _ = parse_label(label)
        eff = get_effect(name)
        if name == "velocity_saturation":
            from ..platform.kinematics import inverse_kinematics

            L = inverse_kinematics(self.scene_geometry, self.replay.poses)
            v = np.abs(np.diff(L, axis=0)) / self.dt
            legs = range(6) if leg < 0 else [leg]
            vc = max(float(v[:, i].max()) for i in legs)
            guess = 0.8 * vc
            # signature: the encoders' peak speed (over 5 samples, so the noise averages)
            # below the commanded one is the limit itself
            m = 5
            enc = [f"leg_len.{i}" for i in legs if f"leg_len.{i}" in self.measured]
            if enc:
                vm = max(float(np.percentile(np.abs(
                    self.measured[c][m:] - self.measured[c][:-m]) / (m * self.dt), 99.8))
                         for c in enc)
                if vm < 0.97 * vc:
                    guess = vm
            return float(np.clip(guess, eff.param.lo, eff.param.hi))
        return eff.probe_value()

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
        for e in _configs(self.accepted):
            effects[e.label] = e
        return dataclasses.replace(self.scene, effects=tuple(effects.values()))

