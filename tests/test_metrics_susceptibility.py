"""Susceptibility measures: φ, κ, ζ, eigenfrequencies, τ-ratios, delay margin and PSI."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rths3d.errors import ConfigError
from rths3d.metrics import (
    damping_ratio,
    delay_margin,
    interface_loop,
    mass_ratio,
    omega_dyn,
    omega_num,
    psi,
    stiffness_ratio,
    tau_ratio,
    tau_ratio_max,
)
from rths3d.metrics.susceptibility import fastest_mode, interface_properties, psi_class


def test_sdof_ratios_match_paper_definitions():
    """φ, κ, ζ, ω_0,NUM and ω_0,DYN equal eqs. 12–13 for the paper's contact test values."""
    m, d, k, me, ke = 9.62, 100.0, 1e4, 0.38, 8650.0
    assert mass_ratio(m, me) == pytest.approx(m / me)
    assert stiffness_ratio(k, ke) == pytest.approx(k / ke)
    assert damping_ratio(d, k, m) == pytest.approx(d / (2 * math.sqrt(k * m)))
    assert omega_num(m, k) == pytest.approx(math.sqrt(k / m))
    assert omega_dyn(m, k, me, ke) == pytest.approx(math.sqrt((k + ke) / (m + me)))
    w, zeta = fastest_mode(m, d, k)
    assert zeta == pytest.approx(d / (2 * math.sqrt(k * m)))
    assert tau_ratio(0.01, w) == pytest.approx(0.01 * math.sqrt(k / m))


def test_mdof_fastest_eigenfrequency_two_mass_chain():
    """Two equal masses in a chain: ω² = (k/m)(3 ± √5)/2, the fastest one is used."""
    m, k = 2.0, 800.0
    M = np.diag([m, m])
    K = np.array([[2 * k, -k], [-k, k]])
    assert omega_num(M, K) == pytest.approx(math.sqrt(k / m * (3 + math.sqrt(5)) / 2))
    # coupling a spring k_e to DOF 1 through Γ = e1 stiffens only the coupled system
    G = np.array([[1.0], [0.0]])
    assert omega_dyn(M, K, 0.0, 0.0, G) == pytest.approx(omega_num(M, K))
    assert omega_dyn(M, K, 0.0, 500.0, G) > omega_num(M, K)
    mass, stiff = interface_properties(M, K, G)
    assert mass[0] == pytest.approx(m)
    assert stiff[0] == pytest.approx(1.0 / np.linalg.inv(K)[0, 0])  # = k for this chain


def test_delay_margin_and_tau_ratio_max():
    """τ_max = PM/ω_c and τ_ratio,max = d/τ_max (dimensionless)."""
    assert delay_margin(0.5, 25.0) == pytest.approx(0.02)
    assert tau_ratio_max(0.01, 0.02) == pytest.approx(0.5)
    assert tau_ratio_max(0.01, math.inf) == 0.0
    with pytest.raises(ConfigError, match="crossover"):
        delay_margin(0.5, 0.0)


def _closed_form_tau_cr(m, c, k, ke):
    """Critical delay of m ẍ + c ẋ + k x + k_e x(t − τ) = 0 from |k_e| = |P(iω)|."""
    # m² ω⁴ + (c² − 2km) ω² + k² − k_e² = 0
    roots = np.roots([m * m, c * c - 2 * k * m, k * k - ke * ke])
    best = math.inf
    for r in roots:
        if abs(r.imag) < 1e-9 and r.real > 0:
            w = math.sqrt(r.real)
            mu = ke / complex(k - m * w * w, c * w)
            best = min(best, ((np.angle(mu) + math.pi) % (2 * math.pi)) / w)
    return best


@pytest.mark.parametrize("m,c,k,ke", [(1.0, 2.0, 1e4, 3e3), (9.62, 100.0, 1e4, 8650.0),
                                      (4.81, 50.0, 5e5, 8650.0),
                                      (1.0, 0.1, 1e4, 30.0)])  # ζ = 5e-4: a narrow band
