"""Scenes: TOML loading, overrides and validation errors (field, value, limit)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from cli_cases import run_in_process

from rths3d.errors import ConfigError
from rths3d.scene import load_scene, scene_from_dict, scene_to_dict, scene_with

SCENES = Path(__file__).resolve().parents[1] / "scenes"


@pytest.mark.parametrize("name", ["paper_contact", "paper_linear", "multidof"])
def test_shipped_scenes_load(name):
    """Every shipped scene loads and validates; dofs match the experiment kind."""
    sc = load_scene(SCENES / f"{name}.toml")
    assert sc.name == name
    assert sc.n_steps == round(sc.duration / sc.dt)
    assert len(sc.numerical.gamma[0]) == len(sc.dofs)


def test_override_changes_value_and_roundtrip():
    """--set overrides reach the scene; scene_to_dict/scene_with round-trip exactly."""
    sc = load_scene(SCENES / "paper_contact.toml", ["numerical.k=5000", "experiment.h0=0.002"])
    assert sc.numerical.K[0][0] == 5000.0
    assert sc.experiment.h0 == 0.002
    again = scene_from_dict(scene_to_dict(sc), name=sc.name, source=sc.source)
    assert again == sc
    sc2 = scene_with(sc, {"numerical.m": 4.81})
    assert sc2.numerical.M[0][0] == 4.81 and sc2.numerical.K[0][0] == 5000.0


@pytest.mark.parametrize("override, field, limit_word", [
    ("numerical.m=-1.0", "numerical.m", "> 0"),
    ("experiment.m=-0.38", "experiment.m", "> 0"),
    ("transfer.kind='magic'", "transfer.kind", "ideal"),
    ("safety.stroke=0.2", "safety.stroke", "0.05"),
    ("excitation.overtravel=0.06", "excitation.overtravel", "safety.stroke"),
    ("experiment.bogus=1", "experiment.bogus", "unknown field"),
    ("dt=0.5", "dt", "0.01"),
])
def test_bad_values_name_field_and_limit(override, field, limit_word):
    """A bad value raises ConfigError whose message names the field and the limit."""
    with pytest.raises(ConfigError) as err:
        load_scene(SCENES / "paper_contact.toml", [override])
    assert err.value.field == field
    assert field in str(err.value) and limit_word in str(err.value)


def test_missing_field_named():
    """A missing required field (the numerical stiffness) is named."""
    raw = scene_to_dict(load_scene(SCENES / "paper_contact.toml"))
    del raw["numerical"]["k"]
    with pytest.raises(ConfigError, match="numerical.k"):
        scene_from_dict(raw)


def test_non_symmetric_matrix_rejected():
    """A non-symmetric stiffness matrix of a multi-DOF substructure is rejected."""
    with pytest.raises(ConfigError, match="numerical.K.*symmetric"):
        load_scene(SCENES / "multidof.toml", ["numerical.K=[[2e4, 1.0], [0.0, 450.0]]"])


@pytest.mark.parametrize("args, word", [
    (["--set", "numerical.m=-1"], "numerical.m"),
    (["--transfer", "magic"], "--transfer"),
    (["--set", "safety.stroke=0.3"], "safety.stroke"),
    (["--out", "rec.txt"], "--out"),
])
def test_cli_bad_scene_one_line_exit_2(args, word, tmp_path):
    """The CLI prints one line naming the field, exits with 2 and shows no traceback (in this
    process, as ``python -m rths3d`` runs it: each case fails before any work)."""
    p = run_in_process("run", str(SCENES / "paper_contact.toml"), *args, cwd=str(tmp_path))
    assert p.returncode == 2
    err = p.stderr.strip().splitlines()
    assert len(err) == 1 and word in err[0]
    assert "Traceback" not in p.stderr + p.stdout


def test_growth_limits_validated():
    """safety.growth ≤ 1 and a negative safety.growth_windows are refused, naming the field."""
    with pytest.raises(ConfigError, match=r"safety\.growth: 1(\.0)? \(must be > 1\)"):
        load_scene(SCENES / "multidof.toml", ["safety.growth=1.0"])
    with pytest.raises(ConfigError, match=r"safety\.growth_windows"):
        load_scene(SCENES / "multidof.toml", ["safety.growth_windows=-1"])


@pytest.mark.parametrize("override", ["safety.force=inf", "safety.velocity=inf",
                                      "experiment.k=inf", "experiment.m=inf",
                                      "excitation.amplitude=inf", "sensor.gain=inf",
                                      "safety.torque=-inf"])
def test_non_finite_values_refused(override):
    """Infinite values are refused as ConfigError '<field>: inf (must be finite)'."""
    field, _, value = override.partition("=")
    with pytest.raises(ConfigError) as err:
        load_scene(SCENES / "paper_linear.toml", ["duration=0.5", override])
    assert err.value.field == field
    assert str(err.value).startswith(f"{field}: {value}") and "finite" in str(err.value)


def test_duration_must_be_a_multiple_of_dt():
    """A dt that does not divide the duration is refused (not rounded); exact ones pass."""
    with pytest.raises(ConfigError) as err:
        load_scene(SCENES / "paper_linear.toml", ["dt=0.003", "duration=0.5"])
    assert str(err.value) == "duration: 0.5 (must be a multiple of dt = 0.003 s)"
    for dt, dur, n in ((0.003, 0.6, 200), (2.5e-4, 2.0, 8000), (1e-3, 10.0, 10000)):
        assert load_scene(SCENES / "paper_linear.toml", [f"dt={dt}", f"duration={dur}"]
                          ).n_steps == n


@pytest.mark.parametrize("override, field", [
    ("sensor.seed=-1", "sensor.seed"),
    ("transfer.substeps=0", "transfer.substeps"),
    ("transfer.substeps=-2", "transfer.substeps"),
])
@pytest.mark.parametrize("kind", ["ideal", "lti", "stewart"])
def test_seed_and_transfer_substeps_validated(override, field, kind):
    """A negative sensor seed and transfer.substeps < 1 are refused naming the scene key."""
    with pytest.raises(ConfigError) as err:
        load_scene(SCENES / "paper_linear.toml", ["duration=0.5", f"transfer.kind='{kind}'",
                                                  "sensor.noise_std=0.1", override])
    assert err.value.field == field


def test_central_difference_refused_when_coupled_mode_too_fast():
    """central_difference is refused when the numerical part with the part's spring has
    ω_max ΔT ≥ 2 (here 2.12), although the numerical part alone (1.87) would pass."""
    base = ["duration=0.5", "numerical.m=1.0", "experiment.k=1e6",
            "numerical.integrator='central_difference'"]
    with pytest.raises(ConfigError) as err:
        load_scene(SCENES / "paper_linear.toml", [*base, "numerical.k=3.5e6"])
    assert err.value.field == "numerical.integrator" and "2.12" in str(err.value)
    sc = load_scene(SCENES / "paper_linear.toml", [*base, "numerical.k=2.5e6"])  # 1.87
    assert sc.numerical.integrator == "central_difference"
    load_scene(SCENES / "paper_linear.toml",
               ["duration=0.5", "numerical.m=1.0", "experiment.k=1e6", "numerical.k=3.5e6"])


def test_folder_or_binary_file_as_scene_is_a_config_error(tmp_path) -> None:
    """A folder or a binary file given as a scene names the path, not a decode traceback."""
    from rths3d.errors import ConfigError

    binary = tmp_path / "run.toml"
    binary.write_bytes(bytes([0x90, 0xFF, 0x00, 0x81]))
    with pytest.raises(ConfigError, match="not a text TOML file"):
        load_scene(binary)
    with pytest.raises(ConfigError, match="folder"):
        load_scene(tmp_path)


@pytest.mark.parametrize("key, written", [("numerical.k", "k"), ("numerical.c", "c"),
                                          ("numerical.m", "m")])
def test_bad_scalar_is_named_as_written(key, written):
    """`--set numerical.k=abc` names numerical.k (the key the user wrote), not numerical.K."""
    with pytest.raises(ConfigError) as err:
        load_scene(SCENES / "paper_contact.toml", [f"{key}=abc"])
    assert err.value.field == f"numerical.{written}" and err.value.value == "abc"
    assert "must be a number" in str(err.value)


def test_excitation_file_is_relative_to_the_scene(tmp_path):
    """A scene's excitation.file is read beside the scene, whatever the current folder: the
    run from another folder applies the CSV's force (f_ext equals the history written
    here, linearly interpolated); a --set path is relative to the current folder."""
    import numpy as np

    from rths3d.record import Record

    scene_dir, elsewhere = tmp_path / "scenes", tmp_path / "elsewhere"
    scene_dir.mkdir()
    elsewhere.mkdir()
    t = np.linspace(0.0, 1.0, 11)
    force = 15.0 * np.sin(2 * np.pi * 1.5 * t)
    (scene_dir / "push.csv").write_text("t,value\n" + "".join(
        f"{float(a)!r},{float(b)!r}\n" for a, b in zip(t, force, strict=True)))
    text = (SCENES / "paper_linear.toml").read_text().replace(
        'signal = "sine"', 'signal = "file"\nfile = "push.csv"').replace(
        "duration = 10.0", "duration = 1.0")
    (scene_dir / "pushed.toml").write_text(text)
    out = tmp_path / "rec.parquet"
    p = subprocess.run([sys.executable, "-m", "rths3d", "run", str(scene_dir / "pushed.toml"),
                        "-t", "ideal", "--no-reference", "--json", "--out", str(out)],
                       cwd=elsewhere, capture_output=True, text=True, timeout=120)
    assert p.returncode == 0, p.stderr
    rec = Record.load(out)
    np.testing.assert_allclose(rec.columns["f_ext.z"], np.interp(rec.t, t, force),
                               atol=1e-9)
    # a path given on the command line is the user's: relative to the current folder
    with pytest.raises(ConfigError, match="excitation.file"):
        from rths3d.loop import run

        sc = load_scene(scene_dir / "pushed.toml", ["excitation.file='push.csv'"])
        run(sc, "ideal", reference=False)


@pytest.mark.parametrize("overrides", [
    {"numerical.k": 5e3}, {"numerical.m": 2.5, "numerical.c": 0.0},
    {"numerical.k": 0.0, "numerical.m": 19.24, "numerical.c": 500.0},
    {"numerical.k": -1.0}, {"numerical.m": 0.0}, {"numerical.c": "a lot"},
    {"numerical.k": float("inf")}, {"numerical.k": [[1.0, 2.0]]},
])
@pytest.mark.parametrize("integrator", ["exact", "central_difference"])
def test_a_changed_one_dof_numerical_substructure_validates_as_a_whole_scene(
        overrides, integrator) -> None:
    """scene_with's cheaper path (only the numerical m, c, k of a one-DOF scene change)
    gives the scene, or the error, that validating the whole changed mapping gives —
    including central_difference's coupled-stability refusal (a stiff numerical spring)."""
    from rths3d.errors import ConfigError
    from rths3d.scene import apply_overrides, scene_from_dict, scene_to_dict, scene_with

    sc = load_scene("paper_contact", [f"numerical.integrator='{integrator}'"])
    cases = [overrides, {**overrides, "numerical.k": 5e7}] if "numerical.k" not in overrides \
        else [overrides]

    def outcome(fn):
        try:
            return fn()
        except ConfigError as exc:
            return ("error", exc.field, str(exc.value), exc.limit)

    for ov in cases:
        full = outcome(lambda ov=ov: scene_from_dict(apply_overrides(scene_to_dict(sc), ov),
                                                     name=sc.name, source=sc.source))
        fast = outcome(lambda ov=ov: scene_with(sc, ov))
        assert fast == full, ov
    stiff = outcome(lambda: scene_with(sc, {"numerical.k": 5e9}))
    assert isinstance(stiff, tuple) == (integrator == "central_difference"), stiff
