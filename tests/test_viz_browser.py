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
