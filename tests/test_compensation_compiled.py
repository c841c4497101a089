"""Adaptive compensators in the 1-D compiled range loop (ideal, delay, LTI transfers):
the records equal the Python driver's (rths3d.loop._Group._python, the compensator's
``command`` calling the same kernel) to 1e-12 of each signal's peak, with the coefficients
over time and a drift stop inside a range."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_closed_stewart import _same  # compiled and Python records to 1e-12 of each peak

from rths3d.loop import run_batch
from rths3d.scene import load_scene
from rths3d.transfer.chain import ChainTransfer

SCENE = Path(__file__).resolve().parents[1] / "scenes" / "paper_contact.toml"


def _both(monkeypatch, go):
    a = go()
    monkeypatch.setattr(ChainTransfer, "compiled", lambda self: None)
    return a, go()


def test_ats_on_the_lti_path_compiled_equals_python_with_a_drift_stop(monkeypatch):
    sc = load_scene(SCENE, ["duration=1.0", "transfer.kind='lti'", "transfer.delay=0.005",
                            "transfer.compensation='ats'", "transfer.compensator.window=0.25"])
    sets = [{}, {"transfer.delay": 0.02}, {"transfer.compensator.a1_bounds": [0.0, 0.002]}]
    a, b = _both(monkeypatch, lambda: run_batch(sc, sets, reference=False))
    for ra, rb in zip(a, b, strict=True):
        _same(ra, rb)
    assert [r.status for r in a] == ["ok", "ok", "stopped"], [r.reason for r in a]
    assert "ats a1 estimate (channel 0) outside its bounds" in a[2].reason
    assert 300 < len(a[2].record.t) < 1001
    for r in a[:2]:  # the coefficients adapted (s): the equality covers the adaptation
        assert np.ptp(r.record.columns["comp.a1.z"]) > 1e-5


@pytest.mark.parametrize("comp, drift, reason", [
    ("rls", {"transfer.compensator.lead_bounds": [0.0, 0.002]}, "rls lead time"),
    ("rodeac", {"transfer.compensator.gain_bounds": [0.95, 0.99]},
     "rodeac inverse DC gain Σθ")])
def test_rls_and_rodeac_on_the_lti_path_compiled_equal_python_with_a_drift_stop(
        monkeypatch, comp, drift, reason):
    sc = load_scene(SCENE, ["duration=0.6", "transfer.kind='lti'", "transfer.delay=0.005",
                            f"transfer.compensation='{comp}'"])
    a, b = _both(monkeypatch, lambda: run_batch(sc, [{}, drift], reference=False))
    for ra, rb in zip(a, b, strict=True):
        _same(ra, rb)
    assert a[0].status == "ok" and f"{reason} (channel 0) outside its bounds" in a[1].reason
    assert np.ptp(a[0].record.columns["comp.theta0.z"]) > 1e-6


def test_lead_on_the_lti_path_compiled_equals_python(monkeypatch):
    """The fixed lead filter in the 1-D compiled loop: the Python driver's record; the filter
    acts (the command differs from the uncompensated test's)."""
    sc = load_scene(SCENE, ["duration=1.0", "transfer.kind='lti'", "transfer.delay=0.005",
                            "transfer.compensation='lead'"])
    a, b = _both(monkeypatch, lambda: run_batch(sc, [{}, {"numerical.k": 5e3}],
                                               reference=False))
    for ra, rb in zip(a, b, strict=True):
        _same(ra, rb)
    plain = run_batch(load_scene(SCENE, ["duration=1.0", "transfer.kind='lti'",
                                         "transfer.delay=0.005"]), [{}], reference=False)[0]
    assert np.max(np.abs(a[0].record.columns["z_meas.z"] - plain.record.columns["z_meas.z"])
                  ) > 1e-6


@pytest.mark.parametrize("comp", ["inverse", "model_based"])
def test_inverse_and_model_based_on_the_lti_path_compiled_equal_python(monkeypatch, comp):
    """The inverse feed-forward, and with it model_based's PI feedback, |u_fb| limit and
    watch, in the 1-D compiled loop: the Python driver's record (its ``command`` runs the
    same kernel), u_fb over time included; a tiny fb_limit stops model_based's third test
    inside a range at the same row with the same reason."""
    over = ["duration=1.0", "transfer.kind='lti'", "transfer.delay=0.005"]
    sc = load_scene(SCENE, [*over, f"transfer.compensation='{comp}'"])
    sets = [{}, {"numerical.k": 5e3}]
    if comp == "model_based":
        sets.append({"transfer.compensator.fb_limit": 2e-7})  # m: |u_fb| reaches 3e-7 m
    a, b = _both(monkeypatch, lambda: run_batch(sc, sets, reference=False))
    for ra, rb in zip(a, b, strict=True):
        _same(ra, rb)
    assert [r.status for r in a[:2]] == ["ok", "ok"]
    plain = run_batch(load_scene(SCENE, over), [{}], reference=False)[0]
    # the compensator acts: the command differs from the uncompensated test's (m)
    assert np.max(np.abs(a[0].record.columns["z_meas.z"] - plain.record.columns["z_meas.z"])
                  ) > 1e-6
    if comp == "model_based":
        assert a[2].status == "stopped"
        assert "model_based feedback correction |u_fb| (channel 0)" in a[2].reason
        assert 100 < len(a[2].record.t) < 1001
        assert np.ptp(a[0].record.columns["comp.u_fb.z"]) > 1e-7  # the feedback acted (m)


def test_inverse_start_from_delay_writes_the_delay_into_the_kernel_rows():
    """With G = 1 and no filter the inverse is the extrapolation u = z + T ż + T²/2 z̈
    (z̈ = Δż/dt, 0 on the first call), T = the predicted delay + dt/2 per test
    (:meth:`InverseCore.start_from_delay`): computed here by hand, per test."""
    from rths3d.compensation import build

    dt, K, n = 1e-3, 3, 2
    delay = np.array([0.004, 0.0, 0.02])
    T = delay + 0.5 * dt
    comp = build("inverse", K, n, dt, {"num": [1.0], "den": [1.0], "filter_order": 0})
    comp.start_from_delay(delay)
    assert np.array_equal(comp.core.delays(comp.params, 0), T)
    rng = np.random.default_rng(4)
    zd_prev = None
    for _ in range(5):
        z, zd = rng.normal(size=(K, n)), rng.normal(size=(K, n))
        zdd = np.zeros((K, n)) if zd_prev is None else (zd - zd_prev) / dt
        want = z + T[:, None] * zd + 0.5 * T[:, None] ** 2 * zdd
        np.testing.assert_allclose(comp.command(z, zd, z), want, rtol=1e-12, atol=1e-12)
        zd_prev = zd


def test_model_based_stopped_tests_hold_their_command():
    """Three tests of one model_based compensator whose plants lag by different gains: each
    stops when its |u_fb| passes fb_limit; its command of that call is the one computed
    (the kernel's stop comes after the command, as for the first test to stop), and from
    the next call on it stays as it was while the other tests go on; u_fb is the kernel's
    (coefficients() and history() are views of its state)."""
    from rths3d.compensation import build

    dt, N, K = 1e-3, 1500, 3
    comp = build("model_based", K, 1, dt, {"fb_limit": 2e-4})
    hist = comp.history()
    assert np.shares_memory(hist, comp.state) and np.shares_memory(
        comp.coefficients()["u_fb"], comp.state)
    gain = np.array([[0.7], [0.8], [0.9]])
    t = np.arange(N) * dt
    zm = np.zeros((K, 1))
    us, fbs, stopped = [], [], []
    for i in range(N):
        z = np.full((K, 1), 0.01 * np.sin(2 * np.pi * 2 * t[i]))
        zd = np.full((K, 1), 0.01 * 2 * np.pi * 2 * np.cos(2 * np.pi * 2 * t[i]))
        u = comp.command(z, zd, zm)
        us.append(u.copy())
        fbs.append(hist[:, 0, 0].copy())
        stopped.append(comp.stopped.copy())
        zm = gain * u
    us, fbs, stopped = np.array(us)[:, :, 0], np.array(fbs), np.array(stopped)
    first = [int(np.argmax(stopped[:, k])) for k in range(K)]
    assert all(stopped[-1]) and len(set(first)) == K, first  # three stops at three calls
    for k, c in enumerate(first):
        assert abs(fbs[c, k]) > 2e-4 >= np.max(np.abs(fbs[:c, k]))  # m
        assert us[c, k] != us[c - 1, k]  # the stopping call's command is its own
        assert np.all(us[c:, k] == us[c, k]) and np.all(fbs[c:, k] == fbs[c, k])
        assert comp.stops[k].t == pytest.approx(c * dt)
        assert "model_based feedback correction |u_fb| (channel 0)" in comp.reasons[k]
