"""Records: schema, round trips through Parquet and CSV, and clear errors for bad files."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from rths3d import Record, RecordBuffer, RecordError
from rths3d.cli import main


def _two_dof_record(n: int = 200, dt: float = 1e-3) -> Record:
    t = np.arange(n) * dt
    cols = {}
    for i, dof in enumerate(("z", "ry")):
        z = 0.005 * np.sin(2 * np.pi * (1 + i) * t)
        cols[f"z_cmd.{dof}"] = z
        cols[f"z_meas.{dof}"] = np.roll(z, 3)
        cols[f"f_meas.{dof}"] = 8650.0 * z
    cols["leg_len.0"] = 0.5 + t
    return Record(t, cols, {"scene": "unit", "dt": dt, "params": {"m_num": 9.62}})


@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
def test_round_trip_is_exact(tmp_path, suffix):
    """Saving and loading keeps every column bit for bit and the metadata."""
    rec = _two_dof_record()
    path = rec.save(tmp_path / f"r{suffix}")
    back = Record.load(path)
    assert back.dofs == ("z", "ry")
    np.testing.assert_array_equal(back.t, rec.t)
    for name, values in rec.columns.items():
        np.testing.assert_array_equal(back.columns[name], values)
    assert back.meta["params"]["m_num"] == 9.62
    assert back.signal("z_cmd").shape == (200, 2)
    assert set(back.group("leg_len")) == {"0"}


def test_bare_single_dof_names_read_as_z(tmp_path):
    """The bare single-DOF column names are read as DOF z."""
    t = np.arange(50) * 1e-3
    path = tmp_path / "bare.csv"
    header = "t,z_cmd,z_meas,f_meas,f_ext,z_ref"
    rows = np.column_stack([t, np.sin(t), np.cos(t), t, 0 * t, np.sin(t)])
    np.savetxt(path, rows, delimiter=",", header=header, comments="")
    rec = Record.load(path)
    assert rec.dofs == ("z",)
    np.testing.assert_allclose(rec.signal("z_meas")[:, 0], np.cos(t))
    out = rec.save(tmp_path / "bare_out.csv", bare=True)
    assert out.read_text().splitlines()[0].split(",")[:3] == ["t", "z_cmd", "z_meas"]


def test_nan_names_column_and_row(tmp_path):
    """A NaN in a column is reported with the column name and the row."""
    rec = _two_dof_record()
    frame = rec.to_frame()
    frame.loc[17, "z_meas.ry"] = np.nan
    path = tmp_path / "nan.csv"
    frame.to_csv(path, index=False)
    with pytest.raises(RecordError, match=r"'z_meas.ry'.*row 17"):
        Record.load(path)


def test_missing_time_and_too_short(tmp_path):
    """A file without t, or shorter than the minimum, is refused with a clear message."""
    path = tmp_path / "not.csv"
    path.write_text("z_cmd,z_meas\n1,2\n")
    with pytest.raises(RecordError, match="missing column 't'"):
        Record.load(path)
    short = tmp_path / "short.csv"
    short.write_text("t,z_cmd,z_meas\n0,1,1\n0.001,1,1\n")
    with pytest.raises(RecordError, match="too short"):
        Record.load(short)


def test_non_uniform_sampling_is_resampled_with_warning():
    """A jittered time base is resampled to its median step, values interpolated linearly."""
    rng = np.random.default_rng(0)
    t = np.cumsum(np.full(400, 1e-3) + rng.uniform(-2e-4, 2e-4, 400))
    data = {"t": t, "z_cmd.z": 3.0 * t, "z_meas.z": 3.0 * t + 1.0}
    with pytest.warns(UserWarning, match="resampled"):
        rec = Record.from_columns(data)
    steps = np.diff(rec.t)
    assert np.ptp(steps) < 1e-12
    np.testing.assert_allclose(rec.signal("z_meas")[:, 0], 3.0 * rec.t + 1.0, atol=1e-12)
    with pytest.raises(RecordError, match="non-uniform"):
        Record.from_columns(data, resample=False)


def test_non_increasing_time_is_refused():
    """Time that steps backwards is an error naming the row."""
    t = np.arange(20) * 1e-3
    t[9] = t[8]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(RecordError, match="row 9"):
            Record.from_columns({"t": t, "z_cmd.z": t, "z_meas.z": t})


def test_buffer_exposes_only_written_rows():
    """A RecordBuffer turns into a record of exactly the rows written so far."""
    buf = RecordBuffer(["t", "z_cmd.z", "z_meas.z"], capacity=100, meta={"dt": 1e-3})
    for k in range(10):
        buf.data[k] = (k * 1e-3, k, k - 1)
        buf.n = k + 1
    rec = buf.to_record()
    assert rec.n == 10 and rec.meta["dt"] == 1e-3
    np.testing.assert_array_equal(rec.signal("z_meas")[:, 0], np.arange(10) - 1)


def test_cli_reports_user_errors_without_traceback(tmp_path, capsys):
    """A user mistake on the command line prints one line and exits with code 2."""
    with pytest.raises(SystemExit) as info:
        main(["metrics", str(tmp_path / "missing.parquet")])
    err = capsys.readouterr().err
    assert info.value.code != 0
    assert "Traceback" not in err


@pytest.mark.parametrize("suffix", [".parquet", ".csv"])
@pytest.mark.parametrize("n", [1, 3])
def test_short_stopped_record_loads(tmp_path, suffix, n):
    """A record of a stopped test loads however short (≥ 1 sample); an 'ok' one needs 8."""
    t = np.arange(n) * 1e-3
    cols = {"z_cmd.z": 1e-3 * t, "z_meas.z": 1e-3 * t, "f_meas.z": 0.1 * t}
    stopped = Record(t, cols, {"status": "stopped", "reason": "stopped at t = 0.003 s"})
    back = Record.load(stopped.save(tmp_path / f"s{suffix}"))
    assert back.n == n and back.meta["status"] == "stopped"
    np.testing.assert_array_equal(back.columns["z_cmd.z"], cols["z_cmd.z"])
    ok = Record(t, cols, {"status": "ok"})
    with pytest.raises(RecordError, match="too short"):
        Record.load(ok.save(tmp_path / f"o{suffix}"))
