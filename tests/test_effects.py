"""Effects library and bench model: off values, analytic signal effects, physics effects."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rths3d.diagnose.bench import BenchConfig, BenchModel, G, load_bench
from rths3d.diagnose.synth import multisine
from rths3d.effects import REGISTRY, describe, get_effect, parse_effect_arg
from rths3d.effects.library import delay_signal, lowpass_signal
from rths3d.errors import ConfigError

DT = 1e-3


@pytest.fixture(scope="module")
def bench():
    return BenchModel(BenchConfig(), DT)


@pytest.fixture(scope="module")
def command():
    return multisine(2.0, DT, seed=3)[1]


def test_library_has_the_issue_effects():
    """The library holds at least the effects the issue lists, each with unit, bounds, scale."""
    need = {"delay", "actuator_lag", "coulomb_friction", "viscous_friction", "backlash",
            "fts_lowpass", "fts_gain", "fts_offset", "fts_crosstalk", "fixture_mass",
            "platform_compliance", "velocity_saturation", "quantisation", "specimen_stiffness",
            "specimen_damping", "contact_gap", "sensor_noise"}
    assert need <= set(REGISTRY)
    for row in describe():
        assert row["unit"] and row["lo"] < row["hi"] and row["scale"] > 0 and row["signature"]


@pytest.mark.parametrize("name", sorted(REGISTRY))
def test_off_value_reproduces_baseline_exactly(bench, command, name):
    """Every effect at its off value gives bit-identical outputs to the nominal model."""
    base = bench.replay(command, {})
    off = bench.replay(command, {name: get_effect(name).param.off})
    for c in base:
        np.testing.assert_array_equal(off[c], base[c])


@pytest.mark.parametrize("name", sorted(n for n, e in REGISTRY.items() if e.candidate))
def test_effect_is_continuous_at_its_off_value(bench, command, name):
    """Just beside the off value (1e-3 of the typical scale) the outputs move by < 2 % of
    the change at the typical scale: the off value is the limit of the effect, not a jump."""
    eff = get_effect(name)
    p = eff.param
    scale_v = eff.probe({}, {}, command, DT)
    near = p.hi if math.isinf(p.off) else p.off + 1e-3 * (scale_v - p.off)
    base = bench.replay(command, {})
    far = bench.replay(command, {name: scale_v})
    close = bench.replay(command, {name: near})
    for c in ("z_meas.z", "f_meas.z", "f_meas.x", "leg_force.0"):
        big = float(np.max(np.abs(far[c] - base[c])))
        small = float(np.max(np.abs(close[c] - base[c])))
        assert small <= 0.02 * big + 1e-12, (c, small, big)


@pytest.mark.parametrize("name", sorted(n for n, e in REGISTRY.items() if e.candidate))
def test_effect_at_scale_changes_the_outputs(bench, command, name):
    """Every candidate at a typical magnitude changes at least one channel beyond 1e-9."""
    eff = get_effect(name)
    value = eff.probe({}, {}, command, DT)
    base = bench.replay(command, {})
    on = bench.replay(command, {name: value})
    assert max(float(np.max(np.abs(on[c] - base[c]))) for c in base if c != "contact") > 1e-9


def test_delay_signal_shifts_a_sine_exactly():
    """delay_signal(sin ωt, τ) = sin ω(t − τ) (linear interpolation, fractional τ)."""
    t = np.arange(4000) * DT
    x = np.sin(2 * math.pi * 2.0 * t)
    y = delay_signal(x, DT, 3.5e-3)
    k = t >= 0.01
    np.testing.assert_allclose(y[k], np.sin(2 * math.pi * 2.0 * (t[k] - 3.5e-3)), atol=2e-4)


def test_lowpass_matches_first_order_frequency_response():
    """Steady-state gain of the low-pass at ω equals 1/√(1 + (ω·tc)²) within 1 %."""
    tc, f = 5e-3, 20.0
    t = np.arange(20000) * DT
    y = lowpass_signal(np.sin(2 * math.pi * f * t), DT, tc)
    gain = np.max(np.abs(y[10000:]))
    assert gain == pytest.approx(1 / math.sqrt(1 + (2 * math.pi * f * tc) ** 2), rel=0.01)


def test_backlash_is_a_play_operator():
    """Backlash of width b: output lags a triangle wave by b/2 and the loop width is b."""
    eff = get_effect("backlash")
    x = np.concatenate([np.linspace(0, 1e-3, 500), np.linspace(1e-3, 0, 500)])
    y = eff.apply_command(x, DT, 1e-4)
    assert y[0] == 0.0
    assert y[499] == pytest.approx(1e-3 - 5e-5)
    assert y[-1] == pytest.approx(5e-5)
    assert np.all(np.abs(y - x) <= 5e-5 + 1e-15)


def test_velocity_saturation_limits_the_rate():
    """The rate limiter never moves faster than v_max and follows slow commands exactly."""
    eff = get_effect("velocity_saturation")
    t = np.arange(2000) * DT
    x = 5e-3 * np.sin(2 * math.pi * 2 * t)  # peak speed 0.063 m/s
    y = eff.apply_command(x, DT, 0.03)
    assert np.max(np.abs(np.diff(y))) <= 0.03 * DT * (1 + 1e-12)
    y2 = eff.apply_command(x, DT, 1.0)
    np.testing.assert_allclose(y2, x, atol=1e-15)


def test_sensor_effects_are_the_documented_formulas():
    """Gain, offset, cross-talk and quantisation act as F'=(1+g)F, F'=F+b, Fx'=Fx+cFz, q·round."""
    f = np.linspace(-5, 5, 11)
    out = {"f_meas.z": f.copy(), "f_meas.x": np.zeros(11), "z_meas.z": f * 1e-4}
    get_effect("fts_gain").apply_output(out, DT, 0.1)
    np.testing.assert_allclose(out["f_meas.z"], 1.1 * f)
    get_effect("fts_offset").apply_output(out, DT, 0.5)
    np.testing.assert_allclose(out["f_meas.z"], 1.1 * f + 0.5)
    get_effect("fts_crosstalk").apply_output(out, DT, 0.02)
    np.testing.assert_allclose(out["f_meas.x"], 0.02 * (1.1 * f + 0.5))
    get_effect("quantisation").apply_output(out, DT, 3e-4)
    k = out["z_meas.z"] / 3e-4
    np.testing.assert_allclose(k, np.round(k), atol=1e-9)


