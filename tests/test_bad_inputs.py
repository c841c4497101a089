"""A table of user mistakes across the commands, each run as a user would run it.

Every case must exit with code 2, print exactly one line on stderr that names the field or
the path (and no traceback), and leave no output file that looks complete. The cases run in
three processes, each importing the package once and calling the command-line entry point
per case as ``python -m rths3d`` does (tests/cli_cases.py), collected once per module.
"""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import tempfile
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from rths3d.dataset.table import FEATURE_SETS
from rths3d.record import Record

GOOD_SPEC = """[sweep]
name = "s"
duration = 0.5
batch_size = 4

[[family]]
name = "contact"
scene = "paper_contact"
transfer = "lti"
[family.grid]
"numerical.k" = [1.0e3, 1.0e4]
"""

# (id, command line with {placeholders}, text stderr must contain, outputs that must not be
# left complete). Placeholders: {d} the case's own folder, {f} the shared fixture folder,
# {busy} a port another server holds, {ro} a folder that refuses files.
CASES: list[tuple[str, str, str, tuple[str, ...]]] = [
    # ---- run
    ("run-missing-scene", "run nope_scene", "scene: 'nope_scene'", ()),
    ("run-scene-folder", "run {f}/adir", "is a folder", ()),
    ("run-scene-invalid-toml", "run {f}/bad.toml", "invalid TOML", ()),
    ("run-scene-unknown-key", "run {f}/unknown_key.toml", "colour", ()),
    ("run-transfer", "run paper_contact -t magic", "--transfer: 'magic'", ()),
    ("run-negative-mass", "run paper_contact --set numerical.m=-1", "numerical.m: -1", ()),
    ("run-k-not-a-number", "run paper_contact --set numerical.k=abc", "numerical.k: 'abc'",
     ()),
    ("run-set-no-equals", "run paper_contact --set numerical.k", "--set: 'numerical.k'", ()),
    ("run-zero-duration", "run paper_contact --set duration=0", "duration: 0", ()),
    ("run-dt-too-large", "run paper_contact --set dt=1", "dt: 1", ()),
    ("run-unknown-field", "run paper_contact --set numerical.q=1", "numerical.q", ()),
    ("run-experiment-kind", "run paper_contact --set experiment.kind=magic",
     "experiment.kind: 'magic'", ()),
    ("run-negative-delay", "run paper_contact --set transfer.delay=-1", "transfer.delay: -1",
     ()),
    ("run-file-signal-without-file", "run paper_contact --set excitation.signal=file",
     "excitation.file", ()),
    ("run-out-suffix", "run paper_contact -t lti --out {d}/out.txt", "--out:",
     ("{d}/out.txt",)),
    ("run-out-is-folder", "run paper_contact -t lti --out {f}/dir.parquet", "is a folder",
     ()),
    ("run-out-under-file", "run paper_contact -t lti --out {f}/blocker/x.parquet",
     "'{f}/blocker' is a file", ()),
    ("run-out-unwritable", "run paper_contact -t lti --out {ro}/x.parquet", "not writable",
     ()),
    ("run-plot-is-file", "run paper_contact -t lti --plot {f}/blocker",
     "--plot: '{f}/blocker' (exists and is not a folder)", ()),
    ("run-unknown-option", "run paper_contact --bogus", "--bogus", ()),
    ("run-no-scene", "run", "'scene'", ()),
    # ---- metrics
    ("metrics-missing", "metrics {f}/missing.parquet", "missing.parquet", ()),
    ("metrics-folder", "metrics {f}/dir.parquet", "is a folder, not a record file", ()),
    ("metrics-garbage", "metrics {f}/garbage.parquet", "garbage.parquet", ()),
    ("metrics-empty-csv", "metrics {f}/empty.csv", "empty.csv", ()),
    ("metrics-format", "metrics {f}/rec.txt", "unknown format '.txt'", ()),
    ("metrics-nan", "metrics {f}/nan.csv", "'z_meas' has 1 NaN/inf", ()),
    ("metrics-time-back", "metrics {f}/timeback.csv", "column 't' is not strictly increasing",
     ()),
    ("metrics-no-time", "metrics {f}/no_t.csv", "missing column 't'", ()),
    ("metrics-short", "metrics {f}/short.csv", "too short", ()),
    ("metrics-no-interface", "metrics {f}/no_interface.csv", "no interface columns", ()),
    ("metrics-plot-under-file", "metrics {f}/rec.parquet --plot {f}/blocker/p",
     "--plot:", ()),
    # ---- sweep
    ("sweep-missing-spec", "sweep {f}/nope.toml --out {d}/o", "spec: '{f}/nope.toml'",
     ("{d}/o",)),
    ("sweep-invalid-toml", "sweep {f}/bad.toml --out {d}/o", "invalid TOML", ("{d}/o",)),
    ("sweep-empty-grid", "sweep {f}/empty_grid.toml --out {d}/o", "family 'contact'.grid",
     ("{d}/o",)),
    ("sweep-no-ranges", "sweep {f}/no_ranges.toml --out {d}/o", "family 'contact'.sample",
     ("{d}/o",)),
    ("sweep-unknown-key", "sweep {f}/unknown_sweep_key.toml --out {d}/o", "sweep.batchsize",
     ("{d}/o",)),
    ("sweep-missing-scene", "sweep {f}/missing_scene.toml --out {d}/o", "nope_scene",
     ("{d}/o",)),
    ("sweep-unknown-parameter", "sweep {f}/unknown_param.toml --out {d}/o", "numerical.kk",
     ("{d}/o",)),
    ("sweep-subset", "sweep {f}/subset.toml --out {d}/o", "subset", ("{d}/o",)),
    ("sweep-duration", "sweep {f}/neg_duration.toml --out {d}/o", "sweep.duration",
     ("{d}/o",)),
    ("sweep-family-name", "sweep {f}/no_name.toml --out {d}/o", "family[0].name",
     ("{d}/o",)),
    ("sweep-out-is-file", "sweep {f}/good.toml --out {f}/blocker", "--out: '{f}/blocker'",
     ()),
    ("sweep-workers", "sweep {f}/good.toml --out {d}/o --workers 0", "workers: 0",
     ("{d}/o",)),
    ("sweep-scheduler", "sweep {f}/good.toml --out {d}/o --scheduler tcp://127.0.0.1:{busy}",
     "scheduler", ("{d}/o/s.parquet",)),
    ("sweep-all-refused", "sweep {f}/refused.toml --out {d}/o --workers 1 --quiet",
     "all 2 tests refused", ()),
    # ---- train
    ("train-missing-table", "train {f}/missing.parquet --features 1 --out {d}/m.json",
     "missing.parquet", ("{d}/m.json",)),
    ("train-feature-set", "train {f}/table.parquet --features 4 --out {d}/m.json",
     "--features: 4", ("{d}/m.json",)),
    ("train-feature-name", "train {f}/table.parquet --features zeta,nope --out {d}/m.json",
     "nope", ("{d}/m.json",)),
    ("train-out-folder", "train {f}/table.parquet --features 3 --out {f}/adir",
     "--out: '{f}/adir'", ()),
    ("train-plot-under-file",
     "train {f}/table.parquet --features 3 --out {d}/m.json --plot {f}/blocker/p.png",
     "--plot:", ("{d}/m.json",)),
    ("train-topologies", "train {f}/table.parquet --features 3 --out {d}/m.json "
     "--topologies x", "--topologies", ("{d}/m.json",)),
    ("train-transform", "train {f}/table.parquet --features 3 --out {d}/m.json "
     "--transform cube", "--transform", ("{d}/m.json",)),
    ("train-ratings", "train {f}/table.parquet --features 3 --out {d}/m.json "
     "--ratings velocity=-1", "--ratings", ("{d}/m.json",)),
    ("train-family", "train {f}/table.parquet --features 3 --out {d}/m.json --family nope",
     "--family: 'nope'", ("{d}/m.json",)),
    ("train-target", "train {f}/table.parquet --features 3 --out {d}/m.json --target nope",
     "nope", ("{d}/m.json",)),
    # ---- predict
    ("predict-missing-model", "predict {f}/nomodel.json {f}/table.parquet", "nomodel.json",
     ()),
    ("predict-model-not-json", "predict {f}/blocker {f}/table.parquet", "blocker", ()),
    ("predict-missing-data", "predict {f}/model.json {f}/missing.parquet", "missing.parquet",
     ()),
    ("predict-garbage-data", "predict {f}/model.json {f}/garbage.parquet", "garbage.parquet",
     ()),
    ("predict-no-features", "predict {f}/model.json {f}/nofeatures.parquet",
     "feature column missing", ()),
    ("predict-none-ok", "predict {f}/model.json {f}/allstopped.parquet",
     "no test has status ok", ()),
    # ---- view
    ("view-port-range", "view {f}/rec.parquet --port 70000", "--port: 70000", ()),
    ("view-port-busy", "view {f}/rec.parquet --port {busy}", "--port: {busy}", ()),
    ("view-port-not-a-number", "view {f}/rec.parquet --port abc", "'--port'", ()),
    ("view-rate", "view {f}/rec.parquet --rate 100", "--rate: 100", ()),
    ("view-speed", "view {f}/rec.parquet --speed 0", "--speed: 0", ()),
    ("view-host", "view {f}/rec.parquet --host 192.0.2.1", "--host: '192.0.2.1'", ()),
    ("view-missing-record", "view {f}/missing.parquet", "missing.parquet", ()),
    ("view-missing-scene", "view nope_scene", "nope_scene", ()),
    ("view-out-suffix", "view paper_contact --out {d}/live.txt", "--out: '{d}/live.txt'",
     ("{d}/live.txt",)),
    ("view-replay-transfer", "view {f}/rec.parquet --transfer lti", "--transfer: 'lti'", ()),
    ("view-span", "view paper_contact --span -1", "--span: -1", ()),
    ("view-exaggeration", "view paper_contact --exaggeration 0.5", "--exaggeration: 0.5",
     ()),
    # ---- diagnose
    ("diagnose-missing", "diagnose {f}/missing.parquet", "missing.parquet", ()),
    ("diagnose-mm", "diagnose {f}/rec_mm.parquet", "'z_cmd.z' reaches", ()),
    ("diagnose-short", "diagnose {f}/rec_short.parquet", "too short", ()),
    ("diagnose-no-command", "diagnose {f}/no_command.parquet", "missing command columns", ()),
    ("diagnose-effect", "diagnose {f}/rec.parquet --add nope", "nope", ()),
    ("diagnose-scene", "diagnose {f}/rec.parquet --scene magic", "magic", ()),
    ("diagnose-report-under-file", "diagnose {f}/rec.parquet --report {f}/blocker/r",
     "--report:", ()),
    ("diagnose-refit", "diagnose {f}/rec.parquet --refit 0", "'--refit'", ()),
    ("diagnose-baseline-missing", "diagnose {f}/rec.parquet --baseline {f}/missing.parquet",
     "--baseline", ()),
    ("diagnose-baseline-short", "diagnose {f}/rec.parquet --baseline {f}/rec_short.parquet",
     "--baseline", ()),
    ("diagnose-baseline-other-test", "diagnose {f}/rec.parquet --baseline "
     "{f}/rec_other.parquet", "must repeat the record's command series", ()),
    # ---- benchmark
    ("benchmark-case", "benchmark rths --case 9", "--case: 9", ()),
    ("benchmark-trials", "benchmark rths --trials -1", "--trials: -1", ()),
    ("benchmark-excitation", "benchmark rths --case 1 --excitation Northridge",
     "excitation: 'Northridge'", ()),
    ("benchmark-data", "benchmark rths --case 1 --data {f}/adir", "data: '{f}/adir'", ()),
    ("benchmark-plot-under-file", "benchmark rths --case 1 --plot {f}/blocker/p.png",
     "--plot:", ()),
    ("benchmark-scene-missing", "benchmark rths --scene {f}/nope.toml", "nope.toml", ()),
    ("benchmark-set-key", "benchmark rths --case 1 --set plant.kk=1", "plant.kk", ()),
    # ---- platform
    ("platform-track-dof", "platform track --dof q --out {d}/t", "dof", ("{d}/t/track.png",)),
    ("platform-track-ramp", "platform track --ramp -1 --out {d}/t", "--ramp: -1",
     ("{d}/t/track.parquet",)),
    ("platform-track-out-file", "platform track --out {f}/blocker", "--out: '{f}/blocker'",
     ()),
    ("platform-track-payload", "platform track --payload-mass -1 --out {d}/t",
     "--payload-mass: -1", ("{d}/t/track.parquet",)),
    ("platform-identify-orders", "platform identify --n-num 3 --n-den 2 --out {d}/tf.json",
     "--n-num/--n-den", ("{d}/tf.json",)),
    ("platform-identify-out", "platform identify --out {f}/blocker/tf.json", "--out:", ()),
    ("platform-no-command", "platform nope", "nope", ()),
]


