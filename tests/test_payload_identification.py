"""Payload identification (rths3d.diagnose.payload) against an analytic payload: the wrench is
computed in the test by Newton–Euler about the centre of mass in world axes, from a pose
trajectory differentiated on a 20× finer time grid, then sampled at 1 kHz with sensor noise."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from rths3d.diagnose.payload import (
    PARAMETERS,
    PayloadIdentification,
    payload_parameters,
    regressor,
)
from rths3d.errors import ConfigError

sys.path.insert(0, str(Path(__file__).resolve().parent))
from independent import rotation_by_products  # noqa: E402

G = 9.81
MASS = 4.0  # kg
COM = np.array([0.02, -0.01, 0.045])  # m, sensor frame
# about the centre of mass: Ixx, Iyy, Izz, Ixy, Ixz, Iyz (kg·m²), a block 0.16 × 0.12 × 0.09 m
INERTIA = np.array([0.0075, 0.0112, 0.0133, 0.0006, -0.0004, 0.0003])
SENSOR = np.array([0.01, -0.005, 0.04, 0.0, 0.0, 0.3])  # sensor frame on the plate (m, rad)


def _tensor(v):
    xx, yy, zz, xy, xz, yz = v
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def _poses(t, axes=(0, 1, 2, 3, 4, 5)):
    """A multisine pose (N, 6) on the chosen axes: 2–9 Hz, ±4 mm, ±0.03 rad."""
    q = np.zeros((t.size, 6))
    freqs = [(2.1, 4.3, 7.9), (2.7, 5.1, 8.3), (1.9, 3.7, 6.1), (2.3, 4.7, 8.9),
             (3.1, 5.9, 7.3), (1.7, 4.1, 6.7)]
    for j in axes:
        amp = 0.004 if j < 3 else 0.03
        for i, f in enumerate(freqs[j]):
            q[:, j] += amp / 3 * np.sin(2 * math.pi * f * t + 0.7 * i + 0.4 * j)
    return q


def _wrench(t_fine, q_fine, step):
    """Sensor-frame wrench the payload exerts on the sensor, by Newton–Euler about its centre
    of mass in world axes (finite differences of quaternion-free rotation matrices on the
    fine grid), every ``step``-th sample."""
    h = t_fine[1] - t_fine[0]
    Rs = rotation_by_products(*SENSOR[3:])
    Rw = np.array([rotation_by_products(*row[3:]) @ Rs for row in q_fine])
    plate_R = np.array([rotation_by_products(*row[3:]) for row in q_fine])
    origin = q_fine[:, :3] + np.einsum("nij,j->ni", plate_R, SENSOR[:3])
    com_w = origin + np.einsum("nij,j->ni", Rw, COM)
    acc = np.gradient(np.gradient(com_w, h, axis=0), h, axis=0)
    # angular velocity from R_{n+1} R_{n-1}^T (small rotation over 2h)
    om = np.zeros((len(t_fine), 3))
    D = Rw[2:] @ np.swapaxes(Rw[:-2], 1, 2)
    om[1:-1] = 0.5 * np.stack([D[:, 2, 1] - D[:, 1, 2], D[:, 0, 2] - D[:, 2, 0],
                               D[:, 1, 0] - D[:, 0, 1]], axis=1) / (2 * h)
    om[0], om[-1] = om[1], om[-2]
    dom = np.gradient(om, h, axis=0)
    Ic = _tensor(INERTIA)
    out = []
    for n in range(0, len(t_fine), step):
        Iw = Rw[n] @ Ic @ Rw[n].T
        f = MASS * (acc[n] - np.array([0.0, 0.0, -G]))
        tau_c = Iw @ dom[n] + np.cross(om[n], Iw @ om[n])
        tau = tau_c + np.cross(com_w[n] - origin[n], f)
        out.append(np.concatenate([Rw[n].T @ f, Rw[n].T @ tau]))
    return np.array(out)


@pytest.fixture(scope="module")
def six_dof():
    dt, sub = 1e-3, 10
    t_f = np.arange(0, 3.0 + 1e-9, dt / sub)
    q_f = _poses(t_f)
    w = _wrench(t_f, q_f, sub)
    q = q_f[::sub]
    rng = np.random.default_rng(4)
    q_meas = q + rng.normal(0, 1e-6, q.shape) * np.r_[1, 1, 1, 5, 5, 5]
    w_meas = w + rng.normal(0, 1.0, w.shape) * np.r_[0.1, 0.1, 0.1, 0.005, 0.005, 0.005]
    return q, q_meas, w, w_meas, dt


def test_regressor_matches_newton_euler_about_the_com():
    """A(a − g, ω, ω̇) φ equals Newton–Euler about the centre of mass at random states."""
    rng = np.random.default_rng(1)
    phi = payload_parameters(MASS, COM, INERTIA)
    Ic = _tensor(INERTIA)
    for _ in range(20):
        a, w, dw = rng.normal(size=(3, 3)) * [[3.0], [1.0], [20.0]]
        ac = a + np.cross(dw, COM) + np.cross(w, np.cross(w, COM))  # COM acceleration − g
        f = MASS * ac
        tau = Ic @ dw + np.cross(w, Ic @ w) + np.cross(COM, f)
        got = regressor(a[None], w[None], dw[None])[0] @ phi
        np.testing.assert_allclose(got, np.r_[f, tau], rtol=1e-12, atol=1e-12)


def test_six_dof_motion_identifies_all_ten(six_dof):
    """A 6-DOF multisine with 1 µm / 5 µrad pose noise and 0.1 N / 5 mN·m wrench noise: mass
    within 0.5 %, centre of mass within 1 mm, the inertia about the COM within 5 % of its
    largest entry, every parameter seen, a finite condition number."""
    _, q_meas, _, w_meas, dt = six_dof
    est = PayloadIdentification(SENSOR, cutoff=25.0).fit(q_meas, w_meas, dt)
    assert est.unseen_ == ()
    assert math.isfinite(est.condition_number_) and est.condition_number_ > 1
    assert abs(est.mass_ - MASS) < 0.005 * MASS
    assert np.max(np.abs(est.com_ - COM)) < 1e-3
    err = np.abs(est.inertia_ - _tensor(INERTIA))
    assert err.max() < 0.05 * np.abs(INERTIA).max(), err
    assert all(np.isfinite(est.std_))
    # the fit's residual is at the filtered noise level: well below the raw noise
    assert est.residual_rms_[2] < 0.1 and est.residual_rms_[5] < 0.005
    assert any("cannot see: nothing" in line for line in est.lines())


def test_heave_only_cannot_see_the_inertia_nor_mcz(six_dof):
    """Heave alone (no rotation): m, m·cx, m·cy identified; m·cz and the six inertia
    entries reported unseen, condition number infinite."""
    dt, sub = 1e-3, 10
    t_f = np.arange(0, 2.0 + 1e-9, dt / sub)
    q_f = _poses(t_f, axes=(2,))
    w = _wrench(t_f, q_f, sub)
    est = PayloadIdentification(SENSOR).fit(q_f[::sub], w, dt)
    assert set(est.unseen_) == {"m*cz", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz"}
    assert math.isinf(est.condition_number_)
    assert abs(est.phi_[0] - MASS) < 1e-3 * MASS
    np.testing.assert_allclose(est.phi_[1:3], MASS * COM[:2], atol=2e-5)
    assert np.isinf(est.std_[PARAMETERS.index("Izz")])


def test_predict_reproduces_the_wrench(six_dof):
    """predict() of the true φ along the true pose reproduces the analytic wrench (after the
    same low-pass) to 1 % of its range."""
    q, _, w, _, dt = six_dof
    est = PayloadIdentification(SENSOR, cutoff=25.0)
    got = est.predict(q, dt, phi=payload_parameters(MASS, COM, INERTIA))
    ref = est._filter(w, dt)
    k = 100
    for j in range(6):
        span = np.ptp(ref[k:-k, j])
        assert np.max(np.abs(got[k:-k, j] - ref[k:-k, j])) < 0.01 * span + 1e-9, j


def test_bad_input_names_the_field():
    """Wrong shapes and values give a ConfigError naming the field."""
    with pytest.raises(ConfigError, match="sensor"):
        PayloadIdentification((0, 0, 0.03))
    with pytest.raises(ConfigError, match="cutoff"):
        PayloadIdentification(cutoff=-1)
    with pytest.raises(ConfigError, match="wrench"):
        PayloadIdentification().fit(np.zeros((100, 6)), np.zeros((99, 6)), 1e-3)
