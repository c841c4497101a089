"""The effects library on the bench: off values, per-leg targets, set-point blocks against
hand-written formulas, physics effects against analytic expectations."""

from __future__ import annotations

import numpy as np
import pytest

from rths3d.bench import Bench, BenchReplay
from rths3d.config import EffectConfig
from rths3d.effects import REGISTRY, describe, get_effect, parse_effect_arg
from rths3d.effects.blocks import PlayBlock, RateLimitBlock, run_blocks
from rths3d.errors import ConfigError
from rths3d.scene import load_scene

DT = 1e-3


@pytest.fixture(scope="module")
def replay():
    """0.6 s of multi-axis poses (ramped in) replayed through the rigid-payload bench."""
    sc = load_scene("bench6", ["duration=0.6"])
    t = np.arange(601) * DT
    ramp = np.minimum(t / 0.1, 1.0)
    poses = np.zeros((t.size, 6))
    for j, (a, f) in enumerate(((2e-3, 3.0), (1.5e-3, 2.2), (3e-3, 4.1), (8e-3, 2.7),
                                (6e-3, 3.3), (5e-3, 1.9))):
        poses[:, j] = a * ramp * np.sin(2 * np.pi * f * t)
    return BenchReplay(sc, poses)


def test_library_has_the_issue_effects_with_per_leg_kinds():
    """The library holds the issue's effects, ≥ 6 of them per-leg kinds, each with unit,
    bounds, scale and a signature."""
    need = {"delay", "actuator_lag", "coulomb_friction", "viscous_friction", "servo_gain",
            "leg_offset", "velocity_saturation", "backlash", "base_anchor", "top_anchor",
            "fts_gain", "fts_crosstalk", "fts_offset", "fts_mount", "fixture_mass",
            "payload_com", "gravity_comp", "platform_compliance", "fts_lowpass",
            "specimen_stiffness", "specimen_mass", "contact_gap", "sensor_noise"}
    assert need <= set(REGISTRY)
    assert sum(e.per_leg for e in REGISTRY.values()) >= 6
    for row in describe():
        assert row["unit"] and row["lo"] < row["hi"] and row["scale"] > 0 and row["signature"]


def test_every_effect_at_its_off_value_reproduces_the_nominal_bench(replay):
    """Every effect, on every kind of target, at its off value: bit-identical replay."""
    sets = [[]]
    for name, eff in REGISTRY.items():
        if name in ("specimen_stiffness", "specimen_damping", "contact_gap"):
            continue  # the rigid part has no spring or surface (tested on paper_contact)
        leg, axis = eff.targets()[-1]
        sets.append([EffectConfig(name, eff.param.off, leg, axis)])
    # the same effects at their typical scale: each must move some channel (an effect that
    # is never applied would pass the off-value check above)
    on = [[EffectConfig(e.name, REGISTRY[e.name].param.scale, e.leg, e.axis)]
          for (e,) in sets[1:]]
    outs = replay.run(sets + on)
    for s, out in zip(sets[1:], outs[1:len(sets)], strict=True):
        for c in replay.channels:
            np.testing.assert_array_equal(out[c], outs[0][c], err_msg=f"{s[0].label} {c}")
    still = []
    for s, out in zip(on, outs[len(sets):], strict=True):
        moved = max(float(np.max(np.abs(out[c] - outs[0][c]))) for c in replay.channels)
        if not moved > 1e-9:
            still.append(s[0].label)
    # the replay is the noise-free model: measurement noise is what it is compared against
    assert still == ["sensor_noise"], still


def test_lag_block_has_the_first_order_gain():
    """LagBlock τ = 5 ms on a 20 Hz sine: steady-state amplitude 1/√(1 + (ωτ)²) (the
    discrete lag of a held input, within 1 %)."""
    from rths3d.effects.blocks import LagBlock

    t = np.arange(4000) * DT
    w, tau = 2 * np.pi * 20.0, 5e-3
    y = run_blocks([LagBlock(1, 1, tau, DT)], np.sin(w * t))
    amp = np.max(np.abs(np.asarray(y).ravel()[2000:]))
    assert amp == pytest.approx(1 / np.sqrt(1 + (w * tau) ** 2), rel=0.01)


def test_rate_limit_and_play_blocks_are_the_textbook_operators():
    """RateLimitBlock and PlayBlock equal a rate limiter and a play operator written here."""
    rng = np.random.default_rng(1)
    u = np.cumsum(rng.normal(0, 1e-4, 500))
    y = run_blocks([RateLimitBlock(1, 1, 0.05, DT)], u)
    ref, prev = np.empty_like(u), 0.0
    for k, x in enumerate(u):
        prev += np.clip(x - prev, -0.05 * DT, 0.05 * DT)
        ref[k] = prev
    np.testing.assert_allclose(y, ref, atol=1e-15)
    y = run_blocks([PlayBlock(1, 1, 2e-4)], u)
    ref, prev = np.empty_like(u), 0.0
    for k, x in enumerate(u):
        prev = min(max(prev, x - 1e-4), x + 1e-4)
        ref[k] = prev
    np.testing.assert_allclose(y, ref, atol=1e-15)


