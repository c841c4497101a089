"""Headless-browser pictures of a running view (Playwright driving a Chromium binary).

Used by the browser test and to make the README picture. Chromium renders WebGL in software
here (SwiftShader); the flags below are the ones that work on a closed network as root.
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

CHROMIUM = "/usr/bin/chromium"
CHROMIUM_FLAGS = (
    "--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
    "--disable-quic", "--no-first-run", "--disable-background-networking",
    "--disable-component-update", "--disable-sync",
)


@dataclass(frozen=True)
class PageCheck:
    """What the page showed: connection state, panel titles found, canvas statistics."""

    connected: bool
    webgl: bool
    """False when the page reported "WebGL unavailable"."""
    ssp_panel: bool
    canvas_std: float
    """Standard deviation of the 3-D canvas pixels (0–255 grey levels; 0 = blank)."""
    canvas_colours: int
    """Distinct colours in the 3-D canvas (a blank canvas has one)."""
    texts: dict[str, bool] = field(default_factory=dict)
    """Whether each of the ``expect`` texts was on the page."""


def chromium_path() -> str | None:
    """The Chromium binary to use (env ``RTHS3D_CHROMIUM`` or /usr/bin/chromium), or None."""
    path = os.environ.get("RTHS3D_CHROMIUM", CHROMIUM)
    return path if Path(path).exists() else None


def require_browser() -> str:
    """The Chromium binary, after checking that a picture can be taken here: Playwright
    installed (the ``browser`` extra) and a Chromium binary present. Otherwise one error
    naming what to install (:class:`~rths3d.errors.RthsError`)."""
    import importlib.util

    from ..errors import MissingDependency, RthsError

    if importlib.util.find_spec("playwright") is None:
        raise MissingDependency("playwright", "a screenshot of the view", "browser")
    exe = chromium_path()
    if exe is None:
        raise RthsError(f"a screenshot of the view needs Chromium at {CHROMIUM} (apt-get "
                        "install chromium) or set RTHS3D_CHROMIUM to its path")
    return exe


def screenshot(url: str, path: str | os.PathLike, *, width: int = 1400, height: int = 900,
               settle: float = 6.0, timeout: float = 60.0,
               expect: tuple[str, ...] = ()) -> PageCheck:
    """Open ``url`` in headless Chromium, wait for the view to connect and draw, save a PNG.

    ``settle`` (s) is the time given to software WebGL to render after the connection. The
    "software rendering" notice is closed before the picture is taken.
    """
    import numpy as np
    from PIL import Image

    exe = require_browser()
    from playwright.sync_api import sync_playwright

    with tempfile.TemporaryDirectory() as profile, sync_playwright() as pw:
        ctx = pw.chromium.launch_persistent_context(
            profile, executable_path=exe, args=list(CHROMIUM_FLAGS), headless=True,
            viewport={"width": width, "height": height})
        try:
            page = ctx.new_page()
            page.goto(url, timeout=timeout * 1000)
            page.get_by_text("Connected").first.wait_for(timeout=timeout * 1000)
            page.wait_for_selector("canvas", timeout=timeout * 1000)
            page.wait_for_timeout(settle * 1000)
            webgl_ok = page.get_by_text("WebGL unavailable").count() == 0
            page.add_style_tag(content=".mantine-Notifications-root { display: none; }")
            page.wait_for_timeout(300)
            ssp = page.get_by_text("SSP: z' against z").count() > 0
            connected = page.get_by_text("Connected").count() > 0
            texts = {x: page.get_by_text(x).count() > 0 for x in expect}
            page.screenshot(path=str(path))
            box = page.locator("canvas").first.bounding_box()
        finally:
            ctx.close()
    img = np.asarray(Image.open(path).convert("RGB"))
    if box:
        x0, y0 = max(int(box["x"]), 0), max(int(box["y"]), 0)
        img = img[y0:y0 + int(box["height"]), x0:x0 + int(box["width"])]
    flat = img.reshape(-1, 3)
    return PageCheck(connected, webgl_ok, ssp, float(img.std()),
                     int(np.unique(flat[:: max(1, flat.shape[0] // 20000)], axis=0).shape[0]),
                     texts)
