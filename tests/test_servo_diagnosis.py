"""The diagnosis screens the servo it was told about (rths3d.diagnose.candidates.servo): the
place of the lag, its value and the delay's value, both ways from the statement; and a
revision that contradicts what the scene states is accepted only when it is decisive
(rths3d.diagnose.candidates.DECISIVE, docs/diagnosis.md)."""

from __future__ import annotations

import math

import pytest

from rths3d.diagnose import Diagnosis, measure
from rths3d.diagnose.candidates import DECISIVE, DESCRIPTIONS, PREFIX, contradicted
from rths3d.diagnose.result import NOISE_LIKE, Candidate
from rths3d.diagnose.rounds import _weigh_statement
from rths3d.scene import load_scene

DUR = "duration=1.5"  # s of record: the bench6 multisine's first 1.5 s


def _stated(**kw: object) -> list[str]:
    """Overrides stating ``kw`` in the scene's [controller] table (the servo's numbers in
    [transfer] too, where bench6 sets them)."""
    out = [DUR]
    for k, v in kw.items():
        out.append(f"controller.{k}={v!r}")
        if k in ("timeconst", "delay"):
            out.append(f"transfer.{k}={v!r}")
    return out


@pytest.fixture(scope="module")
def servo_record():
    """A bench6 record of a bench whose 3 ms lag sits after the hold, 1 ms of delay."""
    truth = load_scene("bench6", _stated(lag="servo", timeconst=0.003, delay=0.001))
    return measure(truth, {}, seed=3)


def _diagnose(record, **stated: object) -> Diagnosis:
    sc = load_scene("bench6", _stated(**stated))
    return Diagnosis(record, sc, candidates=["servo_gain.leg0", "actuator_lag.leg1",
                                             "delay.leg2"], refit=3,
                     descriptions=("servo", "controller"))


def test_servo_candidate_revises_both_ways():
    """For a stated 3 ms lag before the hold and 1 ms delay: the other place, the lag halved
    and 1.5 times, the delay halved and 1.5 times, each one revision (k = 1) refined along
    its line; without a stated lag only upward steps (half a sample) and no place."""
    sc = load_scene("bench6", _stated(timeconst=0.003, delay=0.001))
    revs = DESCRIPTIONS["servo"].revisions(sc, {}, 1e-3)
    got = sorted((k, v) for r in revs for k, v in r.changes.items())
    assert got == sorted([("controller.lag", "servo"), ("transfer.timeconst", 0.0015),
                          ("transfer.timeconst", 0.0045), ("transfer.delay", 0.0005),
                          ("transfer.delay", 0.0015)])
    assert all(r.k == 1 for r in revs)
    assert all(r.refine for r in revs if "controller.lag" not in r.changes)
    bare = DESCRIPTIONS["servo"].revisions(load_scene("bench6", [DUR]), {}, 1e-3)
    assert sorted((k, v) for r in bare for k, v in r.changes.items()) == [
        ("transfer.delay", 0.0005), ("transfer.timeconst", 0.0005)]


def test_statements_are_the_controller_tables_keys():
    """Only what the scene's [controller] table sets is a statement: a revision of an unstated
    key contradicts nothing, of a stated one names the stated and the revised value."""
    sc = load_scene("bench6", _stated(timeconst=0.003))
    assert contradicted(sc, {"controller.lag": "servo"}) == {}
    assert contradicted(sc, {"transfer.timeconst": 0.002}) == {
        "transfer.timeconst": (0.003, 0.002)}
    assert contradicted(sc, {"transfer.timeconst": 0.003}) == {}


@pytest.mark.parametrize("e0,e1,ok", [(10.0, 3.25, True), (10.0, 3.3, False),
                                      (10.0, 1.0, True), (5.0, 4.5, False)])
def test_decisive_rule(e0, e1, ok):
    """A contradicting revision is decisive when it removes at least 75 % of the validation
    error's excess over noise: (e0 − e1)/(e0 − 1) ≥ 0.75; the evidence says by how much."""
    c = Candidate(PREFIX + "x", "scene", "", error_before=e0, error_after=e1)
    assert _weigh_statement(c, {"transfer.delay": (0.002, 0.001)}) is ok
    share = (e0 - e1) / (e0 - 1)
    assert c.evidence == (
        "contradicts your description: stated transfer.delay = 0.002, the measurement says "
        f"0.001, by validation error {e0:.3g} → {e1:.3g} noise units ({share:.0%} of the "
        "excess over noise)")
    assert ("not decisive" in c.note) is (not ok)
    assert _weigh_statement(Candidate("y", "", ""), {}) is True  # nothing contradicted
    assert DECISIVE == 0.75


