"""Transfer-system parts: delay line, LTI actuator, compensation, sensor model."""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.signal

from rths3d.transfer import Compensator, DelayLine, LTIActuator, SensorModel
from rths3d.transfer.actuators import PerTestDelayLine, PerTestLTIActuator


def test_delay_line_integer_and_fractional():
    """A 3 ms delay shifts by 3 samples; 2.5 ms interpolates linearly between samples."""
    u = np.arange(1.0, 11.0)
    d = DelayLine(1, 1, 3e-3, 1e-3)
    y = np.array([d(np.array([[v]]))[0, 0] for v in u])
    np.testing.assert_allclose(y, np.r_[0, 0, 0, u[:-3]])
    d = DelayLine(1, 1, 2.5e-3, 1e-3)
    y = np.array([d(np.array([[v]]))[0, 0] for v in u])
    np.testing.assert_allclose(y[4:], u[4:] - 2.5)


def test_per_test_delay_line_equals_one_delay_line_per_test():
    """Per-test delays (integer, fractional, zero) give exactly each test's own DelayLine."""
    delays, dt = [3e-3, 2.5e-3, 0.0, 12.25e-3], 1e-3
    per = PerTestDelayLine(4, 2, delays, dt)
    own = [DelayLine(1, 2, d, dt) for d in delays]
    u = np.random.default_rng(0).standard_normal((40, 4, 2))
    for n in range(40):
        y = per(u[n]).copy()
        for k in range(4):
            np.testing.assert_array_equal(y[k], own[k](u[n][k:k + 1])[0])
    per.reset()
    y = per(u[0])  # τ > 0 starts from 0 again; τ = 0 passes u
    assert not y[[0, 1, 3]].any()
    np.testing.assert_array_equal(y[2], u[0][2])


def test_per_test_lti_equals_one_actuator_per_test():
    """Models of different order (1st, 2nd, 3rd with feedthrough) stepped together equal
    their own LTIActuators to rounding."""
    w = 2 * math.pi * 40
    models = [([w * w], [1, 1.2 * w, w * w]), ([50.0], [1, 50.0]),
              ([1e-3, 2.0, 3e4], [1e-4, 1.0, 2e2, 3e4])]
    dt = 1e-3
    per = PerTestLTIActuator(3, 2, models, dt)
    own = [LTIActuator(1, 2, num, den, dt) for num, den in models]
    assert per.ns == 3 and [a.ns for a in own] == [2, 1, 3]
    u = np.random.default_rng(2).standard_normal((300, 3, 2))
    for n in range(300):
        y = per(u[n]).copy()
        for k in range(3):
            np.testing.assert_allclose(y[k], own[k](u[n][k:k + 1])[0], rtol=1e-13, atol=1e-15)
    per.reset()
    assert np.array_equal(per(np.zeros((3, 2))), np.zeros((3, 2)))


def test_per_test_compensation_time_equals_one_compensator_per_test():
    """A per-test τ_c (0 = none) gives exactly z + τ_c ż per test; polynomial stays shared."""
    z, zd = np.array([[1.0], [2.0], [3.0]]), np.array([[-0.5], [0.25], [4.0]])
    per = Compensator(3, 1, "velocity", [0.0, 4e-3, 1e-2], 1e-3)
    out = per(z, zd)
    for k, (kind, tau) in enumerate((("none", 0.0), ("velocity", 4e-3), ("velocity", 1e-2))):
        np.testing.assert_array_equal(out[k], Compensator(1, 1, kind, tau, 1e-3)(z[k:k + 1],
                                                                                 zd[k:k + 1])[0])
    with pytest.raises(ValueError, match="velocity"):
        Compensator(3, 1, "polynomial", [0.0, 4e-3, 1e-2], 1e-3)


