"""Experimental parts: the numpy specimen against the MuJoCo specimen and against statics."""

from __future__ import annotations

import numpy as np
import pytest

from rths3d.experiment import MujocoSpecimen, Specimen1D, payload_xml, world_xml
from rths3d.scene import ExperimentConfig

DT = 1e-3


def _drive(spec, z):
    out = []
    for n in range(len(z) - 1):
        out.append(spec.advance(z[n:n + 1, None] * np.ones((spec.K, 1)),
                                z[n + 1:n + 2, None] * np.ones((spec.K, 1))).copy())
    return np.array(out)[:, :, 0]


def _numpy(cfg, K=1, **kw):
    h0 = cfg.h0 if cfg.kind == "contact" else np.inf
    return Specimen1D(K, cfg.m, cfg.k, cfg.d, h0, cfg.k_contact, cfg.d_contact, dt=DT,
                      substeps=cfg.substeps, **kw)


def test_numpy_equals_mujoco_linear_part():
    """Linear part: the numpy model and the MuJoCo specimen (FTS reading) agree to 1e-6."""
    cfg = ExperimentConfig(kind="linear", m=0.5, k=8650.0)
    t = np.arange(1501) * DT
    z = 0.004 * np.sin(2 * np.pi * 3 * t) + 0.002 * np.sin(2 * np.pi * 17 * t)
    fa = _drive(_numpy(cfg), z)
    fb = _drive(MujocoSpecimen(cfg, ("z",), DT), z)
    assert np.max(np.abs(fa - fb)) < 1e-6 * np.max(np.abs(fa))


def test_numpy_close_to_mujoco_contact_part():
    """Contact part: penalty model and MuJoCo soft contact agree within 10 % RMS and peak."""
    cfg = ExperimentConfig(kind="contact", h0=0.003)
    t = np.arange(2001) * DT
    z = 0.004 * (1 - np.cos(2 * np.pi * 1.0 * t))
    fa = _drive(_numpy(cfg), z)[:, 0]
    fb = _drive(MujocoSpecimen(cfg, ("z",), DT), z)[:, 0]
    assert np.sqrt(np.mean((fa - fb) ** 2)) < 0.10 * np.sqrt(np.mean(fa**2))
    assert abs(fa.max() - fb.max()) < 0.10 * fa.max()
    assert fa.max() > 20.0  # the mass really hits the surface


def test_numpy_contact_statics_series_springs():
    """Pushed slowly into the surface, F = (z − h0)·k k_c/(k + k_c) (springs in series)."""
    cfg = ExperimentConfig(kind="contact", h0=0.002, d_contact=40.0, d=5.0)
    t = np.arange(3001) * DT
    z = np.minimum(t, 1.0) * 0.006
    f = _drive(_numpy(cfg), z)[-1, 0]
    k, kc = cfg.k, cfg.k_contact
    assert f == pytest.approx((0.006 - 0.002) * k * kc / (k + kc), rel=1e-3)


def test_rk4_and_euler_converge_to_same_response():
    """The specimen's RK4 and semi-implicit Euler agree better as substeps increase."""
    cfg = ExperimentConfig(kind="contact", h0=0.003)
    t = np.arange(1001) * DT
    z = 0.004 * (1 - np.cos(2 * np.pi * 1.0 * t))
    ref = _drive(_numpy(cfg, method="rk4"), z)
    errs = []
    for ns in (2, 8, 32):
        c = ExperimentConfig(kind="contact", h0=0.003, substeps=ns)
        errs.append(np.max(np.abs(_drive(_numpy(c), z) - ref)))
    assert errs[0] > errs[1] > errs[2]


def test_multidof_contact_wrench_moment_balance():
    """Multi-DOF bar pressed into the surface: f_ry = −arm·f_z at rest, f_z > 0."""
    cfg = ExperimentConfig(kind="multidof", h0=0.002, m=0.5, inertia=0.002, k_rot=40.0,
                           arm=0.1, d=20.0, d_rot=0.5)
    spec = MujocoSpecimen(cfg, ("z", "ry"), DT)
    t = np.arange(2001) * DT
    zz = np.minimum(t / 0.5, 1.0) * 0.005
    f = None
    for n in range(2000):
        a = np.array([[zz[n], 0.0]])
        b = np.array([[zz[n + 1], 0.0]])
        f = spec.advance(a, b).copy()
    assert f[0, 0] > 5.0
    assert f[0, 1] == pytest.approx(-cfg.arm * f[0, 0], rel=0.1)


@pytest.mark.parametrize("kind", ["contact", "linear", "multidof"])
def test_fragments_compile_on_the_platform(kind):
    """The MJCF fragments compile in the Stewart platform model (surface above the tip)."""
    model_mod = pytest.importorskip("rths3d.platform.model")
    import mujoco

    cfg = ExperimentConfig(kind=kind)
    g = model_mod.PlatformConfig().geometry
    site = (0.0, 0.0, g.home_height + g.fts_height)
    m = model_mod.build_model(model_mod.PlatformConfig(), payload_xml(cfg), world_xml(cfg, site))
    assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "exp_heave") >= 0
    if kind != "linear":
        assert mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "exp_surface") >= 0


def test_rk4_part_converges_at_fourth_order_to_the_exact_linear_response():
    """The reference's RK4 part (no contact) against scipy's lsim, exact for a mount moving
    linearly over each step (m ẍ = k (z − x) + d (ż − ẋ), F = k (z − x) + d (ż − ẋ)): the
    error falls 16× per halving of the substep (fourth order) and is < 2e-5 of the peak force
    at the reference's 2 substeps of 1 ms."""
    from scipy import signal

    m, k, d = 0.4, 8650.0, 3.0
    t = np.arange(2001) * DT
    z = 0.004 * np.sin(2 * np.pi * 3 * t) + 0.001 * np.sin(2 * np.pi * 23 * t)
    A = [[0, 1], [-k / m, -d / m]]
    _, _, xs = signal.lsim(signal.StateSpace(A, [[0], [k / m]], [[1, 0]], [[0]]), z, t,
                           interp=True)
    # d ż/m: the mount's velocity is constant within a step, a held input (superposition)
    zd = np.diff(z) / DT
    _, _, xd = signal.lsim(signal.StateSpace(A, [[0], [d / m]], [[1, 0]], [[0]]),
                           np.append(zd, zd[-1]), t, interp=False)
    x, v = xs[:, 0] + xd[:, 0], xs[:, 1] + xd[:, 1]
    want = k * (z[1:] - x[1:]) + d * (zd - v[1:])
    errs = []
    for ns in (2, 4, 8):
        f = _drive(Specimen1D(2, m, k, d, np.inf, dt=DT, substeps=ns, method="rk4"), z)
        np.testing.assert_array_equal(f[:, 0], f[:, 1])  # tests of a batch step alike
        errs.append(np.max(np.abs(f[:, 0] - want)) / np.max(np.abs(want)))
    assert errs[0] < 2e-5
    assert errs[0] / errs[1] > 12 and errs[1] / errs[2] > 12
