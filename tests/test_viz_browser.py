"""Real-browser test of the view: headless Chromium opens the page, connects, and draws."""

from __future__ import annotations

import importlib.util

import pytest
from test_viz import delayed_sine_record

from rths3d.viz import Viewer, buffer_from_record
from rths3d.viz.screenshot import chromium_path, screenshot

pytestmark = pytest.mark.browser


@pytest.fixture(scope="module")
def browser_ready() -> None:
    if chromium_path() is None:
        pytest.skip("headless Chromium not found at /usr/bin/chromium (Debian package "
                    "'chromium'); set RTHS3D_CHROMIUM to another binary")
    if importlib.util.find_spec("playwright") is None:
        pytest.skip("playwright is not installed (pip install playwright)")


def test_browser_shows_platform_and_ssp_panel(browser_ready, tmp_path):
    """Chromium connects, the 3-D canvas is not blank (many colours, real contrast) and the SSP
    panel is on the page."""
    rec = delayed_sine_record(duration=3.0, model=True)
    with Viewer(buffer_from_record(rec), port=0, exaggeration=20.0) as v:
        shot = tmp_path / "viewer.png"
        check = screenshot(v.url, shot, settle=4.0)
        assert v.updates > 0
    assert shot.stat().st_size > 20_000
    assert check.connected and check.webgl
    assert check.ssp_panel
    assert check.canvas_std > 10.0 and check.canvas_colours > 50


def test_browser_shows_a_diagnosis_replay_leg_by_leg(browser_ready, tmp_path):
    """A diagnosis replay (report's replay.parquet: measurement, model and residual columns
    in six DOF) opens side by side: the platform and its model twin, the leg-force panel
    (measured and model) and the residual per leg."""
    import numpy as np

    from rths3d.diagnose import Diagnosis, measure
    from rths3d.diagnose.report import replay_record
    from rths3d.scene import load_scene

    rec = measure(load_scene("bench6", ["duration=1.2"]), {"coulomb_friction.leg2": 30.0},
                  seed=2)
    diag = Diagnosis(rec, candidates=["coulomb_friction.leg2"])
    rep = replay_record(diag)
    assert {f"model.leg_force.{i}" for i in range(6)} <= set(rep.columns)
    assert np.max(np.abs(rep.columns["residual.leg_force.2"])) > 10  # friction unmodelled
    with Viewer(buffer_from_record(rep), port=0, exaggeration=20.0) as v:
        shot = tmp_path / "legs.png"
        check = screenshot(v.url, shot, settle=4.0,
                           expect=("leg forces of the chosen leg: measured and model (N)",
                                   "residual per leg (leg force, noise units)"))
        assert v.updates > 0
    assert check.connected and all(check.texts.values()), check.texts


def test_browser_draws_the_fidelity_estimate_as_a_band(browser_ready, tmp_path):
    """A record with the surrogate reference's columns (as ``rths3d metrics --save-estimate``
    writes them) and the monitor's metadata: the running RMS of ê with its members' band and
    the limit, for the chosen DOF."""
    from rths3d.loop import run
    from rths3d.record import Record
    from rths3d.scene import load_scene
    from rths3d.surrogate import SurrogateReference

    rec = run(load_scene("paper_contact", {"transfer.kind": "lti", "transfer.delay": 0.01,
                                           "duration": 3.0, "safety.fidelity_limit": 2e-4,
                                           "safety.fidelity_warmup": 1.0})).record
    cols = dict(rec.columns)
    cols.update(SurrogateReference().fit(rec).columns(rec))
    assert {"e_hat_rms.z", "e_hat_rms_lo.z", "e_hat_rms_hi.z"} <= set(cols)
    with Viewer(buffer_from_record(Record(rec.t, cols, rec.meta)), port=0) as v:
        check = screenshot(v.url, tmp_path / "fidelity.png", settle=4.0,
                           expect=("running RMS of ê = z' − ẑ^r, z (m, 0.25 s)",))
        assert v.updates > 0
    assert check.connected and all(check.texts.values()), check.texts
