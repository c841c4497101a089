"""Robustness of the measures to real signals: zero, constant, short, NaN, mismatched input."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rths3d.errors import ConfigError, RecordError
from rths3d.metrics import (
    compute_measures,
    e_error,
    e_mre_ref,
    e_peak_ref,
    e_rel_ref,
    e_rel_ref_f,
    e_rel_track,
    e_rel_track_f,
    fei,
    paei,
    theta_pc,
    ti,
)
from rths3d.record import Record

DT = 1e-3


def test_zero_command_gives_documented_nan():
    """A zero command makes the ratios undefined: NaN, not inf, not a crash."""
    z = np.zeros(100)
    zp = np.linspace(0, 1e-3, 100)
    assert math.isnan(e_rel_track(z, zp))
    assert math.isnan(e_rel_track_f(z, zp))
    r = fei(z, zp, DT)
    assert math.isnan(r.A) and math.isnan(r.d) and math.isnan(r.f_eq)
    assert ti(z, zp) == 0.0


def test_constant_signals():
    """Constant signals: no AC content, FEI NaN; SSP indicators NaN; identical → errors 0."""
    c = np.full(64, 0.3)
    assert math.isnan(fei(c, c, DT).A)
    assert math.isnan(theta_pc(c, c))
    assert all(math.isnan(v) for v in paei(c, c))
    assert e_rel_track(c, c) == 0.0


def test_nan_is_a_clear_error():
    """A NaN names the signal and the sample index."""
    z = np.sin(np.arange(50) * 0.1)
    zp = z.copy()
    zp[17] = np.nan
    with pytest.raises(RecordError, match=r"z_meas.*sample 17"):
        e_rel_track(z, zp)


def test_different_lengths_are_an_error():
    """Signals of different lengths are refused with both lengths named."""
    with pytest.raises(RecordError, match=r"100 vs 99"):
        e_rel_track(np.ones(100), np.ones(99))
    with pytest.raises(RecordError, match="shape"):
        e_rel_ref(np.ones((100, 2)), np.ones((100, 3)))


def test_too_short_is_an_error():
    """Fewer than four samples is refused naming the limit."""
    with pytest.raises(RecordError, match="at least 4"):
        e_rel_track([1.0, 2.0], [1.0, 2.0])
    with pytest.raises(RecordError, match="at least 2"):
        e_error([1.0], [1.0], [1.0])


def test_bad_dt_and_exponent():
    """dt ≤ 0 and a non-positive FEI exponent are refused naming the field."""
    z = np.sin(np.arange(64) * 0.2)
    with pytest.raises(RecordError, match="dt"):
        fei(z, z, 0.0)
    with pytest.raises(ConfigError, match="^l:"):
        fei(z, z, DT, l=0)


def test_identical_records_give_zero_reference_errors():
    """z' = z^r → every reference error is exactly 0."""
    rng = np.random.default_rng(3)
    zr = rng.standard_normal((2000, 2))
    for fn in (e_rel_ref, e_mre_ref, e_peak_ref, e_rel_ref_f):
        assert np.all(fn(zr, zr.copy()) == 0.0)


def test_reference_error_known_value():
    """z' = 1.1 z^r: e_rel,ref = e_MRE,ref = e_peak,ref = 0.1."""
    t = np.arange(4000) * DT
    zr = np.sin(2 * np.pi * t)
    for fn in (e_rel_ref, e_mre_ref, e_peak_ref, e_rel_ref_f):
        assert fn(zr, 1.1 * zr) == pytest.approx(0.1, rel=1e-9)


def test_compute_measures_short_and_zero_record():
    """A very short zero record gives NaN measures, never a crash."""
    t = np.arange(8) * DT
    rec = Record(t, {"z_cmd.z": np.zeros(8), "z_meas.z": np.zeros(8)})
    m = compute_measures(rec)
    assert math.isnan(m["e_rel_track"]) and math.isnan(m["fei_d"])
    assert math.isnan(m.get("j1", math.nan))  # no motion: no delay to find


def test_reference_of_other_length_is_refused():
    """A reference run covering other samples is an error, not silently cut."""
    t = np.arange(100) * DT
    rec = Record(t, {"z_cmd.z": np.sin(t), "z_meas.z": np.sin(t)})
    with pytest.raises(RecordError, match="reference"):
        compute_measures(rec, z_ref=np.sin(np.arange(90) * DT))


def test_record_without_measured_motion_is_refused():
    """Tracking needs z and z': a record with z_cmd only says so."""
    t = np.arange(100) * DT
    rec = Record(t, {"z_cmd.z": np.sin(t), "f_meas.z": np.sin(t)})
    with pytest.raises(RecordError, match="z_meas"):
        compute_measures(rec)


def test_nan_inside_a_record_names_the_column():
    """A NaN in a record built in memory names the record column, row and time."""
    t = np.arange(50) * DT
    zp = np.sin(t)
    zp[7] = np.nan
    rec = Record(t, {"z_cmd.ry": np.sin(t), "z_meas.ry": zp})
    with pytest.raises(RecordError, match=r"z_meas\.ry.*row 7"):
        compute_measures(rec)


def test_fei_of_constant_command_is_nan():
    """A constant command (round-off left in its non-DC bins) has no AC content: FEI NaN."""
    r = fei(np.ones(2000), 1.1 * np.ones(2000), DT)
    assert math.isnan(r.A) and math.isnan(r.d) and math.isnan(r.f_eq)
    two = fei(np.column_stack([np.ones(2000), np.sin(np.arange(2000) * 0.05)]),
              np.column_stack([1.1 * np.ones(2000), np.sin(np.arange(2000) * 0.05)]), DT)
    assert math.isnan(two.A[0]) and two.A[1] == pytest.approx(1.0, rel=1e-6)


def test_theta_pc_of_constant_command_is_nan():
    """Θ_PC is NaN when the command is constant, not the 1e16 of tan(π/2) on round-off."""
    assert math.isnan(theta_pc(np.ones(2000), np.sin(0.01 * np.arange(2000))))
    assert math.isnan(theta_pc(np.zeros(2000), np.sin(0.01 * np.arange(2000))))
    z = np.sin(0.01 * np.arange(2000))
    assert theta_pc(z, 1e8 * z) == pytest.approx(1e8, rel=1e-9)  # a real steep slope stays


def test_tracking_delay_of_constant_signals_is_nan():
    """J1 of constant signals (no finite correlation at any lag) is NaN, not 0 s."""
    from rths3d.metrics.criteria import j_criteria, tracking_delay

    c = np.full(500, 0.02)
    assert math.isnan(tracking_delay(c, c, DT))
    assert math.isnan(j_criteria(c, c, dt=DT)["j1"])


def test_paei_history_non_finite_window_or_step_is_config_error():
    """A NaN/inf/text window or step raises ConfigError naming it, not a ValueError."""
    from rths3d.metrics import paei_history

    t = np.arange(3000) * DT
    z = np.sin(2 * np.pi * t)
    for kw, field in ((dict(window=math.nan), "window"), (dict(window="half"), "window"),
                      (dict(window=0.5, step=math.nan), "step"),
                      (dict(window=0.5, step=-0.1), "step")):
        with pytest.raises(ConfigError, match=f"^{field}:"):
            paei_history(z, z, DT, **kw)
