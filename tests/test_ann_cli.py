"""Tests of `rths3d train` and `rths3d predict` on a sweep-shaped table with known structure."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pandas as pd
import pytest
from cli_cases import run_in_process

from rths3d.dataset.table import FEATURE_SETS


@pytest.fixture(scope="module")
def table(tmp_path_factory):
    """A table whose target is a smooth function of two set-3 features (others noise)."""
    rng = np.random.default_rng(0)
    n = 160
    names = FEATURE_SETS[1]
    data = {f"feature.{k}": rng.uniform(0.0, 1.0, n) for k in names}
    y = 0.05 + 0.1 * data["feature.e_rel_track"] ** 2 + 0.05 * data["feature.fei_d"]
    data["target.e_rel_ref"] = y
    data["test_id"] = [f"t{i:03d}" for i in range(n)]
    data["family"] = ["synthetic"] * n
    data["status"] = ["ok"] * (n - 2) + ["stopped"] * 2
    path = tmp_path_factory.mktemp("tbl") / "sweep.parquet"
    pd.DataFrame(data).to_parquet(path)
    return path


def run(*args: str) -> subprocess.CompletedProcess:
    """``rths3d ARGS`` in this process (as ``python -m rths3d`` runs it; the command line's
    own process is exercised by tests/test_cli_help.py and the bad-input table)."""
    return run_in_process(*args)


@pytest.fixture(scope="module")
def record(tmp_path_factory):
    """A real 1-s record of the paper's contact test (1-DOF numerical part)."""
    rec = tmp_path_factory.mktemp("rec") / "rec.parquet"
    r = run("run", "paper_contact", "-t", "lti", "--set", "duration=1", "--out", str(rec))
    assert r.returncode == 0, r.stderr
    return rec


@pytest.fixture(scope="module")
def model(table, tmp_path_factory):
    """A small set-3 model trained on the table."""
    path = tmp_path_factory.mktemp("model") / "m.json"
    p = run("train", str(table), "--features", "3", "--out", str(path), "--json",
            "--topologies", "3", "--trainings", "1", "--transform", "linear")
    assert p.returncode == 0, p.stderr
    return path


def strict_json(text: str):
    def reject(name):
        raise ValueError(f"bare {name} is not JSON")

    return json.loads(text, parse_constant=reject)


def test_train_json_keys_and_scores(table, tmp_path) -> None:
    """train --json prints r_train, r_val, r_test, mse, topology with ρ > 0.99 on a smooth
    target, and predict reproduces the targets of the same table."""
    model = tmp_path / "m.json"
    p = run("train", str(table), "--features", "3", "--out", str(model), "--json",
            "--topologies", "5;3,3", "--trainings", "3", "--transform", "linear")
    assert p.returncode == 0, p.stderr  # (features uniform on a linear scale: linear map)
    res = json.loads(p.stdout.strip().splitlines()[-1])
    for key in ("r_train", "r_val", "r_test", "mse", "topology"):
        assert key in res
    assert res["r_train"] > 0.99 and res["r_test"] > 0.99
    assert res["n_samples"] == 158  # the two stopped tests are not trained on
    q = run("predict", str(model), str(table), "--json")
    assert q.returncode == 0, q.stderr
    pr = json.loads(q.stdout)
    assert len(pr["prediction"]) == 158 and len(pr["spread"]) == 158
    assert pr["r"] > 0.99 and pr["extrapolation"] == []


def test_train_defaults_and_paper_net_flags(table, tmp_path) -> None:
    """`rths3d train` defaults to the log map with the linear bypass; --transform linear
    --no-bypass stores the paper's plain net."""
    common = ("--features", "3", "--json", "--topologies", "3", "--trainings", "1")
    for name, extra in (("d.json", ()), ("p.json", ("--transform", "linear", "--no-bypass"))):
        p = run("train", str(table), "--out", str(tmp_path / name), *common, *extra)
        assert p.returncode == 0, p.stderr
    d = json.loads((tmp_path / "d.json").read_text())
    plain = json.loads((tmp_path / "p.json").read_text())
    assert (d["transform"], d["bypass"]) == ("log", True)
    assert (plain["transform"], plain["bypass"]) == ("linear", False)