def test_interface_loop_matches_closed_form(m, c, k, ke):
    """Grid + bisection critical delay equals the closed-form SDOF stability switch."""
    loop = interface_loop(m, c, k, 0.0, 0.0, ke)
    expected = _closed_form_tau_cr(m, c, k, ke)
    assert loop.tau_cr == pytest.approx(expected, rel=1e-6)
    assert loop.psi == pytest.approx(math.log10(expected / 1e-3), rel=1e-6)


def _simulate_dde(tau, m=1.0, c=2.0, k=1e4, ke=3e3, h=2e-5, T=2.0):
    """Peak |x| over the first and last 0.2 s of m ẍ + c ẋ + k x + k_e x(t − τ) = 0."""
    n = int(T / h)
    lag = int(round(tau / h))
    x = np.zeros(n)
    x[0] = 1e-3
    v = 0.0
    for i in range(n - 1):  # semi-implicit Euler (symplectic: adds no artificial damping)
        xd = x[i - lag] if i >= lag else x[0]
        v += h * (-c * v - k * x[i] - ke * xd) / m
        x[i + 1] = x[i] + h * v
    w = int(0.2 / h)
    return np.abs(x[:w]).max(), np.abs(x[-w:]).max()


def test_psi_critical_delay_separates_decay_from_growth():
    """Simulating the delayed coupled system: it decays at 0.7 τ_cr and grows at 1.3 τ_cr."""
    loop = interface_loop(1.0, 2.0, 1e4, 0.0, 0.0, 3e3)
    first, last = _simulate_dde(0.7 * loop.tau_cr)
    assert last < first
    first, last = _simulate_dde(1.3 * loop.tau_cr)
    assert last > first


def test_neutral_and_never_unstable_cases():
    """Experimental mass above the numerical one: τ_cr = 0 (PSI = −∞); a weak specimen spring
    (|k_e| < min|P|) never crosses: τ_cr = ∞."""
    assert interface_loop(1.0, 2.0, 1e4, 2.0, 0.0, 10.0).tau_cr == 0.0
    assert psi(0.0) == -math.inf
    loop = interface_loop(1.0, 200.0, 1e4, 0.0, 0.0, 10.0)  # min|P| ≈ c ω_n = 2e4 ≫ 10
    assert loop.tau_cr == math.inf
    assert psi_class(1.0) == "slightly sensitive"
    assert psi_class(0.3) == "moderately sensitive"
    assert psi_class(-0.5) == "extremely sensitive"


def test_bad_parameters_name_the_field():
    """Non-positive masses or stiffnesses raise ConfigError naming the field."""
    with pytest.raises(ConfigError, match="m_exp"):
        mass_ratio(1.0, 0.0)
    with pytest.raises(ConfigError, match="k_num"):
        stiffness_ratio(-1.0, 1.0)
    with pytest.raises(ConfigError, match="d_num"):
        damping_ratio(float("nan"), 1.0, 1.0)


def _simulate_2dof(tau, h=2e-5, T=2.0):
    """Peak |x1| over the first and last 0.2 s of a 2-DOF chain (m1 = 1, m2 = 0.5 kg;
    k1 = 1e4, k2 = 4e3 N/m; c = 1 N·s/m each) with a delayed spring k_e = 2e3 N/m on DOF 1."""
    m1, m2, k1, k2, c, ke = 1.0, 0.5, 1e4, 4e3, 1.0, 2e3
    n = int(T / h)
    lag = int(round(tau / h))
    x1 = np.zeros(n)
    x1[0] = 1e-3
    x2 = v1 = v2 = 0.0
    for i in range(n - 1):
        xd = x1[i - lag] if i >= lag else x1[0]
        f12 = k2 * (x2 - x1[i]) + c * (v2 - v1)
        v1 += h * (-k1 * x1[i] - c * v1 + f12 - ke * xd) / m1
        v2 += h * (-f12) / m2
        x1[i + 1] = x1[i] + h * v1
        x2 += h * v2
    w = int(0.2 / h)
    return np.abs(x1[:w]).max(), np.abs(x1[-w:]).max()


