"""The RTHS benchmark engine without the benchmark's data (a clone on its own).

The published records may not be copied into the project, so the tests that compare with
Table 3 need `../shared/external/rths-benchmark` and skip without it (tests/test_rthsbench.py).
Everything the engine does is checked here on a ground motion generated in this file: a
Kanai–Tajimi filtered white noise (ω_g = 15.6 rad/s, ζ_g = 0.6, the classic firm-soil values)
under a trapezoid-exponential envelope, written in the benchmark's CSV format and read through
the same loader and data-folder lookup as the real records.
"""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
from scipy import signal

from rths3d.community import (
    BenchmarkConfig,
    ControllerParams,
    PlantParams,
    case_matrices,
    run_case,
    run_trials,
)
from rths3d.community.stability import spectral_radius
from rths3d.errors import SafetyStop
from rths3d.lti import RK4Stepper, load_ground_motion

J = [f"J{i}" for i in range(1, 10)]
DT_RECORD = 0.02  # s, as the benchmark's records
PGA = 3.13  # m/s², unscaled (the intensity 0.4 applies on top, as for the real records)


def synthetic_accelerogram(duration: float = 16.0, seed: int = 11) -> tuple[np.ndarray,
                                                                             np.ndarray]:
    """Time (s) and ground acceleration (m/s²): Kanai–Tajimi-filtered white noise, enveloped
    (rise 0–2 s, strong 2–7 s, exponential decay), scaled to PGA."""
    t = np.arange(0.0, duration + 1e-9, DT_RECORD)
    w = np.random.default_rng(seed).standard_normal(t.size)
    wg, zg = 15.6, 0.6
    kt = signal.lti([2 * zg * wg, wg ** 2], [1.0, 2 * zg * wg, wg ** 2])
    _, a, _ = signal.lsim(kt, w, t)
    env = np.where(t < 2.0, (t / 2.0) ** 2, np.where(t < 7.0, 1.0, np.exp(-0.35 * (t - 7.0))))
    a = a * env
    return t, PGA * a / np.max(np.abs(a))


@pytest.fixture(scope="module")
def bench_dir(tmp_path_factory):
    """A benchmark folder holding the synthetic record as data/ground_motion_ElCentro.csv."""
    root = tmp_path_factory.mktemp("bench")
    (root / "data").mkdir()
    t, a = synthetic_accelerogram()
    lines = ["t_s,accel_mps2"] + [f"{x:.4f},{y:.9g}" for x, y in zip(t, a, strict=True)]
    (root / "data" / "ground_motion_ElCentro.csv").write_text("\n".join(lines) + "\n")
    return root


@pytest.fixture(scope="module")
def gm(bench_dir):
    return load_ground_motion(bench_dir / "data" / "ground_motion_ElCentro.csv")


@pytest.fixture(scope="module")
def nominal(gm):
    return {c: run_case(BenchmarkConfig(case=c), gm=gm) for c in (1, 4)}


def test_the_loader_reads_the_generated_record(gm) -> None:
    """The record's samples, PGA and length come back as written."""
    t, a = synthetic_accelerogram()
    assert gm.t.size == t.size and gm.t_end == pytest.approx(t[-1])
    assert gm.pga == pytest.approx(PGA, rel=1e-6)


def test_nominal_cases_complete_with_the_loop_delay(nominal) -> None:
    """The nominal loop completes every case; J1, the tracking delay, is a property of the
    actuator and its controller (4.6 ms on the published record): near it for any broadband
    ground motion (4.6 ms here too). J2–J9 are finite and positive."""
    for c, res in nominal.items():
        assert res.status == "ok", res.reason
        row = res.table_row()
        assert abs(row["J1"] - 4.6) <= 0.2, (c, row["J1"])
        assert all(np.isfinite(row[k]) and row[k] > 0 for k in J[1:]), row


def test_reference_response_converges_to_a_finer_integration(nominal) -> None:
    """The FOH reference equals an 8-substep RK4 integration of the reference structure."""
    from rths3d.community.simulate import reference_system

    res = nominal[1]
    n = 4096 * 8
    m = case_matrices(1, 29.13, PlantParams().c_e, 1.19e6)
    st = RK4Stepper(reference_system(m), res.config.dt, substeps=8, input="linear")
    ag = res.ag[:n]
    y = np.zeros((n, 3))
    for k in range(n - 1):
        y[k + 1] = st.step(ag[k:k + 1, None], ag[k + 1:k + 2, None])[0]
    np.testing.assert_allclose(y, res.x_ref[:n], atol=1e-9 * np.max(np.abs(y)) + 1e-15)