def test_cli_bad_input_one_line_exit_2(table, tmp_path) -> None:
    """Bad feature set or a missing table: one error line, exit code 2, no traceback."""
    p = run("train", str(table), "--features", "4", "--out", str(tmp_path / "m.json"))
    assert p.returncode == 2 and "features" in p.stderr and "Traceback" not in p.stderr
    q = run("predict", str(tmp_path / "none.json"), str(table))
    assert q.returncode == 2 and "model" in q.stderr and "Traceback" not in q.stderr


def test_train_on_named_features_and_predict(table, tmp_path) -> None:
    """--features takes Table-3 feature names: the model uses exactly those, in that order,
    and the two features the target depends on give ρ > 0.99; unknown or repeated names are
    one error line naming --features."""
    model = tmp_path / "m.json"
    p = run("train", str(table), "--features", "fei_d, e_rel_track", "--out", str(model),
            "--json", "--topologies", "5", "--trainings", "2", "--transform", "linear")
    assert p.returncode == 0, p.stderr
    res = json.loads(p.stdout.strip().splitlines()[-1])
    assert res["features"] == ["fei_d", "e_rel_track"]
    assert json.loads(model.read_text())["feature_names"] == ["fei_d", "e_rel_track"]
    assert res["r_test"] > 0.99
    q = run("predict", str(model), str(table), "--json")
    assert q.returncode == 0, q.stderr
    assert json.loads(q.stdout)["r"] > 0.99
    for bad, why in (("e_rel_track,nope", "Table-3 feature names"),
                     ("zeta,zeta", "each feature at most once"), (",", "Table-3")):
        b = run("train", str(table), "--features", bad, "--out", str(tmp_path / "b.json"))
        assert b.returncode == 2 and "--features" in b.stderr and why in b.stderr, b.stderr
        assert "Traceback" not in b.stderr


def test_train_extra_parameter_and_predict_a_record(table, record, tmp_path) -> None:
    """--extra adds a test parameter as an input (named in the JSON and the model); predict
    reads it from a table's column or from a record's scene; a bad name is one error line."""
    frame = pd.read_parquet(table)
    frame["param.experiment.h0"] = np.linspace(0.002, 0.01, len(frame))  # m
    frame["param.transfer.compensation"] = "none"
    path = tmp_path / "with_gap.parquet"
    frame.to_parquet(path)
    model = tmp_path / "m.json"
    p = run("train", str(path), "--features", "3", "--extra", "experiment.h0", "--out",
            str(model), "--json", "--topologies", "3", "--trainings", "1")
    assert p.returncode == 0, p.stderr
    assert json.loads(p.stdout.strip().splitlines()[-1])["extra"] == ["param.experiment.h0"]
    assert json.loads(model.read_text())["feature_names"][-1] == "param.experiment.h0"
    q = run("predict", str(model), str(path), "--json")
    assert q.returncode == 0, q.stderr
    assert len(json.loads(q.stdout)["prediction"]) == 158
    # a real (1 s) record: the features from its signals, h0 from its scene
    rec = record
    q = run("predict", str(model), str(rec), "--json")
    assert q.returncode == 0, q.stderr
    pred = json.loads(q.stdout)
    assert len(pred["prediction"]) == 1 and np.isfinite(pred["prediction"][0])
    from rths3d.ann import FidelityANN
    from rths3d.dataset.runner import record_features
    from rths3d.record import Record

    feats, net = record_features(Record.load(rec)), FidelityANN.load(model)
    x = [[feats[n] for n in net.feature_names[:-1]] + [0.005]]  # the scene's h0 (m)
    assert net.predict(np.array(x), warn=False)[0] == pytest.approx(pred["prediction"][0])
    for bad, why in (("nope", "not a parameter column"),
                     ("transfer.compensation", "must be a numeric parameter")):
        b = run("train", str(path), "--features", "3", "--extra", bad, "--out",
                str(tmp_path / "b.json"))
        assert b.returncode == 2 and f"extra: '{bad}'" in b.stderr and why in b.stderr
        assert "Traceback" not in b.stderr


