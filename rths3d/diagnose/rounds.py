"""One round of the diagnosis: screen every candidate, refit the best, rank them.

1. **screen** (:meth:`RoundStages._screen`): the calibrations are fitted from the measured
   channels and every candidate is replayed at its probe value in one batch (spread over the
   replay's threads, :meth:`~.engine.Diagnosis.outputs`); the linear estimate of each value
   along its sensitivity and its predicted error drop follow from the residuals;
2. **refit** (:meth:`RoundStages._refit`): the best ``refit`` single-parameter candidates
   are replayed at their linear estimate, then one batched secant step; the better of the
   two (training error) is kept;
3. **rank** (:meth:`RoundStages._rank`): every evaluated candidate by the held-out ΔIC, the
   significance tests, the confounded pairs and the verdict (docs/diagnosis.md).

:meth:`RoundStages.run` times each stage (``RoundResult.seconds``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..effects import get_effect, parse_label
from .candidates import DECISIVE, contradicted, is_revision
from .localise import effective_samples, remaining_structure
from .result import MULTI, NOISE_LIKE, Candidate, RoundResult

__all__ = ["RoundStages", "Screen"]


@dataclass
class Screen:
    """What the screening found: the baseline residual and its figures, the candidates,
    their trial effect sets, probe values and replays, linear estimates, predicted error
    drops (``gain``) and residual changes (``deltas``, training samples, noise units)."""

    r0: dict[str, np.ndarray]
    rvec: np.ndarray
    e_tr0: float
    e_va0: float
    white: dict[str, float]
    neff: float
    sse0: float
    cands: dict[str, Candidate]
    trials: dict[str, dict[str, float]]
    probes: dict[str, float]
    outs: dict[str, dict[str, np.ndarray]]
    est: dict[str, float]
    gain: dict[str, float]
    deltas: dict[str, np.ndarray]
    revs: tuple[str, ...] = ()
    """The revisions of the description screened (each replayed once, in ``outs``)."""


class RoundStages:
    """The round of a :class:`~.engine.Diagnosis` (which derives from this class): its
    replays (``outputs``, ``_res``, ``_vec``, ``_error``), samples (``train``, ``val``),
    candidates and calibrations (``_multi``) are the diagnosis' own."""

    def run(self) -> RoundResult:
        """Screen every candidate, refit the best ``refit``, rank them (one round); the
        stages timed in ``RoundResult.seconds``."""
        t0 = time.perf_counter()
        n0 = self.nsim
        s = self._screen()
        t1 = time.perf_counter()
        fin, final_sets = self._refit(s)
        t2 = time.perf_counter()
        res = self._rank(s, fin, final_sets)
        t3 = time.perf_counter()
        res.seconds = {"screen": t1 - t0, "refit": t2 - t1, "rank": t3 - t2, "round": t3 - t0,
                       "simulations": float(self.nsim - n0), "threads": float(self.threads)}
        return res

    def _screen(self) -> Screen:
        """Fit the calibrations, replay every other candidate at its probe value (one batch)
        and estimate each value linearly along its sensitivity."""
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
        # the probes of single-parameter candidates through the screening integrator (their
        # changes are all the screen uses); the calibrations as fitted, with the reference
        outs: dict[str, dict[str, np.ndarray]] = {}
        for screen in (True, False):
            labs = [k for k in trials if (k not in MULTI) == screen]
            outs.update(zip(labs, self.outputs([trials[k] for k in labs], screen=screen),
                            strict=True))
        # linear estimate along each probe's sensitivity
        est: dict[str, float] = {}
        gain: dict[str, float] = {}
        deltas: dict[str, np.ndarray] = {}

        def estimate(lab: str, cand: Candidate) -> None:
            rp = self._res(outs[lab])
            d = self._vec(rp, tr)
            dvec = rvec - d  # the change the trial makes, in noise units
            ok = np.isfinite(dvec)
            if not ok.all() or not np.any(dvec):
                cand.note = "probe failed (the platform stopped)" if not ok.all() else \
                    "no effect on the measured channels"
                return
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
                return
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

        for lab, cand in cands.items():
            estimate(lab, cand)
        # an anchor off its drawn place lengthens its leg as an encoder offset does, plus
        # a part that changes with the pose: where a leg's offset leads the screen, that
        # leg's anchors are screened too (one more batch), so the offset does not take
        # what the anchor did
        extra = self._anchor_followups(gain)
        if extra:
            for lab in extra:
                eff = get_effect(lab.split(".")[0])
                probes[lab] = self._probe(lab)
                cands[lab] = Candidate(lab, eff.param.name, eff.param.unit)
                trials[lab] = {**self.accepted, lab: probes[lab]}
            self.progress(f"screen {len(extra)} anchors of the leading leg")
            outs.update(zip(extra, self.outputs([trials[k] for k in extra], screen=True),
                            strict=True))
            for lab in extra:
                estimate(lab, cands[lab])
        for lab, (cand, out) in revs.items():
            cands[lab], outs[lab] = cand, out
        return Screen(r0, rvec, e_tr0, e_va0, white, neff, sse0, cands, trials, probes, outs,
                      est, gain, deltas, tuple(revs))

    def _anchor_followups(self, gain: dict[str, float]) -> list[str]:
        """The follow-up candidates (:attr:`Effect.followups`) of the leg whose effect has the
        largest predicted error drop of the single-parameter candidates, not yet screened:
        for an encoder offset ``base_anchor.leg{i}.{x,y,z}`` and ``top_anchor.leg{i}.{x,y,z}``."""
        single = [k for k in gain if k not in MULTI and not is_revision(k)]
        if not single:
            return []
        name, leg, _ = parse_label(max(single, key=lambda k: gain[k]))
        if leg < 0:
            return []
        return [lab for lab in (f"{f}.leg{leg}.{ax}" for f in get_effect(name).followups
                                for ax in get_effect(f).axes)
                if lab not in gain and lab not in self.accepted]

    def _refit(self, s: Screen
               ) -> tuple[dict[str, dict[str, np.ndarray]], dict[str, dict[str, float]]]:
        """The best single-parameter candidates by predicted error drop, replayed at the linear
        estimate and after one secant step (two batches): the replays kept (training error) and
        their effect sets; the calibrations' replays as screened."""
        tr = self.train
        cands, trials, probes, outs, est, gain = s.cands, s.trials, s.probes, s.outs, s.est, s.gain
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
            if k in MULTI and k in trials and k in s.deltas:
                fin[k], final_sets[k] = outs[k], trials[k]
        for k in s.revs:  # a revision of the description: replayed once, as screened
            fin[k], final_sets[k] = outs[k], dict(self.accepted)
        return fin, final_sets

    def _rank(self, s: Screen, fin: dict[str, dict[str, np.ndarray]],
              final_sets: dict[str, dict[str, float]]) -> RoundResult:
        """Every evaluated candidate scored on the validation blocks (the refitted ones from
        their replays, the others by the linear prediction), ranked; the verdict."""
        tr, va = self.train, self.val
        r0, rvec, e_tr0, e_va0, white, neff, sse0 = (s.r0, s.rvec, s.e_tr0, s.e_va0, s.white,
                                                      s.neff, s.sse0)
        cands, trials, probes, outs, est = s.cands, s.trials, s.probes, s.outs, s.est
        self.progress("rank")
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
            decisive = True
            if is_revision(k):
                decisive = _weigh_statement(cand, contradicted(self.scene, cand.changes))
                self._evidence[k] = cand.evidence
            cand.significant = bool(cand.fitted and cand.score > 0 and g >= self.min_gain
                                    and excludes and decisive)
            if not cand.significant:
                cand.note = "; ".join(s for s in (
                    "not refitted (linear estimate)" if not cand.fitted else "",
                    "ΔIC ≤ 0" if cand.score <= 0 else "",
                    f"validation gain {g:.2%} < {self.min_gain:.0%}" if g < self.min_gain
                    else "", "interval includes off" if not excludes else "",
                    cand.note if not decisive else "") if s)
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
        _description_first(ranked, cands, confounded)
        proposal = next((c for c in ranked if c.significant), None)
        absorbed: dict[str, float] = {}
        if proposal is not None and not _explains(proposal, e_va0):
            # (at the noise level already there is nothing for several to explain)
            joint = self._joint(proposal, s, fin) if e_va0 > NOISE_LIKE else None
            if joint is not None and _share(e_va0, joint[1]) >= DECISIVE:
                proposal.detail.append(
                    "explains the record jointly with " + ", ".join(joint[0]) +
                    f": validation error {e_va0:.3g} → {joint[1]:.3g} noise units")
            else:
                # no candidate takes the record most of the way to noise, alone or with
                # the next ones: what they would absorb is part of a residual the library
                # does not explain, and their estimates are biased by it
                for c in ranked:
                    if c.significant:
                        c.significant = False
                        absorbed[c.effect] = _share(e_va0, c.error_after)
                        c.note = (f"absorbs {absorbed[c.effect]:.0%} of an unexplained "
                                  f"residual's excess over noise ({DECISIVE:.0%} needed"
                                  + (f"; {joint[1]:.3g} noise units jointly with "
                                     + ", ".join(joint[0][1:]) if joint else "") + ")")
                proposal = None
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
        limit = float("nan")
        if proposal is None and not noise_like:
            limit = detection_limit(e_va0)
        return RoundResult(ranked, dict(self.accepted), proposal is None and noise_like,
                           proposal, confounded, e_tr0, e_va0, chan_rms, dict(self.sigma),
                           white, partly, remaining, detection_limit=limit,
                           absorbed=absorbed)

    def _joint(self, proposal: Candidate, s: Screen, fin: dict[str, dict[str, np.ndarray]]
               ) -> tuple[list[str], float] | None:
        """The proposal fitted jointly with the single-parameter effects that best explain
        what it leaves (greedy, by the projection of the training residual after it on each
        screened candidate's change; up to :data:`JOINT` in all, none nearly parallel to one
        already taken), the accepted effects held: their labels and the validation error
        they leave (noise units); None when the proposal has no such partners (a revision,
        a calibration)."""
        if is_revision(proposal.effect) or proposal.effect in MULTI or \
                proposal.effect not in fin:
            return None
        tr = self.train
        rest = self._vec(self._res(fin[proposal.effect]), tr)
        taken = [s.rvec - rest]
        group = {proposal.effect: proposal.value}
        pool = {k: d for k, d in s.deltas.items()
                if k not in MULTI and not is_revision(k) and k in s.probes
                and k != proposal.effect and np.all(np.isfinite(d)) and np.any(d)}
        while len(group) < JOINT and pool:
            best, best_gain = None, 0.0
            for k, d in pool.items():
                dd = float(np.dot(d, d))
                if any(abs(float(np.dot(d, t))) >= 0.95 * math.sqrt(dd * float(np.dot(t, t)))
                       for t in taken):
                    continue
                g = float(np.dot(rest, d)) ** 2 / dd
                if g > best_gain:
                    best, best_gain = k, g
            if best is None:
                break
            d = pool.pop(best)
            eff = get_effect(best.split(".")[0])
            off, probe = eff.param.off, s.probes[best]
            alpha = float(np.dot(rest, d)) / float(np.dot(d, d))
            if math.isinf(off):
                continue
            group[best] = float(np.clip(off + alpha * (probe - off), eff.param.lo,
                                        eff.param.hi))
            rest = rest - alpha * d
            taken.append(d)
        if len(group) < 2:
            return None
        self.progress("joint fit")
        values, _ = self.fit(group, dict(self.accepted))
        out = self.predict({**self.accepted, **values})
        return list(group), self._error(self._res(out), self.val)


