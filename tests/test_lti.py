"""Tests of the general LTI machinery (rths3d.lti) against analytic answers and scipy."""

from __future__ import annotations

import json
import math
from fractions import Fraction

import control
import numpy as np
import pytest
import scipy.signal

from rths3d.errors import ConfigError, RecordError
from rths3d.lti import (
    Converter,
    DifferenceEquation,
    RK4Stepper,
    ScalarStepper,
    StateSpaceStepper,
    affine_step_matrices,
    band_limited_std,
    c2d,
    controller_from_dict,
    feedback,
    lead_lag,
    load_ground_motion,
    lsim_foh,
    parallel,
    pi_controller,
    quantize,
    series,
    simulink_randn,
    simulink_seed_state,
    ss,
    tf,
    tustin_tf,
)
from rths3d.lti.noise import simulink_uniform

WN, ZETA = 2 * np.pi * 5.0, 0.1  # rad/s, -
OSC = ([WN**2], [1.0, 2 * ZETA * WN, WN**2])


def osc_step_exact(t: np.ndarray) -> np.ndarray:
    """Unit-step response of ω²/(s² + 2ζω s + ω²)."""
    wd = WN * math.sqrt(1 - ZETA**2)
    return 1 - np.exp(-ZETA * WN * t) * (np.cos(wd * t) + ZETA / math.sqrt(1 - ZETA**2) * np.sin(wd * t))


def test_tf_frequency_response_matches_scipy_freqs():
    """tf() realises N(s)/D(s): G(jω) equals scipy.signal.freqs."""
    num, den = [3.0, 2.0, 1.0], [1.0, 4.0, 9.0, 5.0]
    w = np.logspace(-1, 2, 30)
    _, h = scipy.signal.freqs(num, den, worN=w)
    np.testing.assert_allclose(tf(num, den).freqresp(w)[:, 0, 0], h, rtol=1e-10)


def test_tf_rejects_improper_and_zero_denominator():
    """Improper transfer functions and zero denominators raise ConfigError naming the field."""
    with pytest.raises(ConfigError, match="num"):
        tf([1.0, 0.0, 0.0], [1.0, 1.0])
    with pytest.raises(ConfigError, match="den"):
        tf([1.0], [0.0])


@pytest.mark.parametrize("method", ["zoh", "foh", "tustin"])
def test_c2d_matches_scipy_cont2discrete(method):
    """c2d gives the same discrete step response as scipy.signal.cont2discrete."""
    dt = 1e-3
    sysc = tf(*OSC)
    d = c2d(sysc, dt, method)
    sp = {"zoh": "zoh", "foh": "foh", "tustin": "bilinear"}[method]
    Ad, Bd, Cd, Dd, _ = scipy.signal.cont2discrete((sysc.A, sysc.B, sysc.C, sysc.D), dt, method=sp)
    u = np.ones(400)
    _, y_ref, _ = scipy.signal.dlsim((Ad, Bd, Cd, Dd, dt), u)
    np.testing.assert_allclose(d.simulate(u)[:, 0], y_ref[:, 0], atol=1e-12)


def test_zoh_step_response_is_exact_at_samples():
    """A ZOH-discretised oscillator hit by a step equals the analytic step response at t_k."""
    dt = 2e-3
    d = c2d(tf(*OSC), dt, "zoh")
    y = d.simulate(np.ones(500))[:, 0]
    np.testing.assert_allclose(y, osc_step_exact(dt * np.arange(500)), atol=1e-12)
    assert d.dcgain()[0, 0] == pytest.approx(1.0, rel=1e-12)


def test_lsim_foh_exact_for_ramp_input():
    """lsim_foh is exact for a ramp into 1/(s+a): y = t/a − (1 − e^{−at})/a²."""
    a, dt = 3.0, 0.05
    t = dt * np.arange(200)
    y = lsim_foh(tf([1.0], [1.0, a]), t, dt)[:, 0]
    exact = t / a - (1 - np.exp(-a * t)) / a**2
    np.testing.assert_allclose(y, exact, atol=1e-13)


