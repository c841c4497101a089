"""The example scripts: `--help` only prints usage, bad arguments give one line and exit 2."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _run(tmp_path: Path, script: str, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(EXAMPLES / script), *args], cwd=tmp_path,
                          capture_output=True, text=True, timeout=600)


@pytest.mark.parametrize("script", ["12_platform_batch.py", "30_metrics_from_record.py",
                                    "44_leave_one_family_out.py", "60_find_missing_effect.py",
                                    "70_rths_benchmark.py", "73_compensators_platform.py"])
def test_help_prints_usage_without_running(tmp_path, script):
    """`--help` prints the usage and exits 0 without running or writing anything."""
    out = _run(tmp_path, script, "--help")
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("usage:") and list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("script, args, needle", [
    ("10_platform_tracking.py", ["--out", "c.parquet"], "--out: 'c.parquet'"),
    ("20_contact_test.py", ["--duration", "-1"], "duration: -1.0"),
    ("30_metrics_from_record.py", ["c.parquet"], "OUT_DIR: 'c.parquet'"),
    ("51_replay.py", ["missing.parquet"], "missing.parquet"),
    ("42_learning_curve.py", ["c.parquet", "--features", "4"], "--features: '4'"),
    ("44_leave_one_family_out.py", ["c.parquet", "--features", "1,x"], "--features: '1,x'"),
    ("43_feature_probe.py", ["c.parquet", "--named", "zeta,nope"], "--named: 'nope'"),
    ("43_feature_probe.py", ["c.parquet", "--forward", "16"], "--forward: 16"),
    ("73_compensators_platform.py", ["--compensators", "ats,smith"], "'smith'"),
    ("73_compensators_platform.py", ["--duration", "0.1"], "--duration: 0.1"),
    ("75_marths_stewart.py", ["--duration", "-1"], "duration: -1.0"),
    ("76_rodeac_noise_seeds.py", ["--seeds", "1"], "--seeds: 1"),
    ("66_foreign_bench.py", ["--bench", "nope"], "--bench: 'nope'"),
    ("66_foreign_bench.py", ["--shard", "3/2"], "--shard: '3/2'"),
])
def test_bad_arguments_give_one_line_and_exit_2(tmp_path, script, args, needle):
    """A user mistake in an example's arguments prints one `error:` line, no traceback."""
    (tmp_path / "c.parquet").write_text("x")
    out = _run(tmp_path, script, *args)
    err = out.stderr.strip().splitlines()
    assert out.returncode == 2 and len(err) == 1, out.stderr
    assert err[0].startswith("error: ") and needle in err[0]


def test_usage_docstrings_list_every_option():
    """The usage lines of 41 and 42 name the options their parsers accept."""
    doc41 = (EXAMPLES / "41_paper_protocol.py").read_text().split('"""')[1]
    doc42 = (EXAMPLES / "42_learning_curve.py").read_text().split('"""')[1]
    assert "[--trainings N]" in doc41 and "table1_lti_large" in doc41
    assert "[--test N]" in doc42