JOINT = 3
"""Candidates fitted together to tell a genuine partial explanation (one of several effects
in the record) from the absorption of a residual the library does not explain."""


def _share(e0: float, e1: float) -> float:
    """The share of the validation error's excess over noise removed, (e0 − e1)/(e0 − 1)."""
    return (e0 - e1) / (e0 - 1.0) if e0 > 1.0 else 0.0


def _explains(cand: Candidate, e0: float) -> bool:
    """Whether a candidate takes the record most of the way to noise (:data:`DECISIVE` of
    the excess over noise, the rule for the scene's statements too) or from above the noise
    level to it (:data:`NOISE_LIKE`). A record at the noise level already needs the former:
    a candidate that removes a sliver of its small excess is no explanation."""
    if _share(e0, cand.error_after) >= DECISIVE:
        return True
    return e0 > NOISE_LIKE and cand.error_after <= NOISE_LIKE


def detection_limit(e0: float) -> float:
    """The smallest effect (the RMS of its signature on the validation blocks, noise units)
    that a diagnosis can still propose on a record whose residual it cannot explain, at
    validation error ``e0``: added to it, the effect must remove :data:`DECISIVE` of the
    excess over noise, e' ≥ (e0 − D)/(1 − D), so its signature is √(e'² − e0²)."""
    if not e0 > 1.0:
        return 0.0
    need = (e0 - DECISIVE) / (1.0 - DECISIVE)
    return math.sqrt(max(need * need - e0 * e0, 0.0))