def test_per_leg_friction_acts_on_its_leg(replay):
    """Coulomb friction of 40 N on leg 3 shifts leg 3's force by ≈ ±40 N while it moves
    and leaves the other legs' forces within a few N."""
    base, fr = replay.run([[], [EffectConfig("coulomb_friction", 40.0, 3)]])
    d = {i: fr[f"leg_force.{i}"] - base[f"leg_force.{i}"] for i in range(6)}
    L = base["leg_len.3"]
    moving = np.abs(np.gradient(L, DT)) > 5e-3
    moving[:150] = False
    assert np.median(np.abs(d[3][moving])) == pytest.approx(40.0, rel=0.15)
    assert all(np.median(np.abs(d[i][moving])) < 8.0 for i in (0, 1, 2, 4, 5))


def test_fts_effects_are_the_calibration_matrix(replay):
    """Gain, cross-talk and offset effects make the raw reading C·w + b of the nominal one."""
    base, cal = replay.run([[], [EffectConfig("fts_gain", 0.05, -1, "fz"),
                                 EffectConfig("fts_crosstalk", 0.02, -1, "fx.fz"),
                                 EffectConfig("fts_offset", 0.3, -1, "ty")]])
    np.testing.assert_allclose(cal["fts.fz"], 1.05 * base["fts.fz"], rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(cal["fts.fx"], base["fts.fx"] + 0.02 * base["fts.fz"],
                               atol=1e-9)
    np.testing.assert_allclose(cal["fts.ty"], base["fts.ty"] + 0.3, atol=1e-9)


def test_fixture_mass_adds_its_weight_to_the_untared_wrench(replay):
    """0.4 kg on the sensor: the raw (zeroed unloaded) fz rises by m·g at rest; the tared
    interface force carries m·a in motion."""
    base, fix = replay.run([[], [EffectConfig("fixture_mass", 0.4)]])
    assert fix["fts.fz"][0] - base["fts.fz"][0] == pytest.approx(0.4 * 9.81, rel=1e-3)
    a = np.gradient(np.gradient(base["pose_meas.z"], DT), DT)
    df = fix["f_meas.z"] - base["f_meas.z"]
    sel = slice(200, 580)
    slope = np.dot(df[sel], a[sel]) / np.dot(a[sel], a[sel])
    assert slope == pytest.approx(0.4, rel=0.1)


def test_effect_labels_and_bad_values_are_named():
    """LABEL[=value] parsing names the effect, leg, axis and the limits."""
    assert parse_effect_arg("delay.leg3=0.004") == ("delay.leg3", 0.004)
    assert parse_effect_arg("fts_crosstalk.fx.fz") == ("fts_crosstalk.fx.fz", None)
    with pytest.raises(ConfigError, match="within"):
        parse_effect_arg("delay=1")
    with pytest.raises(ConfigError, match="leg"):
        parse_effect_arg("base_anchor.x")
    with pytest.raises(ConfigError, match="known effects"):
        get_effect("gremlins")


def test_specimen_effects_on_the_contact_part():
    """Part effects at their off value reproduce the contact bench; a stiffer spring changes
    the measured force."""
    sc = load_scene("paper_contact", ["duration=0.3", "transfer.kind='stewart'"])
    t = np.arange(301) * DT
    poses = np.zeros((t.size, 6))
    poses[:, 2] = 3e-3 * np.minimum(t / 0.1, 1) * np.sin(2 * np.pi * 8 * t)
    rp = BenchReplay(sc, poses)
    outs = rp.run([[], [EffectConfig("specimen_stiffness", 0.0)],
                   [EffectConfig("contact_gap", 0.0)], [EffectConfig("specimen_damping", 0.0)],
                   [EffectConfig("specimen_stiffness", 0.3)]])
    for o in outs[1:4]:
        np.testing.assert_array_equal(o["f_meas.z"], outs[0]["f_meas.z"])
    assert np.max(np.abs(outs[4]["f_meas.z"] - outs[0]["f_meas.z"])) > 0.05


def test_servo_gain_and_compliance_combine_in_series():
    """A leg's gain error and the platform's compliance act together, in either declared
    order: leg 2's position gain is kp(1 + dkp) in series with c, kp_2 = k/(1 + k c) with
    k = kp(1 + dkp), written here; the other legs kp/(1 + kp c)."""
    sc = load_scene("bench6")
    dkp, c = 0.3, 2e-6
    effects = [EffectConfig("servo_gain", dkp, leg=2), EffectConfig("platform_compliance", c)]
    for order in (effects, effects[::-1]):
        bench = Bench.from_scene(sc).with_effects(order)
        spec = bench.spec()
        kp = bench.kp
        k2 = kp * (1 + dkp)
        for i in range(6):
            want = k2 / (1 + k2 * c) if i == 2 else kp / (1 + kp * c)
            act = spec.actuator(f"leg{i}")
            assert act.gainprm[0] == pytest.approx(want, rel=1e-12)
            assert act.biasprm[1] == pytest.approx(-want, rel=1e-12)
