"""Compensators on the MuJoCo Stewart platform: per interface DOF and per leg
(``transfer.compensate``), their start from the predicted delay (``transfer.comp_init``),
their coefficients in records, sweep tables and scenes, and the issue's figures.

Independent paths: leg rates against finite differences of the numpy inverse kinematics,
the per-leg hook's commanded lengths against that inverse kinematics, per-leg delays made
different per leg (the bench's per-leg set-point lags, ``actuator_lag`` effects),
and accuracy against the reference solution z^r (not against the compensator's own view).
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rths3d.compensation import build
from rths3d.config import EffectConfig
from rths3d.errors import ConfigError
from rths3d.loop import run
from rths3d.metrics import compute_measures
from rths3d.platform import DEFAULT_GEOMETRY, inverse_kinematics
from rths3d.scene import load_scene, scene_with
from rths3d.transfer import StewartTransfer, batch_key
from rths3d.transfer.legs import LEG_CHANNELS, leg_channels

DELAY = 0.005  # s, the actuators' transport delay of the issue's must-show
PLATFORM = {"transfer.kind": "stewart", "transfer.delay": DELAY,
            "transfer.compensator.rls.spacing": 0.004}
LEG_TIMECONST = (0.001, 0.002, 0.003, 0.004, 0.005, 0.006)  # s, per leg


def _uneven(scene):
    """The platform with leg servos that differ: each leg's set-point lag from LEG_TIMECONST
    (1…6 ms instead of the common 3 ms), declared as the bench's per-leg ``actuator_lag``
    effects."""
    lags = tuple(EffectConfig("actuator_lag", tc, leg=i) for i, tc in enumerate(LEG_TIMECONST))
    return dataclasses.replace(scene_with(scene, {"transfer.timeconst": 0.0}),
                               effects=scene.effects + lags)


def _scene(name: str, compensation: str, **extra):
    return load_scene(name, {**PLATFORM, "transfer.compensation": compensation, **extra})


def _measures(res) -> dict:
    m = compute_measures(res.record)
    return m["dofs"] if "dofs" in m else {"z": m}


@pytest.fixture(scope="module")
def contact():
    """paper_contact on the platform, 5 ms delay, 6 s (three contacts): e_rel,ref of no
    compensation, ATS per DOF, ATS per leg and RLS per leg, and their records."""
    out = {}
    for key, comp, where in (("none", "none", "interface"), ("ats", "ats", "interface"),
                             ("ats_legs", "ats", "legs"), ("rls_legs", "rls", "legs")):
        res = run(_scene("paper_contact", comp, duration=6.0,
                         **{"transfer.compensate": where}))
        assert res.status == "ok", res.reason
        out[key] = (res, _measures(res)["z"])
    return out


def test_contact_ats_and_per_leg_adaptive_third_of_uncompensated_error(contact):
    """Stewart platform, 5 ms transport delay, paper_contact: ATS and the per-leg adaptive
    compensators (ATS and RLS on each leg) bring e_rel,ref to ≤ 1/3 of no compensation,
    and remove the delay (FEI d < 1 ms against ≈ 7.7 ms)."""
    none = contact["none"][1]
    assert 0.005 < none["fei_d"] < 0.010  # 5 ms transport + the servo's lag
    for key in ("ats", "ats_legs", "rls_legs"):
        m = contact[key][1]
        assert m["e_rel_ref"] <= none["e_rel_ref"] / 3, (key, m["e_rel_ref"], none["e_rel_ref"])
        assert abs(m["fei_d"]) < 1e-3, (key, m["fei_d"])


def test_records_carry_coefficients_over_time_and_meta(contact):
    """Records carry comp.<coef>.<channel> for every channel (legs: leg0…leg5) from the
    initial values in the metadata (the predicted delay: a1 = d, a2 = d²/2) to their final
    ones, and the compensator's name, mode and start in transfer_meta."""
    res = contact["ats_legs"][0]
    rec, meta = res.record, res.record.meta["transfer_meta"]
    cm = meta["compensator"]
    assert (cm["name"], cm["compensate"], cm["init"]) == ("ats", "legs", "predicted")
    assert cm["channels"] == list(LEG_CHANNELS)
    d = meta["predicted_delay"]
    assert cm["initial"]["a1"] == pytest.approx([d] * 6)
    assert cm["initial"]["a2"] == pytest.approx([0.5 * d * d] * 6)
    for i in range(6):
        a1 = rec.columns[f"comp.a1.leg{i}"]
        assert len(a1) == rec.n and a1[0] == pytest.approx(d)
        assert np.ptp(a1) > 1e-5  # it adapted
        assert abs(a1[-1] - d) < 2e-3  # to about the predicted delay
    iface = contact["ats"][0].record
    assert {c for c in iface.columns if c.startswith("comp.")} == {
        "comp.a0.z", "comp.a1.z", "comp.a2.z"}
    assert not any(c.startswith("comp.") for c in contact["none"][0].record.columns)


