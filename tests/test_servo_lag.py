"""The servo's first-order lag where the bench has it (``[controller] lag``): a digital
set-point filter before the hold (today's) or continuous dynamics after the hold, integrated
with the physics (docs/bench.md, rths3d.platform.model)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rths3d.errors import ConfigError
from rths3d.platform.model import ActuatorConfig, PlatformConfig, build_model, predicted_delay
from rths3d.platform.sim import PlatformBatch

TAU = 0.004  # s
KP, KV = 2.0e5, 2.0e3  # N/m, N·s/m


def _heave(k: int) -> float:
    """A heave command (m): rest, a 0.1 m/s ramp for 10 ms, a hold, a ramp back."""
    return 1e-4 * (min(max(k - 5, 0), 10) - min(max(k - 30, 0), 10))


def stepped_setpoints(actuator: ActuatorConfig, n: int = 60, substeps: int = 1):
    """Step a platform with ``actuator`` through :func:`_heave`; per sample: the set-points
    c_k the servo was given (m, (n+1, 6)) and the set-point the servo acted on, from the
    measured leg state: x = s + (F + kv·ṡ)/kp (m, (n+1, 6)); and the interface step (s)."""
    cfg = PlatformConfig(substeps=substeps, actuator=actuator)
    KP, KV = actuator.kp, actuator.kv  # noqa: N806
    sim = PlatformBatch(cfg)
    c, x = [sim._cnew[0].copy()], []

    def lagged() -> np.ndarray:
        return sim.live_legs_q[0] + (sim.meas_legs_f[0] + KV * sim.live_legs_v[0]) / KP

    x.append(lagged())
    for k in range(n):
        p = np.zeros((1, 6))
        p[0, 2] = _heave(k)
        sim.step(p)
        assert not sim.stopped[0]
        c.append(sim._cnew[0].copy())
        x.append(lagged())
    return np.array(c), np.array(x), cfg.dt


def _servo_setpoints(hold: str, n: int = 60, substeps: int = 1):
    """:func:`stepped_setpoints` with the servo lag after the hold."""
    return stepped_setpoints(ActuatorConfig(kp=KP, kv=KV, timeconst=TAU, delay=0.0,
                                            lag="servo", hold=hold), n, substeps)


def _closed_form(c: np.ndarray, h: float, hold: str) -> np.ndarray:
    """The lag 1/(1 + sτ) of the held set-points c (m, per sample), in closed form."""
    e = math.exp(-h / TAU)
    ref = np.empty_like(c)
    ref[0] = c[0]
    for k in range(len(c) - 1):
        if hold == "zoh":  # u = c_{k+1} from t_k on
            ref[k + 1] = c[k + 1] + (ref[k] - c[k + 1]) * e
        else:  # u = c_k + ρ (t − t_k)
            rho = (c[k + 1] - c[k]) / h
            ref[k + 1] = c[k + 1] - TAU * rho + (ref[k] - c[k] + TAU * rho) * e
    return ref


@pytest.mark.parametrize("hold", ["ramp", "zoh"])
def test_servo_lag_is_the_continuous_lag_of_the_held_setpoint(hold):
    """The set-point the servo acts on is, at every sample, the closed-form response of
    1/(1 + sτ) to the held set-point (a ramp between samples, or a zero-order hold), to the
    physics integrator's accuracy: fourth order in the physics step."""
    c, x, h = _servo_setpoints(hold)
    span = np.ptp(c, axis=0).max()
    assert span > 5e-4  # the legs moved (m)
    err = np.abs(x - _closed_form(c, h, hold)).max()
    assert err < 2e-5 * span, err
    # the lag is there: the set-point itself is far from what the servo acted on
    assert np.abs(x - c).max() > 0.1 * span
    # and the remainder is RK4's: half the physics step, about 1/16 of it
    c2, x2, _ = _servo_setpoints(hold, substeps=2)
    err2 = np.abs(x2 - _closed_form(c2, h, hold)).max()
    assert err2 < err / 8, (err, err2)


def test_servo_lag_differs_from_the_setpoint_lag():
    """The same time constant before and after the hold gives different plate motions (the
    servo's lag is not the digital filter's), and both follow the command in the end."""
    out = {}
    for lag in ("setpoint", "servo"):
        sim = PlatformBatch(PlatformConfig(actuator=ActuatorConfig(timeconst=TAU, lag=lag)))
        z = []
        for k in range(80):
            p = np.zeros((1, 6))
            p[0, 2] = _heave(k) if k < 30 else 1e-3
            sim.step(p)
            z.append(sim.pose[0, 2] - sim.rest_pose[0, 2])
        out[lag] = np.array(z)
    d = np.abs(out["servo"] - out["setpoint"]).max()
    assert d > 5e-6  # m: the placement matters
    for z in out.values():
        assert abs(z[-1] - 1e-3) < 2e-5


def test_default_model_has_no_lag_actuators():
    """Today's bench (``lag = "setpoint"``) builds the model it always did: six servos, no
    lag actuators; ``lag = "servo"`` adds six filters of the stated time constant."""
    m0 = build_model(PlatformConfig(actuator=ActuatorConfig(timeconst=TAU)))
    m1 = build_model(PlatformConfig(actuator=ActuatorConfig(timeconst=TAU, lag="servo")))
    assert m0.nu == 6 and m0.na == 6
    assert m1.nu == 12 and m1.na == 12
    assert np.allclose(m1.actuator_dynprm[6:, 0], TAU)
    assert np.allclose(m1.actuator_gainprm[6:, 0], -2.0e5 * TAU)