def test_lti_matches_scipy_dlsim_and_dc_gain():
    """The LTI actuator equals scipy's ZOH discretisation stepped with dlsim, DC gain 1."""
    w, z = 2 * math.pi * 40, 0.6
    num, den = [w * w], [1, 2 * z * w, w * w]
    dt = 1e-3
    a = LTIActuator(2, 1, num, den, dt)
    rng = np.random.default_rng(1)
    u = rng.standard_normal((300, 2))
    y = np.array([a(u[n][:, None])[:, 0].copy() for n in range(300)])
    dsys = scipy.signal.cont2discrete((num, den), dt, method="zoh")
    for k in range(2):
        _, yd = scipy.signal.dlsim(dsys, np.r_[u[:, k], 0.0])
        # our output at call n is the response after command n was applied for one step
        np.testing.assert_allclose(y[:, k], yd[1:, 0], atol=1e-12)
    a = LTIActuator(1, 1, num, den, dt)
    for _ in range(3000):
        out = a(np.array([[1.0]]))
    assert out[0, 0] == pytest.approx(1.0, abs=1e-9)


def test_velocity_feedforward_cancels_delay_on_ramp():
    """Velocity feed-forward by τ ahead of a τ delay reproduces a ramp exactly."""
    dt, tau = 1e-3, 4e-3
    comp = Compensator(1, 1, "velocity", tau, dt)
    d = DelayLine(1, 1, tau, dt)
    for n in range(50):
        t = n * dt
        y = d(comp(np.array([[2.0 * t]]), np.array([[2.0]])).copy())
    assert y[0, 0] == pytest.approx(2.0 * 49 * dt, abs=1e-12)


def test_polynomial_extrapolation_exact_for_quadratic():
    """Second-order polynomial extrapolation predicts a quadratic exactly τ ahead."""
    dt, tau = 1e-3, 3e-3
    comp = Compensator(1, 1, "polynomial", tau, dt, order=2)
    f = lambda t: 1.0 + 2.0 * t - 30.0 * t * t  # noqa: E731
    for n in range(10):
        out = comp(np.array([[f(n * dt)]]), np.zeros((1, 1)))
    assert out[0, 0] == pytest.approx(f(9 * dt + tau), abs=1e-12)


def test_sensor_first_order_gain_offset():
    """First-order sensor settles to gain·F + offset with the time constant's exponential."""
    dt, tc = 1e-3, 0.01
    s = SensorModel(1, 1, dt, "first_order", tc, gain=1.1, offset=0.5)
    ys = [s(np.array([[10.0]]))[0, 0] for _ in range(200)]
    assert ys[-1] == pytest.approx(11.5, rel=1e-6)
    # after one time constant (10 steps): 1 − e^{-1} of the step (plus the offset)
    assert ys[9] == pytest.approx(11.0 * (1 - math.exp(-1.0)) + 0.5, rel=1e-9)


def test_sensor_noise_statistics_and_ideal_passthrough():
    """Noise has the requested standard deviation; the ideal sensor passes F'_m = F_m."""
    s = SensorModel(1000, 1, 1e-3, noise_std=0.3, seed=3)
    y = s(np.zeros((1000, 1)))
    assert np.std(y) == pytest.approx(0.3, rel=0.1)
    ideal = SensorModel(2, 1, 1e-3)
    f = np.array([[1.0], [2.0]])
    assert ideal(f) is f


def test_lti_default_model_lags_like_the_stewart_platform():
    """The 1-D LTI path (identified G·e^(−sT)) has the Stewart platform's FEI delay at 1 Hz."""
    import json
    from pathlib import Path

    from rths3d.loop import run
    from rths3d.metrics import compute_measures
    from rths3d.scene import load_scene

    root = Path(__file__).resolve().parents[1]
    tf = json.loads((root / "assets" / "platform_heave_tf.json").read_text())
    # the identification run's actuator settings, so the file's measured 1 Hz delay applies
    act = tf["platform"]
    sets = [f"transfer.{k}={act[k]}" for k in ("kp", "kv", "timeconst", "delay")]
    scene = load_scene(root / "scenes" / "paper_linear.toml",
                       ["excitation.frequency=1.0", "duration=3.0", *sets])
    d = {kind: compute_measures(run(scene, kind, reference=False).record)["fei_d"]
         for kind in ("lti", "stewart")}
    measured_1hz = float(np.mean([c["delay_1hz"] for c in tf["conditions"]]))
    assert d["stewart"] == pytest.approx(measured_1hz, abs=0.3e-3)
    # without the transport delay the LTI path lagged ~1.5 ms less than the platform
    assert d["lti"] == pytest.approx(d["stewart"], abs=0.3e-3)