def test_batched_engine_equals_generated_loop(gm) -> None:
    """The numpy engine (trials stepped together) reproduces the generated single-test loop."""
    cfg = BenchmarkConfig(case=2, t_end=2.0)
    plants = [PlantParams(), PlantParams().perturbed(np.random.default_rng(3))]
    a = run_trials(cfg, plants=plants, gm=gm, engine="python")
    b = run_trials(cfg, plants=plants, gm=gm, engine="numpy")
    for ra, rb in zip(a, b, strict=True):
        np.testing.assert_allclose(rb.x_m, ra.x_m, atol=1e-15)
        np.testing.assert_allclose(rb.x_num, ra.x_num, atol=1e-15)
        np.testing.assert_allclose(rb.f_act, ra.f_act, rtol=1e-12, atol=1e-9)


def test_strong_motion_stops_safely_at_the_force_limit(gm) -> None:
    """Five times the intensity drives the actuator past 8900 N: the run stops at that sample
    with the reason, keeps every sample before it (all below the limit) and its reference;
    raise_on_stop raises the SafetyStop instead."""
    cfg = BenchmarkConfig(case=3, intensity=2.0)
    res = run_case(cfg, gm=gm)
    assert res.status == "stopped"
    assert "8900" in res.reason and "actuator force" in res.reason
    assert abs(res.f_act[-1]) >= 8900 and np.all(np.abs(res.f_act[:-1]) < 8900)
    assert res.x_ref.shape == (res.t.size, 3)
    with pytest.raises(SafetyStop, match="actuator force"):
        run_case(cfg, gm=gm, raise_on_stop=True)
    free = run_case(replace(cfg, force_limit=1e9), gm=gm)
    assert free.status == "ok" and free.peak_force > 8900


def test_unstable_controller_is_stopped(gm) -> None:
    """A PI gain of 40 makes the loop unstable (spectral radius > 1); the run stops."""
    cfg = BenchmarkConfig(case=1, controller=ControllerParams(kp=40.0), t_end=3.0)
    assert spectral_radius(cfg) > 1.0
    res = run_case(cfg, gm=gm)
    assert res.status == "stopped" and res.t[-1] < 3.0


def test_record_roundtrip_and_metrics_layer(nominal, tmp_path) -> None:
    """A run becomes an rths3d Record (saved and read back) whose measures give the same
    J1–J9 as the benchmark's own evaluation."""
    from rths3d.metrics import compute_measures
    from rths3d.record import Record

    res = nominal[4]
    path = res.to_record().save(tmp_path / "case4.parquet")
    rec = Record.load(path)
    np.testing.assert_array_equal(rec.signal("z_meas")[:, 0], res.x_m)
    m = compute_measures(rec)
    for k, v in res.j.items():
        assert m[k] == pytest.approx(v, abs=1e-12), k


def test_cli_reads_the_data_folder(bench_dir, tmp_path, capsys, monkeypatch) -> None:
    """`rths3d benchmark rths --data DIR` (and RTHS3D_BENCHMARK_DIR) runs on the folder's
    record: J1–J9 in Table-3 units, the plot written; a folder without data/ is one error."""
    from rths3d.cli import main

    png = tmp_path / "case1.png"
    with pytest.raises(SystemExit) as ex:
        main(["benchmark", "rths", "--case", "1", "--json", "--data", str(bench_dir),
              "--plot", str(png), "--set", "benchmark.t_end=6.0"])
    assert ex.value.code == 0
    out = json.loads(capsys.readouterr().out)
    row = out["cases"]["1"]
    assert row["status"] == "ok" and abs(row["J1"] - 4.6) <= 0.2
    assert png.stat().st_size > 10_000 and out["plot"] == str(png)
    monkeypatch.setenv("RTHS3D_BENCHMARK_DIR", str(bench_dir))
    with pytest.raises(SystemExit) as ex:
        main(["benchmark", "rths", "--case", "2", "--json", "--set", "benchmark.t_end=3.0"])
    assert ex.value.code == 0 and json.loads(capsys.readouterr().out)["cases"]["2"]["J1"] > 0
    with pytest.raises(SystemExit) as ex:
        main(["benchmark", "rths", "--case", "1", "--data", str(tmp_path)])
    err = capsys.readouterr().err.strip().splitlines()
    assert ex.value.code == 2 and len(err) == 1 and err[0].startswith("error: data:")
