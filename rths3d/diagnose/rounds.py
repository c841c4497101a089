"""One round of the diagnosis: screen every candidate, refit the best, rank them.

1. **screen** (:func:`screen`): the calibrations are fitted from the measured channels and
   every candidate is replayed at its probe value in one batch (spread over the replay's
   threads, :meth:`~.engine.Diagnosis.outputs`); the linear estimate of each value along its
   sensitivity and its predicted error drop follow from the residuals;
2. **refit** (:func:`refit`): the best ``refit`` single-parameter candidates are replayed at
   their linear estimate, then one batched secant step; the better of the two (training
   error) is kept;
3. **rank** (:func:`rank`): every evaluated candidate by the held-out ΔIC, the significance
   tests, the confounded pairs and the verdict (docs/diagnosis.md).

:func:`run_round` times each stage (``RoundResult.seconds``).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..effects import get_effect
from .calibrations import multi
from .candidates import is_revision
from .localise import effective_samples, remaining_structure
from .result import MULTI, NOISE_LIKE, Candidate, RoundResult

if TYPE_CHECKING:
    from .engine import Diagnosis

__all__ = ["Screen", "rank", "refit", "run_round", "screen"]


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


def run_round(diag: Diagnosis) -> RoundResult:
    """Screen every candidate, refit the best ``diag.refit``, rank them (one round), timed."""
    t0 = time.perf_counter()
    n0 = diag.nsim
    s = screen(diag)
    t1 = time.perf_counter()
    fin, final_sets = refit(diag, s)
    t2 = time.perf_counter()
    res = rank(diag, s, fin, final_sets)
    t3 = time.perf_counter()
    res.seconds = {"screen": t1 - t0, "refit": t2 - t1, "rank": t3 - t2, "round": t3 - t0,
                   "simulations": float(diag.nsim - n0), "threads": float(diag.threads)}
    return res


def screen(diag: Diagnosis) -> Screen:
    """Fit the calibrations, replay every other candidate at its probe value (one batch) and
    estimate each value linearly along its sensitivity."""
    base = diag.predict()
    r0 = diag._res(base)
    tr, va = diag.train, diag.val
    rvec = diag._vec(r0, tr)
    rr = float(np.dot(rvec, rvec))
    e_tr0, e_va0 = diag._error(r0, tr), diag._error(r0, va)
    nval = int(va.sum())
    white = {c: effective_samples(r0[c][va]) / nval for c in diag.channels}
    neff = max(2.0, float(np.mean(list(white.values()))) * nval * len(diag.channels))
    sse0 = float(np.dot(diag._vec(r0, va), diag._vec(r0, va)))

    cands: dict[str, Candidate] = {}
    trials: dict[str, dict[str, float]] = {}
    probes: dict[str, float] = {}
    for lab in diag.candidate_names:
        if lab in diag.accepted:
            continue
        if lab in MULTI:
            vals = multi(diag, lab, base)
            if vals:
                cands[lab] = Candidate(lab, "θ", "m" if lab[0] == "k" else "1",
                                       values=vals, k=len(vals))
                trials[lab] = {**diag.accepted, **vals}
                if lab == "kinematic_calibration":
                    cands[lab].detail = diag.kinematic_.report_.lines()
            continue
        name = lab.split(".")[0]
        eff = get_effect(name)
        p = diag._probe(lab)
        probes[lab] = p
        cands[lab] = Candidate(lab, eff.param.name, eff.param.unit)
        trials[lab] = {**diag.accepted, lab: p}
    revs = diag._screen_revisions()
    diag.progress(f"screen {len(trials)} candidates and {len(revs)} revisions")
    outs = dict(zip(trials, diag.outputs(list(trials.values())), strict=True))
    # linear estimate along each probe's sensitivity
    est: dict[str, float] = {}
    gain: dict[str, float] = {}
    deltas: dict[str, np.ndarray] = {}
    for lab, cand in cands.items():
        rp = diag._res(outs[lab])
        d = diag._vec(rp, tr)
        dvec = rvec - d  # the change the trial makes, in noise units
        ok = np.isfinite(dvec)
        if not ok.all() or not np.any(dvec):
            cand.note = "probe failed (the platform stopped)" if not ok.all() else \
                "no effect on the measured channels"
            continue
        dd = float(np.dot(dvec, dvec))
        rd = float(np.dot(rvec, dvec))
        cand.share = rd * rd / (rr * dd) if rr > 0 and dd > 0 else 0.0
        for c in diag.channels:
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
    for lab, (cand, out) in revs.items():
        cands[lab], outs[lab] = cand, out
    return Screen(r0, rvec, e_tr0, e_va0, white, neff, sse0, cands, trials, probes, outs,
                  est, gain, deltas, tuple(revs))


def refit(diag: Diagnosis, s: Screen
          ) -> tuple[dict[str, dict[str, np.ndarray]], dict[str, dict[str, float]]]:
    """The best single-parameter candidates by predicted error drop, replayed at the linear
    estimate and after one secant step (two batches): the replays kept (training error) and
    their effect sets; the calibrations' replays as screened."""
    tr = diag.train
    cands, trials, probes, outs, est, gain = s.cands, s.trials, s.probes, s.outs, s.est, s.gain
    order = sorted(gain, key=lambda k: -gain[k])
    top = [k for k in order if k not in MULTI][: diag.refit]
    # the best single-parameter candidates: simulated at the linear estimate, then one
    # batched secant step; the better of the two (training error) is kept
    diag.progress(f"refit {len(top)} candidates")
    first = dict(zip(top, diag.outputs([{**diag.accepted, k: est[k]} for k in top]),
                     strict=True))
    second_v: dict[str, float] = {}
    for k in top:
        eff = get_effect(k.split(".")[0])
        p, v = probes[k], est[k]
        rv = diag._vec(diag._res(first[k]), tr)
        if v == p or not np.all(np.isfinite(rv)):
            continue
        J = (rv - diag._vec(diag._res(outs[k]), tr)) / (v - p)  # secant d(residual)/dθ
        jj = float(np.dot(J, J))
        if jj > 0:
            second_v[k] = float(np.clip(v - float(np.dot(J, rv)) / jj, eff.param.lo,
                                        eff.param.hi))
    second = dict(zip(second_v, diag.outputs(
        [{**diag.accepted, k: v} for k, v in second_v.items()]), strict=True))
    fin: dict[str, dict[str, np.ndarray]] = {}
    final_sets: dict[str, dict[str, float]] = {}
    for k in top:
        o1, o2 = first[k], second.get(k)
        e1 = diag._vec(diag._res(o1), tr)
        use2 = o2 is not None and np.all(np.isfinite(diag._vec(diag._res(o2), tr))) and \
            float(np.dot(*(2 * [diag._vec(diag._res(o2), tr)]))) < float(np.dot(e1, e1))
        fin[k] = o2 if use2 else o1
        final_sets[k] = {**diag.accepted, k: second_v[k] if use2 else est[k]}
    for k in cands:
        if k in MULTI and k in trials and k in s.deltas:
            fin[k], final_sets[k] = outs[k], trials[k]
    for k in s.revs:  # a revision of the description: replayed once, as screened
        fin[k], final_sets[k] = outs[k], dict(diag.accepted)
    return fin, final_sets