@pytest.mark.parametrize("timeconst, velocity_ff",
                         [(0.0, True), (0.0, False), (0.006, True), (0.006, False)])
def test_lti_default_model_follows_the_leg_servo_settings(timeconst, velocity_ff):
    """Set-point lag and feed-forward change the LTI path's delay and tracking as the platform's."""
    from pathlib import Path

    from rths3d.loop import run
    from rths3d.metrics import compute_measures
    from rths3d.scene import load_scene

    root = Path(__file__).resolve().parents[1]
    scene = load_scene(root / "scenes" / "paper_linear.toml",
                       ["excitation.frequency=1.0", "duration=3.0",
                        f"transfer.timeconst={timeconst}",
                        f"transfer.velocity_ff={str(velocity_ff).lower()}"])
    m = {kind: compute_measures(run(scene, kind, reference=False).record)
         for kind in ("lti", "stewart")}
    # the settings move the delay by −3.5 … +12.8 ms from the identified 2.5 ms
    assert m["lti"]["fei_d"] == pytest.approx(m["stewart"]["fei_d"], abs=0.1e-3)
    # without the lag the tracking error is 0.1–0.2 % and the identified second-order model
    # leaves part of it out (the platform's set-point ramp and servo): 0.1 % absolute
    assert m["lti"]["e_rel_track"] == pytest.approx(m["stewart"]["e_rel_track"], rel=0.1,
                                                    abs=1e-3)


def test_predicted_delay_of_a_model_with_feedthrough():
    """transfer_meta.predicted_delay of G = 1 after 2 ms is 2 ms (the feedthrough gets no
    half-step lead), and the simulation stays a plain 2-sample delay."""
    from pathlib import Path

    from rths3d.loop import run
    from rths3d.scene import load_scene

    scenes = Path(__file__).resolve().parents[1] / "scenes"
    sc = load_scene(scenes / "paper_linear.toml", ["duration=1.0", "transfer.kind='lti'",
                                                   "transfer.num=[1.0]", "transfer.den=[1.0]",
                                                   "transfer.delay=0.002"])
    rec = run(sc, reference=False).record
    assert rec.meta["transfer_meta"]["predicted_delay"] == pytest.approx(0.002, abs=1e-9)
    z, zm = rec.columns["z_cmd.z"], rec.columns["z_meas.z"]
    np.testing.assert_array_equal(zm[2:], z[:-2])
    # a strictly proper model keeps its half-step lead
    sc2 = load_scene(scenes / "paper_linear.toml", ["duration=1.0", "transfer.kind='lti'",
                                                    "transfer.num=[400.0]",
                                                    "transfer.den=[1.0, 400.0]"])
    pred = run(sc2, reference=False).record.meta["transfer_meta"]["predicted_delay"]
    assert pred == pytest.approx(1 / 400 - 0.0005, abs=1e-8)


