"""Tests of `rths3d train` and `rths3d predict` on a sweep-shaped table with known structure."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pandas as pd
import pytest

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
    return subprocess.run([sys.executable, "-m", "rths3d", *args], capture_output=True,
                          text=True, timeout=300)


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


def test_train_extra_parameter_and_predict_a_record(table, tmp_path) -> None:
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
    rec = tmp_path / "rec.parquet"
    r = run("run", "paper_contact", "-t", "lti", "--set", "duration=1", "--out", str(rec))
    assert r.returncode == 0, r.stderr
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
