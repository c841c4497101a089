"""Known answers of the tracking, SSP and FEI measures on delayed, scaled sines."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from rths3d.metrics import (
    e_mte_track,
    e_peak_track,
    e_rel_track,
    e_rel_track_f,
    fei,
    paei,
    theta_pc,
    ti,
    ti_history,
)

DT = 1e-3
DURATION = 4.0  # s: a whole number of periods for every f below
FREQS = (0.25, 0.5, 1.0, 2.0, 5.0)  # Hz
AMPS = (0.8, 1.0, 1.2)
DELAYS = (0.001, 0.005, 0.02)  # s
GRID = list(itertools.product(FREQS, AMPS, DELAYS))


def sines(f: float, a: float, tau: float, endpoint: bool = False):
    """z = sin 2πft, z' = a sin 2πf(t − τ) on whole periods (N or N+1 samples)."""
    n = int(round(DURATION / DT)) + (1 if endpoint else 0)
    t = np.arange(n) * DT
    return t, np.sin(2 * np.pi * f * t), a * np.sin(2 * np.pi * f * (t - tau))


@pytest.mark.parametrize("f,a,tau", GRID)
def test_fei_recovers_delay_and_amplitude(f, a, tau):
    """FEI on whole periods: d = τ within 1 %, A = a within 1e-3, f_eq = f."""
    _, z, zp = sines(f, a, tau)
    r = fei(z, zp, DT)
    assert r.d == pytest.approx(tau, rel=0.01)
    assert abs(r.A - a) < 1e-3
    assert r.f_eq == pytest.approx(f, rel=1e-9)
    assert r.phi == pytest.approx(-2 * np.pi * f * tau, rel=0.01)


@pytest.mark.parametrize("f,a,tau", GRID)
def test_e_rel_track_closed_form(f, a, tau):
    """e_rel,track = √(1 + a² − 2a cos 2πfτ) for a delayed, scaled sine."""
    _, z, zp = sines(f, a, tau)
    expected = math.sqrt(1 + a * a - 2 * a * math.cos(2 * math.pi * f * tau))
    assert e_rel_track(z, zp) == pytest.approx(expected, rel=1e-9)
    # Parseval: the frequency-domain twin (eq. 4, complex reading) equals it on whole periods
    assert e_rel_track_f(z, zp) == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize("f,a,tau", GRID)
def test_ti_per_period_analytic(f, a, tau):
    """TI after k whole periods equals −kπ a sin(2πfτ) (trapezoid error < 2e-4)."""
    _, z, zp = sines(f, a, tau, endpoint=True)
    hist = ti_history(z, zp)
    per = int(round(1.0 / (f * DT)))
    phi = 2 * math.pi * f * tau
    for k in range(1, int(round(DURATION * f)) + 1):
        assert hist[k * per] == pytest.approx(-k * math.pi * a * math.sin(phi), rel=2e-4)
    # the sampled sum has the exact value −(N/2) a sin φ sin(ωΔT)
    n_int = len(z) - 1
    exact = -0.5 * n_int * a * math.sin(phi) * math.sin(2 * math.pi * f * DT)
    assert ti(z, zp) == pytest.approx(exact, rel=1e-8)


def test_ti_sign_and_rotation_sense():
    """Lag drives TI negative and the SSP (z horizontal, z' vertical) counter-clockwise."""
    t, z, zp = sines(1.0, 1.0, 0.02, endpoint=True)
    assert ti(z, zp) < 0
    assert ti(zp, z) > 0  # lead (roles swapped) drives TI positive
    # shoelace signed area of the traversed curve (positive = counter-clockwise)
    area = 0.5 * np.sum(z[:-1] * zp[1:] - z[1:] * zp[:-1])
    assert area > 0
    assert ti(z, zp) == pytest.approx(-area, rel=1e-12)


@pytest.mark.parametrize("f,a,tau", GRID)
def test_paei_recovers_phase_and_amplitude(f, a, tau):
    """PAEI ellipse fit: phase 2πfτ and amplitude a within 2 %."""
    _, z, zp = sines(f, a, tau, endpoint=True)
    phase, amp = paei(z, zp)
    assert phase == pytest.approx(2 * math.pi * f * tau, rel=0.02)
    assert amp == pytest.approx(a, rel=0.02)


def test_paei_lead_is_negative_and_large_lag_resolved():
    """PAEI gives a negative phase for a lead and resolves lags beyond 90° (atan2)."""
    _, z, zp = sines(1.0, 1.0, -0.01, endpoint=True)
    assert paei(z, zp)[0] == pytest.approx(-2 * math.pi * 0.01, rel=0.02)
    _, z, zp = sines(1.0, 0.9, 0.35, endpoint=True)  # 126° lag
    phase, amp = paei(z, zp)
    assert phase == pytest.approx(2 * math.pi * 0.35, rel=0.02)
    assert amp == pytest.approx(0.9, rel=0.02)


@pytest.mark.parametrize("f,a", list(itertools.product(FREQS, AMPS)))
def test_theta_pc_gives_amplitude_without_delay(f, a):
    """Θ_PC (major-axis slope) equals a within 1 % for τ = 0."""
    _, z, zp = sines(f, a, 0.0)
    assert theta_pc(z, zp) == pytest.approx(a, rel=0.01)


