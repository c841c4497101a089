"""Where users read the surrogate estimate: `rths3d predict --json` scores its ρ, the coverage
of its band and the share flagged; `rths3d metrics` prints the band and the flag.

The tables here are written in the test with answers known by construction (which tests lie
in their band, which are flagged); the record comes from the closed loop."""

from __future__ import annotations

import json
import subprocess

import numpy as np
import pandas as pd
import pytest
from cli_cases import run_in_process

from rths3d.cli.train import surrogate_scores


def _table(n: int = 40, seed: int = 0) -> pd.DataFrame:
    """Truth t, an estimate within ±2 % of it, a band ±5 % around the estimate; tests 0–3:
    estimate 4× too low, tests 0–1 flagged, 2–3 not; test 4: no estimate, flagged."""
    rng = np.random.default_rng(seed)
    t = np.exp(rng.uniform(np.log(0.01), np.log(10.0), n))
    e = t * rng.uniform(0.98, 1.02, n)
    e[:4] = t[:4] / 4.0
    e[4] = np.nan
    flag = np.zeros(n)
    flag[[0, 1, 4]] = 1.0
    return pd.DataFrame({"test_id": [f"t{i}" for i in range(n)], "family": ["f"] * n,
                         "status": ["ok"] * n, "feature.e_rel_track": t,
                         "feature.e_rel_ref_hat": e, "measure.e_rel_ref_hat_lo": e / 1.05,
                         "measure.e_rel_ref_hat_hi": e * 1.05, "measure.surrogate_flag": flag,
                         "target.e_rel_ref": t})


def test_surrogate_scores_know_the_answer() -> None:
    frame = _table()
    s = surrogate_scores(frame)
    n = len(frame)
    assert s["n"] == n and s["nan"] == 1
    assert s["flagged"] == pytest.approx(3 / n)
    assert s["coverage"] == pytest.approx((n - 5) / n)          # 0–4 outside their band
    assert s["coverage_or_flagged"] == pytest.approx((n - 2) / n)  # 2, 3 neither
    assert s["underestimated_3x_unflagged"] == 2
    ok = np.isfinite(frame["feature.e_rel_ref_hat"])
    rho = np.corrcoef(frame["feature.e_rel_ref_hat"][ok], frame["target.e_rel_ref"][ok])[0, 1]
    assert s["r"] == pytest.approx(rho)
    assert 0.0 < s["r_log10"] < 1.0
    # without the surrogate columns, or for another target: nothing to report
    assert surrogate_scores(frame.drop(columns=["measure.surrogate_flag"])) is None
    assert surrogate_scores(frame, "e_peak_ref") is None


def _cli(*args: str) -> subprocess.CompletedProcess:
    return run_in_process(*args)  # as python -m rths3d runs it, in this process


def test_predict_json_reports_the_surrogate(tmp_path) -> None:
    table = tmp_path / "sweep.parquet"
    frame = _table(60, 1)
    frame.to_parquet(table)
    model = tmp_path / "m.json"
    p = _cli("train", str(table), "--features", "e_rel_track", "--out", str(model), "--json",
             "--topologies", "2", "--trainings", "1")
    assert p.returncode == 0, p.stderr
    q = _cli("predict", str(model), str(table), "--json")
    assert q.returncode == 0, q.stderr
    sur = json.loads(q.stdout)["surrogate"]
    assert sur == pytest.approx(surrogate_scores(frame), nan_ok=True)
    text = _cli("predict", str(model), str(table))
    assert "surrogate ê_rel,ref: ρ" in text.stdout and "flagged 5.0 %" in text.stdout
