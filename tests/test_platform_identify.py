"""Heave identification: multisine, response measurement, TF fit and the TF file."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rths3d.errors import ConfigError
from rths3d.platform.calibrate.heave import (
    DEFAULT_TF_PATH,
    fit_transfer_function,
    heave_response,
    identify_heave,
    load_heave_tf,
    multisine,
)
from rths3d.platform.model import PlatformConfig, predicted_delay


def test_multisine_lines_amplitudes_and_periodicity():
    """Lines lie on the period's grid within the band; amplitudes respect the velocity cap."""
    f, z = multisine(0.1, 50.0, n_lines=40, period=10.0, amplitude=5e-4, velocity=5e-3)
    assert f.min() == pytest.approx(0.1) and f.max() == pytest.approx(50.0)
    assert np.allclose(f * 10.0, np.round(f * 10.0))
    spec = np.abs(np.fft.rfft(z)) * 2 / z.size
    idx = np.round(f * 10.0).astype(int)
    assert np.allclose(spec[idx], np.minimum(5e-4, 5e-3 / (2 * np.pi * f)), rtol=1e-9)
    off = np.ones(spec.size, bool)
    off[idx] = False
    assert spec[off].max() < 1e-12  # energy only at the excited lines
    with pytest.raises(ConfigError, match="frequency range"):
        multisine(0.1, 800.0)


def test_fit_recovers_known_transfer_function():
    """A response generated from a known TF with delay is fitted back to its coefficients."""
    num = np.array([0.012, 1.0])
    den = np.array([4.0e-5, 0.015, 1.0])
    T = 0.0021
    f = np.geomspace(0.1, 50, 40)
    s = 2j * np.pi * f
    H = np.polyval(num, s) / np.polyval(den, s) * np.exp(-s * T)
    n, d, delay, err = fit_transfer_function(f, H, 1, 2, guess=([0.0, 1.0], [0.0, 0.01, 1.0],
                                                                 0.0))
    assert err < 1e-8
    assert np.allclose(n, num, rtol=1e-5) and np.allclose(d, den, rtol=1e-5)
    assert delay == pytest.approx(T, abs=1e-8)


def test_heave_response_low_frequency_matches_prediction():
    """Measured heave response: unit gain and the predicted delay at low frequency."""
    cfg = PlatformConfig()
    f, H = heave_response(cfg, periods=2, f_min=0.2, f_max=40.0, n_lines=16, period=5.0)
    i = int(np.argmin(np.abs(f - 1.0)))
    assert abs(abs(H[i]) - 1.0) < 0.01
    delay = -np.angle(H[i]) / (2 * np.pi * f[i])
    assert delay == pytest.approx(predicted_delay(cfg, f[i]), abs=0.5e-3)
    # the phase lag grows with frequency (a causal, delayed system)
    assert np.all(np.diff(np.unwrap(np.angle(H))) < 0)


def test_identify_save_load_round_trip(tmp_path):
    """identify → JSON file (documented keys) → load_heave_tf gives the same response."""
    poses = {"home": (0,) * 6, "raised 20 mm": (0, 0, 0.02, 0, 0, 0)}
    res = identify_heave(PlatformConfig(), poses=poses, f_min=0.2, f_max=40.0, n_lines=16,
                         period=5.0)
    assert res.tf.fit_error < 0.05
    assert 0.0 <= res.tf.delay < 0.01
    path = res.save(tmp_path / "tf.json")
    raw = json.loads(path.read_text())
    for key in ("format", "num", "den", "delay", "dt", "fit_error", "frequency_range",
                "conditions", "frequencies", "response", "platform"):
        assert key in raw
    assert [c["label"] for c in raw["conditions"]] == list(poses)
    tf = load_heave_tf(path)
    f = np.array([0.5, 2.0, 20.0])
    assert np.allclose(tf.frequency_response(f), res.tf.frequency_response(f))
    # the fit keeps the low-frequency delay the actuator settings predict
    assert tf.phase_delay(1.0) == pytest.approx(predicted_delay(PlatformConfig(), 1.0),
                                                abs=0.5e-3)
    png = res.bode_plot(tmp_path / "bode.png")
    assert png.stat().st_size > 10_000


def test_load_errors_name_file_and_key(tmp_path):
    """Missing files and keys raise ConfigError naming them."""
    with pytest.raises(ConfigError, match="does not exist"):
        load_heave_tf(tmp_path / "nope.json")
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps({"num": [1.0], "den": [1.0]}))
    with pytest.raises(ConfigError, match="bad.json: delay"):
        load_heave_tf(bad)


def test_shipped_tf_file_is_valid():
    """The repository's assets/platform_heave_tf.json loads and has unit DC gain."""
    if not DEFAULT_TF_PATH.exists():
        pytest.skip("assets/platform_heave_tf.json not generated yet")
    tf = load_heave_tf()
    assert abs(abs(tf.frequency_response(np.array([0.1]))[0]) - 1.0) < 0.01
    assert 0.0 < tf.phase_delay(1.0) < 0.02


def test_phase_delay_is_unwrapped_and_continuous():
    """phase_delay keeps the phase continuous past ±π: a 4 ms delay reads 4 ms at 200 Hz, and
    the fitted TF's delay stays positive and smooth up to Nyquist (150 Hz: 3.37 ms)."""
    from rths3d.platform.calibrate.heave import HeaveTF

    assert HeaveTF((1.0,), (1.0,), 0.004).phase_delay(200.0) == pytest.approx(0.004, rel=1e-12)
    tf = HeaveTF((0.01675675345674155, 1.001559159783512),
                 (5.2526425650756956e-05, 0.01820975589072879, 1.0), 0.0020143104599365065)
    assert tf.phase_delay(150.0) == pytest.approx(3.367e-3, abs=1e-5)
    f = np.linspace(0.05, 500.0, 2000)
    d = np.array([tf.phase_delay(x) for x in f])
    ref = -np.unwrap(np.angle(tf.frequency_response(f))) / (2 * np.pi * f)
    np.testing.assert_allclose(d, ref, rtol=0, atol=1e-15)
    assert d.min() > 0.0024
    # below the wrap the value is the principal angle's, bit for bit (published figures)
    g = complex(tf.frequency_response(np.array([1.0]))[0])
    assert tf.phase_delay(1.0) == -np.arctan2(g.imag, g.real) / (2 * np.pi * 1.0)