def rank(diag: Diagnosis, s: Screen, fin: dict[str, dict[str, np.ndarray]],
         final_sets: dict[str, dict[str, float]]) -> RoundResult:
    """Every evaluated candidate scored on the validation blocks (the refitted ones from
    their replays, the others by the linear prediction), ranked; the verdict."""
    tr, va = diag.train, diag.val
    r0, rvec, e_tr0, e_va0, white, neff, sse0 = (s.r0, s.rvec, s.e_tr0, s.e_va0, s.white,
                                                  s.neff, s.sse0)
    cands, trials, probes, outs, est = s.cands, s.trials, s.probes, s.outs, s.est
    diag.progress("rank")
    lin: dict[str, dict[str, np.ndarray]] = {}
    for k in cands:
        if k in fin or k not in est or k in MULTI:
            continue
        # not refitted: the linear prediction along the probe's sensitivity, on every
        # sample (the validation blocks included)
        eff = get_effect(k.split(".")[0])
        p, off = probes[k], eff.param.off
        a = 1.0 if math.isinf(off) else (est[k] - off) / (p - off)
        rp = diag._res(outs[k])
        lin[k] = {c: r0[c] - a * (r0[c] - rp[c]) for c in diag.channels}
        final_sets[k] = {**diag.accepted, k: est[k]}
    fitted_changes: dict[str, np.ndarray] = {}
    for k in list(fin) + list(lin):
        cand = cands[k]
        r1 = diag._res(fin[k]) if k in fin else lin[k]
        v1 = diag._vec(r1, va)
        if not np.all(np.isfinite(v1)):
            cand.note = "the platform stopped at the fitted value"
            continue
        cand.fitted = k in fin
        cand.train_before, cand.error_before = e_tr0, e_va0
        cand.train_after = diag._error(r1, tr)
        cand.error_after = diag._error(r1, va)
        sse1 = float(np.dot(v1, v1))
        cand.score = neff * math.log(sse0 / sse1) - cand.k * math.log(neff) \
            if sse1 > 0 and sse0 > 0 else -math.inf
        g = 1.0 - (cand.error_after / cand.error_before) ** 2 if cand.error_before else 0.0
        if is_revision(k):
            excludes = diag._revs[k].excludes_current(diag.scene)
        elif k in MULTI:
            cand.values = {lab: final_sets[k][lab] for lab in trials[k]
                           if lab not in diag.accepted}
            excludes = True
        else:
            cand.value = final_sets[k][k]
            eff = get_effect(k.split(".")[0])
            J = (diag._vec(r1, tr) - rvec) / (cand.value - eff.param.off) \
                if not math.isinf(eff.param.off) and cand.value != eff.param.off else None
            if J is not None and np.dot(J, J) > 0:
                rt = diag._vec(r1, tr)
                s2 = float(np.dot(rt, rt)) / max(rt.size - 1, 1) / max(
                    float(np.mean(list(white.values()))), 1e-3)
                sd = math.sqrt(s2 / float(np.dot(J, J)))
                cand.ci = (cand.value - 1.96 * sd, cand.value + 1.96 * sd)
                excludes = not (cand.ci[0] <= eff.param.off <= cand.ci[1])
            else:
                cand.ci = (cand.value, cand.value)
                excludes = math.isinf(eff.param.off) and cand.value < eff.param.hi
        cand.significant = bool(cand.fitted and cand.score > 0 and g >= diag.min_gain
                                and excludes)
        if not cand.significant:
            cand.note = "; ".join(s for s in (
                "not refitted (linear estimate)" if not cand.fitted else "",
                "ΔIC ≤ 0" if cand.score <= 0 else "",
                f"validation gain {g:.2%} < {diag.min_gain:.0%}" if g < diag.min_gain
                else "", "interval includes off" if not excludes else "") if s)
        fitted_changes[k] = diag._vec(r0, tr) - diag._vec(r1, tr)
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
    chan_rms = {c: float(np.sqrt(np.mean((r0[c][1:] * diag.sigma[c]) ** 2)))
                for c in diag.channels}
    noise_like = e_va0 <= NOISE_LIKE
    partly = False
    remaining: dict[str, Any] = {}
    if proposal is not None:
        after = diag._res(fin[proposal.effect])
        if proposal.error_after > NOISE_LIKE:
            partly = True
            remaining = remaining_structure(after, diag, diag.channels)
    elif not noise_like:
        remaining = remaining_structure(r0, diag, diag.channels)
        partly = bool(diag.accepted)
    return RoundResult(ranked, dict(diag.accepted), proposal is None and noise_like,
                       proposal, confounded, e_tr0, e_va0, chan_rms, dict(diag.sigma),
                       white, partly, remaining)
