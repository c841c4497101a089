"""Numerical substructures: integrators against analytic / scipy solutions, eigen-analysis."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.signal

from rths3d.errors import ConfigError
from rths3d.numerical import (
    LinearSubstructure,
    coupled_fastest_eigenfrequency,
    fastest_eigenfrequency,
    load_history,
)
from rths3d.scene import ExcitationConfig


def _simulate(sub, N, f=None):
    z = [sub.z[:, 0].copy()]
    for n in range(N):
        sub.step(n, np.zeros((sub.K_tests, sub.n_if)) if f is None else f)
        z.append(sub.z[:, 0].copy())
    return np.array(z)


def _two_dof():
    M = np.diag([4.0, 1.0])
    K = np.array([[3000.0, -1000.0], [-1000.0, 1000.0]])
    C = 0.002 * K + 0.1 * M
    return M, C, K


def test_exact_matches_scipy_lsim_mdof():
    """Exact discretisation of a 2-DOF system equals scipy's lsim (first-order hold) to 1e-12."""
    M, C, K = _two_dof()
    dt, N = 1e-3, 3000
    t = np.arange(N + 1) * dt
    p = np.column_stack([10 * np.sin(2 * np.pi * 1.3 * t), 5 * np.cos(2 * np.pi * 0.7 * t)])
    sub = LinearSubstructure(M, C, K, np.array([[0.0], [1.0]]), p, dt)
    z = _simulate(sub, N)[:, 0]
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-Minv @ K, -Minv @ C]])
    B = np.vstack([np.zeros((2, 2)), Minv])
    _, y, _ = scipy.signal.lsim((A, B, np.array([[0, 1.0, 0, 0]]), np.zeros((1, 2))), p, t)
    assert np.max(np.abs(z - y)) < 1e-12 * max(1.0, np.max(np.abs(y))) + 1e-14


def test_central_difference_second_order():
    """Central difference converges to the exact free vibration at order 2 in ΔT."""
    m, k = 2.0, 800.0
    w = math.sqrt(k / m)
    errs = []
    for dt in (2e-3, 1e-3, 5e-4):
        N = int(round(1.0 / dt))
        t = np.arange(N + 1) * dt
        p = np.full((N + 1, 1), 10.0)  # step load from rest: x = F/k (1 − cos ωt)
        sub = LinearSubstructure([[m]], [[0.0]], [[k]], [[1.0]], p, dt, "central_difference")
        z = _simulate(sub, N)[:, 0]
        exact = 10.0 / k * (1 - np.cos(w * t))
        errs.append(np.max(np.abs(z - exact)))
    orders = np.log2(np.array(errs[:-1]) / np.array(errs[1:]))
    assert np.all(orders > 1.8), orders


def test_central_difference_stability_limit():
    """Central difference beyond ω_max ΔT = 2 is refused with a ConfigError naming the limit."""
    with pytest.raises(ConfigError, match="< 2"):
        LinearSubstructure([[1.0]], [[0.0]], [[1e7]], [[1.0]], np.zeros((11, 1)), 1e-3,
                           "central_difference")


def test_batched_tests_equal_single_runs():
    """K tests with different parameters stepped together equal the same tests run alone."""
    dt, N = 1e-3, 500
    t = np.arange(N + 1) * dt
    p = np.sin(2 * np.pi * 2 * t)[:, None]
    ks = [500.0, 5e3, 5e4]
    M = np.array([[[9.62]]] * 3)
    C = np.array([[[100.0]]] * 3)
    K = np.array([[[k]] for k in ks])
    batch = _simulate(LinearSubstructure(M, C, K, [[1.0]], p, dt), N)
    for i, k in enumerate(ks):
        single = _simulate(LinearSubstructure([[9.62]], [[100.0]], [[k]], [[1.0]], p, dt), N)
        np.testing.assert_allclose(batch[:, i], single[:, 0], rtol=0, atol=1e-15)


def test_interface_force_enters_with_minus_gamma():
    """A constant interface force F'_m gives the static displacement −F/k (sign convention)."""
    dt, N = 1e-3, 20000
    sub = LinearSubstructure([[1.0]], [[60.0]], [[900.0]], [[1.0]], np.zeros((N + 1, 1)), dt)
    z = _simulate(sub, N, np.array([[9.0]]))
    assert z[-1, 0] == pytest.approx(-9.0 / 900.0, rel=1e-9)


