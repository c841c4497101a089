"""The reference solution z^r: exact coupling against an independent linear solution, and
convergence as the step shrinks on the contact test."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import scipy.signal

from rths3d.reference import reference_solution
from rths3d.scene import load_scene

SCENES = Path(__file__).resolve().parents[1] / "scenes"


def test_linear_two_mass_reference_matches_scipy_state_space():
    """Linear two-mass test: z^r equals scipy.signal's coupled 2-DOF solution to < 1e-4."""
    sc = load_scene(SCENES / "paper_linear.toml", ["duration=4.0"])
    ref = reference_solution([sc])
    zr = ref["z_ref"][0, :, 0]
    mN, cN, kN = sc.numerical.M[0][0], sc.numerical.C[0][0], sc.numerical.K[0][0]
    e = sc.experiment
    M = np.diag([mN, e.m])
    K = np.array([[kN + e.k, -e.k], [-e.k, e.k]])
    C = np.array([[cN + e.d, -e.d], [-e.d, e.d]])
    Minv = np.linalg.inv(M)
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-Minv @ K, -Minv @ C]])
    B = np.vstack([np.zeros((2, 1)), Minv[:, :1]])
    t = np.arange(sc.n_steps + 1) * sc.dt
    u = sc.excitation.amplitude * np.sin(2 * np.pi * sc.excitation.frequency * t)
    _, y, _ = scipy.signal.lsim((A, B, np.array([[1.0, 0, 0, 0]]), np.zeros((1, 1))), u, t)
    assert np.max(np.abs(zr - y)) < 1e-4 * np.max(np.abs(y))
    # equilibrium: the force on the numerical side is the part's restoring force
    assert ref["iterations"] <= 10


def test_contact_reference_converges_as_step_shrinks():
    """Contact test: z^r at ΔT = 2, 1, 0.5 ms approaches the 0.25 ms solution monotonically."""
    base = ["duration=1.0", "excitation.frequency=1.0", "experiment.h0=0.002",
            "excitation.overtravel=0.006"]
    sols = {}
    for dt in (2e-3, 1e-3, 5e-4, 2.5e-4):
        sc = load_scene(SCENES / "paper_contact.toml", base + [f"dt={dt}"])
        sols[dt] = reference_solution([sc])["z_ref"][0, :, 0]
    fine = sols[2.5e-4]
    errs = []
    for dt in (2e-3, 1e-3, 5e-4):
        step = int(round(dt / 2.5e-4))
        errs.append(np.sqrt(np.mean((sols[dt] - fine[::step]) ** 2)))
    assert errs[0] > errs[1] > errs[2]
    assert errs[2] < 0.01 * np.sqrt(np.mean(fine**2))
    # the test really has contact: the interface displacement stays below the support peak
    assert fine.max() < 0.002 + 0.006


def test_interface_iteration_needs_two_passes_per_step():
    """Quadratic first guess: every step of a linear and a contact test converges in 2 passes."""
    for name in ("paper_linear", "paper_contact"):
        sc = load_scene(SCENES / f"{name}.toml", ["duration=4.0"])
        assert reference_solution([sc])["iterations"] <= 2, name


def test_secant_pass_converges_a_mixed_batch_in_two_passes():
    """Secant step: 8 contact tests from k = 250 to 2e6 N/m average ≤ 2.01 passes per step."""
    from rths3d.scene import scene_with

    sc = load_scene(SCENES / "paper_contact.toml",
                    ["duration=2.0", "experiment.h0=0.002", "excitation.frequency=1.0"])
    scenes = [scene_with(sc, {"numerical.k": k, "numerical.m": m})
              for k in (250.0, 1e4, 1e5, 2e6) for m in (4.81, 19.24)]
    ref = reference_solution(scenes)
    assert ref["mean_iterations"] <= 2.01
    # the same answer as each test solved alone (to the interface tolerance, accumulated)
    for k in (0, 7):
        alone = reference_solution([scenes[k]])["z_ref"][0]
        assert np.max(np.abs(ref["z_ref"][k] - alone)) < 1e-9
