"""A diagnosis round batched over threads: the replays cut into one batch per thread give the
same channels, and the same ranking, as one batch on one thread; the round reports its time
per stage."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rths3d.diagnose import Diagnosis, measure
from rths3d.diagnose.report import write_report
from rths3d.scene import load_scene

CANDIDATES = ["coulomb_friction.leg1", "coulomb_friction.leg2", "delay.leg2",
              "actuator_lag.leg3", "servo_gain.leg0", "viscous_friction.leg4",
              "fts_gain.fz", "fts_calibration"]


@pytest.fixture(scope="module")
def record():
    sc = load_scene("bench6", ["duration=1.0"])
    return measure(sc, {"coulomb_friction.leg2": 30.0}, seed=5)


def test_threaded_round_equals_one_batch_and_reports_its_time(record, tmp_path):
    """Two threads (the screening's 7 replays and the refits' cut into two batches each)
    against one thread (one batch): every replayed channel equal to the last bit, the same
    candidates in the same order with the same fitted values; the round's stages timed."""
    # the effects' round alone: the description's revisions (screened every round by
    # default) are tested in test_description_candidates.py
    one = Diagnosis(record, candidates=CANDIDATES, nthread=1, refit=4, descriptions=())
    two = Diagnosis(record, candidates=CANDIDATES, nthread=2, refit=4, descriptions=())
    assert (one.threads, two.threads) == (1, 2)
    sets = [{c: one._probe(c)} for c in CANDIDATES if c != "fts_calibration"]
    for screen in (False, True):  # the reference replays, and the screening's probes
        a, b = one.outputs(sets, screen=screen), two.outputs(sets, screen=screen)
        for x, y in zip(a, b, strict=True):
            assert set(x) == set(y)
            for ch in x:
                np.testing.assert_array_equal(x[ch], y[ch], err_msg=ch)
    n0 = two.nsim
    ra, rb = one.run(), two.run()
    assert [c.effect for c in ra.candidates] == [c.effect for c in rb.candidates]
    for c1, c2 in zip(ra.candidates, rb.candidates, strict=True):
        assert (c1.value == c2.value) or (math.isnan(c1.value) and math.isnan(c2.value))
        assert c1.score == c2.score
    assert rb.candidates[0].effect == "coulomb_friction.leg2"
    t = rb.seconds
    assert set(t) == {"screen", "refit", "rank", "round", "simulations", "threads"}
    assert all(t[k] > 0 for k in ("screen", "refit", "rank"))
    # the stages cover the round: their sum is the round's time within the timer's calls
    assert t["screen"] + t["refit"] + t["rank"] == pytest.approx(t["round"], abs=1e-3)
    # the screening's replays were cached above: the round replays only its refits (two
    # secant steps of at most 4 candidates)
    assert t["simulations"] == two.nsim - n0 and 1 <= t["simulations"] <= 8
    assert t["threads"] == 2
    assert rb.as_dict()["seconds"] == t
    text = write_report(two, rb, tmp_path / "rep").read_text()
    assert f"- round time: {t['round']:.1f} s" in text


def test_a_revision_that_is_the_same_physics_as_the_best_effect_ranks_first():
    """An extra mass on a rigid part and its stated mass revised explain a record alike
    (fitted changes correlated 1.0): the revision goes first when its validation error is
    within 2 % of the effect's (measured on a foreign bench: 1.0087 against 1.0014); not when
    it explains clearly less, nor when the two are different physics."""
    from rths3d.diagnose.candidates import PREFIX
    from rths3d.diagnose.result import Candidate
    from rths3d.diagnose.rounds import _description_first

    def cands(rev_err: float) -> tuple[list, dict]:
        eff = Candidate("specimen_mass", "dm", "1", error_after=1.0014, significant=True)
        rev = Candidate(PREFIX + "experiment.m=3.9945", "θ", "1", error_after=rev_err,
                        significant=True)
        other = Candidate("fts_gain.fz", "g", "1", error_after=6.3, significant=True)
        return [eff, rev, other], {c.effect: c for c in (eff, rev, other)}

    for rev_err, rho, first in ((1.0087, 0.99999, PREFIX + "experiment.m=3.9945"),
                                (1.05, 0.99999, "specimen_mass"),
                                (1.0087, 0.9, "specimen_mass")):
        ranked, by = cands(rev_err)
        _description_first(ranked, by, [("specimen_mass", PREFIX + "experiment.m=3.9945",
                                         rho)])
        assert ranked[0].effect == first, (rev_err, rho)
        assert len(ranked) == 3


