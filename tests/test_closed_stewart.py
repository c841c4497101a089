"""The closed vRTHS loop with the Stewart platform: compiled ranges against the Python driver.

The Python driver (rths3d.loop._Group._python, one step at a time through
PlatformBatch.advance) is the reference; the compiled ranges (rths3d.platform.closed) must
give the same record to 1e-12 of each signal's peak, including sensor noise, start sampling,
a zero-order hold, a monitor stop and a platform stop inside a range.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rths3d.loop import run, run_batch
from rths3d.scene import load_scene
from rths3d.transfer.stewart import StewartTransfer

SCENE = Path(__file__).resolve().parents[1] / "scenes" / "paper_contact.toml"


def _both(monkeypatch, go):
    out = {}
    for flag in (True, False):
        monkeypatch.setattr(StewartTransfer, "closed_loop", flag)
        out[flag] = go()
    return out[True], out[False]


def _same(a, b) -> None:
    assert a.record.meta["loop"] == "compiled" and b.record.meta["loop"] == "python"
    assert (a.status, a.reason) == (b.status, b.reason)
    ra, rb = a.record, b.record
    assert len(ra.t) == len(rb.t)
    for c in rb.columns:
        x, y = np.asarray(ra.columns[c]), np.asarray(rb.columns[c])
        peak = float(np.max(np.abs(y))) if y.size else 0.0
        err = float(np.max(np.abs(x - y))) if y.size else 0.0
        assert err <= 1e-12 * peak or err == 0.0, (c, err, peak)


@pytest.mark.slow  # the Python path of a whole Stewart test
def test_single_test_compiled_equals_python(monkeypatch):
    sc = load_scene(SCENE, ["duration=0.3", "transfer.kind='stewart'",
                            "transfer.compensation='polynomial'", "transfer.comp_time=0.004"])
    a, b = _both(monkeypatch, lambda: run(sc, reference=False))
    _same(a, b)
    assert a.status == "ok" and len(a.record.t) == 301
    # the test moved: the equality is not one of two idle records (m)
    assert np.ptp(a.record.columns["z_meas.z"]) > 1e-4


def test_batch_noise_start_sampling_zoh_and_stops_inside_a_range(monkeypatch):
    """Three tests stepped together with sensor noise (in the loop's z' and F', and on the
    recorded channels), start sampling and a zero-order hold: one stopped by the monitor
    (measured force), the others by the platform (a leg's measured force) at other rows."""
    sc = load_scene(SCENE, ["duration=0.6", "transfer.kind='stewart'",
                            "controller.sample='start'", "controller.hold='zoh'",
                            "sensor.noise_std=0.05", "effect.sensor_noise=1.0",
                            "platform.leg_force_limit=41.5"])
    sets = [{}, {"safety.force": 3.0}, {"numerical.k": 14000.0}]
    a, b = _both(monkeypatch, lambda: run_batch(sc, sets, reference=False))
    for ra, rb in zip(a, b, strict=True):
        _same(ra, rb)
    assert a[1].status == "stopped" and "measured force" in a[1].reason
    assert all(r.status == "stopped" and "leg" in r.reason for r in (a[0], a[2]))
    n = [len(r.record.t) for r in a]
    assert all(1 < m < 601 for m in n) and len(set(n)) == 3, n


def test_command_limit_stop_inside_a_range(monkeypatch):
    """A leg commanded faster than its limit (0.01 m/s) in the middle of the run: the step
    that stops it is finished by the Python driver's own method (its SafetyStop)."""
    sc = load_scene(SCENE, ["duration=0.4", "transfer.kind='stewart'",
                            "platform.leg_velocity_limit=0.01"])
    a, b = _both(monkeypatch, lambda: run(sc, reference=False))
    _same(a, b)
    assert a.status == "stopped" and "commanded velocity" in a.reason
    assert 1 < len(a.record.t) < 401


def test_ats_compiled_equals_python_with_adaptation_and_a_drift_stop(monkeypatch):
    """ATS per interface DOF steps inside the compiled closed loop: its adaptation (window
    0.25 s, so the coefficients move within the test) and its drift stop (a1 bounded below
    the delay: the estimate stays outside for longer than bound_time) give the Python
    driver's record, the stop's row and its reason."""
    sc = load_scene(SCENE, ["duration=0.8", "transfer.kind='stewart'", "transfer.delay=0.005",
                            "transfer.compensation='ats'", "transfer.compensator.window=0.25"])
    sets = [{}, {"transfer.delay": 0.02}, {"transfer.compensator.a1_bounds": [0.0, 0.002]}]
    a, b = _both(monkeypatch, lambda: run_batch(sc, sets, reference=False))
    for ra, rb in zip(a, b, strict=True):
        _same(ra, rb)
    assert [r.status for r in a] == ["ok", "ok", "stopped"]
    assert "ats a1 estimate (channel 0) outside its bounds" in a[2].reason
    assert 300 < len(a[2].record.t) < 801
    # the coefficients adapted during the test (s): the equality covers the adaptation
    for r in a[:2]:
        assert np.ptp(r.record.columns["comp.a1.z"]) > 5e-4


def test_per_leg_ats_compiled_equals_python_with_a_drift_stop_naming_the_leg(monkeypatch):
    """ATS on the six legs (the platform's leg hook) steps inside the compiled closed loop:
    the leg channels, the leg compensator's kernel and the commanded lengths give the Python
    driver's record, and a drifting leg compensator stops its test at the same row with
    the leg named."""
    sc = load_scene(SCENE, ["duration=0.8", "transfer.kind='stewart'", "transfer.delay=0.005",
                            "transfer.compensation='ats'", "transfer.compensate='legs'",
                            "transfer.compensator.window=0.25"])
    sets = [{}, {"transfer.delay": 0.02}, {"transfer.compensator.a1_bounds": [0.0, 0.002]}]
    a, b = _both(monkeypatch, lambda: run_batch(sc, sets, reference=False))
    for ra, rb in zip(a, b, strict=True):
        _same(ra, rb)
    assert [r.status for r in a] == ["ok", "ok", "stopped"]
    assert "ats a1 estimate (leg 0) outside its bounds" in a[2].reason
    assert 300 < len(a[2].record.t) < 801
    for r in a[:2]:  # the legs' coefficients adapted (s)
        assert np.ptp(r.record.columns["comp.a1.leg0"]) > 5e-4


@pytest.mark.slow  # the Python path of a six-DOF Stewart test
def test_ats_six_dof_compiled_equals_python(monkeypatch):
    sc = load_scene(SCENE.parent / "bench6.toml", [
        "duration=1.0", "transfer.kind='stewart'", "transfer.compensation='ats'",
        "transfer.compensator.window=0.2"])
    a, b = _both(monkeypatch, lambda: run(sc, reference=False))
    _same(a, b)
    coefs = [c for c in a.record.columns if c.startswith("comp.a1.")]
    assert len(coefs) == 6
    # the equality covers the adaptation: coefficients of several DOFs moved (s)
    assert sum(np.ptp(a.record.columns[c]) > 1e-4 for c in coefs) >= 2


def test_plugin_compensator_without_kernel_runs_on_the_python_path(monkeypatch):
    """A user's compensator in plain Python (velocity feed-forward u = z + τ ż written with
    numpy, no kernel) runs on the Python driver and says so; its record is that of the
    shipped ``velocity`` compensator (its kernel, compiled loop) to 1e-12."""
    from dataclasses import dataclass

    from rths3d.compensation import COMPENSATORS, BaseCompensator, CompensatorConfig

    @dataclass(frozen=True)
    class PlugConfig(CompensatorConfig):
        tau: float = 0.0

    class Plug(BaseCompensator):
        name = "plug_velocity"
        Config = PlugConfig

        def command(self, z, zdot, z_meas):
            self.u[:] = z + self.config.tau * zdot
            self.calls += 1
            return self.u

    monkeypatch.setitem(COMPENSATORS, "plug_velocity", Plug)
    over = ["duration=0.3", "transfer.kind='stewart'", "transfer.delay=0.005"]
    plug = run(load_scene(SCENE, over + ["transfer.compensation='plug_velocity'",
                                         "transfer.compensator.tau=0.004"]), reference=False)
    vel = run(load_scene(SCENE, over + ["transfer.compensation='velocity'",
                                        "transfer.comp_time=0.004"]), reference=False)
    assert plug.record.meta["loop"] == "python" and vel.record.meta["loop"] == "compiled"
    for c in ("z_cmd.z", "z_meas.z", "f_meas.z"):
        x, y = np.asarray(plug.record.columns[c]), np.asarray(vel.record.columns[c])
        assert np.max(np.abs(x - y)) <= 1e-12 * np.max(np.abs(y)), c
    assert np.ptp(vel.record.columns["z_meas.z"]) > 1e-4


DRIFT = {  # a setting whose bound the estimate leaves, and the start of its stop reason
    "rls": ({"transfer.compensator.lead_bounds": [0.0, 0.002]}, "rls lead time"),
    "rodeac": ({"transfer.compensator.gain_bounds": [0.95, 0.99]},
               "rodeac inverse DC gain Σθ"),
}


@pytest.mark.parametrize("comp", ["rls", "rodeac"])
@pytest.mark.parametrize("where", ["interface", "legs"])
def test_rls_and_rodeac_compiled_equal_python_with_a_drift_stop(monkeypatch, comp, where):
    """RLS and RoDeAC per interface DOF and per leg in the compiled closed loop: the Python
    driver's record, and an estimate held outside its bounds stops the test at the same
    row with the channel named."""
    sc = load_scene(SCENE, ["duration=0.6", "transfer.kind='stewart'", "transfer.delay=0.005",
                            f"transfer.compensation='{comp}'", f"transfer.compensate='{where}'"])
    drift, reason = DRIFT[comp]
    a, b = _both(monkeypatch, lambda: run_batch(sc, [{}, drift], reference=False))
    for ra, rb in zip(a, b, strict=True):
        _same(ra, rb)
    ch = "leg 0" if where == "legs" else "channel 0"
    assert a[0].status == "ok" and f"{reason} ({ch}) outside its bounds" in a[1].reason
    col = "comp.theta0." + ("leg0" if where == "legs" else "z")
    assert np.ptp(a[0].record.columns[col]) > 1e-6  # θ adapted: the equality covers it


@pytest.mark.parametrize("where", ["interface", "legs"])
def test_lead_compiled_equals_python(monkeypatch, where):
    """The fixed lead filter (the RTHS benchmark's G_T, direct form I) per interface DOF and
    per leg in the compiled closed loop: the Python driver's record (its ``command`` runs
    the same kernel)."""
    sc = load_scene(SCENE, ["duration=0.6", "transfer.kind='stewart'", "transfer.delay=0.005",
                            "transfer.compensation='lead'", f"transfer.compensate='{where}'"])
    a, b = _both(monkeypatch, lambda: run_batch(sc, [{}, {"numerical.k": 5e3}],
                                               reference=False))
    for ra, rb in zip(a, b, strict=True):
        _same(ra, rb)
    assert all(r.status == "ok" for r in a)


@pytest.mark.parametrize("comp", ["inverse", "model_based"])
@pytest.mark.parametrize("where", ["interface", "legs"])
def test_inverse_and_model_based_compiled_equal_python(monkeypatch, comp, where):
    """The inverse feed-forward and model_based (inverse + PI feedback, its |u_fb| limit and
    watch) per interface DOF and per leg in the compiled closed loop: the Python driver's
    record, u_fb over time included; a tiny fb_limit (3 µm) stops model_based's third test
    inside a range at the same row with the channel named."""
    sc = load_scene(SCENE, ["duration=0.6", "transfer.kind='stewart'", "transfer.delay=0.005",
                            f"transfer.compensation='{comp}'", f"transfer.compensate='{where}'"])
    sets = [{}, {"numerical.k": 5e3}]
    if comp == "model_based":
        sets.append({"transfer.compensator.fb_limit": 3e-6})
    a, b = _both(monkeypatch, lambda: run_batch(sc, sets, reference=False))
    for ra, rb in zip(a, b, strict=True):
        _same(ra, rb)
    assert [r.status for r in a[:2]] == ["ok", "ok"]
    if comp == "model_based":
        ch = "leg 0" if where == "legs" else "channel 0"
        assert a[2].status == "stopped"
        assert f"model_based feedback correction |u_fb| ({ch})" in a[2].reason
        assert 100 < len(a[2].record.t) < 601
        col = "comp.u_fb." + ("leg0" if where == "legs" else "z")
        assert np.ptp(a[0].record.columns[col]) > 1e-6  # the feedback acted (m)


@pytest.mark.parametrize("comp", ["inverse", "model_based"])
@pytest.mark.parametrize("where", ["interface", "legs"])
def test_inverse_and_model_based_six_dof_compiled_equal_python(monkeypatch, comp, where):
    """inverse and model_based on a six-DOF Stewart test, per interface DOF and per leg:
    the Python driver's record (every DOF's or leg's u_fb included), and for model_based a
    second test whose fb_limit (8 µm) one channel passes stops at the same row with the
    same reason."""
    sc = load_scene(SCENE.parent / "bench6.toml", [
        "duration=0.5", "transfer.kind='stewart'", f"transfer.compensation='{comp}'",
        f"transfer.compensate='{where}'"])
    sets = [{}]
    if comp == "model_based":
        sets.append({"transfer.compensator.fb_limit": 8e-6})
    a, b = _both(monkeypatch, lambda: run_batch(sc, sets, reference=False))
    for ra, rb in zip(a, b, strict=True):
        _same(ra, rb)
    assert a[0].status == "ok"
    moved = [c for c in ("pose_meas.x", "pose_meas.y", "pose_meas.rz")
             if np.ptp(a[0].record.columns[c]) > 1e-4]  # m, rad: a six-DOF motion
    assert len(moved) == 3, moved
    if comp == "model_based":
        coefs = [c for c in a[0].record.columns if c.startswith("comp.u_fb.")]
        assert len(coefs) == 6
        assert sum(np.ptp(a[0].record.columns[c]) > 1e-6 for c in coefs) >= 4  # m
        assert a[1].status == "stopped"
        assert "model_based feedback correction |u_fb|" in a[1].reason
        assert 100 < len(a[1].record.t) < 501