def _weigh_statement(cand: Candidate, against: dict[str, tuple[Any, Any]]) -> bool:
    """A revision that contradicts the scene's statements (``against``: key → (stated,
    revised)) is decisive when it removes at least :data:`DECISIVE` of the validation
    error's excess over noise; the evidence goes to ``cand.evidence`` (and, when it is not
    decisive, to its note). True when the revision may be accepted."""
    if not against:
        return True
    e0, e1 = cand.error_before, cand.error_after
    share = _share(e0, e1)
    what = "; ".join(f"stated {key} = {old!r}, the measurement says {new!r}"
                     for key, (old, new) in against.items())
    cand.evidence = (f"contradicts your description: {what}, by validation error {e0:.3g} → "
                     f"{e1:.3g} noise units ({share:.0%} of the excess over noise)")
    if share >= DECISIVE:
        return True
    cand.note = (f"contradicts your description and is not decisive ({share:.0%} of the "
                 f"excess over noise removed, {DECISIVE:.0%} needed)")
    return False


def _description_first(ranked: list[Candidate], cands: dict[str, Candidate],
                       confounded: list[tuple[str, str, float]]) -> None:
    """Where the best candidate is an effect and a revision of the description is the same
    physics (its fitted change correlated ≥ 0.99 with the effect's: a rigid part's mass
    stated wrong and an extra mass on it) and explains the record as well (validation error
    within 2 %), the revision ranks first: the stated description is what is wrong, as for
    the controller's conventions (k = 0). In place."""
    top = next((c for c in ranked if c.significant), None)
    if top is None or is_revision(top.effect):
        return
    for a, b, rho in confounded:
        other = b if a == top.effect else a if b == top.effect else None
        if other is None or not is_revision(other) or abs(rho) < 0.99:
            continue
        rev = cands[other]
        if rev.significant and rev.error_after <= 1.02 * top.error_after:
            ranked.remove(rev)
            ranked.insert(ranked.index(top), rev)
            return