def test_predicted_delay_of_the_servo_lag():
    """The predicted delay with the servo lag adds the continuous lag's phase delay
    atan(ωτ)/ω, where the set-point lag adds its discrete filter's."""
    f = 2.0
    w = 2 * math.pi * f
    base = predicted_delay(PlatformConfig(actuator=ActuatorConfig(timeconst=0.0, delay=0.0)), f)
    servo = predicted_delay(PlatformConfig(actuator=ActuatorConfig(
        timeconst=TAU, delay=0.0, lag="servo")), f)
    assert servo - base == pytest.approx(math.atan(w * TAU) / w, rel=1e-9)


def test_bad_lag_and_too_coarse_a_step_are_refused():
    """A bad ``lag`` and a servo lag faster than the physics step can integrate are each one
    ConfigError naming the field and the limit."""
    with pytest.raises(ConfigError) as e:
        ActuatorConfig(lag="valve")
    assert "controller.lag" in str(e.value) and "setpoint | servo" in str(e.value)
    with pytest.raises(ConfigError) as e:
        PlatformConfig(actuator=ActuatorConfig(timeconst=2e-4, lag="servo"))
    assert "platform.substeps" in str(e.value) and "substeps >= 2" in str(e.value)


def test_bench_init_lag_servo_loads_and_runs(tmp_path):
    """`rths3d bench init --lag servo` writes a scene whose controller has the lag after the
    hold (the model carries the lag actuators) and that runs closed loop; a bad value is one
    line naming ``controller.lag``, exit code 2."""
    from typer.testing import CliRunner

    from rths3d.bench import platform_config
    from rths3d.cli import app, main
    from rths3d.loop import run
    from rths3d.scene import load_scene

    out = tmp_path / "servo.toml"
    res = CliRunner().invoke(app, ["bench", "init", str(out), "--timeconst", "0.003",
                                   "--lag", "servo"])
    assert res.exit_code == 0, res.output
    sc = load_scene(out, ["duration=0.05"])
    assert sc.controller.lag == "servo" and sc.transfer.timeconst == 0.003
    cfg = platform_config(sc)
    assert cfg.actuator.servo_lag == 0.003 and cfg.actuator.setpoint_lag == 0.0
    rec = run(sc, reference=False).record
    assert rec.meta["status"] == "ok"
    assert np.all(np.isfinite(rec.columns["leg_force.0"]))
    with pytest.raises(SystemExit) as e:
        main(["bench", "init", str(tmp_path / "bad.toml"), "--lag", "valve"])
    assert e.value.code == 2


@pytest.mark.parametrize("hold,K", [("ramp", 1), ("zoh", 2)])
def test_servo_lag_compiled_loop_equals_python_driver(monkeypatch, hold, K):
    """The closed loop with the servo lag after the hold: the compiled ranges and the Python
    driver give the same record (to 1e-12 of each signal's peak), one test ramped and two
    tests stepped together with a zero-order hold; the lag actuators moved the legs."""
    from pathlib import Path

    from rths3d.loop import run_batch
    from rths3d.scene import load_scene
    from rths3d.transfer.stewart import StewartTransfer

    sc = load_scene(Path(__file__).resolve().parents[1] / "scenes" / "paper_contact.toml",
                    ["duration=0.3", "transfer.kind='stewart'", "transfer.timeconst=0.003",
                     "controller.lag='servo'", f"controller.hold='{hold}'"])
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
        assert np.ptp(a.record.columns["z_meas.z"]) > 1e-4


def test_servo_gain_effect_scales_the_gain_on_the_lagged_setpoint():
    """A leg-gain effect with the lag after the hold acts on the lagged set-point: the
    bench with ``servo_gain`` −15 % on every leg gives the record of a scene stating
    kp = 0.85·2·10⁵ N/m, which the model builder writes directly (no feed-forward and no
    gravity compensation, which would read the stated gain), to 1e-9 of each channel's peak.
    Scaling the servo's actuator alone leaves the lag's force −kp·τ·f at the old gain."""
    from rths3d.diagnose import measure
    from rths3d.scene import load_scene

    base = ["duration=0.5", "controller.lag='servo'", "controller.timeconst=0.003",
            "transfer.timeconst=0.003", "controller.feedforward='none'",
            "controller.gravity='none'"]
    a = measure(load_scene("bench6", base), {"servo_gain": -0.15}, noise=0.0)
    b = measure(load_scene("bench6", [*base, "controller.kp=170000.0",
                                      "transfer.kp=170000.0"]), {}, noise=0.0)
    moved = 0
    for c in b.columns:
        if c == "t":
            continue
        x, y = np.asarray(a.columns[c]), np.asarray(b.columns[c])
        peak = float(np.max(np.abs(y)))
        assert float(np.max(np.abs(x - y))) <= 1e-9 * peak + 1e-15, c
        moved += c.startswith("leg_force.") and peak > 1.0
    assert moved == 6
