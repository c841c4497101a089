"""The maRTHS benchmark against its specification and data (shared/external/marths-benchmark:
SPEC.md and data/, read here for validation only): matrices, specimen, plant, the Newmark
solutions against an independent linear solution, the stored RoDeAC θ₀/P₀ from the offline
calibration, the quirks, the perturbed trials and the command line."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from marths_reference import rk4_outputs, specimen_force, trapezoid

from rths3d.community.marths import (
    COUPLER,
    NOMINAL,
    MarthsConfig,
    perturbed_plants,
    reference_signals,
    report,
    run_marths,
    specimen,
    structure,
)
from rths3d.compensation.rodeac import butter_ba

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("RTHS3D_SHARED") or REPO.parent / "shared")
SKIP = ("needs the maRTHS benchmark's specification and data beside the clone "
        "(../shared/external/marths-benchmark); the engine itself is tested on generated "
        "data in tests/test_marths_offline.py")


@pytest.fixture(scope="module")
def bench_dir() -> Path:
    p = SHARED / "external" / "marths-benchmark"
    if not (p / "data" / "reference_K.csv").is_file():
        pytest.skip(SKIP)
    return p


def _json(bench_dir, name):
    return json.loads((bench_dir / "data" / name).read_text())


def _csv(bench_dir, name):
    return np.loadtxt(bench_dir / "data" / name, delimiter=",")


@pytest.fixture(scope="module")
def nominal(bench_dir):
    """RoDeAC with the benchmark's stored θ₀, P₀; nominal plant; El Centro × 0.4."""
    return run_marths(MarthsConfig(), "rodeac", data_path=str(bench_dir))[0]


def test_matrices_specimen_and_plant_match_the_exported_data(bench_dir):
    part = structure(str(bench_dir))
    for name, m in (("reference_C", part.C), ("numerical_K", part.KN),
                    ("numerical_M", part.MN), ("numerical_C", part.CN)):
        want = _csv(bench_dir, f"{name}.csv")
        assert np.max(np.abs(m - want)) <= 1e-12 * np.max(np.abs(want)), name
    assert part.MN[26, 26] == pytest.approx(6778.37553528592, rel=1e-12)  # ρ = 785e3 quirk
    pf = _json(bench_dir, "partitioning.json")["physical_ideal_3dof"]
    assert pf["KP"][1][2] < 0  # the −2EI_b/L_b sign the code subtracts
    sp, d5 = specimen(), _json(bench_dir, "physical_feedback_5dof.json")
    for key in ("K5", "M5", "C5"):
        want = np.array(d5[key])
        assert np.max(np.abs(getattr(sp, key) - want)) <= 1e-9 * np.max(np.abs(want)), key
    assert np.allclose(sp.omega, [357.18, 927.13, 1102.67, 1629.83, 2061.44], rtol=0,
                       atol=1e-9)
    G = -np.linalg.solve(np.array(d5["K5"])[2:, 2:], np.array(d5["K5"])[2:, :2])
    assert np.allclose(sp.G, G, rtol=1e-12)
    kin = _json(bench_dir, "benchmark_settings.json")["kinematics_coupler"]
    assert np.allclose(COUPLER.params(), [kin["dv1_m"], kin["dv2_m"], kin["alpha1_rad"],
                                          kin["alpha2_rad"]], rtol=1e-14)
    pl = _json(bench_dir, "plant.json")
    assert np.allclose(NOMINAL.dc_gain(), pl["dc_gain_matrix"], rtol=1e-9)
    ssd = pl["ss_nominal_plantFRAME_SS"]
    A, B, C = (np.array(ssd[k]) for k in "ABC")
    for key, fr in pl["frequency_response"].items():
        i, j = int(key[1]) - 1, int(key[2]) - 1
        w = 2 * np.pi * np.array(fr["freq_Hz"])
        H = NOMINAL.freqresp(w)[:, i, j]
        assert np.allclose(np.abs(H), fr["mag"], rtol=0, atol=6e-7)  # 6 decimals
        assert np.allclose(np.degrees(np.angle(H)), fr["phase_deg"], atol=2e-3)
        Hs = np.array([(C @ np.linalg.solve(1j * wk * np.eye(8) - A, B))[i, j] for wk in w])
        assert np.allclose(H, Hs, rtol=1e-9)
    ctl = _json(bench_dir, "controller_rodeac.json")["noise_filter"]
    b, a = butter_ba(4, 20.0, 1 / 1024)
    assert np.allclose(b, ctl["b"], rtol=1e-12) and np.allclose(a, ctl["a"], rtol=1e-12)