@pytest.mark.parametrize("place", [None, "setpoint"])
def test_lag_place_unstated_is_found_first(servo_record, place):
    """Described with the right lag and delay but without their place (a user who does not
    know it), or with the place stated wrong (``lag = "setpoint"``): the place is proposed
    first and the record ends at noise; the stated place is contradicted decisively and the
    proposal says so."""
    kw = {} if place is None else {"lag": place}
    d = _diagnose(servo_record, timeconst=0.003, delay=0.001, **kw)
    r = d.run()
    assert r.error_val > 5.0  # noise units: the place matters
    assert r.proposal is not None and r.proposal.effect == PREFIX + "controller.lag=servo"
    if place is None:
        assert not r.proposal.evidence  # the place was not stated: nothing contradicted
    else:
        assert r.proposal.evidence.startswith(
            "contradicts your description: stated controller.lag = 'setpoint', the "
            "measurement says 'servo'")
    d.revise(r.proposal.effect)
    r2 = d.run()
    assert r2.error_val <= NOISE_LIKE and r2.proposal is None


@pytest.mark.parametrize("key,stated,true", [("timeconst", 0.006, 0.003),
                                             ("delay", 0.002, 0.001)])
def test_overstated_lag_or_delay_is_corrected_down(servo_record, key, stated, true):
    """A lag or a delay stated twice what the bench has is revised down to it (within
    10 %), as a decisive contradiction of the statement reported with both values — not
    absorbed by gains — and the record ends at noise."""
    kw = {"lag": "servo", "timeconst": 0.003, "delay": 0.001}
    kw[key] = stated
    d = _diagnose(servo_record, **kw)
    r = d.run()
    p = r.proposal
    assert p is not None and p.effect.startswith(PREFIX + f"transfer.{key}=")
    v = p.changes[f"transfer.{key}"]
    assert math.isclose(v, true, rel_tol=0.1), v
    assert p.evidence.startswith(f"contradicts your description: stated transfer.{key} = "
                                 f"{stated!r}, the measurement says {v!r}")
    d.revise(p.effect)
    assert d.revisions[-1]["evidence"] == p.evidence
    assert d.run().error_val <= NOISE_LIKE


def test_correct_statements_survive_an_unexplained_record():
    """A bench described right whose legs have friction no candidate offers: the best
    candidates are revisions contradicting the stated servo, which explain a little (ΔIC > 0,
    a validation gain of several %) but not decisively — none is accepted, in --auto as
    well, and the stated description is unchanged."""
    stated = _stated(lag="servo", timeconst=0.003, delay=0.001, gravity="nominal",
                     feedforward="backward", hold="ramp")
    truth = load_scene("bench6", stated)
    rec = measure(truth, {"viscous_friction.leg1": 300.0, "coulomb_friction.leg3": 20.0},
                  seed=4)
    d = Diagnosis(rec, truth, candidates=["servo_gain.leg0"], refit=2,
                  descriptions=("servo", "controller"))
    r = d.run()
    top = r.candidates[0]
    assert top.effect.startswith(PREFIX) and top.evidence
    gain = 1 - (top.error_after / top.error_before) ** 2
    assert top.score > 0 and gain > 0.05  # it would pass the other tests
    assert not top.significant and "not decisive" in top.note
    assert r.proposal is None and r.error_val > 5.0
    d.auto(max_rounds=2)
    assert d.revisions == []
    assert d.scene.controller == truth.controller and d.scene.transfer == truth.transfer


def test_correct_null_proposes_nothing_and_keeps_the_statements(servo_record):
    """The bench described right (its 3 ms lag after the hold, 1 ms delay, stated): only
    noise — nothing proposed, and --auto revises no statement (the servo's revisions, both
    ways, are screened and rejected)."""
    d = _diagnose(servo_record, lag="servo", timeconst=0.003, delay=0.001)
    stated = d.scene
    r = d.run()
    assert r.proposal is None and r.error_val <= NOISE_LIKE
    assert any(c.effect.startswith(PREFIX + "transfer.") for c in r.candidates)
    d.auto(max_rounds=2)
    assert d.revisions == [] and d.accepted == {}
    assert d.scene.controller == stated.controller and d.scene.transfer == stated.transfer