def test_eigenfrequencies_sdof_and_eq12():
    """SDOF ω = √(k/m); coupled ω_DYN = √((k_N + k_E)/(m_N + m_E)) (paper eq. 12)."""
    assert fastest_eigenfrequency([[9.62]], [[1e4]]) == pytest.approx(math.sqrt(1e4 / 9.62))
    w = coupled_fastest_eigenfrequency([[9.62]], [[1e4]], [[1.0]], [[0.38]], [[8650.0]])
    assert w == pytest.approx(math.sqrt((1e4 + 8650) / (9.62 + 0.38)), rel=1e-12)


def test_mdof_fastest_eigenfrequency_two_dof_chain():
    """2-DOF chain: the fastest eigenfrequency matches the closed-form root."""
    M, _, K = _two_dof()
    a, b, c = 4.0, -(3000.0 * 1.0 + 1000.0 * 4.0), 3000.0 * 1000.0 - 1000.0**2
    w2 = (-b + math.sqrt(b * b - 4 * a * c)) / (2 * a)
    assert fastest_eigenfrequency(M, K) == pytest.approx(math.sqrt(w2), rel=1e-12)


def test_support_motion_load_is_k_u_plus_c_udot():
    """Support motion (paper z_d): p = k z_d + c ż_d with z_d = peak/2 (1 − cos 2π f t)."""
    exc = ExcitationConfig(kind="support", signal="raised_cosine", frequency=0.5,
                           overtravel=0.005)
    t = np.linspace(0, 2, 201)
    p = load_history(exc, [[9.62]], [[100.0]], [[1e4]], t, h0=0.005)[:, 0]
    zd = 0.01 / 2 * (1 - np.cos(np.pi * t))
    zdd = 0.01 / 2 * np.pi * np.sin(np.pi * t)
    np.testing.assert_allclose(p, 1e4 * zd + 100.0 * zdd, atol=1e-12)


def test_ground_acceleration_from_csv(tmp_path):
    """Ground acceleration from a CSV record: p = −M·1·ü_g, linearly interpolated."""
    f = tmp_path / "ag.csv"
    f.write_text("t,value\n0,0\n1,2.0\n2,0\n")
    exc = ExcitationConfig(kind="ground", signal="file", file=str(f), column="value")
    p = load_history(exc, np.diag([2.0, 3.0]), np.zeros((2, 2)), np.eye(2), np.array([0.5, 1.5]))
    np.testing.assert_allclose(p, [[-2.0, -3.0], [-2.0, -3.0]])


def test_plugged_in_nonlinear_substructure_runs_in_loop_and_reference():
    """A plugged-in Duffing substructure with k₃ = 0 reproduces the linear loop and its
    reference; a stiffening k₃ > 0 lowers the peak interface displacement."""
    from pathlib import Path

    from rths3d.loop import run
    from rths3d.numerical import CubicSpringSubstructure
    from rths3d.scene import load_scene

    sc = load_scene(Path(__file__).resolve().parents[1] / "scenes" / "paper_linear.toml",
                    ["duration=2.0"])
    lin = run(sc, "ideal").record
    nl0 = run(sc, "ideal", numerical=lambda s: CubicSpringSubstructure.from_scenes(s, 0.0))
    z0 = nl0.record.columns["z_cmd.z"]
    zl = lin.columns["z_cmd.z"]
    assert np.max(np.abs(z0 - zl)) < 1e-5 * np.max(np.abs(zl))
    assert np.max(np.abs(nl0.record.columns["z_ref.z"] - lin.columns["z_ref.z"])) \
        < 1e-5 * np.max(np.abs(zl))
    stiff = run(sc, "ideal", reference=False,
                numerical=lambda s: CubicSpringSubstructure.from_scenes(s, 1e9))
    assert np.max(np.abs(stiff.record.columns["z_cmd.z"])) < 0.9 * np.max(np.abs(zl))
    assert stiff.record.meta["numerical"]["k3"] == 1e9