def test_newmark_solutions_match_the_trapezoidal_descriptor_solution(bench_dir, nominal):
    """Reference (no feedback) and numerical substructure (under the run's logged specimen
    force) against the trapezoidal rule on E ż = A z + b, solved with scipy: ≤ 1e-6 of peak."""
    part = structure(str(bench_dir))
    dt = 1 / 1024

    def logged(U):
        return np.column_stack([1000 * U[:, 26], -U[:, 20], U[:, 25], U[:, 21], U[:, 12],
                                U[:, 2]])

    ref = logged(trapezoid(part.M, part.C, part.K, part.l, nominal.ag, dt))
    F = np.zeros((nominal.t.size, 29))
    F[:, 26], F[:, 20], F[:, 28] = (nominal.force[:, 0], -nominal.force[:, 1],
                                    -nominal.force[:, 2])
    num = logged(trapezoid(part.MN, part.CN, part.KN, part.l, nominal.ag, dt, F))
    for c in range(6):
        assert np.max(np.abs(nominal.ref[:, c] - ref[:, c])) <= 1e-6 * np.abs(ref[:, c]).max()
        assert np.max(np.abs(nominal.num[:, c] - num[:, c])) <= 1e-6 * np.abs(num[:, c]).max()
    assert np.array_equal(reference_signals(part, nominal.ag, dt), nominal.ref)


def test_nominal_run_follows_the_stored_plant_noise_and_specimen(bench_dir, nominal):
    """The measured displacements are the stored 8-state realisation stepped by RK4 from the
    logged commands plus one noise sequence (seed 123, std √(1.5e-7·1024) mm) shared by both
    channels; the force is the 5-DOF specimen of the data file on the measured x̂, θ̂."""
    r = nominal
    ssd = _json(bench_dir, "plant.json")["ss_nominal_plantFRAME_SS"]
    A, B, C = (np.array(ssd[k]) for k in "ABC")
    y = rk4_outputs(A, B, C, r.u, 1 / 1024)
    n = r.xa_m - y
    assert np.max(np.abs(n[:, 0] - n[:, 1])) <= 1e-9 * np.abs(y).max()  # identical noise
    assert np.std(n[:, 0]) == pytest.approx(math.sqrt(1.5e-7 * 1024), rel=0.02)
    want = math.sqrt(1.5e-7 * 1024) * np.random.default_rng(123).standard_normal(r.t.size)
    assert np.max(np.abs(n[:, 0] - want)) <= 1e-9 * np.abs(y).max()
    d5 = _json(bench_dir, "physical_feedback_5dof.json")
    K5, M5, C5 = (np.array(d5[k]) for k in ("K5", "M5", "C5"))
    G = -np.linalg.solve(K5[2:, 2:], K5[2:, :2])
    f = specimen_force(r.x_hat[:, 0] / 1000, r.x_hat[:, 1], K5, C5, M5, G, 1 / 1024)
    assert np.max(np.abs(r.force - f)) <= 1e-7 * np.abs(f).max()
    # θ̂ from the measurement is free of the (shared) noise: it follows the noise-free y
    kin = _json(bench_dir, "benchmark_settings.json")["kinematics_coupler"]
    s = (y[:, 0] - y[:, 1]) / 1000 / (2 * kin["dv2_m"] * math.sin(kin["alpha2_rad"]))
    assert np.max(np.abs(r.x_hat[:, 1] - np.arcsin(s))) <= 1e-9 * np.abs(r.x_hat[:, 1]).max()


