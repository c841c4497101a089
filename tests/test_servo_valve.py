"""The servo-valve after the hold (``[controller] valve_hz``, ``valve_damping``): a
second-order response of the held set-point, integrated with the physics at the physics step
(rths3d.platform.model: a spool driven as a mass–spring–damper, the servo's stiffness on
it through a tendon). Checked against the closed form of the valve's response, computed here
from the matrix exponential of its own state equations."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
from test_servo_lag import stepped_setpoints

from rths3d.errors import ConfigError
from rths3d.platform.model import ActuatorConfig, PlatformConfig, build_model, predicted_delay

KP, KV = 2.0e5, 2.0e3  # N/m, N·s/m
HZ, ZETA = 60.0, 0.6  # the valve's natural frequency (Hz) and damping ratio (1)
SCENE = Path(__file__).resolve().parents[1] / "scenes" / "paper_contact.toml"


def _valve_setpoints(hold: str, n: int = 60, substeps: int = 1):
    """The set-points c_k given to the servo and the valve output y it acted on
    (:func:`test_servo_lag.stepped_setpoints`: y from the measured leg state)."""
    return stepped_setpoints(ActuatorConfig(kp=KP, kv=KV, timeconst=0.0, delay=0.0,
                                            hold=hold, valve_hz=HZ, valve_damping=ZETA),
                             n, substeps)


def _closed_form(c: np.ndarray, h: float, hold: str) -> np.ndarray:
    """ÿ + 2ζω ẏ + ω² y = ω² r of the held set-points c: the state (y, ẏ, r, ṙ) over a step
    by its exact transition matrix, r held (zoh) or ramped from c_k to c_{k+1}."""
    w = 2 * math.pi * HZ
    A = np.array([[0.0, 1.0, 0.0, 0.0], [-w * w, -2 * ZETA * w, w * w, 0.0],
                  [0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 0.0, 0.0]])
    E = scipy.linalg.expm(A * h)
    out = np.empty_like(c)
    out[0] = c[0]
    for i in range(c.shape[1]):
        st = np.array([c[0, i], 0.0, c[0, i], 0.0])
        for k in range(len(c) - 1):
            st[2:] = (c[k + 1, i], 0.0) if hold == "zoh" else (c[k, i],
                                                                (c[k + 1, i] - c[k, i]) / h)
            st = E @ st
            out[k + 1, i] = st[0]
    return out


@pytest.mark.parametrize("hold", ["ramp", "zoh"])
def test_valve_is_the_second_order_response_of_the_held_setpoint(hold):
    """At every sample the servo acts on the closed-form response of the valve to the held
    set-point (ramped or held), to the physics integrator's accuracy (fourth order: half the
    physics step, about 1/16 of the error); the valve is there (the output is far from the
    set-point)."""
    c, y, h = _valve_setpoints(hold)
    span = float(np.ptp(c, axis=0).max())
    assert span > 5e-4  # m: the legs moved
    err = float(np.abs(y - _closed_form(c, h, hold)).max())
    assert err < 2e-4 * span, err
    assert np.abs(y - c).max() > 0.2 * span
    c2, y2, _ = _valve_setpoints(hold, substeps=2)
    err2 = float(np.abs(y2 - _closed_form(c2, h, hold)).max())
    assert err2 < err / 8, (err, err2)


def test_default_model_has_no_valve_and_the_valve_model_its_spools():
    """Today's bench builds the model it always did; a valve adds six spools (one slide
    each), six tendons and twelve actuators, the spool's rate ω and damping ζ."""
    m0 = build_model(PlatformConfig())
    m1 = build_model(PlatformConfig(actuator=ActuatorConfig(valve_hz=HZ, valve_damping=ZETA)))
    assert (m0.nu, m0.na, m0.ntendon) == (6, 6, 0)
    assert (m1.nu, m1.na, m1.ntendon, m1.nv - m0.nv) == (18, 6, 6, 6)
    w = 2 * math.pi * HZ
    stiff, damp = -m1.actuator_biasprm[:6, 1], -m1.actuator_biasprm[:6, 2]
    mass = m1.body_mass[m1.body("leg0_spool").id]
    assert np.allclose(np.sqrt(stiff / mass), w, rtol=1e-10)
    assert np.allclose(damp / (2 * mass * w), ZETA, rtol=1e-10)
    assert np.allclose(-m1.actuator_biasprm[6:12, 1], KP)


def test_predicted_delay_of_the_valve():
    """The predicted delay with the valve adds its phase delay atan2(2ζωw, ω² − w²)/w."""
    f = 3.0
    w = 2 * math.pi * f
    wn = 2 * math.pi * HZ
    base = predicted_delay(PlatformConfig(actuator=ActuatorConfig(timeconst=0.0, delay=0.0)), f)
    valve = predicted_delay(PlatformConfig(actuator=ActuatorConfig(
        timeconst=0.0, delay=0.0, valve_hz=HZ, valve_damping=ZETA)), f)
    assert valve - base == pytest.approx(math.atan2(2 * ZETA * wn * w, wn * wn - w * w) / w,
                                         rel=1e-9)