def test_bench_at_rest_reads_zero(bench):
    """At rest at home the tared force, leg force and displacement are exactly zero."""
    out = bench.replay(np.zeros(500), {})
    for c in ("z_meas.z", "f_meas.z", "f_meas.x", "leg_force.0"):
        assert np.max(np.abs(out[c])) < 1e-9


def test_fts_force_obeys_newton_for_the_payload(bench):
    """Below contact and far below the specimen resonance, f_meas ≈ (m_fts + m_exp·H)·z̈ with
    H = 1/(1 − (ω/ωn)²) the base-excitation gain of the specimen (within 3 %)."""
    cfg = bench.cfg
    f, a = 2.0, 5e-4
    t = np.arange(6000) * DT
    w = 2 * math.pi * f
    z = a * np.sin(w * t) * np.clip(t / 0.5, 0, 1)
    out = bench.replay(z, {})
    wn = math.sqrt(cfg.k_exp / cfg.m_exp)
    h = 1 / (1 - (w / wn) ** 2)
    expect = (cfg.m_fts + cfg.m_exp * h) * a * w * w
    amp = np.max(np.abs(out["f_meas.z"][3000:]))
    assert amp == pytest.approx(expect, rel=0.03)
    assert np.max(np.abs(out["z_meas.z"][3000:] - z[3000:])) < 0.02 * a


def test_fixture_mass_adds_m_times_acceleration(bench):
    """The fixture-mass effect adds m_f·z̈ to the measured force (within 3 % of m_f·a·ω²)."""
    f, a, mf = 3.0, 3e-4, 0.5
    t = np.arange(5000) * DT
    w = 2 * math.pi * f
    z = a * np.sin(w * t) * np.clip(t / 0.5, 0, 1)
    d = bench.replay(z, {"fixture_mass": mf})["f_meas.z"] - bench.replay(z, {})["f_meas.z"]
    assert np.max(np.abs(d[2500:])) == pytest.approx(mf * a * w * w, rel=0.03)


def test_coulomb_friction_shifts_leg_force_by_fc(bench):
    """With dry friction F_c, the leg force during steady motion differs by ±F_c."""
    t = np.arange(3000) * DT
    z = 2e-3 * np.sin(2 * math.pi * 0.5 * t) * np.clip(t / 0.3, 0, 1)
    d = bench.replay(z, {"coulomb_friction": 30.0})["leg_force.0"] - \
        bench.replay(z, {})["leg_force.0"]
    v = np.gradient(z, DT)
    moving = np.abs(v) > 2e-3
    np.testing.assert_allclose(d[moving] * np.sign(v[moving]), 30.0, rtol=0.05)


