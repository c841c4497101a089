"""Diagnosis: hidden effects found from the measurement file alone, null case, bad files, CLI."""

from __future__ import annotations

import hashlib
import json
import math

import numpy as np
import pytest

from rths3d.cli import main as cli_main
from rths3d.diagnose import Diagnosis, load_measurement, synthetic_measurement
from rths3d.diagnose.localise import effective_samples, fei, noise_floor, transfer_estimate
from rths3d.errors import ConfigError, RecordError
from rths3d.record import Record

# (effect, two magnitudes): every candidate of the library, SI units of its parameter
MATRIX = {
    "delay": (0.002, 0.006), "actuator_lag": (0.003, 0.008), "fts_lowpass": (0.002, 0.005),
    "fts_gain": (0.05, 0.15), "fts_offset": (0.3, 1.0), "fts_crosstalk": (0.02, 0.05),
    "coulomb_friction": (20.0, 60.0), "viscous_friction": (200.0, 600.0),
    "backlash": (2e-5, 6e-5), "fixture_mass": (0.2, 0.6), "platform_compliance": (2e-7, 6e-7),
    "velocity_saturation": (0.02, 0.014), "quantisation": (2e-5, 5e-5),
    "specimen_stiffness": (0.1, 0.3), "specimen_damping": (0.5, 1.5),
    "contact_gap": (2e-4, -3e-4),
}


def _diagnose_file(tmp_path, effects, seed, name="m.parquet"):
    rec = synthetic_measurement(effects, duration=3.0, seed=seed)
    path = rec.save(tmp_path / name)
    loaded, _, _ = load_measurement(path)  # the diagnosis sees only the file
    diag = Diagnosis(loaded)
    return diag, diag.run()


@pytest.mark.slow
def test_hidden_effect_matrix(tmp_path):
    """16 effects × 2 seeded magnitudes: true effect first in ≥ 90 %, top two in all, error falls
    by ≥ 80 % of its non-noise part and the fitted parameter is within 10 % of the truth."""
    rng = np.random.default_rng(2024)
    first = 0
    total = 0
    failures = []
    for name, mags in MATRIX.items():
        for value in mags:
            seed = int(rng.integers(1, 10_000))
            diag, res = _diagnose_file(tmp_path, {name: value}, seed, f"{name}_{seed}.parquet")
            ranked = [c.effect for c in res.candidates]
            total += 1
            first += ranked[0] == name
            if name not in ranked[:2]:
                failures.append(f"{name}={value}: ranked {ranked[:3]}")
                continue
            cand = res.candidates[ranked.index(name)]
            e_true = diag.errors({name: value})[1]
            fall = (cand.error_before - cand.error_after) / (cand.error_before - e_true)
            if fall < 0.8:
                failures.append(f"{name}={value}: error fell by {fall:.2f} of the non-noise part")
            if abs(cand.value - value) > 0.1 * abs(value):
                failures.append(f"{name}={value}: fitted {cand.value:.4g}")
            if not cand.significant:
                failures.append(f"{name}={value}: not significant ({cand.note})")
    assert not failures, failures
    assert first / total >= 0.9


def test_two_effects_found_in_two_rounds(tmp_path):
    """Coulomb friction plus FTS low-pass: found one per round, then only noise remains, and
    the waterfall falls to the noise floor on training and validation data."""
    rec = synthetic_measurement({"coulomb_friction": 40.0, "fts_lowpass": 0.003}, seed=5)
    diag = Diagnosis(load_measurement(rec.save(tmp_path / "two.csv"))[0])
    rounds = diag.auto()
    found = [r.proposal.effect for r in rounds if r.proposal]
    assert sorted(found) == ["coulomb_friction", "fts_lowpass"]
    assert rounds[-1].noise_only
    assert diag.accepted["coulomb_friction"] == pytest.approx(40.0, rel=0.05)
    assert diag.accepted["fts_lowpass"] == pytest.approx(0.003, rel=0.05)
    steps = diag.waterfall
    assert len(steps) == 3
    assert steps[0]["error_val"] > 10 * steps[-1]["error_val"]
    assert steps[-1]["error_train"] < 1.2 and steps[-1]["error_val"] < 1.2


@pytest.mark.parametrize("seed", [11, 12, 13])
def test_noise_only_proposes_nothing(tmp_path, seed):
    """Measurements with sensor noise only: no candidate significant, noise_only is True."""
    diag, res = _diagnose_file(tmp_path, {}, seed)
    assert res.noise_only and res.proposal is None
    assert not any(c.significant for c in res.candidates)
    assert res.error_val == pytest.approx(1.0, abs=0.1)


