"""Output paths: checked before the work; a result the target refuses at the end is kept.

The end-of-run failures are made real, not simulated: a folder where the command will write a
file (the check of the output folder passes, the write itself fails with IsADirectoryError),
or a folder replaced by a file after the check.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest

from rths3d.cli._output import KEPT_PREFIX, Keeper
from rths3d.errors import ConfigError
from rths3d.figures import check_output
from rths3d.record import Record

KEPT = re.compile(r"kept in (\S+?)\)?$")


def cli(*args: str, tmp: Path, timeout: float = 300):
    """The command line, with its temporary folder (where kept results go) in ``tmp``."""
    spare = tmp / "tmp"
    spare.mkdir(exist_ok=True)
    return subprocess.run([sys.executable, "-m", "rths3d", *args], capture_output=True,
                          text=True, timeout=timeout, env={**os.environ, "TMPDIR": str(spare)})


@pytest.fixture(autouse=True)
def _own_tempdir(tmp_path_factory, monkeypatch):
    """Kept results of this process go below pytest's folders, not the machine's /tmp."""
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path_factory.mktemp("kept")))


def _record(n: int = 300) -> Record:
    t = np.arange(n) * 1e-3
    z = 1e-3 * np.sin(2 * np.pi * 2.0 * t)
    return Record(t, {"z_cmd.z": z, "z_meas.z": 0.98 * z, "f_meas.z": 50.0 * z}, {})


def _kept_path(stderr: str) -> Path:
    line = stderr.strip().splitlines()[-1]
    m = KEPT.search(line)
    assert m, line
    return Path(m.group(1))


@pytest.fixture
def unwritable(tmp_path) -> Path:
    """A folder this process cannot write into: read-only by mode, or (as root, who writes
    anywhere by mode) a read-only file system's folder."""
    d = tmp_path / "ro"
    d.mkdir()
    d.chmod(0o555)
    try:
        tempfile.mkstemp(dir=d)
    except OSError:
        return d
    for cand in (Path("/sys"), Path("/proc/sys")):
        try:
            tempfile.mkstemp(dir=cand)
        except OSError:
            return cand
    pytest.skip("no unwritable folder on this machine")


def test_check_output_tries_the_folder(unwritable) -> None:
    """A folder that refuses files (even to root, whom os.access lets through) is a
    ConfigError naming the option before any work."""
    with pytest.raises(ConfigError, match=r"^--out: .*not writable"):
        check_output(unwritable / "x.parquet", "--out")
    with pytest.raises(ConfigError, match=r"^--plot: "):
        check_output(unwritable / "plots", "--plot", folder=True)


def test_check_output_without_create_leaves_no_folder(tmp_path) -> None:
    """create=False checks the nearest existing folder and creates nothing."""
    target = tmp_path / "a" / "b"
    assert check_output(target, "--out", folder=True, create=False) == target
    assert not (tmp_path / "a").exists()


def test_keeper_keeps_a_record_whose_folder_became_a_file(tmp_path) -> None:
    """The folder passes the check, then is replaced by a file: the record is written to a
    temporary folder, equal to the original, and one error names the option, the path, the
    reason and where the record is. Nothing partial is left at the target."""
    folder = tmp_path / "out"
    check_output(folder / "rec.parquet", "--out")
    folder.rmdir()
    folder.write_text("in the way")
    rec = _record()
    keeper = Keeper()
    written = keeper.write(rec.save, folder / "rec.parquet", "--out")
    assert written.parent.name.startswith(KEPT_PREFIX) and written.name == "rec.parquet"
    back = Record.load(written)
    np.testing.assert_array_equal(back.columns["z_meas.z"], rec.columns["z_meas.z"])
    with pytest.raises(ConfigError) as info:
        keeper.finish()
    msg = str(info.value)
    assert msg.startswith(f"--out: '{folder / 'rec.parquet'}' (cannot be written (")
    assert str(written.parent) in msg and "\n" not in msg
    assert folder.read_text() == "in the way"


