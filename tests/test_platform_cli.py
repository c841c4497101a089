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
    from rths3d.platform.calibrate.heave import load_heave_tf

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


def test_identify_out_folder_gets_default_name_and_plot_path_is_real(tmp_path, capsys):
    """`identify --out DIR/` (and an existing folder) writes DIR/platform_heave_tf.json, and
    `--plot NAME` without a suffix prints the PNG actually written (NAME.png)."""
    from rths3d.platform.calibrate.heave import DEFAULT_TF_PATH, load_heave_tf

    new = tmp_path / "assets"
    code, out, err = _run(["platform", "identify", "--quick", "--out", f"{new}/"], capsys)
    assert code == 0, err
    assert load_heave_tf(new / DEFAULT_TF_PATH.name).fit_error < 0.05
    assert f"TF file {new / DEFAULT_TF_PATH.name}" in out
    code, out, err = _run(["platform", "identify", "--quick", "--out", str(new), "--plot",
                           str(tmp_path / "adir")], capsys)
    assert code == 0, err
    assert f"Bode plot {tmp_path / 'adir.png'}" in out and (tmp_path / "adir.png").is_file()
    assert sorted(p.name for p in new.iterdir()) == ["platform_heave_bode.png",
                                                     DEFAULT_TF_PATH.name]


def test_tf_save_to_unwritable_path_is_config_error_without_temp_file(tmp_path):
    """`IdentifyResult.save` onto a folder raises ConfigError and leaves no temporary file."""
    import numpy as np

    from rths3d.errors import ConfigError
    from rths3d.platform.calibrate.heave import HeaveTF, IdentifyResult

    f = np.array([0.5, 1.0, 2.0])
    res = IdentifyResult(HeaveTF((1.0,), (0.01, 1.0), 0.001), f, {"home": np.ones(3) + 0j},
                         {"home": (0.0,) * 6}, {"home": 0.0})
    (tmp_path / "tf.json").mkdir()
    with pytest.raises(ConfigError, match="cannot write"):
        res.save(tmp_path / "tf.json")
    assert [p.name for p in tmp_path.iterdir()] == ["tf.json"]


@pytest.mark.parametrize("args, needle", [
    (["track", "--out", "{file}"], "--out: '{file}' (exists and is not a folder)"),
    (["track", "--out", "{file}/sub"], "is a file, not a folder"),
    (["track", "--ramp", "-1", "--out", "{tmp}/t"], "--ramp: -1.0 (must be >= 0 s)"),
    (["identify", "--out", "{file}/tf.json"], "--out: '{file}/tf.json'"),
    (["identify", "--out", "{tmp}/tf.json", "--plot", "{file}/b.png"], "--plot:"),
])
def test_bad_output_paths_and_ramp_exit_2_before_running(tmp_path, capsys, args, needle):
    """Unusable output paths and a negative ramp exit 2 with one line, before any run."""
    file = tmp_path / "c.parquet"
    file.write_text("x")
    fill = {"file": str(file), "tmp": str(tmp_path)}
    code, out, err = _run(["platform", *(a.format(**fill) for a in args)], capsys)
    assert code == 2 and needle.format(**fill) in err
    assert len(err.strip().splitlines()) == 1 and out == ""