def test_lsim_foh_matches_scipy_lsim_for_mimo_oscillator():
    """lsim_foh equals scipy.signal.lsim (linear interpolation) for a 2-DOF system."""
    M, K, C = np.diag([1.0, 2.0]), np.array([[300.0, -100.0], [-100.0, 100.0]]), np.eye(2) * 0.5
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    B = np.vstack([np.zeros((2, 1)), -np.ones((2, 1))])
    sysc = ss(A, B, np.hstack([np.eye(2), np.zeros((2, 2))]))
    dt = 0.01
    t = dt * np.arange(600)
    u = np.sin(7 * t) * np.exp(-0.2 * t)
    _, y_ref, _ = scipy.signal.lsim((A, B, sysc.C, sysc.D), u, t)
    np.testing.assert_allclose(lsim_foh(sysc, u, dt), y_ref, atol=1e-9 * np.max(np.abs(y_ref)))


def test_block_diagram_series_parallel_feedback():
    """series, parallel and feedback equal the polynomial algebra of their transfer functions."""
    g1, g2 = tf([1.0], [1.0, 2.0]), tf([3.0, 1.0], [1.0, 5.0, 6.0])
    w = np.array([0.3, 1.0, 4.0])
    h1, h2 = g1.freqresp(w)[:, 0, 0], g2.freqresp(w)[:, 0, 0]
    np.testing.assert_allclose(series(g1, g2).freqresp(w)[:, 0, 0], h1 * h2, rtol=1e-12)
    np.testing.assert_allclose(parallel(g1, g2).freqresp(w)[:, 0, 0], h1 + h2, rtol=1e-12)
    np.testing.assert_allclose(feedback(g2).freqresp(w)[:, 0, 0], h2 / (1 + h2), rtol=1e-12)
    np.testing.assert_allclose(feedback(g2, g1).freqresp(w)[:, 0, 0], h2 / (1 + h1 * h2),
                               rtol=1e-12)
    np.testing.assert_allclose(feedback(g2, g1, sign=+1).freqresp(w)[:, 0, 0],
                               h2 / (1 - h1 * h2), rtol=1e-12)


def test_tustin_coefficients_equal_benchmark_spec(rths_benchmark_dir):
    """Tustin of the benchmark's PI and phase lead equals the difference equations of SPEC §8."""
    io = json.loads((rths_benchmark_dir / "data" / "plant_controller_io.json").read_text())
    c = io["controller"]
    dt = io["io"]["dt"]
    ref = c["discrete_difference_equations"]
    pl = lead_lag(c["phase_lead"]["num"], c["phase_lead"]["den"], dt)
    np.testing.assert_allclose(pl.b, ref["phase_lead"]["b"], rtol=1e-12)
    np.testing.assert_allclose(pl.a, ref["phase_lead"]["a"], rtol=1e-12, atol=1e-15)
    pi = pi_controller(c["PI"]["Kp"], c["PI"]["Ki"], dt)
    np.testing.assert_allclose(pi.b, ref["PI"]["b"], rtol=1e-14)
    np.testing.assert_allclose(pi.a, ref["PI"]["a"], rtol=1e-14)


def test_pi_coefficients_are_kp_plus_minus_ki_dt_over_2():
    """PI by Tustin: b = (Kp + Ki·Ts/2, −(Kp − Ki·Ts/2)), a = (1, −1)."""
    kp, ki, dt = 2.0, 95.0, 1.0 / 4096
    pi = pi_controller(kp, ki, dt)
    assert pi.b == pytest.approx((kp + ki * dt / 2, -(kp - ki * dt / 2)), rel=1e-15)
    assert pi.a == pytest.approx((1.0, -1.0))


def test_tustin_preserves_dc_gain_and_maps_pole():
    """Tustin keeps the DC gain of a lead filter and maps its pole p to (1 + p·T/2)/(1 − p·T/2)."""
    dt, p = 1e-3, -300.0
    b, a = tustin_tf([5.0, 100.0], [1.0, -p], dt)
    assert np.sum(b) / np.sum(a) == pytest.approx(100.0 / 300.0, rel=1e-12)
    assert -a[1] == pytest.approx((1 + p * dt / 2) / (1 - p * dt / 2), rel=1e-12)