def test_add_fixed_effect_and_confounded_pairs(tmp_path):
    """--add with a value holds the effect; delay and actuator lag are reported confounded."""
    rec = synthetic_measurement({"delay": 0.004}, seed=3)
    diag = Diagnosis(rec)
    res = diag.run()
    assert res.proposal.effect == "delay"
    pairs = {frozenset((a, b)) for a, b, _ in res.confounded}
    assert frozenset(("delay", "actuator_lag")) in pairs
    diag.add("delay", 0.004, fix=True)
    assert diag.accepted == {"delay": 0.004}
    assert diag.waterfall[-1]["error_val"] < 0.1 * diag.waterfall[0]["error_val"]
    with pytest.raises(ConfigError, match="delay.tau"):
        diag.add("delay", -1.0)


# ---------------------------------------------------------------------------- bad files
def _good_columns(n=2000):
    t = np.arange(n) * 1e-3
    z = 1e-3 * np.sin(2 * math.pi * t)
    return {"t": t, "z_cmd.z": z, "z_meas.z": z, "f_meas.z": np.sin(t)}


@pytest.mark.parametrize("mutate, match", [
    (lambda c: c.pop("z_cmd.z"), "missing column 'z_cmd.z'"),
    (lambda c: c.__setitem__("z_meas.z", c["z_meas.z"] * 1e3), "'z_meas.z' reaches .*SI units"),
    (lambda c: c.__setitem__("f_meas.z", np.where(np.arange(c["t"].size) == 7, np.nan,
                                                  c["f_meas.z"])), "NaN/inf .* row 7"),
    (lambda c: [c.__setitem__(k, v[:500]) for k, v in list(c.items())], "too short"),
    (lambda c: c.__setitem__("z_cmd.z", np.zeros(c["t"].size)), "constant"),
])
def test_bad_measurement_files_give_clear_errors(tmp_path, mutate, match):
    """Missing command, mm units, NaN, too short, constant command: RecordError naming the
    column; the file on disk is left untouched."""
    cols = _good_columns()
    mutate(cols)
    path = tmp_path / "bad.csv"
    import pandas as pd

    pd.DataFrame(cols).to_csv(path, index=False)
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    with pytest.raises(RecordError, match=match):
        load_measurement(path)
    assert hashlib.sha256(path.read_bytes()).hexdigest() == digest


def test_non_uniform_sampling_is_resampled_with_a_warning(tmp_path):
    """A jittered time base is resampled and the warning is returned to the caller."""
    cols = _good_columns()
    cols["t"] = cols["t"] + np.r_[0, 2e-4 * np.sin(np.arange(cols["t"].size - 1))]
    import pandas as pd

    path = tmp_path / "j.csv"
    pd.DataFrame(cols).to_csv(path, index=False)
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    rec, channels, warns = load_measurement(tmp_path / "j.csv")
    assert warns and "resampled" in warns[0]
    assert channels == ("z_meas.z", "f_meas.z")
    assert rec.dt == pytest.approx(1e-3, rel=1e-3)
    assert hashlib.sha256(path.read_bytes()).hexdigest() == digest


# ---------------------------------------------------------------------------- localisation
def test_localisation_known_answers():
    """FEI of a delayed multisine gives the delay; noise floor and n_eff of white and AR(1)
    noise match their analytic values; H1 transfer of a scaled signal is the scale."""
    rng = np.random.default_rng(0)
    dt = 1e-3
    t = np.arange(8000) * dt
    x = sum(np.sin(2 * math.pi * f * t + p) for f, p in ((1.0, 0.3), (2.0, 1.0), (3.0, 2.0)))
    y = sum(np.sin(2 * math.pi * f * (t - 0.005) + p) for f, p in ((1.0, 0.3), (2.0, 1.0),
                                                                     (3.0, 2.0)))
    res = fei(x, y, dt)
    assert res["amplitude"] == pytest.approx(1.0, abs=0.01)
    assert res["delay"] == pytest.approx(0.005, rel=0.05)
    e = rng.standard_normal(20000) * 0.3
    assert noise_floor(e) == pytest.approx(0.3, rel=0.03)
    assert effective_samples(e) == pytest.approx(20000, rel=0.1)
    rho = 0.8
    ar = np.zeros(20000)
    for k in range(1, ar.size):
        ar[k] = rho * ar[k - 1] + e[k]
    assert effective_samples(ar) == pytest.approx(20000 * (1 - rho) / (1 + rho), rel=0.25)
    f, h, coh = transfer_estimate(e, 1.3 * e, dt)
    assert np.allclose(np.abs(h[1:]), 1.3) and np.all(coh[1:] > 0.99)


