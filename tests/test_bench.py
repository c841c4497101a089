"""The bench: one model for the loop, the replay and synthetic measurements; its timing
convention, its records and its effects checked against independent expectations."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from rths3d.bench import Bench, BenchReplay, ReplayInput
from rths3d.config import EffectConfig
from rths3d.effects import noise_sigma
from rths3d.errors import ConfigError
from rths3d.loop import run, run_batch
from rths3d.metrics import compute_measures
from rths3d.platform.calibrate.kinematic import CalibratedGeometry
from rths3d.platform.model import predicted_delay
from rths3d.record import DOFS
from rths3d.scene import load_scene, scene_from_dict, scene_to_dict, scene_to_toml


@pytest.fixture(scope="module")
def contact():
    return load_scene("paper_contact", ["duration=1.5", "transfer.kind='stewart'"])


def test_physics_step_drops_out_of_the_closed_loop(contact):
    """Closed-loop records with 1 and 4 physics substeps agree to a tenth of the sensor noise
    or better (RK4 and the ramped set-point; the old convention differed by µm and tenths of
    N), contact impacts included."""
    a = run(contact, reference=False).record
    b = run(dataclasses.replace(contact, transfer=dataclasses.replace(contact.transfer,
                                                                       substeps=4)),
            reference=False).record
    assert np.max(np.abs(a.columns["z_meas.z"] - b.columns["z_meas.z"])) < 1e-7
    assert np.max(np.abs(a.columns["f_meas.z"] - b.columns["f_meas.z"])) < 0.01
    assert np.max(np.abs(a.columns["leg_force.0"] - b.columns["leg_force.0"])) < 0.05


def test_record_carries_every_bench_channel_zeroed_at_rest(contact):
    """A Stewart record has pose, leg lengths, tared leg forces and the raw wrench; at rest
    (before the test moves) the tared channels read 0 and the raw FTS reads the payload's
    weight m·g (zeroed unloaded), the encoders the home leg lengths."""
    rec = run(dataclasses.replace(contact, duration=0.3), reference=False).record
    cols = rec.columns
    for sig, labs in (("pose_meas", DOFS), ("leg_len", "012345"), ("leg_force", "012345"),
                      ("fts", ("fx", "fy", "fz", "tx", "ty", "tz"))):
        assert all(f"{sig}.{c}" in cols for c in labs), sig
    m = contact.experiment.m
    # the first steps barely move (raised cosine): tared channels ~0, raw weight on fz
    assert abs(cols["leg_force.0"][1]) < 0.5
    assert cols["fts.fz"][1] == pytest.approx(m * 9.81, rel=0.01)
    home = Bench.from_scene(contact).platform.geometry.home_leg_lengths()
    assert cols["leg_len.3"][1] == pytest.approx(home[3], abs=1e-5)


def test_measurement_noise_has_its_nominal_sigma(contact):
    """sensor_noise = 2 adds white noise of 2 σ to every channel (σ from the table)."""
    sc = dataclasses.replace(contact, duration=1.0)
    clean = run(sc, reference=False).record
    noisy = run(dataclasses.replace(sc, effects=(EffectConfig("sensor_noise", 2.0),)),
                reference=False).record
    from rths3d.diagnose.localise import noise_floor

    for c in ("pose_meas.z", "leg_len.2", "leg_force.4", "fts.tx", "z_meas.z", "f_meas.z"):
        d = noisy.columns[c][1:] - clean.columns[c][1:]
        # the noisy force also feeds back through the numerical substructure (a smooth
        # change of the motion): the white part is measured from second differences
        assert noise_floor(d) == pytest.approx(2 * noise_sigma(c), rel=0.1), c


def test_scene_effects_round_trip_and_one_line_errors():
    """[[effect]] tables survive scene_to_dict and TOML; bad tables name field and limit."""
    import tomllib

    sc = load_scene("multidof", ["effect.coulomb_friction.leg3=12.5",
                                 "effect.fts_crosstalk.fx.fz=0.02", "effect.delay=0.002"])
    assert [e.label for e in sc.effects] == ["coulomb_friction.leg3", "fts_crosstalk.fx.fz",
                                             "delay"]
    again = scene_from_dict(tomllib.loads(scene_to_toml(sc)), name=sc.name, source=sc.source)
    assert again == sc
    raw = scene_to_dict(load_scene("paper_contact"))
    for tab, needle in (
        ({"name": "gremlins", "value": 1.0}, "known effects"),
        ({"name": "delay", "value": 0.9}, r"within \[0, 0.05\] s"),
        ({"name": "base_anchor", "value": 1e-3, "axis": "x"}, r"effect\[0\].leg"),
        ({"name": "fts_gain", "value": 0.1, "axis": "fw"}, "must be one of fx"),
        ({"name": "delay", "value": 0.001, "leg": 7}, "must be 0…5"),
        ({"name": "delay", "value": 0.001, "colour": "red"}, "unknown field"),
    ):
        with pytest.raises(ConfigError, match=needle) as ex:
            scene_from_dict({**raw, "effect": [tab]})
        assert "\n" not in str(ex.value)


def test_leg_delay_effect_moves_the_fei_delay_by_its_value(contact):
    """A transport delay of 3 ms on every leg, declared in the scene, delays the achieved
    motion by 3 ms more (FEI delay), as the actuator settings predict."""
    sc = dataclasses.replace(contact, duration=4.0)
    d0 = compute_measures(run(sc, reference=False).record)["fei_d"]
    d1 = compute_measures(run(dataclasses.replace(
        sc, effects=(EffectConfig("delay", 0.003),)), reference=False).record)["fei_d"]
    assert d1 - d0 == pytest.approx(0.003, abs=0.1e-3)
    pd = predicted_delay(Bench.from_scene(sc).platform, 0.5)
    assert d0 == pytest.approx(pd, abs=0.3e-3)


def test_lti_path_takes_delay_and_sensor_effects():
    """On the ideal transfer system the delay effect delays z' by exactly its samples; a
    per-leg effect, which a 1-D chain cannot carry, is listed as ignored."""
    sc = load_scene("paper_linear", ["duration=0.5", "transfer.kind='ideal'",
                                     "effect.delay=0.003", "effect.backlash.leg2=1e-5"])
    rec = run(sc, reference=False).record
    z, zm = rec.columns["z_cmd.z"], rec.columns["z_meas.z"]
    np.testing.assert_array_equal(zm[3:], z[:-3])
    assert rec.meta["transfer_meta"]["ignored_effects"] == ["backlash.leg2"]


def test_batch_of_effect_values_equals_single_runs(contact):
    """Tests differing only in effect values (friction on a leg, a leg delay) step together
    and each equals its own single run."""
    sc = dataclasses.replace(contact, duration=0.6, effects=(
        EffectConfig("coulomb_friction", 10.0, 2), EffectConfig("delay", 0.001, 4)))
    sets = [{"effect.coulomb_friction.leg2": 20.0}, {"effect.delay.leg4": 0.003}]
    batch = run_batch(sc, sets, reference=False)
    from rths3d.scene import scene_with

    for s, r in zip(sets, batch, strict=True):
        one = run(scene_with(sc, s), reference=False).record
        np.testing.assert_allclose(r.record.columns["leg_force.2"], one.columns["leg_force.2"],
                                   atol=1e-9)


def test_geometry_effects_read_like_the_calibration_model():
    """With anchor and encoder errors, the encoders of the true platform read what the
    calibration module's model (1) gives at the measured absolute pose: the bench's true
    geometry is the one a kinematic calibration identifies."""
    sc = load_scene("bench6", ["duration=0.8", "effect.base_anchor.leg1.x=1.5e-3",
                               "effect.top_anchor.leg4.z=-1e-3", "effect.leg_offset.leg2=4e-4"])
    rec = run(sc, reference=False).record
    q = np.column_stack([rec.columns[f"pose_meas.{d}"] for d in DOFS])[1:]
    L = np.column_stack([rec.columns[f"leg_len.{i}"] for i in range(6)])[1:]
    g = Bench.from_scene(sc).true_geometry()
    assert isinstance(g, CalibratedGeometry)
    # equality constraints hold the chain to a few µm
    assert np.max(np.abs(g.encoder_lengths(q) - L)) < 1e-5
    nominal = CalibratedGeometry.from_nominal(g.nominal())
    assert np.max(np.abs(nominal.encoder_lengths(q) - L)) > 3e-4


def test_replay_of_a_noise_free_record_reproduces_it():
    """Open-loop replay of a closed-loop record (4 substeps) at 1 substep with the same
    effects reproduces every channel to far below the sensor noise."""
    sc = load_scene("bench6", ["duration=0.8", "transfer.substeps=4",
                               "effect.viscous_friction.leg3=500", "effect.fts_gain.fz=0.05"])
    rec = run(sc, reference=False).record
    rp = BenchReplay(sc, ReplayInput.from_record(rec, sc.dofs))
    out = rp.run([list(sc.effects)])[0]
    for c in rp.channels:
        err = np.max(np.abs(out[c][1:] - rec.columns[c][1:]))
        assert err < 0.1 * noise_sigma(c), (c, err)


def test_the_platform_integrator_is_a_scene_choice():
    """transfer.integrator: implicitfast (first order) follows the RK4 record within a few
    µm (docs/platform.md: 3.3 µm from the converged pose with one substep), and says so in
    the metadata; any other name is one ConfigError naming the field."""
    recs = {}
    for integ in ("RK4", "implicitfast"):
        sc = load_scene("paper_contact", {"transfer.kind": "stewart", "duration": 1.5,
                                          "transfer.integrator": integ})
        res = run(sc, reference=False)
        assert res.status == "ok"
        assert res.record.meta["transfer_meta"]["integrator"] == integ
        recs[integ] = res.record.signal("z_meas")[:, 0]
    diff = np.max(np.abs(recs["RK4"] - recs["implicitfast"]))
    assert 0 < diff < 2e-5, diff
    with pytest.raises(ConfigError, match="transfer.integrator"):
        load_scene("paper_contact", {"transfer.integrator": "Euler4"})


def test_a_batch_of_one_bench_compiles_it_once_and_gives_each_test_its_own_model():
    """Tests of one bench share one compilation (a copy each); the copies equal a model
    compiled on its own, field by field, and editing one test's model leaves the others;
    a bench of another payload mass gets its own model."""
    import mujoco

    from rths3d.bench.base import bench_models

    sc = load_scene("paper_contact")
    b = Bench.from_scene(sc)
    heavy = dataclasses.replace(b, part=dataclasses.replace(b.part, m=2.0 * b.part.m))
    models = bench_models([b, b, heavy, b])
    assert len({id(m) for m in models}) == 4
    alone = b.model()
    for m in (models[0], models[1], models[3]):
        for field in ("body_mass", "body_inertia", "actuator_gainprm", "eq_data", "qpos0"):
            np.testing.assert_array_equal(getattr(m, field), getattr(alone, field))
    pid = mujoco.mj_name2id(alone, mujoco.mjtObj.mjOBJ_BODY, "exp_mass")  # the part
    assert pid >= 0
    assert models[2].body_mass[pid] == pytest.approx(2.0 * alone.body_mass[pid])  # kg
    models[1].body_mass[pid] += 1.0
    assert models[0].body_mass[pid] == models[3].body_mass[pid] == alone.body_mass[pid]
