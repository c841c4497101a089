"""Tests of the shared figure writer (rths3d.figures)."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import pytest

from rths3d.errors import ConfigError
from rths3d.figures import check_output, new_figure, save_figure


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


def test_path_without_suffix_returns_the_png_written(tmp_path: Path) -> None:
    """A path without a suffix (even beside a folder of that name) returns NAME.png, the file
    matplotlib writes."""
    (tmp_path / "adir").mkdir()
    out = save_figure(new_figure((2.0, 2.0)), tmp_path / "adir")
    assert out == tmp_path / "adir.png" and out.is_file()


def test_check_output_rejects_unusable_paths_before_work(tmp_path: Path) -> None:
    """`check_output` creates usable folders and raises ConfigError naming the option for a
    file where a folder is needed, a folder where a file is needed, a file in the way."""
    blocker = tmp_path / "c.parquet"
    blocker.write_text("x")
    assert check_output(tmp_path / "new" / "f.png", "--plot") == tmp_path / "new" / "f.png"
    assert (tmp_path / "new").is_dir()
    assert check_output(tmp_path / "dir", "--out", folder=True).is_dir()
    for path, folder, needle in ((blocker, True, "exists and is not a folder"),
                                 (tmp_path, False, "is a folder; give a file name"),
                                 (blocker / "x.png", False, "is a file, not a folder"),
                                 (blocker / "sub", True, "is a file, not a folder")):
        with pytest.raises(ConfigError, match=f"^--opt: .*{needle}"):
            check_output(path, "--opt", folder=folder)