def test_predict_json_is_valid_with_nan_and_scores_finite_rows(table, model, tmp_path) -> None:
    """A NaN feature gives a null prediction (strict JSON) and a warning naming the row; a NaN
    target or prediction is left out of ρ and MSE instead of making them NaN."""
    frame = pd.read_parquet(table)
    frame.loc[0, "feature.e_rel_track"] = np.nan
    frame.loc[1, "target.e_rel_ref"] = np.nan
    path = tmp_path / "nan.parquet"
    frame.to_parquet(path)
    q = run("predict", str(model), str(path), "--json")
    assert q.returncode == 0, q.stderr
    pr = strict_json(q.stdout)
    assert pr["prediction"][0] is None and pr["spread"][0] is None
    assert pr["r"] > 0.9 and np.isfinite(pr["mse"]) and pr["n_scored"] == 156
    assert "rows 0;" in q.stderr and "e_rel_track" in q.stderr


def test_train_rejects_unwritable_out_and_plot_before_training(table, tmp_path) -> None:
    """--out onto a folder or --plot below a file: one error line naming the option, exit 2,
    before any training and without a temp file."""
    (tmp_path / "folder").mkdir()
    (tmp_path / "file").write_text("")
    common = ("--features", "3", "--topologies", "3", "--trainings", "1")
    for args, field in (((("--out", str(tmp_path / "folder"))), "--out"),
                        (("--out", str(tmp_path / "m.json"), "--plot",
                          str(tmp_path / "file" / "p.png")), "--plot")):
        p = run("train", str(table), *args, *common)
        assert p.returncode == 2 and p.stderr.startswith(f"error: {field}:"), p.stderr
        assert "Traceback" not in p.stderr and "training" not in p.stderr
    assert sorted(q.name for q in tmp_path.iterdir()) == ["file", "folder"]


def test_train_family_filter_needs_a_family_column(table, tmp_path) -> None:
    """--family on a table without a 'family' column is one error line, exit 2."""
    path = tmp_path / "nofam.parquet"
    pd.read_parquet(table).drop(columns="family").to_parquet(path)
    p = run("train", str(path), "--features", "3", "--family", "synthetic", "--out",
            str(tmp_path / "m.json"))
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert "--family: 'synthetic' (table has no 'family' column)" in p.stderr


def test_predict_warns_on_a_stopped_record_and_needs_ok_tests(table, model, record,
                                                              tmp_path) -> None:
    """A stopped record is predicted with a warning naming status and reason; a table without
    any test of status ok is one error line, exit 2."""
    from rths3d.record import Record

    rec = Record.load(record)
    rec.meta["status"], rec.meta["reason"] = "stopped", "leg 3 velocity over its limit"
    stopped = rec.save(tmp_path / "stopped.parquet")
    q = run("predict", str(model), str(stopped), "--json")
    assert q.returncode == 0, q.stderr
    assert len(strict_json(q.stdout)["prediction"]) == 1
    assert "'stopped'" in q.stderr and "leg 3 velocity over its limit" in q.stderr
    frame = pd.read_parquet(table)
    frame["status"] = "stopped"
    path = tmp_path / "allstopped.parquet"
    frame.to_parquet(path)
    p = run("predict", str(model), str(path))
    assert p.returncode == 2 and "no test has status ok" in p.stderr
    assert "Traceback" not in p.stderr


def test_predict_reads_numerical_k_from_a_1dof_record(table, record, tmp_path) -> None:
    """A model with the input numerical.k reads it from a 1-DOF record's 1×1 matrix K; a
    record with a matrix numerical part is one error line saying it is not a scalar."""
    from rths3d.ann import FidelityANN
    from rths3d.dataset.runner import record_features
    from rths3d.record import Record

    frame = pd.read_parquet(table)
    frame["param.numerical.k"] = np.linspace(2e3, 2e4, len(frame))  # N/m
    path = tmp_path / "with_k.parquet"
    frame.to_parquet(path)
    model = tmp_path / "k.json"
    p = run("train", str(path), "--features", "3", "--extra", "numerical.k", "--out",
            str(model), "--json", "--topologies", "3", "--trainings", "1")
    assert p.returncode == 0, p.stderr
    q = run("predict", str(model), str(record), "--json")
    assert q.returncode == 0, q.stderr
    rec = Record.load(record)
    k = rec.meta["params"]["numerical.K"]
    assert np.shape(k) == (1, 1)
    feats, net = record_features(rec), FidelityANN.load(model)
    x = [[feats[n] for n in net.feature_names[:-1]] + [k[0][0]]]
    pred = strict_json(q.stdout)["prediction"][0]
    assert net.predict(np.array(x), warn=False)[0] == pytest.approx(pred)
    rec.meta["params"]["numerical.K"] = [[1e4, 0.0], [0.0, 1e4]]
    two = rec.save(tmp_path / "two_dof.parquet")
    b = run("predict", str(model), str(two))
    assert b.returncode == 2 and "Traceback" not in b.stderr
    assert "numerical.k" in b.stderr and "not a scalar" in b.stderr