def test_controller_from_dict_forms_and_errors():
    """Scene controller specs (pi, tf, difference) build; missing keys/unknown types name the field."""
    dt = 1e-3
    assert controller_from_dict({"type": "pi", "kp": 1.0, "ki": 10.0}, dt).b == pytest.approx(
        (1.005, -0.995))
    d = controller_from_dict({"type": "difference", "b": [2.0, 1.0], "a": [2.0, -1.0]}, dt)
    assert d.a == (1.0, -0.5) and d.b == (1.0, 0.5)
    lead = controller_from_dict({"type": "tf", "num": [2.0, 1.0], "den": [1.0, 1.0]}, dt)
    assert lead.dcgain() == pytest.approx(1.0)
    with pytest.raises(ConfigError, match=r"controller\.ki"):
        controller_from_dict({"type": "pi", "kp": 1.0}, dt)
    with pytest.raises(ConfigError, match=r"controller\.type"):
        controller_from_dict({"type": "pid2"}, dt)


def test_steppers_agree_with_lfilter_and_simulate():
    """ScalarStepper, batched StateSpaceStepper and DifferenceEquation.filter give one answer."""
    de = lead_lag([50.8, 8570.0], [1.0, 8570.0], 1 / 4096)
    rng = np.random.default_rng(1)
    u = rng.standard_normal((300, 3))
    ref = np.stack([de.filter(u[:, j]) for j in range(3)], axis=1)
    batch = de.batch(3)
    got = np.empty_like(u)
    for k in range(u.shape[0]):
        got[k] = batch.step(u[k][:, None])[:, 0]
    np.testing.assert_allclose(got, ref, rtol=1e-10, atol=1e-12)
    sc = de.scalar()
    np.testing.assert_allclose([sc.step(float(v)) for v in u[:, 0]], ref[:, 0], rtol=1e-10,
                               atol=1e-12)
    # a 2nd-order discrete system through the state-space path
    d = c2d(tf(*OSC), 1e-3, "zoh")
    sc2 = ScalarStepper(d)
    y = [sc2.step(1.0) for _ in range(200)]
    np.testing.assert_allclose(y, d.simulate(np.ones(200))[:, 0], atol=1e-12)
    st = StateSpaceStepper(d, K=2)
    y2 = [st.step(np.ones((2, 1)))[1, 0] for _ in range(200)]
    np.testing.assert_allclose(y2, y, atol=1e-12)


def test_rk4_stepper_fourth_order_convergence_and_multirate():
    """RK4Stepper converges at 4th order to the exact step response; substeps are multi-rate."""
    dt, n = 0.01, 100
    exact = osc_step_exact(dt * np.arange(1, n + 1))
    errs = []
    for sub in (1, 2, 4):
        st = RK4Stepper(tf(*OSC), dt, substeps=sub)
        y = np.array([st.step(np.ones((1, 1)))[0, 0] for _ in range(n)])
        errs.append(np.max(np.abs(y - exact)))
    assert errs[0] < 1e-3
    assert errs[0] / errs[1] == pytest.approx(16.0, rel=0.15)
    assert errs[1] / errs[2] == pytest.approx(16.0, rel=0.15)


def test_rk4_stepper_linear_input_exact_for_polynomial_rates():
    """With linear interpolation, RK4 on ẋ = u(t) integrates a ramp input exactly."""
    st = RK4Stepper(ss([[0.0]], [[1.0]], [[1.0]]), 0.1, input="linear", K=2)
    for k in range(10):
        u0 = np.array([[0.1 * k], [1.0]])
        u1 = np.array([[0.1 * (k + 1)], [1.0]])
        y = st.step(u0, u1)
    np.testing.assert_allclose(y[:, 0], [0.5, 1.0], atol=1e-14)  # ∫₀¹ t dt, ∫₀¹ 1 dt
    with pytest.raises(ConfigError, match="u1"):
        st.step(np.zeros((2, 1)))