@pytest.fixture(scope="module")
def uneven():
    """multidof through a platform whose legs lag differently (1…6 ms filters), 8 s: ATS per
    interface DOF against ATS per leg."""
    out = {}
    for where in ("interface", "legs"):
        sc = _scene("multidof", "ats", duration=8.0, **{"transfer.compensate": where})
        res = run(_uneven(sc))
        assert res.status == "ok", res.reason
        out[where] = (res, _measures(res))
    return out


def test_per_leg_ats_identifies_each_legs_lag(uneven):
    """Per-leg ATS ends with a1 per leg apart as the legs' lag time constants are (1 ms
    steps, the discrete lag delaying a held input by ≈ τ − ΔT/2): a1_i − a1_0 = τ_i − τ_0
    within 0.15 ms."""
    rec = uneven["legs"][0].record
    a1 = np.array([rec.columns[f"comp.a1.leg{i}"][-1] for i in range(6)])
    np.testing.assert_allclose(a1 - a1[0], np.subtract(LEG_TIMECONST, LEG_TIMECONST[0]),
                               atol=1.5e-4)


def test_multidof_per_leg_beats_per_dof_on_uneven_legs(uneven):
    """multidof on a platform with uneven legs: the per-leg compensator beats the per-DOF
    one — heave commands tilt the plate through the legs' different lags, which no
    compensator of the pitch DOF can undo: e_rel,ref of ry ≤ 0.75 × the per-DOF one, heave
    no worse (within 10 %)."""
    legs, iface = uneven["legs"][1], uneven["interface"][1]
    assert legs["ry"]["e_rel_ref"] <= 0.75 * iface["ry"]["e_rel_ref"]
    assert legs["z"]["e_rel_ref"] <= 1.1 * iface["z"]["e_rel_ref"]


# ---------------------------------------------------------------------------------------
# the per-leg hook


def test_leg_channels_equal_the_inverse_kinematics_and_its_finite_differences():
    """The compiled per-leg channels: s = L(p) − L_home of the numpy inverse kinematics,
    ṡ = (L(p + ε ṗ) − L(p − ε ṗ)) / 2ε, for rotated and translated poses and all six pose
    rates, and the measured extensions passed through."""
    g = DEFAULT_GEOMETRY
    rng = np.random.default_rng(3)
    poses = rng.uniform(-1, 1, (5, 6)) * [0.02, 0.02, 0.02, 0.1, 0.1, 0.1]
    rates = rng.uniform(-1, 1, (5, 6)) * [0.1, 0.1, 0.1, 0.5, 0.5, 0.5]
    q = rng.normal(size=(5, 6))
    home = g.home_leg_lengths()
    s, sd, sm = np.zeros((5, 6)), np.zeros((5, 6)), np.zeros((5, 6))
    leg_channels(poses, rates, np.ascontiguousarray(g.base_anchors()),
                 np.ascontiguousarray(g.top_anchors()), float(g.home_height), home, q, s, sd,
                 sm)
    np.testing.assert_allclose(s, inverse_kinematics(g, poses) - home, atol=1e-14)
    eps = 1e-6
    fd = (inverse_kinematics(g, poses + eps * rates)
          - inverse_kinematics(g, poses - eps * rates)) / (2 * eps)
    np.testing.assert_allclose(sd, fd, atol=1e-8)
    np.testing.assert_array_equal(sm, q)


