"""Tests of the shared figure writer (rths3d.figures)."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt

from rths3d.figures import new_figure, save_figure


def test_png_written_into_new_folder_with_its_size(tmp_path: Path) -> None:
    """The PNG lands in a folder that did not exist, with figsize × dpi pixels."""
    fig = new_figure((4.0, 3.0))
    ax = fig.subplots()
    ax.plot([0.0, 1.0], [0.0, 2.0])
    out = save_figure(fig, tmp_path / "a" / "b" / "line.png", title="a line", dpi=50)
    assert out == tmp_path / "a" / "b" / "line.png"
    head = out.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n"
    width, height = int.from_bytes(head[16:20], "big"), int.from_bytes(head[20:24], "big")
    assert (width, height) == (200, 150)
    assert fig.get_suptitle() == "a line"


def test_drawing_leaves_pyplot_and_the_backend_alone(tmp_path: Path) -> None:
    """No figure is registered with pyplot and a user's backend (here svg, not the Agg that
    writes the PNG) is not switched."""
    backend = matplotlib.get_backend()
    matplotlib.use("svg")
    try:
        before = plt.get_fignums()
        fig = new_figure()
        fig.subplots(2, 1, sharex=True)
        out = save_figure(fig, tmp_path / "two.png", rect=(0, 0, 1, 0.95))
        assert plt.get_fignums() == before
        assert matplotlib.get_backend() == "svg"
        assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    finally:
        matplotlib.use(backend)