def test_rodeac_nominal_elcentro_reports_24_numbers_and_the_quirks(nominal):
    j = report([nominal.j])
    assert sum(len(v) for v in j.values()) == 24
    assert j["J4"] == j["J1"]
    assert nominal.status == "ok"
    # RoDeAC tracks: a few % of the targets' spread, no sample of delay
    assert max(j["J2"]) < 5.0 and max(abs(v) for v in j["J1"]) <= 1.0
    none = run_marths(MarthsConfig(), "none")[0]
    jn = report([none.j])
    assert min(jn["J2"]) > 5 * max(j["J2"]) and min(jn["J1"]) > 10.0
    # realizability logging: the volts stay within ±3.8 V for both
    assert np.abs(nominal.command_volts).max() < 3.8


def test_offline_calibration_reproduces_the_stored_theta0_and_p0(bench_dir):
    """99 open-loop runs (3 records × {0.2, 0.4, 0.6} × [nominal + 10 perturbed plants]):
    the means are within 1 % of the stored θ₀ (each element) and P₀; the package's
    rodeac_initial.json is this calibration."""
    from rths3d.community.marths import offline_calibration, rodeac_initial

    cal = offline_calibration(data_path=str(bench_dir))
    assert len(cal.runs) == 99
    ctl = _json(bench_dir, "controller_rodeac.json")
    for j, act in enumerate(("act1", "act2")):
        th, P = np.array(ctl[f"theta0_{act}"]), np.array(ctl[f"P0_{act}"])
        assert np.all(np.abs(cal.theta_mean[j] - th) <= 0.01 * np.abs(th)), act
        # P₀ as a matrix (Frobenius norm) and its diagonal element-wise; the off-diagonal
        # entries, set by the noise's share of ΓᵀΓ, differ by up to 1.2 % (docs/marths.md)
        assert np.linalg.norm(cal.P_mean[j] - P) <= 0.01 * np.linalg.norm(P), act
        assert np.all(np.abs(np.diag(cal.P_mean[j]) - np.diag(P)) <= 0.01 * np.diag(P)), act
    th0, p0 = rodeac_initial()
    assert np.allclose(th0, cal.theta_mean.ravel(), rtol=1e-9)
    assert np.allclose(p0, cal.P_mean.reshape(2, -1).ravel(), rtol=1e-9)


def test_twenty_perturbed_plants_all_complete_with_rodeac(bench_dir):
    rs = run_marths(MarthsConfig(), "rodeac", plants=perturbed_plants(20, seed=123))
    assert len(rs) == 20 and all(r.status == "ok" for r in rs)
    j = report([r.j for r in rs])
    assert max(j["J2"]) < 5.0


def _cli(*args: str) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    return subprocess.run([sys.executable, "-m", "rths3d", "benchmark", "marths", *args],
                          capture_output=True, text=True, env=env, timeout=600)


def test_cli_json_table_plot_and_bad_input(bench_dir, tmp_path):
    p = _cli("--t-end", "12", "--json", "--plot", str(tmp_path / "m.png"))
    assert p.returncode == 0, p.stderr
    out = json.loads(p.stdout)
    e = out["records"]["ElCentro"]["rodeac"]
    assert e["status"] == "ok" and sum(len(v) for v in e["J"].values()) == 24
    assert e["J"]["J4"] == e["J"]["J1"] and out["initial"] == "stored"
    assert (tmp_path / "m.png").stat().st_size > 10_000
    p = _cli("--t-end", "6", "--compensator", "none", "--trials", "1")
    assert p.returncode == 0, p.stderr
    assert "J2.act1" in p.stdout and "none μ1/1" in p.stdout
    for args, field in ((("--intensity", "-1"), "intensity"),
                        (("--record", "Loma"), "record"),
                        (("--compensator", "magic"), "compensator"),
                        (("--trials", "-2"), "trials")):
        p = _cli(*args)
        assert p.returncode == 2, (args, p.stderr)
        lines = p.stderr.strip().splitlines()
        assert len(lines) == 1 and field in lines[0] and "Traceback" not in p.stderr