def _unwritable(base: Path) -> Path | None:
    d = base / "ro"
    d.mkdir()
    d.chmod(0o555)
    for cand in (d, Path("/sys")):
        try:
            fd, name = tempfile.mkstemp(dir=cand)
        except OSError:
            return cand
        os.close(fd)
        os.unlink(name)
    return None


def _write_fixtures(f: Path) -> None:
    """Files the cases read: good ones to misuse, bad ones to refuse."""
    from rths3d.ann import FidelityANN

    (f / "adir").mkdir()
    (f / "dir.parquet").mkdir()
    (f / "blocker").write_text("a file, not a folder\n")
    (f / "bad.toml").write_text("[sweep\nname = ")
    (f / "unknown_key.toml").write_text('name = "x"\ncolour = "red"\n')
    (f / "garbage.parquet").write_bytes(b"PAR1 not really parquet")
    (f / "empty.csv").write_text("")
    (f / "rec.txt").write_text("t,z_cmd,z_meas\n")
    t = np.arange(3000) * 1e-3
    z = 2e-3 * np.sin(2 * np.pi * 1.0 * t)
    zm = 2e-3 * np.sin(2 * np.pi * 1.0 * (t - 0.004))
    rec = Record(t, {"z_cmd.z": z, "z_meas.z": zm, "f_meas.z": 800.0 * zm}, {})
    rec.save(f / "rec.parquet")
    Record(t, {k: v * 1e3 for k, v in rec.columns.items()}, {}).save(f / "rec_mm.parquet")
    rec.slice(0, 500).save(f / "rec_short.parquet")
    Record(t, {"z_cmd.z": 1.1 * z, "z_meas.z": zm, "f_meas.z": 800.0 * zm}, {}).save(
        f / "rec_other.parquet")
    Record(t, {"z_meas.z": zm, "f_meas.z": 800.0 * zm}, {}).save(f / "no_command.parquet")
    frame = pd.DataFrame({"t": t[:50], "z_cmd": z[:50], "z_meas": zm[:50]})
    nan = frame.copy()
    nan.loc[7, "z_meas"] = np.nan
    nan.to_csv(f / "nan.csv", index=False)
    back = frame.copy()
    back.loc[20, "t"] = back.loc[10, "t"]
    back.to_csv(f / "timeback.csv", index=False)
    frame.drop(columns="t").to_csv(f / "no_t.csv", index=False)
    frame.head(3).to_csv(f / "short.csv", index=False)
    pd.DataFrame({"t": t[:50], "voltage": z[:50]}).to_csv(f / "no_interface.csv", index=False)
    # sweep specs
    specs = {
        "good": GOOD_SPEC,
        "empty_grid": GOOD_SPEC.split("[family.grid]")[0] + "[family.grid]\n",
        "no_ranges": GOOD_SPEC.split("[family.grid]")[0] + "[family.sample]\nn = 3\n",
        "unknown_sweep_key": GOOD_SPEC.replace("batch_size", "batchsize"),
        "missing_scene": GOOD_SPEC.replace('"paper_contact"', '"nope_scene"'),
        "unknown_param": GOOD_SPEC.replace('"numerical.k"', '"numerical.kk"'),
        "subset": GOOD_SPEC.replace('transfer = "lti"', 'transfer = "lti"\nsubset = 5'),
        "neg_duration": GOOD_SPEC.replace("duration = 0.5", "duration = -1.0"),
        "no_name": GOOD_SPEC.replace('name = "contact"\n', ""),
        "refused": GOOD_SPEC.replace('"numerical.k" = [1.0e3, 1.0e4]',
                                     '"numerical.m" = [-1.0, -2.0]'),
    }
    for name, text in specs.items():
        (f / f"{name}.toml").write_text(text)
    # a sweep-shaped table and a small model trained on it
    rng = np.random.default_rng(0)
    n = 60
    names = FEATURE_SETS[3]
    data = {f"feature.{k}": rng.uniform(0.1, 1.0, n) for k in FEATURE_SETS[1]}
    data["target.e_rel_ref"] = 0.05 + 0.1 * data["feature.e_rel_track"] ** 2
    data["test_id"] = [f"t{i}" for i in range(n)]
    data["family"] = "synthetic"
    data["status"] = "ok"
    table = pd.DataFrame(data)
    table.to_parquet(f / "table.parquet")
    table.assign(status="stopped").to_parquet(f / "allstopped.parquet")
    table.drop(columns=[f"feature.{names[0]}"]).to_parquet(f / "nofeatures.parquet")
    model = FidelityANN(topologies=((2,),), n_trainings=1, seed=0)
    model.fit(table[[f"feature.{k}" for k in names]].to_numpy(),
              table["target.e_rel_ref"].to_numpy(), feature_names=list(names))
    model.save(f / "model.json")


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    """Every case of the table, run by three processes (tests/cli_cases.py)."""
    root = tmp_path_factory.mktemp("bad_inputs")
    f = root / "fixtures"
    f.mkdir()
    _write_fixtures(f)
    ro = _unwritable(root)
    busy = socket.socket()
    busy.bind(("127.0.0.1", 0))
    busy.listen()
    fill = {"f": str(f), "ro": str(ro), "busy": str(busy.getsockname()[1])}
    spare = root / "tmp"
    spare.mkdir()
    env = {**os.environ, "TMPDIR": str(spare), "COLUMNS": "200"}

    todo = [c for c in CASES if "{ro}" not in c[1] or ro]
    runs = []
    for name, line, _needle, _outputs in todo:
        d = root / name
        d.mkdir()
        runs.append({"argv": [a.format(d=d, **fill) for a in line.split()], "cwd": str(d)})
    # three processes, each importing the package once and running its share of the cases
    # as `python -m rths3d` would (tests/cli_cases.py): a fresh interpreter per case spent
    # ≈ 2 s of imports on each of them
    helper = Path(__file__).resolve().parent / "cli_cases.py"

    def share(i: int) -> list[dict]:
        cases, res = root / f"cases{i}.json", root / f"results{i}.json"
        cases.write_text(json.dumps(runs[i::3]))
        p = subprocess.run([sys.executable, str(helper), str(cases), str(res)],
                           capture_output=True, text=True, timeout=900, cwd=root, env=env,
                           stdin=subprocess.DEVNULL)
        assert p.returncode == 0, p.stderr[-3000:]
        return json.loads(res.read_text())

    try:
        with ThreadPoolExecutor(max_workers=3) as pool:
            parts = list(pool.map(share, range(3)))
    finally:
        busy.close()
    out = {}
    for i, part in enumerate(parts):
        for case, r in zip(todo[i::3], part, strict=True):
            out[case[0]] = (SimpleNamespace(returncode=r["code"], stderr=r["stderr"]),
                            root / case[0])
    return out, fill


def test_the_table_is_large_and_covers_every_command() -> None:
    assert len({c[0] for c in CASES}) == len(CASES) >= 60
    first = {c[1].split()[0] for c in CASES}
    assert first >= {"run", "metrics", "sweep", "train", "predict", "view", "diagnose",
                     "benchmark", "platform"}


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_bad_input_is_one_clean_line(case, results) -> None:
    """Exit code 2, one line on stderr naming the field or path, no traceback, no output
    file that looks complete."""
    name, _line, needle, outputs = case
    out, fill = results
    if name not in out:
        pytest.skip("no unwritable folder on this machine")
    p, d = out[name]
    lines = p.stderr.strip().splitlines()
    assert p.returncode == 2, (p.returncode, p.stderr[-2000:])
    assert "Traceback" not in p.stderr
    assert len(lines) == 1, p.stderr
    assert lines[0].startswith("error: "), lines[0]
    assert needle.format(d=d, **fill) in lines[0], lines[0]
    for o in outputs:
        path = Path(o.format(d=d, **fill))
        assert not path.exists() or (path.is_dir() and not any(path.iterdir())), path