def test_train_on_several_tables_equals_the_joined_table(table, tmp_path) -> None:
    """train A B trains on A and B joined: the same model as on one table holding both, with
    a test given in both tables kept once (and said so)."""
    whole = pd.read_parquet(table)
    a, b = tmp_path / "a.parquet", tmp_path / "b.csv"
    whole.iloc[:100].to_parquet(a)
    whole.iloc[90:].to_csv(b, index=False)  # rows 90-99 in both tables
    common = ("--features", "3", "--json", "--topologies", "3", "--trainings", "1",
              "--transform", "linear")
    p1 = run("train", str(table), "--out", str(tmp_path / "one.json"), *common)
    p2 = run("train", str(a), str(b), "--out", str(tmp_path / "two.json"), *common)
    assert p1.returncode == 0 and p2.returncode == 0, p2.stderr
    assert "10 tests appear in more than one table" in p2.stderr
    r1, r2 = (json.loads(p.stdout.strip().splitlines()[-1]) for p in (p1, p2))
    assert r2["n_samples"] == r1["n_samples"] == 158
    assert r2["r_test"] == pytest.approx(r1["r_test"], rel=1e-9)
    assert r2["mse"] == pytest.approx(r1["mse"], rel=1e-9)


def test_train_ratings_keep_the_tests_within_the_bench(table, tmp_path) -> None:
    """--ratings velocity=V trains on the tests whose peak command velocity is ≤ V only (the
    same model as on the table cut by hand); a bad rating is one line naming the option."""
    whole = pd.read_parquet(table)
    whole["measure.velocity_peak"] = np.linspace(0.01, 0.4, len(whole))  # m/s
    full = tmp_path / "full.parquet"
    whole.to_parquet(full)
    cut = tmp_path / "cut.parquet"
    whole[whole["measure.velocity_peak"] <= 0.3].to_parquet(cut)
    common = ("--features", "3", "--json", "--topologies", "3", "--trainings", "1",
              "--transform", "linear")
    p1 = run("train", str(full), "--ratings", "velocity=0.3", "--out",
             str(tmp_path / "a.json"), *common)
    p2 = run("train", str(cut), "--out", str(tmp_path / "b.json"), *common)
    assert p1.returncode == 0 and p2.returncode == 0, p1.stderr
    r1, r2 = (json.loads(p.stdout.strip().splitlines()[-1]) for p in (p1, p2))
    assert r1["n_samples"] == r2["n_samples"] < 158
    assert r1["mse"] == pytest.approx(r2["mse"], rel=1e-9)
    bad = run("train", str(full), "--ratings", "speed=1", "--out", str(tmp_path / "c.json"),
              "--features", "3")
    assert bad.returncode == 2 and "--ratings" in bad.stderr
    assert "Traceback" not in bad.stderr and len(bad.stderr.strip().splitlines()) == 1


def test_predict_warns_on_a_record_in_mm(model, record, tmp_path) -> None:
    """`predict` on a record whose displacements are in mm still predicts, with one warning
    per implausible column naming it (the features would be 1000 times off); none for the
    record in SI units."""
    from rths3d.record import Record

    rec = Record.load(record)
    cols = {k: v * 1e3 if k.startswith(("z_cmd.", "z_meas.", "z_ref.")) else v
            for k, v in rec.columns.items()}
    bad = Record(rec.t, cols, dict(rec.meta)).save(tmp_path / "mm.parquet")
    q = run("predict", str(model), str(bad), "--json")
    assert q.returncode == 0, q.stderr
    warned = [ln for ln in q.stderr.splitlines() if "beyond the plausible limit" in ln]
    assert {ln.split("'")[1] for ln in warned} == {"z_cmd.z", "z_meas.z", "z_ref.z"}
    ok = run("predict", str(model), str(record), "--json")
    assert ok.returncode == 0 and "plausible" not in ok.stderr