# ---------------------------------------------------------------------------- CLI
def test_cli_json_report_and_effects(tmp_path, capsys):
    """`rths3d diagnose --json --report` prints the interface keys and writes the report, the
    three plots and a replay with model.<column> columns; `rths3d effects --json` lists all."""
    rec = synthetic_measurement({"fixture_mass": 0.4}, seed=8)
    path = rec.save(tmp_path / "meas.parquet")
    with pytest.raises(SystemExit) as ex:
        cli_main(["diagnose", str(path), "--scene", "bench", "--json", "--report",
                  str(tmp_path / "rep")])
    assert ex.value.code == 0
    out = json.loads(capsys.readouterr().out)
    assert {"candidates", "accepted", "noise_only"} <= set(out)
    top = out["candidates"][0]
    assert {"effect", "params", "score", "error_before", "error_after"} <= set(top)
    assert top["effect"] == "fixture_mass" and not out["noise_only"]
    for f in ("report.md", "localisation.png", "signatures.png", "waterfall.png"):
        assert (tmp_path / "rep" / f).stat().st_size > 1000
    replay = Record.load(tmp_path / "rep" / "replay.parquet")
    assert "model.f_meas.z" in replay.columns and "f_meas.z" in replay.columns
    with pytest.raises(SystemExit) as ex:
        cli_main(["diagnose", str(path), "--add", "fixture_mass=0.4", "--json"])
    out = json.loads(capsys.readouterr().out)
    assert out["accepted"] == [{"effect": "fixture_mass", "params": {"m_f": 0.4}}]
    assert out["noise_only"]
    with pytest.raises(SystemExit) as ex:
        cli_main(["effects", "--json"])
    rows = json.loads(capsys.readouterr().out)
    assert len(rows) >= 16


def test_cli_bad_input_one_line_exit_2(tmp_path, capsys):
    """A missing file or unknown effect prints one error line and exits with code 2."""
    with pytest.raises(SystemExit) as ex:
        cli_main(["diagnose", str(tmp_path / "nope.parquet")])
    assert ex.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "does not exist" in err[0]
    path = synthetic_measurement({}, seed=1).save(tmp_path / "m.parquet")
    with pytest.raises(SystemExit) as ex:
        cli_main(["diagnose", str(path), "--add", "gremlins"])
    assert ex.value.code == 2
    assert "known effects" in capsys.readouterr().err


def test_hidden_friction_found_on_the_stewart_platform(tmp_path):
    """Stewart backend: Coulomb leg friction hidden in a measurement is ranked first, fitted
    within 10 %, and the error falls to the noise floor."""
    rec = synthetic_measurement({"coulomb_friction": 20.0}, duration=2.0, seed=4,
                                model="stewart")
    loaded, _, _ = load_measurement(rec.save(tmp_path / "stewart.parquet"))
    assert loaded.meta["bench"]["model"] == "stewart"
    diag = Diagnosis(loaded, top_k=3)
    res = diag.run()
    top = res.candidates[0]
    assert top.effect == "coulomb_friction" and top.significant
    assert top.value == pytest.approx(20.0, rel=0.1)
    assert top.error_after < 1.2 < 10 < top.error_before


def test_missing_library_effect_is_unexplained_not_noise():
    """When the true effect is not among the candidates, the rounds end 'unexplained' (no
    proposal, noise_only False, error well above the noise floor) — never 'only noise'."""
    from rths3d.effects import REGISTRY

    rec = synthetic_measurement({"coulomb_friction": 40.0}, seed=21)
    cands = [n for n, e in REGISTRY.items() if e.candidate and n not in
             ("coulomb_friction", "backlash")]
    diag = Diagnosis(rec, candidates=cands, top_k=3)
    rounds = diag.auto(max_rounds=3)
    last = rounds[-1]
    assert last.error_val > 1.5
    if last.proposal is None:
        assert last.status == "unexplained" and not last.noise_only
    assert not any(r.noise_only for r in rounds)


def test_cli_duplicate_effect_and_report_on_a_file_exit_2_before_diagnosing(tmp_path, capsys,
                                                                           monkeypatch):
    """An effect given twice with --add, or a --report folder that is a file, exits 2 with one
    line before the measurement is even read."""
    import rths3d.diagnose as diagnose_pkg

    path = synthetic_measurement({}, seed=1).save(tmp_path / "m.parquet")

    def no_load(*_a, **_k):
        raise AssertionError("the measurement was read before the options were checked")

    monkeypatch.setattr(diagnose_pkg, "load_measurement", no_load)
    for args, needle in (
        (["--add", "delay", "--add", "delay=0.01"], "effect 'delay' given twice"),
        (["--report", str(path)], f"--report: '{path}' (exists and is not a folder)"),
        (["--report", str(path / "rep")], "is a file, not a folder"),
    ):
        with pytest.raises(SystemExit) as ex:
            cli_main(["diagnose", str(path), *args])
        err = capsys.readouterr().err.strip().splitlines()
        assert ex.value.code == 2 and len(err) == 1 and needle in err[0]
