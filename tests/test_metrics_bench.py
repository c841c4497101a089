"""The bench-load peaks (stroke, command velocity, interface force) on known signals and runs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rths3d import Record, RecordError
from rths3d.metrics import compute_measures, force_peak, stroke_peak, velocity_peak

DT = 1e-3


def test_peaks_of_a_sine_with_offset():
    """z = 0.01 sin 2π·2t (m), F = −3 + 2 sin: stroke 0.01 m, velocity 2π·2·0.01 m/s, force 5 N."""
    t = np.arange(4000) * DT
    z = 0.01 * np.sin(2 * np.pi * 2.0 * t)
    f = -3.0 + 2.0 * np.sin(2 * np.pi * 2.0 * t)
    assert stroke_peak(z) == pytest.approx(0.01, rel=1e-6)
    # central differences under-read a sine by (ω dt)²/6 = 2.6e-5
    assert velocity_peak(z, DT) == pytest.approx(2 * np.pi * 2.0 * 0.01, rel=1e-4)
    assert force_peak(f) == pytest.approx(5.0, rel=1e-6)


def test_peaks_per_dof_and_sign():
    """(N, 2) input gives one peak per DOF; a negative excursion counts as its magnitude."""
    t = np.arange(2000) * DT
    z = np.column_stack([-0.02 * np.sin(2 * np.pi * t) ** 2, 0.1 * np.sin(2 * np.pi * 0.5 * t)])
    np.testing.assert_allclose(stroke_peak(z), [0.02, 0.1], rtol=1e-5)
    np.testing.assert_allclose(velocity_peak(z, DT), [0.02 * 2 * np.pi, 0.1 * np.pi], rtol=1e-4)


def test_bad_input_names_the_signal():
    """A non-finite sample and a bad dt raise RecordError naming the signal and the value."""
    z = np.zeros(10)
    z[3] = np.nan
    with pytest.raises(RecordError, match="'z'.*sample 3"):
        stroke_peak(z)
    with pytest.raises(RecordError, match="dt"):
        velocity_peak(np.zeros(10), 0.0)


def test_compute_measures_carries_the_bench_load():
    """compute_measures reports stroke_peak, velocity_peak and force_peak of the record."""
    t = np.arange(3000) * DT
    z = 0.005 * (1 - np.cos(2 * np.pi * t))
    rec = Record(t, {"z_cmd": z, "z_meas": np.roll(z, 3), "f_meas": 8650.0 * z})
    m = compute_measures(rec)
    assert m["stroke_peak"] == pytest.approx(0.01, rel=1e-5)
    assert m["velocity_peak"] == pytest.approx(0.005 * 2 * np.pi, rel=1e-4)
    assert m["force_peak"] == pytest.approx(86.5, rel=1e-5)


def test_velocity_rating_below_the_peak_stops_the_run():
    """A completed run's velocity_peak, set as the bench's velocity rating just below it, stops
    the same test with the velocity limit (the peak measures what the bench limits)."""
    scene_mod = pytest.importorskip("rths3d.scene")
    loop = pytest.importorskip("rths3d.loop")
    scene = scene_mod.load_scene("paper_contact", ["duration=3.0"])
    done = loop.run(scene, "lti", reference=False)
    assert done.status == "ok", done.reason
    m = compute_measures(done.record)
    assert 0 < m["velocity_peak"] < scene.safety.velocity
    assert m["force_peak"] < scene.safety.force
    assert m["stroke_peak"] < scene.safety.stroke
    rated = scene_mod.load_scene("paper_contact",
                                 ["duration=3.0", f"safety.velocity={0.97 * m['velocity_peak']}"])
    stopped = loop.run(rated, "lti", reference=False)
    assert stopped.status == "stopped"
    assert "velocity" in stopped.reason
    assert math.isfinite(compute_measures(stopped.record)["velocity_peak"])