def test_affine_step_matrices_rejects_nonlinear_step():
    """affine_step_matrices recovers Φ, Γ of a linear map and refuses a nonlinear one."""
    Phi, Gam = affine_step_matrices(lambda x, u: np.array([2 * x[0] + u[0], x[0] - x[1]]), 2, 1)
    np.testing.assert_array_equal(Phi, [[2, 0], [1, -1]])
    np.testing.assert_array_equal(Gam, [[1], [0]])
    with pytest.raises(ValueError, match="not linear"):
        affine_step_matrices(lambda x, u: x**2 + u, 1, 1)


def test_quantize_rounds_halves_away_from_zero():
    """quantize rounds halves away from zero (MATLAB round), both for floats and arrays."""
    q = 2.0**-18
    for v, want in [(2.5 * q, 3 * q), (-2.5 * q, -3 * q), (0.49 * q, 0.0), (1.5 * q, 2 * q)]:
        assert quantize(v, q) == want
    np.testing.assert_array_equal(quantize(np.array([2.5, -2.5, 0.5, -0.5]) * q,
                                          q), np.array([3, -3, 1, -1]) * q)


def test_converter_order_ad_versus_da():
    """A/D saturates then quantises; D/A quantises then saturates (differs at the limit)."""
    ad = Converter(q=1.0, lo=-2.2, hi=2.2, kind="ad")
    da = Converter(q=1.0, lo=-2.2, hi=2.2, kind="da")
    assert ad(5.0) == 2.0  # saturate to 2.2, then round to 2
    assert da(5.0) == 2.2  # round to 5, then saturate
    assert Converter.from_bits(18, -3.8, 3.8).q == pytest.approx(7.6 / 2**18)
    with pytest.raises(ConfigError, match="converter.q"):
        Converter(q=-1.0)


def test_simulink_randn_matches_matlab_seed0_sequence():
    """The Random Number block emulation with seed 0 gives MATLAB's documented legacy sequence."""
    assert simulink_seed_state(0) == 1144108930
    w = simulink_randn(5, 0)
    np.testing.assert_allclose(w, [1.1650, 0.6268, 0.0751, 0.3516, -0.6965], atol=5e-5)


