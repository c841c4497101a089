"""Tests of the RTHS benchmark criteria J1–J9 (rths3d.metrics.criteria) on signals with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rths3d.errors import ConfigError
from rths3d.metrics.criteria import benchmark_row, j_criteria, peak_error, std_error, tracking_delay

DT = 1.0 / 4096


def _chirp(n: int = 20000) -> np.ndarray:
    t = DT * np.arange(n)
    return np.sin(2 * np.pi * (0.5 + 1.5 * t) * t) * np.exp(-0.1 * t)


@pytest.mark.parametrize("lag", [0, 7, 19, 33])
def test_tracking_delay_recovers_integer_lag(lag):
    """J1 finds the sample lag of a delayed copy (Pearson correlation peak), in s."""
    x = _chirp()
    y = np.concatenate([np.zeros(lag), x[: x.size - lag]])
    assert tracking_delay(x, y, DT) == pytest.approx(lag * DT, abs=1e-15)


def test_tracking_delay_is_gain_and_offset_invariant():
    """Pearson normalisation makes J1 independent of gain and offset of the measurement."""
    x = _chirp()
    y = 0.7 * np.concatenate([np.zeros(12), x[:-12]]) + 3e-3
    assert tracking_delay(x, y, DT) == pytest.approx(12 * DT)


def test_j1_rounding_to_tenth_of_ms():
    """Code convention: J1 = R(10000·lag·Δt)/10 ms; 19 samples at 4096 Hz → 4.6 ms."""
    x = _chirp()
    y = np.concatenate([np.zeros(19), x[:-19]])
    j = j_criteria(x, y, dt=DT)
    assert j["j1"] == pytest.approx(4.6e-3, abs=1e-15)
    assert benchmark_row(j)["J1"] == pytest.approx(4.6)
    assert j_criteria(x, y, dt=DT, convention="paper")["j1"] == pytest.approx(19 * DT)


def test_j2_j3_for_gain_error():
    """A 10 % gain error gives J2 = J3 = 10 % (std and peak ratios)."""
    x = _chirp()
    j = j_criteria(x, 1.1 * x, dt=DT)
    assert j["j2"] == pytest.approx(10.0, abs=1e-9)
    assert j["j3"] == pytest.approx(10.0, abs=1e-9)
    assert math.isnan(j["j4"]) and math.isnan(j["j9"])


def test_std_removes_mean_rms_does_not():
    """std_error ignores a constant offset (code); the RMS form (paper) counts it."""
    x = _chirp()
    off = 0.05 * np.max(np.abs(x))
    assert std_error(x + off, x) == pytest.approx(0.0, abs=1e-9)
    rms_x = math.sqrt(np.mean(x * x))
    assert std_error(x + off, x, rms=True) == pytest.approx(100 * off / rms_x, rel=1e-9)
    assert peak_error(x + off, x) == pytest.approx(100 * off / np.max(np.abs(x)), rel=1e-9)


def _floors():
    """Reference floors and responses with RMS errors 1, 2, 3 % and peak errors from a spike."""
    x = _chirp()
    ref = np.stack([x, 2 * x, 3 * x], axis=1)
    num = ref * np.array([1.01, 1.02, 1.03])
    return x, ref, num


def test_code_order_versus_paper_order():
    """Code order: J4 J5 = floor-1 std/peak, J6 J7 = floors 2, 3 std; paper: J4–J6 RMS, J7–J9 peak."""
    x, ref, num = _floors()
    spike = num.copy()
    spike[5000, 1] += 0.2 * 2  # floor-2 peak error 20 %
    xm = 1.01 * x
    code = j_criteria(x, xm, spike, ref, dt=DT, rounded=False)
    paper = j_criteria(x, xm, spike, ref, dt=DT, convention="paper")
    assert code["j4"] == pytest.approx(1.0, rel=1e-9)
    assert code["j5"] == pytest.approx(1.0, rel=1e-9)
    assert code["j7"] == pytest.approx(3.0, rel=1e-9)
    assert code["j8"] == pytest.approx(100 * abs(spike[5000, 1] - ref[5000, 1]) / 2 / np.max(np.abs(x)), rel=1e-9)
    assert code["j9"] == pytest.approx(3.0, rel=1e-9)
    # paper: J7 is the floor-1 peak error, J9 the floor-3 peak error, J5 floor-2 RMS
    assert paper["j7"] == pytest.approx(1.0, rel=1e-9)
    assert paper["j9"] == pytest.approx(3.0, rel=1e-9)
    assert paper["j8"] == pytest.approx(code["j8"], rel=1e-12)
    assert paper["j5"] > 2.0  # RMS of floor 2 includes the spike


def test_rounding_halves_away_from_zero_to_hundredths():
    """Code convention rounds J2–J9 to 0.01 % with halves away from zero (MATLAB round)."""
    x = _chirp()
    j = j_criteria(x, 1.123456 * x, dt=DT)
    assert j["j2"] == 12.35 and j["j3"] == 12.35
    j_raw = j_criteria(x, 1.123456 * x, dt=DT, rounded=False)
    assert j_raw["j2"] == pytest.approx(12.3456, rel=1e-9)


def test_interface_only_reference_gives_j4_j5():
    """With a 1-D reference only J4 and J5 are computed; J6–J9 stay NaN."""
    x = _chirp()
    j = j_criteria(x, 1.02 * x, x_ref=1.01 * x, dt=DT, rounded=False)
    assert j["j4"] == pytest.approx(100 * 0.01 / 1.01, rel=1e-9)
    assert all(math.isnan(j[k]) for k in ("j6", "j7", "j8", "j9"))


def test_bad_inputs_name_the_field():
    """Length mismatches, bad conventions and too many lags raise ConfigError naming the field."""
    x = _chirp(200)
    with pytest.raises(ConfigError, match="x_meas"):
        j_criteria(x, x[:-1], dt=DT)
    with pytest.raises(ConfigError, match="convention"):
        j_criteria(x, x, dt=DT, convention="matlab")
    with pytest.raises(ConfigError, match="max_lag"):
        tracking_delay(x, x, DT, max_lag=500)
    with pytest.raises(ConfigError, match="x_ref"):
        j_criteria(x, x, x_ref=np.zeros((10, 3)), dt=DT)