def test_keeper_passes_other_errors_through(tmp_path) -> None:
    """Only failures of the file system are kept elsewhere; a bad value stays an error."""
    from rths3d.errors import RecordError

    keeper = Keeper()
    with pytest.raises(RecordError, match="unknown format"):
        keeper.write(_record().save, tmp_path / "rec.txt", "--out")
    assert keeper.kept == []
    keeper.finish()


def test_record_save_leaves_no_partial_file(tmp_path) -> None:
    """A record that cannot be renamed into place (a folder of that name) leaves neither a
    file nor its temporary behind."""
    (tmp_path / "rec.parquet").mkdir()
    with pytest.raises(OSError):
        _record().save(tmp_path / "rec.parquet")
    assert [p.name for p in tmp_path.iterdir()] == ["rec.parquet"]
    assert (tmp_path / "rec.parquet").is_dir()


def test_record_load_of_a_folder_says_so(tmp_path) -> None:
    """A folder named like a record is refused as a folder, not as 'missing column t'."""
    from rths3d.errors import RecordError

    (tmp_path / "x.parquet").mkdir()
    with pytest.raises(RecordError, match="is a folder, not a record file"):
        Record.load(tmp_path / "x.parquet")


def test_run_keeps_plot_and_record_when_writing_fails_at_the_end(tmp_path) -> None:
    """`run --out D/rec.parquet --plot D`: the folder is fine, but the plot's file name is
    taken by a folder, so writing the PNG fails after the test ran. The summary is printed,
    the record is written where asked, the plot is kept in a temporary folder, one error line
    says where, exit 2."""
    plots = tmp_path / "plots"
    (plots / "paper_contact_lti.png").mkdir(parents=True)
    p = cli("run", "paper_contact", "-t", "lti", "--set", "duration=0.5", "--no-reference",
            "--out", str(tmp_path / "rec.parquet"), "--plot", str(plots), tmp=tmp_path)
    assert p.returncode == 2, p.stderr
    assert "Traceback" not in p.stderr and len(p.stderr.strip().splitlines()) == 1
    assert p.stderr.startswith(f"error: --plot: '{plots}' (cannot be written (")
    assert "e_rel,track" in p.stdout and (tmp_path / "rec.parquet").is_file()
    kept = _kept_path(p.stderr)
    png = kept / "paper_contact_lti.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert str(png) in p.stdout  # the summary names the file that was written
    assert not [q for q in plots.iterdir() if q.name != "paper_contact_lti.png"]


def test_metrics_keeps_its_plots_when_writing_fails(tmp_path) -> None:
    """`metrics --plot D` with D/ssp.png taken by a folder: the table is printed, the three
    plots are kept together in a temporary folder, one error line, exit 2."""
    rec = _record(2000).save(tmp_path / "rec.parquet")
    plots = tmp_path / "plots"
    (plots / "ssp.png").mkdir(parents=True)
    p = cli("metrics", str(rec), "--plot", str(plots), tmp=tmp_path)
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1 and "--plot:" in p.stderr
    assert "e_rel_track" in p.stdout
    kept = _kept_path(p.stderr)
    assert sorted(q.name for q in kept.iterdir()) == ["fei.png", "ssp.png", "time.png"]
    assert sorted(q.name for q in plots.iterdir()) == ["ssp.png"]


@pytest.mark.skipif(os.name != "posix", reason="POSIX permissions")
def test_run_refuses_an_unwritable_out_before_running(unwritable, tmp_path) -> None:
    """An --out in a folder that refuses files: one line, exit 2, at once (no test run)."""
    p = cli("run", "paper_contact", "-t", "lti", "--out", str(unwritable / "r.parquet"),
            tmp=tmp_path)
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert p.stderr.startswith("error: --out:") and "not writable" in p.stderr
    assert p.stdout == ""