def test_simulink_uniform_jump_ahead_equals_schrage_recursion():
    """The vectorised LCG equals the sequential Schrage recursion (a = 16807, m = 2³¹ − 1)."""
    s0 = 1144108930
    u, _ = simulink_uniform(10000, s0)
    s, seq = s0, []
    for _ in range(10000):
        lo, hi = (s % 127773) * 16807, (s // 127773) * 2836
        s = lo - hi if lo >= hi else 2147483647 - (hi - lo)
        seq.append(s * 4.6566128752457969e-10)
    np.testing.assert_array_equal(u, seq)


def test_simulink_randn_statistics_and_noise_std():
    """The emulated normal sequence has zero mean and unit variance; √(Cov/Δt) gives SPEC's stds."""
    w = simulink_randn(200_000, 0)
    assert abs(w.mean()) < 0.01 and abs(w.std() - 1.0) < 0.01
    assert band_limited_std(6.25e-14, 1 / 4096) == pytest.approx(1.6e-5, rel=1e-12)
    assert band_limited_std(1.16e-3, 1 / 4096) == pytest.approx(2.1797614548385793, rel=1e-12)


def test_ground_motion_csv_interpolation(tmp_path):
    """A CSV record is read, scaled and linearly interpolated; zero outside; bad files raise."""
    p = tmp_path / "gm.csv"
    p.write_text("t_s,accel_mps2\n0.0,0.0\n0.1,1.0\n0.2,-1.0\n")
    gm = load_ground_motion(p, scale=0.5)
    np.testing.assert_allclose(gm(np.array([0.05, 0.1, 0.15, 0.3, -1.0])),
                               [0.25, 0.5, 0.0, 0.0, 0.0], atol=1e-15)
    assert gm.pga == pytest.approx(0.5) and gm.t_end == pytest.approx(0.2)
    assert gm.sample(0.05).shape == (5,)
    with pytest.raises(RecordError, match="not found"):
        load_ground_motion(tmp_path / "missing.csv")
    bad = tmp_path / "bad.csv"
    bad.write_text("t,a\n0.0,0.0\n0.0,1.0\n")
    with pytest.raises(ConfigError, match="increasing"):
        load_ground_motion(bad)


def test_benchmark_records_pga(rths_benchmark_dir):
    """The benchmark's El Centro, Kobe and Morgan records have SPEC §4's PGA, length and t_end."""
    for name, pga, n, t_end in [("ElCentro", 3.134930, 2060, 41.18),
                                ("Kobe", 6.329845, 5095, 50.94),
                                ("Morgan", 2.389171, 7995, 39.97)]:
        gm = load_ground_motion(rths_benchmark_dir / "data" / f"ground_motion_{name}.csv", 0.4)
        assert gm.t.size == n and gm.t_end == pytest.approx(t_end)
        assert gm.pga == pytest.approx(0.4 * pga, rel=1e-6)


def test_difference_equation_validates():
    """A zero leading denominator coefficient is refused with the field named."""
    with pytest.raises(ConfigError, match=r"controller\.a"):
        DifferenceEquation.from_arrays([1.0], [0.0, 1.0], 1e-3)


def test_ground_motion_zero_order_hold():
    """held() keeps each record sample until the next one and is zero outside the record."""
    from rths3d.lti import GroundMotion

    gm = GroundMotion(np.array([0.0, 0.1, 0.2]), np.array([1.0, 2.0, 3.0]), scale=2.0)
    np.testing.assert_allclose(gm.held(np.array([-0.01, 0.0, 0.05, 0.1, 0.199, 0.2, 0.3])),
                               [0.0, 2.0, 2.0, 4.0, 4.0, 6.0, 0.0])


def test_system_from_scene_data():
    """Scene tables build tf, state-space and series systems; incomplete tables name the field."""
    from rths3d.lti import system_from_dict

    g = system_from_dict({"series": [{"num": [1.0], "den": [1.0, 2.0]},
                                     {"A": [[-3.0]], "B": [[1.0]], "C": [[3.0]]}]})
    w = np.array([0.5, 2.0])
    np.testing.assert_allclose(g.freqresp(w)[:, 0, 0], 3.0 / ((1j * w + 2) * (1j * w + 3)), rtol=1e-12)
    with pytest.raises(ConfigError, match=r"plant\.den"):
        system_from_dict({"num": [1.0]}, field="plant")
    with pytest.raises(ConfigError, match=r"plant\.C"):
        system_from_dict({"A": [[0.0]], "B": [[1.0]]}, field="plant")


def test_prewarped_tustin_is_exact_at_the_prewarp_frequency():
    """Tustin prewarped at ω₀ reproduces G(jω₀) of the oscillator exactly (plain Tustin does
    not), for the state-space c2d and for the coefficient form tustin_tf alike."""
    dt, w0 = 1 / 200, 2 * np.pi * 40.0  # 40 Hz of a 100 Hz Nyquist: Tustin warps strongly
    exact = WN**2 / (WN**2 - w0**2 + 2j * ZETA * WN * w0)
    warped = c2d(tf(*OSC), dt, "tustin", prewarp=w0).freqresp([w0])[0, 0, 0]
    plain = c2d(tf(*OSC), dt, "tustin").freqresp([w0])[0, 0, 0]
    assert abs(warped - exact) < 1e-12 * abs(exact)
    assert abs(plain - exact) > 1e-3 * abs(exact)
    b, a = tustin_tf(*OSC, dt, prewarp=w0)
    z1 = np.exp(-1j * w0 * dt)  # z⁻¹ on the unit circle
    g = np.polyval(b[::-1], z1) / np.polyval(a[::-1], z1)
    assert abs(g - exact) < 1e-12 * abs(exact)
    lead = controller_from_dict({"type": "tf", "num": OSC[0], "den": OSC[1], "prewarp": w0},
                                dt)
    np.testing.assert_allclose(lead.b, b, rtol=1e-15)


def test_tustin_tf_equals_exact_rational_substitution_and_python_control():
    """tustin_tf of a 3rd-order filter equals s ← 2/T (z−1)/(z+1) done in exact rational
    arithmetic to the last digit, and python-control's sample_system to its round-off."""
    num, den, dt = [3, 2, 1], [1, 4, 9, 5], Fraction(1, 4096)

    def substitute(c: list[int], n: int) -> list[Fraction]:
        out = [Fraction(0)] * (n + 1)  # ascending powers of z
        for i, ci in enumerate(c):
            p = len(c) - 1 - i  # power of s
            poly = [Fraction(1)]
            for _ in range(p):  # × (z − 1)
                poly = [b - a for a, b in zip([*poly, 0], [0, *poly], strict=True)]
            for _ in range(n - p):  # × (z + 1)
                poly = [a + b for a, b in zip([*poly, 0], [0, *poly], strict=True)]
            for j, v in enumerate(poly):
                out[j] += ci * (2 / dt) ** p * v
        return out[::-1]

    bq, aq = substitute(num, 3), substitute(den, 3)
    b_exact = np.array([float(v / aq[0]) for v in bq])
    a_exact = np.array([float(v / aq[0]) for v in aq])
    b, a = tustin_tf(num, den, float(dt))
    np.testing.assert_allclose(b, b_exact, rtol=1e-15)
    np.testing.assert_allclose(a, a_exact, rtol=1e-15)
    g = control.sample_system(control.tf(num, den), float(dt), "tustin")
    np.testing.assert_allclose(np.asarray(g.num[0][0]) / g.den[0][0][0], b, rtol=1e-10)
    np.testing.assert_allclose(np.asarray(g.den[0][0]) / g.den[0][0][0], a, rtol=1e-12)


def test_design_objects_are_python_control_systems():
    """tf, ss, series, feedback and c2d give control.StateSpace objects that python-control's
    own functions take: its forced_response (an independent FOH solver) equals lsim_foh, and
    a difference equation's control.tf has the frequency response of scipy.signal.freqz."""
    g = series(tf([1.0], [1.0, 2.0]), tf(*OSC))
    d = c2d(g, 1e-3, "zoh")
    for sys in (g, feedback(g), ss([[-1.0]], [[1.0]], [[1.0]]), d):
        assert isinstance(sys, control.StateSpace)
    assert g.dt == 0 and d.dt == 1e-3 and control.isdtime(d, strict=True)
    t = 1e-3 * np.arange(800)
    u = np.sin(30 * t) + 0.5 * np.cos(110 * t)
    y_ct = control.forced_response(g, t, u).outputs
    np.testing.assert_allclose(lsim_foh(g, u, 1e-3)[:, 0], y_ct, atol=1e-12 * np.max(np.abs(y_ct)))
    de = lead_lag([50.8, 8570.0], [1.0, 8570.0], 1 / 4096)
    w = 2 * np.pi * np.array([1.0, 30.0, 300.0, 1500.0])
    _, h = scipy.signal.freqz(de.b, de.a, worN=w / (2 * np.pi), fs=4096)
    np.testing.assert_allclose(de.to_tf()(np.exp(1j * w / 4096)), h, rtol=1e-12)
    np.testing.assert_allclose(de.to_ss().freqresp(w)[:, 0, 0], h, rtol=1e-10)


def test_bad_prewarp_and_connections_name_the_field():
    """A prewarp outside Tustin or (0, π/dt), mismatched block sizes and a singular algebraic
    loop are ConfigErrors naming the field."""
    g = tf(*OSC)
    with pytest.raises(ConfigError, match="prewarp.*only Tustin"):
        c2d(g, 1e-3, "zoh", prewarp=10.0)
    with pytest.raises(ConfigError, match=r"prewarp: 4000\.0"):
        c2d(g, 1e-3, "tustin", prewarp=4000.0)  # above π/dt = 3141.6 rad/s
    with pytest.raises(ConfigError, match=r"controller\.prewarp"):
        controller_from_dict({"type": "tf", "num": [1.0], "den": [1.0, 1.0], "prewarp": -1.0},
                             1e-3)
    with pytest.raises(ConfigError, match="series"):
        series(ss([[-1.0]], [[1.0, 1.0]], [[1.0], [2.0]]), g)  # 2 outputs into 1 input
    with pytest.raises(ConfigError, match="feedback"):
        feedback(ss(np.zeros((0, 0)), np.zeros((0, 1)), np.zeros((1, 0)), [[1.0]]), sign=+1)
    with pytest.raises(ConfigError, match="method"):
        c2d(g, 1e-3, "impulse")