def test_platform_compliance_static_deflection(bench):
    """Series compliance c deflects the plate by c·F_leg statically (hold under payload)."""
    c = 2e-6
    t = np.arange(2000) * DT
    z = 1e-3 * np.clip(t / 0.5, 0, 1) ** 2
    z[1000:] = z[999]
    cfg = bench.cfg
    out0 = bench.replay(z, {})
    out1 = bench.replay(z, {"platform_compliance": c})
    # gravity compensation uses the nominal kp: extra sag = W·(1/kp' − 1/kp) = W·c
    w_total = (cfg.m_plate + cfg.m_fts + cfg.m_exp) * G
    assert out0["z_meas.z"][-1] - out1["z_meas.z"][-1] == pytest.approx(w_total * c, rel=0.02)


def test_parameter_checks_name_field_value_and_limit():
    """Out-of-bounds or non-numeric effect values raise ConfigError naming the limits."""
    assert parse_effect_arg("delay=0.004") == ("delay", 0.004)
    assert parse_effect_arg("backlash") == ("backlash", None)
    with pytest.raises(ConfigError, match=r"delay.tau.*within"):
        parse_effect_arg("delay=1.0")
    with pytest.raises(ConfigError, match="known effects"):
        parse_effect_arg("gremlins")
    with pytest.raises(ConfigError, match="number"):
        parse_effect_arg("fts_gain=abc")


def test_bench_config_validation(tmp_path):
    """Bench parameters are checked: negative mass and unknown TOML keys give ConfigError."""
    with pytest.raises(ConfigError, match="bench.m_exp"):
        BenchConfig(m_exp=-1.0)
    p = tmp_path / "s.toml"
    p.write_text("[bench]\nk_exp = 2e4\nwrong = 1\n")
    with pytest.raises(ConfigError, match="wrong"):
        load_bench(p)
    p.write_text("[bench]\nk_exp = 2e4\n")
    assert load_bench(p).k_exp == 2e4
    with pytest.raises(ConfigError, match="scene"):
        load_bench(tmp_path / "missing.toml")


@pytest.fixture(scope="module")
def stewart():
    from rths3d.diagnose.stewart import StewartBenchModel

    return StewartBenchModel(BenchConfig(), DT)


def test_stewart_off_values_and_rest(stewart, command):
    """Stewart backend: at rest every tared channel reads ~0, and every effect at its off
    value reproduces the nominal replay bit for bit."""
    rest = stewart.replay(np.zeros(300), {})
    assert np.max(np.abs(rest["z_meas.z"])) < 1e-6
    assert np.max(np.abs(rest["f_meas.z"])) < 0.05  # N, below the sensor noise
    base = stewart.replay(command, {})
    for name, eff in REGISTRY.items():
        off = stewart.replay(command, {name: eff.param.off})
        for c in base:
            np.testing.assert_array_equal(off[c], base[c])


def test_stewart_friction_acts_on_every_leg(stewart, command):
    """Leg friction F_c on the Stewart platform shifts each leg force by about ±F_c while
    the legs move (heave: all six legs alike)."""
    d = {c: stewart.replay(command, {"coulomb_friction": 25.0})[c] - stewart.replay(
        command, {})[c] for c in stewart.channels}
    legs = np.column_stack([d[f"leg_force.{i}"] for i in range(6)])
    v = np.gradient(command, DT)
    moving = np.abs(v) > 5e-3
    shift = np.median(np.abs(legs[moving]), axis=0)
    np.testing.assert_allclose(shift, 25.0, rtol=0.15)


def test_bench_from_a_vrths_scene():
    """A loop scene with a contact specimen maps onto the bench: m, k, h0, servo gains, and
    k_contact (N/m) becomes the mass-normalised k_contact/m (1/s²); other kinds are refused."""
    from rths3d.diagnose.bench import resolve_scene
    from rths3d.scene import load_scene

    sc = load_scene("paper_contact")
    cfg, kind = resolve_scene("paper_contact")
    assert kind in ("bench", "stewart")
    assert cfg.m_exp == sc.experiment.m and cfg.k_exp == sc.experiment.k
    assert cfg.h0 == sc.experiment.h0 and cfg.kp == sc.transfer.kp
    assert cfg.k_contact == pytest.approx(sc.experiment.k_contact / sc.experiment.m)
    with pytest.raises(ConfigError, match="experiment.kind"):
        resolve_scene("multidof")