def test_actuator_steps_allocate_no_arrays(peak_bytes):
    """One step of the delay lines, LTI actuators, polynomial compensation and noisy, lagged,
    delayed sensors of K = 2000 channels allocates no array (< 4 kB traced, a (K,) float
    array is 16 kB)."""
    K = 2000
    u = np.linspace(0.0, 1e-3, K).reshape(K, 1)
    parts = [DelayLine(K, 1, 0.0025, 1e-3),
             PerTestDelayLine(K, 1, np.linspace(0.0, 0.004, K), 1e-3),
             LTIActuator(K, 1, [1.0, 30.0], [1.0, 30.0, 900.0], 1e-3),
             LTIActuator(K, 1, [1.0, 30.0], [1.0, 50.0], 1e-3),
             PerTestLTIActuator(K, 1, [([1.0, 30.0], [1.0, 50.0]), ([900.0], [1.0, 30.0, 900.0])]
                                * (K // 2), 1e-3),
             SensorModel(K, 1, 1e-3, "first_order", 0.004, 0.5, 1.1, 0.1, 0.002, seed=7),
             SensorModel(K, 1, 1e-3, "first_order", 0.004, 0.5, 1.1, 0.1, 0.0,
                         seed=list(range(K)))]
    for part in parts:
        assert peak_bytes(lambda p=part: p(u)) < 4096, type(part).__name__
    comp = Compensator(K, 1, "polynomial", 0.003, 1e-3, 3)
    assert peak_bytes(lambda: comp(u, u)) < 4096


@pytest.mark.parametrize("num, den", [
    ([1.0], [1.0, 2.0]),                                  # first order
    ([(2 * math.pi * 40) ** 2], [1.0, 2 * 0.6 * 2 * math.pi * 40, (2 * math.pi * 40) ** 2]),
    ([0.0, 3.0, 7.0, 2.0], [2.0, 5.0, 11.0, 4.0]),         # biproper, leading zero in num
    ([1.0, -40.0, 600.0], [1.0, 40.0, 600.0, 8000.0]),     # non-minimum phase, 3 states
    ([0.0, 0.0, 5.0], [1.0, 1.0, 3.0]),                    # leading zeros in num
    ([4.0], [2.0]),                                        # a static gain
])
def test_discretisation_is_python_controls_to_the_last_bit(num, den):
    """discretise_tf computes what python-control's sample_system(tf2ss(tf)) gives (without
    slycot, SciPy's realisation and zero-order hold) to the last bit, without importing it;
    and the identified platform model the LTI path uses."""
    import control

    from rths3d.transfer.actuators import default_transfer_function, discretise_tf

    cases = [(num, den, 1e-3), (num, den, 2.5e-4)]
    if len(num) == 1 and num[0] == 1.0:
        tf_num, tf_den, _ = default_transfer_function()
        cases.append((tf_num, tf_den, 1e-3))
    for n, d, dt in cases:
        Ad, Bd, Cd, Dd = discretise_tf(n, d, dt)
        sys = control.tf2ss(control.tf(n, d))
        if sys.nstates == 0:
            assert Ad.shape == (0, 0) and Dd == float(np.asarray(sys.D)[0, 0])
            continue
        ref = control.sample_system(sys, dt, method="zoh")
        np.testing.assert_array_equal(Ad, np.asarray(ref.A))
        np.testing.assert_array_equal(Bd, np.asarray(ref.B)[:, 0])
        np.testing.assert_array_equal(Cd, np.asarray(ref.C)[0])
        assert Dd == float(np.asarray(ref.D)[0, 0])


def test_low_frequency_delay_is_scipys_and_the_first_order_lag():
    """delay_estimate equals −∠H(jω)/ω of SciPy's freqs at 10⁻³ rad/s, and a first-order
    lag 1/(τs + 1) delays by τ (s) at low frequency."""
    from rths3d.transfer.actuators import delay_estimate

    for num, den in (([1.0, -40.0, 600.0], [1.0, 40.0, 600.0, 8000.0]),
                     ([(2 * math.pi * 40) ** 2], [1.0, 48 * math.pi, (2 * math.pi * 40) ** 2])):
        _, h = scipy.signal.freqs(num, den, worN=[1e-3])
        assert delay_estimate(num, den) == pytest.approx(-np.angle(h[0]) / 1e-3, rel=1e-12)
    assert delay_estimate([1.0], [4e-3, 1.0]) == pytest.approx(4e-3, rel=1e-6)
