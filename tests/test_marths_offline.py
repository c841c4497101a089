"""The maRTHS engine on data the tests generate (no benchmark folder needed): a synthetic
29-DOF frame and ground motion written to a temporary benchmark folder, every relation of
the loop re-solved independently from the logged signals (tests/marths_reference.py), RoDeAC
against a plain implementation, the uncertainty model and the criteria."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.signal
from marths_reference import (
    actuator_to_frame,
    frame_to_actuator,
    rk4_outputs,
    rodeac_reference,
    specimen_force,
    trapezoid,
)

from rths3d.community.marths import (
    NOMINAL,
    MarthsConfig,
    find_delay,
    marths_criteria,
    partition,
    perturbed_plants,
    reference_signals,
    report,
    run_marths,
    specimen,
)
from rths3d.compensation import build
from rths3d.compensation.rodeac import butter_ba, fit_inverse
from rths3d.errors import ConfigError

FS = 1024.0
DT = 1.0 / FS


@pytest.fixture(scope="module")
def folder(tmp_path_factory):
    """A benchmark folder with a synthetic frame (stiff, SPD, massless rotations) and an
    8 s ground motion (a 1.5 Hz and 4 Hz burst, 0.01 s samples) under the El Centro name."""
    d = tmp_path_factory.mktemp("marths")
    (d / "data").mkdir()
    rng = np.random.default_rng(7)
    R = rng.standard_normal((29, 29))
    K = 2e8 * np.eye(29) + 2e6 * R @ R.T
    m = np.where(np.arange(29) % 3 == 0, 0.0, 2500.0)
    m[[12, 25, 26]] = [11000.0, 11000.0, 7600.0]
    np.savetxt(d / "data" / "reference_K.csv", K, delimiter=",")
    np.savetxt(d / "data" / "reference_M.csv", np.diag(m), delimiter=",")
    t = np.arange(0, 8.0001, 0.01)
    a = np.where((t > 1) & (t < 6), 2.0 * np.sin(2 * np.pi * 1.5 * t)
                 + 1.0 * np.sin(2 * np.pi * 4 * t), 0.0) * np.sin(np.pi * (t - 1) / 5) ** 2
    a[(t <= 1) | (t >= 6)] = 0.0
    np.savetxt(d / "data" / "ground_motion_ElCentro.csv", np.column_stack([t, a]),
               delimiter=",", header="t_s,accel_mps2", comments="")
    return d


@pytest.fixture(scope="module")
def run_none(folder):
    return run_marths(MarthsConfig(intensity=0.5), "none", data_path=str(folder))[0]


def test_reference_newmark_matches_the_trapezoidal_descriptor_solution(folder):
    K = np.loadtxt(folder / "data" / "reference_K.csv", delimiter=",")
    M = np.loadtxt(folder / "data" / "reference_M.csv", delimiter=",")
    part = partition(K, M)
    t = np.arange(0, 8.0, DT)
    ag = 3.0 * np.sin(2 * np.pi * 2.0 * t) * (t < 4)
    ref = reference_signals(part, ag, DT)
    U = trapezoid(part.M, part.C, part.K, part.l, ag, DT)
    want = np.column_stack([1000 * U[:, 26], -U[:, 20], U[:, 25], U[:, 21], U[:, 12], U[:, 2]])
    for c in range(6):
        assert np.max(np.abs(ref[:, c] - want[:, c])) <= 1e-6 * np.max(np.abs(want[:, c]))


def test_every_relation_of_the_loop_from_its_logs(folder, run_none):
    """Without compensation the command is the target; the measurement is the plant (another
    realisation, RK4 in the test) plus the seeded noise on both channels; x̂, θ̂ and the
    targets follow the kinematics; the force is the specimen's on the measurement; the
    numerical substructure is the trapezoidal solution under that force."""
    r = run_none
    assert r.status == "ok" and r.t.size == int(8.0 * FS) + 1
    assert np.max(np.abs(r.u - r.xa_t)) <= 1e-15 * np.max(np.abs(r.xa_t))  # mm → m → mm
    # plant: four SISO realisations side by side (16 states), from the zpk
    A, B, C = np.zeros((16, 16)), np.zeros((16, 2)), np.zeros((2, 16))
    for n, (i, j) in enumerate(((1, 1), (1, 2), (2, 1), (2, 2))):
        z, p, k = NOMINAL.entry(i, j)
        a, b, c, _ = scipy.signal.zpk2ss(z, p, k)
        sl = slice(4 * n, 4 * n + 4)
        A[sl, sl], B[sl, j - 1], C[i - 1, sl] = a.real, b[:, 0].real, c[0].real
    noise = math.sqrt(1.5e-7 * FS) * np.random.default_rng(123).standard_normal(r.t.size)
    y = rk4_outputs(A, B, C, r.u, DT) + noise[:, None]
    assert np.max(np.abs(r.xa_m - y)) <= 1e-9 * np.max(np.abs(y))
    x, th = actuator_to_frame(r.xa_m[:, 0], r.xa_m[:, 1])
    assert np.allclose(r.x_hat[:, 0], 1000 * x, rtol=0, atol=1e-12)
    assert np.allclose(r.x_hat[:, 1], th, rtol=0, atol=1e-14)
    a1, a2 = frame_to_actuator(r.num[:, 0] / 1000, r.num[:, 1])
    assert np.allclose(r.xa_t, np.column_stack([a1, a2]), rtol=0, atol=1e-12)
    sp = specimen()
    f = specimen_force(x, th, sp.K5, sp.C5, sp.M5, sp.G, DT)
    assert np.max(np.abs(r.force - f)) <= 1e-9 * np.max(np.abs(f))
    K = np.loadtxt(folder / "data" / "reference_K.csv", delimiter=",")
    M = np.loadtxt(folder / "data" / "reference_M.csv", delimiter=",")
    part = partition(K, M)
    F = np.zeros((r.t.size, 29))
    F[:, 26], F[:, 20], F[:, 28] = r.force[:, 0], -r.force[:, 1], -r.force[:, 2]
    U = trapezoid(part.MN, part.CN, part.KN, part.l, r.ag, DT, F)
    want = np.column_stack([1000 * U[:, 26], -U[:, 20], U[:, 25], U[:, 21], U[:, 12], U[:, 2]])
    for c in range(6):
        assert np.max(np.abs(r.num[:, c] - want[:, c])) <= 1e-6 * np.max(np.abs(want[:, c]))


def test_criteria_from_the_logged_signals(run_none):
    r = run_none
    j = r.j
    assert j["J4"] == j["J1"]  # the code's copy
    for i in range(2):
        e = r.xa_m[:, i] - r.xa_t[:, i]
        assert j["J2"][i] == pytest.approx(100 * np.std(e, ddof=1) / np.std(r.xa_t[:, i], ddof=1))
        assert j["J3"][i] == pytest.approx(100 * np.abs(e).max() / np.abs(r.xa_t[:, i]).max())
        e = r.x_hat[:, i] - r.ref[:, i]
        assert j["J9"][i] == pytest.approx(100 * np.abs(e).max() / np.abs(r.ref[:, i]).max())
    for i in range(4):
        e = r.num[:, 2 + i] - r.ref[:, 2 + i]
        assert j["J8"][i] == pytest.approx(100 * np.std(e, ddof=1)
                                           / np.std(r.ref[:, 2 + i], ddof=1))
    # the plant lags (tens of ms at 1–4 Hz): J1 by a direct correlation over ±100 lags
    for i in range(2):
        a, b = r.xa_t[:, i], r.xa_m[:, i]
        c = [abs(np.dot(a[max(0, -L):a.size - max(0, L)], b[max(0, L):b.size - max(0, -L)]))
             for L in range(-100, 101)]
        assert j["J1"][i] == pytest.approx(1000 * (int(np.argmax(c)) - 100) / FS)
        assert j["J1"][i] > 5.0  # ms: uncompensated


def test_find_delay_signs_and_ties():
    t = np.arange(2000) * DT
    x = np.sin(2 * np.pi * 3 * t) * np.hanning(t.size)
    for d in (-12, 0, 1, 37):
        assert find_delay(x, np.roll(x, d)) == d
    # ties: |c| equal at −3 and +3 → +3; at +2 and +5 → +2 (the smallest |lag|)
    y = np.zeros(50)
    y[20] = 1.0
    x = np.zeros(50)
    x[17] = x[23] = 1.0
    assert find_delay(x, y) == 3
    x = np.zeros(50)
    x[18] = x[15] = 1.0
    assert find_delay(x, y) == 2
    assert find_delay(np.ones(8), np.zeros(8)) == 0


def test_report_rounds_half_away_from_zero_and_averages():
    keys = {"J1": 2, "J2": 2, "J3": 2, "J4": 2, "J5": 2, "J6": 2, "J7": 2, "J8": 4, "J9": 2,
            "J10": 4}
    a = {k: [0.25] * n for k, n in keys.items()}
    b = {k: [-0.75] * n for k, n in keys.items()}
    assert report([a])["J2"] == [0.3, 0.3]
    assert report([b])["J10"] == [-0.8] * 4
    assert report([a, b])["J5"] == [-0.3, -0.3]  # mean −0.25 → −0.3


def _lag_plant(noise):
    """x_{k+1} = 0.92 x_k + 0.07 u_{k−2} (DC gain 0.875, ≈ 14 ms) plus noise, in m."""
    def plant(k, u):
        x = 0.0
        for i in range(k - 2):
            x = 0.92 * x + 0.07 * u[i]
        return x + noise[k]
    return plant


def test_rodeac_matches_a_plain_implementation_and_p0_zero_freezes_theta():
    """Closed loop with a lagging plant written here: the compiled RoDeAC (exact algebraic
    loop) equals a plain implementation iterating the loop to convergence; the one-pass
    variant does not; P₀ = 0 leaves the fixed FIR θ₀."""
    n = 1200
    t = np.arange(n) * DT
    z = (2e-3 * np.sin(2 * np.pi * 1.3 * t) + 1e-3 * np.sin(2 * np.pi * 4.1 * t)) \
        * np.minimum(1.0, t / 0.3)
    noise = 1e-5 * np.random.default_rng(1).standard_normal(n)
    th0 = [5.4, 2.0, -1.5, -5.0]
    P0 = (np.diag([8e4, 1e5, 1e5, 8e4]) - 2e4 * (np.ones((4, 4)) - np.eye(4))).ravel()
    b, a = butter_ba(4, 20.0, DT)
    plant = _lag_plant(noise)
    want = rodeac_reference(z, plant, th0, P0, b, a)

    def closed_loop(params):
        comp = build("rodeac", 1, 1, DT, params)
        u = np.zeros(n)
        for k in range(n):
            zm = np.array([[plant(k, u[:k])]])
            u[k] = comp.command(z[k:k + 1, None], z[k:k + 1, None], zm)[0, 0]
        return u, comp

    got, comp = closed_loop({"theta0": th0, "p0": list(P0)})
    assert not comp.stopped[0], comp.reasons[0]
    assert np.max(np.abs(got - want)) <= 1e-9 * np.max(np.abs(want))
    assert np.max(np.abs(comp.theta[0, 0] - th0)) > 1e-2  # it adapted
    one_pass, _ = closed_loop({"theta0": th0, "p0": list(P0), "algebraic_loop": False})
    assert np.max(np.abs(one_pass - want)) > 1e-7 * np.max(np.abs(want))
    fixed, _ = closed_loop({"theta0": th0, "p0": [0.0]})
    fir = scipy.signal.lfilter(th0, [1.0], z)
    assert np.max(np.abs(fixed - fir)) <= 1e-12 * np.max(np.abs(fir))


def test_rodeac_calibration_is_batch_least_squares():
    rng = np.random.default_rng(3)
    x = rng.standard_normal(4000)
    theta = np.array([3.0, -1.0, 0.5, -1.4])
    z = scipy.signal.lfilter(theta, [1.0], x)
    th, P = fit_inverse(z, x)
    assert np.allclose(th, theta, atol=1e-10)
    G = np.column_stack([np.concatenate([np.zeros(i), x[:x.size - i]])[3:] for i in range(4)])
    assert np.allclose(P, np.linalg.inv(G.T @ G), rtol=1e-10)


def test_uncertainty_model_is_seeded_and_keeps_the_low_frequency_gains():
    a, b = perturbed_plants(3, seed=5), perturbed_plants(3, seed=5)
    assert a == b and a[0] != a[1]
    n = np.random.default_rng(5).standard_normal(9)
    p = a[0]
    assert p.z1[0] == pytest.approx(NOMINAL.z1[0] * (1 + 0.055 * n[0]))
    assert p.p1[1] == pytest.approx(NOMINAL.p1[1] * (1 + 0.06 * n[3]))
    assert p.frame == pytest.approx(NOMINAL.frame * (1 + 0.05 * n[4]))
    assert p.z22 == pytest.approx(NOMINAL.z22 * (1 + 0.03 * n[8]))
    H0n, H0p = NOMINAL.dc_gain(), p.dc_gain()
    for i, j in ((1, 0), (0, 1), (1, 1)):
        assert abs(H0p[i, j]) == pytest.approx(abs(H0n[i, j]), rel=1e-12)
    w = np.array([2 * np.pi * 0.01])
    assert abs(p.freqresp(w)[0, 0, 0]) == pytest.approx(abs(NOMINAL.freqresp(w)[0, 0, 0]),
                                                        rel=1e-12)


def test_a_diverging_trial_stops_safely_and_the_others_go_on(folder):
    """Two plants, RoDeAC with a 40× inverse gain and no adaptation on one of two
    per-actuator setups: the gain bound stops it after bound_time, with the reason."""
    good = {"theta0": [1.0, 0.0, 0.0, 0.0], "p0": [0.0]}
    bad = {"theta0": [40.0, 0.0, 0.0, 0.0], "p0": [0.0]}
    rs = run_marths(MarthsConfig(intensity=0.5), "rodeac", (bad, good),
                    plants=[NOMINAL, perturbed_plants(1)[0]], data_path=str(folder))
    for r in rs:
        assert r.status == "stopped"
        assert "actuator 1: rodeac inverse DC gain" in r.reason
        assert "exceeds the limit 20" in r.reason
        assert r.t[-1] == pytest.approx(0.25, abs=2 * DT)
        assert not r.j
    rs = run_marths(MarthsConfig(intensity=0.5, stroke_limit=0.04), "none",
                    data_path=str(folder))  # mm; the run reaches 0.07 mm
    assert rs[0].status == "stopped" and "measured actuator displacement" in rs[0].reason
    assert np.abs(rs[0].xa_m[-1]).max() > 0.04 >= np.abs(rs[0].xa_m[:-1]).max()


def test_bad_configuration_names_the_field():
    with pytest.raises(ConfigError, match="intensity"):
        MarthsConfig(intensity=-1)
    with pytest.raises(ConfigError, match="record"):
        MarthsConfig(record="Northridge")
    with pytest.raises(ConfigError, match="rodeac.p0"):
        build("rodeac", 1, 2, DT, {"p0": [1.0, 2.0]})
    assert marths_criteria  # the public name exists (used by the CLI)


def test_per_actuator_compensation_allocates_nothing_per_step(peak_bytes):
    from rths3d.community.marths.engine import _Comps

    K = 3
    conf = {"theta0": [1.0, 0.0, 0.0, 0.0], "p0": [1e4]}
    comps = _Comps("rodeac", (conf, conf), K, DT, "stored", None)
    z, zd, zm = (1e-3 * np.random.default_rng(i).standard_normal((K, 2)) for i in range(3))
    comps.bind(z, zd, zm)
    u = comps.command()
    assert u.shape == (K, 2) and np.all(np.isfinite(u))
    assert peak_bytes(lambda: (comps.command(), comps.stopped()), 50) < 4096


def test_example_refuses_bad_arguments_in_one_line():
    import subprocess
    import sys
    from pathlib import Path

    script = Path(__file__).resolve().parents[1] / "examples" / "74_marths_compare.py"
    out = subprocess.run([sys.executable, str(script), "--trials", "-1"], capture_output=True,
                         text=True, timeout=300)
    err = out.stderr.strip().splitlines()
    assert out.returncode == 2 and len(err) == 1 and err[0].startswith("error: --trials")
