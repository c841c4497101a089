"""Adaptive compensators in the 1-D compiled range loop (ideal, delay, LTI transfers):
the records equal the Python driver's (rths3d.loop._Group._python, the compensator's
``command`` calling the same kernel) to 1e-12 of each signal's peak, with the coefficients
over time and a drift stop inside a range."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rths3d.loop import run_batch
from rths3d.scene import load_scene
from rths3d.transfer.chain import ChainTransfer

SCENE = Path(__file__).resolve().parents[1] / "scenes" / "paper_contact.toml"


def _both(monkeypatch, go):
    a = go()
    monkeypatch.setattr(ChainTransfer, "compiled", lambda self: None)
    return a, go()


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