def test_screening_through_implicitfast_sees_the_changes_rk4_sees(record):
    """The screening's probes through implicitfast, anchored on the RK4 replay: each probe's
    change (every channel in noise units, as the screen pools them) within 6 % of the change
    two RK4 replays give (measured: 0.1–4.4 %, Coulomb friction the largest), although the
    implicitfast replay itself is off the RK4 one by more than twice that error; the round
    ranks as the all-RK4 round does (the same refitted candidates in the same order, the
    hidden friction first, its value within 0.5 % and within 5 % of the hidden 30 N)."""
    fast = Diagnosis(record, candidates=CANDIDATES, refit=4, descriptions=())
    ref = Diagnosis(record, candidates=CANDIDATES, refit=4, descriptions=(),
                    screen_integrator="RK4")
    assert fast.screen_integrator == "implicitfast"
    sets = [{c: fast._probe(c)} for c in CANDIDATES if c != "fts_calibration"]
    base = ref.predict()
    got = fast.outputs(sets, screen=True)
    want = ref.outputs(sets, screen=True)  # RK4 screening: the reference replays themselves
    assert all(w is r for w, r in zip(want, ref.outputs(sets), strict=True))
    raw = fast._outputs([{}], fast._screen_replay(), "screen")[0]  # implicitfast alone

    def pooled(d: dict) -> np.ndarray:
        return np.concatenate([d[ch] / fast.sigma[ch] for ch in fast.channels])

    off = np.linalg.norm(pooled(raw) - pooled(base))
    for s, g, w in zip(sets, got, want, strict=True):
        dw, dg = pooled(w) - pooled(base), pooled(g) - pooled(base)
        err = np.linalg.norm(dg - dw)
        assert err <= 0.06 * np.linalg.norm(dw), (s, err / np.linalg.norm(dw))
        assert off > 2 * err, (s, off, err)
    ra, rb = fast.run(), ref.run()
    order = [c.effect for c in ra.candidates if c.fitted]
    assert order == [c.effect for c in rb.candidates if c.fitted]
    assert ra.candidates[0].effect == rb.candidates[0].effect == "coulomb_friction.leg2"
    assert ra.candidates[0].value == pytest.approx(rb.candidates[0].value, rel=5e-3)
    assert ra.candidates[0].value == pytest.approx(30.0, rel=0.05)  # the hidden value, N


def test_unknown_screen_integrator_names_the_field(record):
    from rths3d.errors import ConfigError

    with pytest.raises(ConfigError, match="screen_integrator: 'Euler'"):
        Diagnosis(record, candidates=CANDIDATES, screen_integrator="Euler")


def test_detection_limit_and_the_unexplained_summary():
    """The detection limit: the effect (RMS of its signature, noise units) that, added to a
    residual at e₀, removes 75 % of the excess over noise when taken out — e′ = 4e₀ − 3,
    √(e′² − e₀²): 35.6 σ at 10, 5.6 σ at 2.26, 0 at the noise level. The JSON summary of an
    unexplained round carries the residual's excess, the limit and what was not proposed;
    a round without a limit writes null, not NaN."""
    import json

    from rths3d.diagnose.result import RoundResult
    from rths3d.diagnose.rounds import detection_limit

    assert detection_limit(10.0) == pytest.approx(math.sqrt(37.0 ** 2 - 100.0))
    assert detection_limit(10.0) == pytest.approx(35.62, abs=0.01)
    assert detection_limit(2.26) == pytest.approx(5.60, abs=0.01)
    assert detection_limit(1.0) == 0.0
    r = RoundResult([], {}, False, None, [], 10.5, 10.0, {}, {}, detection_limit=35.62,
                    absorbed={"viscous_friction": 0.37})
    d = json.loads(json.dumps(r.as_dict()))
    assert r.status == "unexplained"
    assert d["systematic_sigma"] == pytest.approx(math.sqrt(99.0))
    assert d["detection_limit"] == 35.62 and d["absorbed"] == {"viscous_friction": 0.37}
    quiet = RoundResult([], {}, True, None, [], 1.0, 1.0, {}, {})
    assert json.loads(json.dumps(quiet.as_dict(), allow_nan=False))["detection_limit"] is None