def test_psi_two_dof_against_simulation():
    """MDOF critical delay (2-DOF chain, interface on DOF 1): the delayed system decays at
    0.7 τ_cr and grows at 1.3 τ_cr."""
    M = np.diag([1.0, 0.5])
    K = np.array([[1e4 + 4e3, -4e3], [-4e3, 4e3]])
    C = np.array([[2.0, -1.0], [-1.0, 1.0]])
    G = np.array([[1.0], [0.0]])
    loop = interface_loop(M, C, K, 0.0, 0.0, 2e3, G)
    assert 0 < loop.tau_cr < 0.05
    first, last = _simulate_2dof(0.7 * loop.tau_cr)
    assert last < first
    first, last = _simulate_2dof(1.3 * loop.tau_cr)
    assert last > first


def _hand_tau_cr(m, c, k, me, ce, ke):
    """SDOF τ_cr from the roots of |Q(iω)|² = |P(iω)|², a quadratic in ω²."""
    roots = np.roots([me * me - m * m, ce * ce - 2 * ke * me - c * c + 2 * k * m,
                      ke * ke - k * k])
    best = math.inf
    for r in roots:
        if abs(r.imag) < 1e-9 and r.real > 0:
            w = math.sqrt(r.real)
            mu = complex(ke - me * w * w, ce * w) / complex(k - m * w * w, c * w)
            best = min(best, ((np.angle(mu) + math.pi) % (2 * math.pi)) / w)
    return best


@pytest.mark.parametrize("args", [(1.0, 0.0, 1.0, 0.38, 5.0, 1.0),
                                  (1.0, 0.0, 1.0, 0.5, 0.0, 1.0),
                                  (9.62, 1e-9, 1e4, 4.81, 0.0, 1e4)])
def test_interface_loop_undamped_numerical_part(args):
    """An undamped or barely damped numerical part (P(iω) singular on the grid, |μ| = 1 at
    round-off on a grid point) gives the closed-form τ_cr instead of crashing."""
    loop = interface_loop(*args)
    expected = _hand_tau_cr(*args)
    if expected < 1e-9:
        assert loop.tau_cr == pytest.approx(expected, abs=1e-12)
    else:
        assert loop.tau_cr == pytest.approx(expected, rel=1e-6)


def test_unstable_without_delay_gives_zero_tau_cr():
    """A coupled system already unstable without delay (negative damping) has τ_cr = 0,
    PSI = −∞; the undamped boundary case keeps τ_cr = 0 through its crossover."""
    loop = interface_loop(9.62, -100.0, 1e4, 0.38, 0.0, 8650.0)
    assert loop.tau_cr == 0.0 and loop.psi == -math.inf
    assert psi_class(loop.psi) == "extremely sensitive"
    # unstable numerical part stabilised by the specimen's damping: a finite τ_cr
    assert interface_loop(9.62, -1.0, 1e4, 0.38, 5.0, 8650.0).tau_cr > 0.0
    assert interface_loop(9.62, 0.0, 1e4, 0.38, 0.0, 8650.0).tau_cr == 0.0


def test_phase_margin_in_degrees_is_refused():
    """A phase margin outside [0, 2π) rad (e.g. 30 meaning degrees) raises ConfigError."""
    with pytest.raises(ConfigError, match="rad, not degrees"):
        delay_margin(30.0, 10.0)
    with pytest.raises(ConfigError, match="phase_margin"):
        delay_margin(-0.1, 10.0)
    assert delay_margin(math.radians(30.0), 10.0) == pytest.approx(math.pi / 60)


def test_bad_model_matrices_raise_config_error():
    """Singular M, negative damping or a wrongly sized Γ raise ConfigError naming the field."""
    K = np.array([[2e4, -1e4], [-1e4, 1e4]])
    with pytest.raises(ConfigError, match="^M:"):
        fastest_mode(np.diag([9.62, 0.0]), np.eye(2), K)
    with pytest.raises(ConfigError, match="^M:"):
        fastest_mode(0.0, 1.0, 1e4)
    with pytest.raises(ConfigError, match="^C:"):
        fastest_mode(9.62, -100.0, 1e4)
    with pytest.raises(ConfigError, match="^M:"):
        interface_loop(np.diag([9.62, 0.0]), np.eye(2), K, 0.38, 0.0, 8650.0, [1.0, 0.0])
    with pytest.raises(ConfigError, match="^gamma:"):
        omega_dyn(np.eye(2), K, 0.38, 8650.0, [1.0, 0.0, 0.0])
    with pytest.raises(ConfigError, match="^K:"):
        omega_num(1.0, "1e4 N/m")