def _two_family_table(path: Path) -> Path:
    """Two families sharing one smooth law target = f(features) (the rest noise)."""
    import numpy as np
    import pandas as pd

    from rths3d.dataset.table import FEATURE_SETS

    rng = np.random.default_rng(1)
    n = 240
    data = {f"feature.{k}": rng.uniform(0.1, 1.0, n) for k in FEATURE_SETS[1]}
    data["target.e_rel_ref"] = (0.05 + 0.1 * data["feature.e_rel_track"] ** 2
                                + 0.05 * data["feature.fei_d"])
    data["test_id"] = [f"t{i}" for i in range(n)]
    data["family"] = ["a", "b"] * (n // 2)
    data["status"] = "ok"
    pd.DataFrame(data).to_parquet(path)
    return path


@pytest.mark.slow  # an end-to-end figure: a sweep and five trainings
def test_leave_one_family_out_scores_each_family(tmp_path):
    """44 leaves each family out in turn, scores it on all its tests and writes the table,
    the JSON summary and a plot per family; an unknown family is one error line."""
    import json

    table = _two_family_table(tmp_path / "fam.parquet")
    out = _run(tmp_path, "44_leave_one_family_out.py", str(table), "--features", "3",
               "--topologies", "4", "--trainings", "2", "--out", "lofo")
    assert out.returncode == 0, out.stderr
    summary = json.loads((tmp_path / "lofo" / "lofo.json").read_text())
    assert [s["left_out"] for s in summary] == ["a", "b"]
    assert all(s["n_left_out"] == 120 and s["r_left_out_median"] > 0.95 for s in summary)
    assert {p.name for p in (tmp_path / "lofo").glob("*.png")} == {"lofo_a_set3.png",
                                                                  "lofo_b_set3.png"}
    bad = _run(tmp_path, "44_leave_one_family_out.py", str(table), "--families", "c")
    assert bad.returncode == 2 and bad.stderr.startswith("error: --families: 'c'"), bad.stderr


@pytest.mark.slow  # an end-to-end figure: a sweep and a forward selection
def test_feature_probe_forward_selection_picks_the_features_the_target_depends_on(tmp_path):
    """43 --forward 2 on a target of e_rel_track and fei_d (the rest noise) picks those two,
    e_rel_track first (it carries more of the variance)."""
    import json

    pytest.importorskip("sklearn")
    table = _two_family_table(tmp_path / "fam.parquet")
    out = _run(tmp_path, "43_feature_probe.py", str(table), "--forward", "2")
    assert out.returncode == 0, out.stderr
    rows = json.loads(out.stdout.strip().splitlines()[-1])["probe"]
    assert [r["set"] for r in rows] == ["e_rel_track", "e_rel_track,fei_d"]
    assert rows[1]["r_test"] > rows[0]["r_test"] and rows[1]["r_test"] > 0.95


def test_compensators_platform_example_makes_the_table(tmp_path):
    """73 runs paper_contact on the platform with none and ATS (both modes), prints the
    markdown table and writes its rows: ATS well below no compensation, e_rel,ref in
    (0, 1), the delay margin of the scene's record."""
    import json

    out = _run(tmp_path, "73_compensators_platform.py", "--scenes", "paper_contact",
               "--compensators", "ats", "--duration", "2", "--json", "rows.json")
    assert out.returncode == 0, out.stderr
    assert "| paper_contact | ats | legs |" in out.stdout
    rows = json.loads((tmp_path / "rows.json").read_text())
    assert [(r["compensator"], r["compensate"]) for r in rows] == [
        ("none", "interface"), ("ats", "interface"), ("ats", "legs")]
    none = rows[0]["e_rel_ref"][0]
    for r in rows[1:]:
        assert r["status"] == "ok" and 0 < r["e_rel_ref"][0] < none / 3
        assert r["tau_ratio_max"] == pytest.approx(max(r["fei_d"]) / r["tau_max"])
    assert 0.0004 < rows[0]["tau_max"] < 0.0005  # s: the undamped part's delay margin


@pytest.mark.parametrize("script, args, module, extra", [
    ("51_replay.py", ["--screenshot", "shot.png"], "playwright", "browser"),
    ("43_feature_probe.py", ["c.parquet"], "sklearn", "probe"),
])
def test_missing_optional_dependency_names_the_extra(tmp_path, script, args, module, extra):
    """Without the optional package (made unimportable, as on a machine without it), one
    line names it and the extra to install, exit 2, before anything runs or is written."""
    (tmp_path / "c.parquet").write_text("x")
    code = (f"import runpy, sys; sys.modules[{module!r}] = None; "
            f"sys.argv = [{script!r}, *{args!r}]; "
            f"runpy.run_path({str(EXAMPLES / script)!r}, run_name='__main__')")
    out = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True,
                         text=True, timeout=120)
    err = out.stderr.strip().splitlines()
    assert out.returncode == 2 and len(err) == 1, out.stderr
    assert err[0].startswith("error: ") and f"pip install 'rths3d[{extra}]'" in err[0]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.parquet"]
