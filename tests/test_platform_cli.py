"""The `rths3d platform` commands: outputs, figures and one-line errors."""

from __future__ import annotations

import json

import pytest

from rths3d.cli import main


def _run(argv, capsys):
    with pytest.raises(SystemExit) as info:
        main(argv)
    out = capsys.readouterr()
    return info.value.code, out.out, out.err


def test_track_writes_plot_record_and_figures(tmp_path, capsys):
    """`platform track --json` writes the PNG and record and prints the figures."""
    code, out, _ = _run(["platform", "track", "--duration", "2", "--out", str(tmp_path),
                         "--json"], capsys)
    assert code == 0
    fig = json.loads(out.strip().splitlines()[-1])
    assert fig["delay"] == pytest.approx(fig["predicted_delay"], abs=0.5e-3)
    assert fig["nrms_error"] < 0.05
    assert (tmp_path / "track.png").stat().st_size > 20_000
    assert (tmp_path / "track.parquet").exists()
    from rths3d.record import Record

    rec = Record.load(tmp_path / "track.parquet")
    assert rec.n == 2000 and rec.meta["status"] == "ok"


def test_track_stop_and_bad_dof_exit_2_with_one_line(tmp_path, capsys):
    """A safety stop and a bad DOF exit with code 2 and a one-line message, no traceback."""
    code, _, err = _run(["platform", "track", "--amplitude", "0.2", "--out", str(tmp_path),
                         "--json"], capsys)
    assert code == 2
    assert "commanded velocity" in err and "Traceback" not in err
    code, _, err = _run(["platform", "track", "--dof", "q", "--out", str(tmp_path)], capsys)
    assert code == 2
    assert err.strip().startswith("error: dof: 'q'") and "Traceback" not in err
    assert len(err.strip().splitlines()) == 1


def test_identify_quick_writes_tf_and_bode(tmp_path, capsys):
    """`platform identify --quick --out` writes a loadable TF file and a Bode plot."""
    from rths3d.platform.identify import load_heave_tf

    path = tmp_path / "tf.json"
    code, out, _ = _run(["platform", "identify", "--quick", "--out", str(path)], capsys)
    assert code == 0
    tf = load_heave_tf(path)
    assert 0.0 <= tf.delay < 0.01 and tf.fit_error < 0.05
    assert (tmp_path / "tf_bode.png").stat().st_size > 20_000
    assert "fit error" in out


def test_info_reports_geometry_and_condition(capsys):
    """`platform info --json` reports the home Jacobian condition and the static leg forces."""
    code, out, _ = _run(["platform", "info", "--payload-mass", "2", "--json"], capsys)
    assert code == 0
    info = json.loads(out.strip().splitlines()[-1])
    assert info["jacobian_cond_home"] == pytest.approx(5.6988, abs=1e-3)
    assert info["jacobian_cond_home_scaled"] < 2.0
    assert info["payload_mass_kg"] == pytest.approx(2.0)
    assert len(info["static_leg_force_n"]) == 6 and min(info["static_leg_force_n"]) > 0