def test_leg_hook_commands_the_compensated_lengths_and_allocates_nothing(peak_bytes):
    """With velocity feed-forward per leg (τ_c = 4 ms) the platform commands
    L = IK(pose) + τ_c·L̇ (inverse kinematics and rates from numpy), and the hook allocates
    nothing per step."""
    sc = scene_with(load_scene("multidof", PLATFORM),
                    {"transfer.compensation": "velocity", "transfer.comp_time": 0.004,
                     "transfer.compensate": "legs", "duration": 0.5})
    tr = StewartTransfer([sc])
    tr.reset()
    g = DEFAULT_GEOMETRY
    idx = [2, 4]
    for k in range(50):
        t = (k + 1) * sc.dt
        z = np.array([[0.002 * np.sin(6 * t), 0.01 * np.sin(4 * t)]])
        zd = np.array([[0.012 * np.cos(6 * t), 0.04 * np.cos(4 * t)]])
        tr.step(z, zd)
        pose, rate = np.zeros((1, 6)), np.zeros((1, 6))
        pose[0, idx], rate[0, idx] = z[0], zd[0]
        eps = 1e-6
        ldot = (inverse_kinematics(g, pose + eps * rate)
                - inverse_kinematics(g, pose - eps * rate)) / (2 * eps)
        want = inverse_kinematics(g, pose) + 0.004 * ldot
        np.testing.assert_allclose(tr.sim.leg_commands, want, atol=1e-9)
    hook, L = tr.sim.leg_hook, tr.sim._L
    assert peak_bytes(lambda: hook(L), 50) < 4096


def test_drifting_per_leg_compensator_stops_the_test_naming_the_leg():
    """An ATS per leg whose a1 bound (4 ms) is below the legs' delay stops the test like any
    safety limit, naming the leg, with the record up to the stop."""
    sc = _scene("paper_contact", "ats", duration=4.0,
                **{"transfer.compensate": "legs", "transfer.compensator.a1_bounds": [0, 0.004]})
    res = run(sc, reference=False)
    assert res.status == "stopped"
    assert "ats a1 estimate (leg " in res.reason and "outside its bounds" in res.reason
    assert 0.5 < res.record.t[-1] < 4.0


# ---------------------------------------------------------------------------------------
# scenes, batches, starts


def test_scene_keys_validated_with_one_line_errors():
    """compensate and comp_init take their listed values; per-leg needs a platform; a
    compensator's sub-table is checked by that compensator, even when another is chosen."""
    base = load_scene("paper_contact")
    with pytest.raises(ConfigError, match=r"transfer.compensate: 'leg' .*interface, legs"):
        scene_with(base, {"transfer.compensate": "leg"})
    with pytest.raises(ConfigError, match=r"transfer.compensate: 'legs' .*legs.*'lti'"):
        scene_with(base, {"transfer.compensate": "legs"})
    with pytest.raises(ConfigError, match=r"transfer.comp_init: 'guess'"):
        scene_with(base, {"transfer.comp_init": "guess"})
    with pytest.raises(ConfigError, match=r"transfer.compensator.rls.tapz"):
        scene_with(base, {"transfer.compensation": "ats", "transfer.compensator.rls.tapz": 3})
    with pytest.raises(ConfigError, match=r"transfer.compensate: 'legs' .*'lti'"):
        # a legs scene moved onto a transfer system without legs is refused where it is built
        run(scene_with(base, {"transfer.kind": "stewart", "transfer.compensate": "legs",
                              "transfer.compensation": "ats"}).with_transfer("lti"))


def test_batch_key_separates_modes_and_compensator_settings():
    """Interface and per-leg compensation step apart, as do different compensators or their
    sub-tables; the other compensators' sub-tables do not split a batch."""
    sc = load_scene("paper_contact", PLATFORM)
    k = [batch_key(scene_with(sc, o)) for o in (
        {"transfer.compensation": "ats"},
        {"transfer.compensation": "ats", "transfer.compensate": "legs"},
        {"transfer.compensation": "ats", "transfer.compensator.ats.window": 0.5},
        {"transfer.compensation": "ats", "transfer.compensator.rls.taps": 3},
        {"transfer.compensation": "rls"})]
    assert len({k[0], k[1], k[2], k[4]}) == 4
    assert k[3] == k[0]


def test_predicted_start_follows_each_tests_transfer_system():
    """comp_init = predicted starts ATS at a1 = each test's predicted delay (pure delay τ,
    the LTI model's, the platform's), `given` at OpenFresco's 20 ms, and a table value
    wins over the prediction."""
    from rths3d.transfer import build_transfer

    sc = load_scene("paper_contact", {"transfer.compensation": "ats", "duration": 0.1})

    def a1(**o):
        s = scene_with(sc, o)
        return float(build_transfer(s, 1).compensator.coefficients()["a1"][0, 0])

    assert a1(**{"transfer.kind": "delay", "transfer.delay": 0.006}) == pytest.approx(0.006)
    assert a1(**{"transfer.kind": "ideal"}) == 0.0
    lti = scene_with(sc, {"transfer.kind": "lti", "transfer.delay": 0.005})
    meta = build_transfer(lti, 1).metas[0]
    assert a1(**{"transfer.kind": "lti", "transfer.delay": 0.005}) == pytest.approx(
        meta["predicted_delay"])
    assert a1(**{"transfer.kind": "delay", "transfer.comp_init": "given"}) == 0.020
    assert a1(**{"transfer.kind": "delay", "transfer.delay": 0.006,
                 "transfer.compensator.a1": 0.003}) == 0.003