def test_peak_and_mte_on_scaled_sine():
    """e_peak,track = |1 − a|/a and e_MTE,track = |1 − a|/a for z' = a z (normalised by z')."""
    _, z, zp = sines(1.0, 0.8, 0.0)
    assert e_peak_track(z, zp) == pytest.approx(0.2 / 0.8, rel=1e-9)
    assert e_mte_track(z, zp) == pytest.approx(0.2 / 0.8, rel=1e-9)
    assert e_mte_track(z, zp, norm="commanded") == pytest.approx(0.2, rel=1e-9)


def test_ideal_transfer_gives_zero_tracking_errors():
    """z' = z on a broadband random command: every tracking error < 1e-9, A = 1, d = 0."""
    rng = np.random.default_rng(1)
    z = np.cumsum(rng.standard_normal((5000, 3)), axis=0) * 1e-4
    zp = z.copy()
    for fn in (e_rel_track, e_mte_track, e_peak_track, e_rel_track_f):
        assert np.all(np.abs(fn(z, zp)) < 1e-9)
    r = fei(z, zp, DT)
    assert np.all(np.abs(r.A - 1) < 1e-9) and np.all(np.abs(r.d) < 1e-9)
    assert np.all(np.abs(ti(z, zp)) < 1e-9)
    phase, amp = paei(z, zp)
    assert np.all(np.abs(phase) < 1e-9) and np.all(np.abs(amp - 1) < 1e-9)


def test_fei_exponent_weights_commanded_spectrum():
    """With two tones, f_eq is the |Z|^l-weighted mean frequency; l changes it as predicted."""
    t = np.arange(4000) * DT
    z = 1.0 * np.sin(2 * np.pi * 1 * t) + 0.5 * np.sin(2 * np.pi * 3 * t)
    zp = z.copy()
    for l in (1.0, 2.0, 4.0):
        w1, w3 = 1.0**l, 0.5**l
        assert fei(z, zp, DT, l=l).f_eq == pytest.approx((w1 * 1 + w3 * 3) / (w1 + w3),
                                                         rel=1e-9)


def test_multi_dof_equals_column_by_column():
    """An (N, ndof) input gives per-column results identical to 1-D calls."""
    cols = [sines(f, a, tau) for f, a, tau in ((0.5, 0.9, 0.004), (2.0, 1.1, 0.012))]
    z = np.column_stack([c[1] for c in cols])
    zp = np.column_stack([c[2] for c in cols])
    for fn in (e_rel_track, e_mte_track, e_peak_track, e_rel_track_f, ti, theta_pc):
        both = fn(z, zp)
        for j in range(2):
            assert both[j] == pytest.approx(fn(z[:, j], zp[:, j]), rel=1e-12)
    r = fei(z, zp, DT)
    assert r.d[1] == pytest.approx(fei(z[:, 1], zp[:, 1], DT).d, rel=1e-12)


def test_paei_history_tracks_a_change_of_delay():
    """Windowed PAEI follows a delay that switches from 5 ms to 15 ms halfway (2 %)."""
    from rths3d.metrics import paei_history

    f = 1.0
    t = np.arange(10000) * DT
    tau = np.where(t < 5.0, 0.005, 0.015)
    z = np.sin(2 * np.pi * f * t)
    zp = 0.9 * np.sin(2 * np.pi * f * (t - tau))
    t_mid, phase, amp = paei_history(z, zp, DT, window=1.0)
    early = (t_mid > 0.6) & (t_mid < 4.4)
    late = (t_mid > 5.6) & (t_mid < 9.4)
    assert np.allclose(phase[early], 2 * np.pi * f * 0.005, rtol=0.02)
    assert np.allclose(phase[late], 2 * np.pi * f * 0.015, rtol=0.02)
    assert np.allclose(amp[early | late], 0.9, rtol=0.02)


def test_ti_scales_with_amplitude_squared():
    """TI is qualitative: scaling both signals by s scales TI by s² (Θ_PC, PAEI, FEI do not)."""
    _, z, zp = sines(1.0, 0.9, 0.01, endpoint=True)
    assert ti(3 * z, 3 * zp) == pytest.approx(9 * ti(z, zp), rel=1e-9)
    assert paei(3 * z, 3 * zp)[0] == pytest.approx(paei(z, zp)[0], rel=1e-9)
    assert fei(3 * z, 3 * zp, DT).d == pytest.approx(fei(z, zp, DT).d, rel=1e-12)


@pytest.mark.parametrize("periods,d", [(4.2, 9.23e-3), (10.3, 9.59e-3)])
def test_fei_leakage_on_partial_periods_is_as_documented(periods, d):
    """On records that are not whole periods the FEI delay has the documented leakage bias."""
    t = np.arange(int(periods / 2.0 / DT)) * DT
    r = fei(np.sin(4 * np.pi * t), np.sin(4 * np.pi * (t - 0.01)), DT)
    assert r.d == pytest.approx(d, abs=0.01e-3)
    assert f"{d * 1e3:.2f} ms on {periods} periods" in " ".join(fei.__doc__.split())