def test_bad_valves_are_refused_with_one_line():
    """A negative frequency, a valve with the lag after the hold, and a valve faster than
    the physics step integrates are each one ConfigError naming the field and the limit."""
    with pytest.raises(ConfigError) as e:
        ActuatorConfig(valve_hz=-1.0)
    assert "valve_hz" in str(e.value) and ">= 0" in str(e.value)
    with pytest.raises(ConfigError) as e:
        ActuatorConfig(valve_hz=HZ, timeconst=0.003, lag="servo")
    assert "controller.valve_hz" in str(e.value) and "as one" in str(e.value)
    with pytest.raises(ConfigError) as e:
        PlatformConfig(actuator=ActuatorConfig(valve_hz=1000.0))
    assert "platform.substeps" in str(e.value) and "substeps >= 3" in str(e.value)
    PlatformConfig(substeps=3, actuator=ActuatorConfig(valve_hz=1000.0))


def test_bench_init_valve_loads_runs_and_writes_back(tmp_path):
    """`rths3d bench init --valve-hz` writes a scene whose model has the valve and that
    runs closed loop; the scene writes the valve back; a scene without one writes no valve
    keys; a bad value is one line naming ``controller.valve_hz``, exit code 2."""
    from cli_cases import run_in_process

    from rths3d.bench import platform_config
    from rths3d.loop import run
    from rths3d.scene import load_scene, scene_to_dict

    out = tmp_path / "valve.toml"
    res = run_in_process("bench", "init", str(out), "--valve-hz", "80", "--valve-damping", "0.5")
    assert res.returncode == 0, res.stderr
    sc = load_scene(out, ["duration=0.05"])
    assert (sc.transfer.valve_hz, sc.transfer.valve_damping) == (80.0, 0.5)
    assert platform_config(sc).actuator.valve == (2 * math.pi * 80.0, 0.5)
    rec = run(sc, reference=False).record
    assert rec.meta["status"] == "ok"
    assert np.all(np.isfinite(rec.columns["leg_force.0"]))
    assert scene_to_dict(sc)["transfer"]["valve_hz"] == 80.0
    assert "valve_hz" not in scene_to_dict(load_scene(SCENE))["transfer"]
    res = run_in_process("bench", "init", str(tmp_path / "bad.toml"), "--valve-hz", "80",
                         "--lag", "servo", "--timeconst", "0.003")
    assert res.returncode == 2 and "controller.valve_hz" in res.stderr
    assert "Traceback" not in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "bad.toml").exists()


@pytest.mark.parametrize("hold,K", [("ramp", 1), ("zoh", 2)])
def test_valve_compiled_loop_equals_python_driver(monkeypatch, hold, K):
    """The closed loop with the valve: the compiled ranges and the Python driver give the
    same record (to 1e-12 of each signal's peak); the valve changed the motion."""
    from rths3d.loop import run_batch
    from rths3d.scene import load_scene
    from rths3d.transfer.stewart import StewartTransfer

    base = ["duration=0.3", "transfer.kind='stewart'", f"controller.hold='{hold}'"]
    sc = load_scene(SCENE, [*base, f"controller.valve_hz={HZ}"])
    sets = [{}, {"numerical.k": 14000.0}][:K]
    out = {}
    for flag in (True, False):
        monkeypatch.setattr(StewartTransfer, "closed_loop", flag)
        out[flag] = run_batch(sc, sets, reference=False)
    for a, b in zip(out[True], out[False], strict=True):
        assert a.record.meta["loop"] == "compiled" and b.record.meta["loop"] == "python"
        assert a.status == b.status == "ok"
        for c in b.record.columns:
            x, y = np.asarray(a.record.columns[c]), np.asarray(b.record.columns[c])
            peak = float(np.max(np.abs(y)))
            assert float(np.max(np.abs(x - y))) <= 1e-12 * peak, c
    plain = run_batch(load_scene(SCENE, base), [{}], reference=False)[0]
    z0 = plain.record.columns["z_meas.z"]
    assert np.abs(out[True][0].record.columns["z_meas.z"] - z0).max() > 0.01 * np.ptp(z0)


def test_servo_gain_effect_scales_the_valves_stiffness():
    """A leg-gain effect with the valve acts on the servo's stiffness on the valve's output:
    ``servo_gain`` −15 % on every leg gives the record of a scene stating kp = 0.85·2·10⁵
    N/m (no feed-forward, no gravity compensation: they would read the stated gain), to
    1e-9 of each channel's peak."""
    from rths3d.diagnose import measure
    from rths3d.scene import load_scene

    base = ["duration=0.5", f"controller.valve_hz={HZ}", "controller.feedforward='none'",
            "controller.gravity='none'"]
    a = measure(load_scene("bench6", base), {"servo_gain": -0.15}, noise=0.0)
    b = measure(load_scene("bench6", [*base, "controller.kp=170000.0", "transfer.kp=170000.0"]),
                {}, noise=0.0)
    moved = 0
    for c in b.columns:
        if c == "t":
            continue
        x, y = np.asarray(a.columns[c]), np.asarray(b.columns[c])
        peak = float(np.max(np.abs(y)))
        assert float(np.max(np.abs(x - y))) <= 1e-9 * peak + 1e-15, c
        moved += c.startswith("leg_force.") and peak > 1.0
    assert moved == 6