def test_rls_start_is_the_quadratic_extrapolation_of_the_delay():
    """RLS from a delay d: θ over three taps s apart reproduces a quadratic's value d ahead
    (so a lead of d), DC gain 1."""
    comp = build("rls", 2, 3, 1e-3, {"spacing": 0.004})
    comp.start_from_delay(np.array([0.006, 0.0]))
    th = comp.coefficients()
    t = -np.arange(4) * 0.004
    for k, d in enumerate((0.006, 0.0)):
        w = np.array([th[f"theta{i}"][k, 0] for i in range(4)])
        for p in ([1, 0, 0], [0.3, -2, 0], [0.1, 0.5, 40]):
            q = np.polyval(p[::-1], t)
            assert w @ q == pytest.approx(np.polyval(p[::-1], d), abs=1e-12)
        assert th["lead"][k, 0] == pytest.approx(d)


# ---------------------------------------------------------------------------------------
# sweeps


def test_sweep_with_the_compensator_as_a_variable_carries_name_and_final_coefficients(
        tmp_path):
    """A sweep whose grid varies transfer.compensation and transfer.compensate on the
    platform runs, and its table carries each test's compensator name, mode and final
    coefficients per channel — those of the test's record at its last sample."""
    from rths3d.dataset import load_spec, run_sweep
    from rths3d.record import Record

    spec = tmp_path / "spec.toml"
    spec.write_text("""
[sweep]
name = "comp"
duration = 1.0
batch_size = 4
keep_records = true

[[family]]
name = "c"
scene = "paper_contact"
transfer = "stewart"
[family.fixed]
"transfer.delay" = 0.005
"transfer.compensator.rls.spacing" = 0.004
[family.grid]
"transfer.compensation" = ["none", "ats", "rls"]
"transfer.compensate" = ["interface", "legs"]
""")
    table = run_sweep(load_spec(spec), tmp_path / "out", workers=1, progress=False)
    assert len(table) == 6 and (table["status"] == "ok").all()
    assert sorted(zip(table["comp_name"], table["comp_mode"], strict=True)) == sorted(
        (c, m) for c in ("none", "ats", "rls") for m in ("interface", "legs"))
    for _, row in table.iterrows():
        rec = Record.load(tmp_path / "out" / "records" / f"{row['test_id']}.parquet")
        chans = ["z"] if row["comp_mode"] == "interface" else list(LEG_CHANNELS)
        if row["comp_name"] == "none":
            assert not any(c.startswith("comp.") for c in rec.columns)
            continue
        coefs = ("a0", "a1", "a2") if row["comp_name"] == "ats" else (
            "theta0", "theta1", "theta2", "theta3", "gain", "lead")
        for c in coefs:
            for ch in chans:
                assert row[f"comp_{c}_final.{ch}"] == rec.columns[f"comp.{c}.{ch}"][-1]
            assert row[f"comp_{c}_final"] == pytest.approx(
                np.mean([row[f"comp_{c}_final.{ch}"] for ch in chans]))
        delay = row["comp_a1_final"] if row["comp_name"] == "ats" else row["comp_lead_final"]
        assert 0.005 < delay < 0.010  # s: about the platform's delay


def test_per_leg_tests_stepped_together_equal_their_runs_alone():
    """Two per-leg ATS tests with different servo gains stepped together (one MuJoCo model
    each) give the records of their runs alone, coefficients included, to rounding."""
    from rths3d.loop import run_batch

    sc = _scene("paper_contact", "ats", duration=1.5, **{"transfer.compensate": "legs"})
    sets = [{"transfer.kp": 2.0e5}, {"transfer.kp": 1.5e5, "transfer.kv": 1.5e3}]
    together = run_batch(sc, sets, reference=False)
    for ps, res in zip(sets, together, strict=True):
        alone = run(scene_with(sc, ps), reference=False).record
        for col in ("z_meas.z", "f_meas.z", "comp.a1.leg0", "comp.a0.leg5"):
            np.testing.assert_allclose(res.record.columns[col], alone.columns[col],
                                       rtol=0, atol=1e-9 * np.abs(alone.columns[col]).max())
    a1 = [r.record.columns["comp.a1.leg0"][0] for r in together]
    assert a1[0] != a1[1]  # each started from its own predicted delay
