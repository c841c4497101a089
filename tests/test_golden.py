"""Golden records: today's loop reproduces the records made before the loop ⇄ transfer ⇄
experiment re-seam (every shipped scene × transfer system, single and batch, with sensor noise,
compensation and safety stops).

Each column must equal the golden one to 1e-12 of its signal's peak over its DOFs (a
``pose_meas.y`` of a heave test is rounding noise; it is measured against the pose's peak).
Before the re-seam a single test and a batch ran different arithmetic (a generated scalar
kernel, numpy/BLAS products); both paths now run the same kernels, which are the scalar ones.
Where a MuJoCo part amplifies the rounding of that change (contact, the part's MuJoCo solver),
the tolerance is the spread the old code itself had between its single and batch runs of the
same test (measured at the golden commit: 6e-11 to 1.3e-10 for the multi-DOF part, 7.6e-6 for
the contact part in MuJoCo, of order 1 for the rounding-noise pose columns of the platform).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent / "golden"))
import cases as golden  # noqa: E402

REL = 1e-12
MUJOCO_PART = {"multidof_ideal": 1e-10, "multidof_delay": 1e-10, "multidof_lti": 1e-10,
               "multidof_lti_batch": 1e-10, "contact_mujoco_part": 1e-6,
               "contact_stewart": 2e-12, "contact_stewart_noise": 2e-12,
               "contact_stops": 2e-12, "multidof_stewart": 2e-12}
"""Cases whose tolerance is the old code's own single-vs-batch spread (module docstring)."""
TOOLCHAIN = 1e-9
"""Floor of every tolerance: the same code compiled by another numba/LLVM and numpy rounds
differently. Measured on 2026-11-27 (numba 0.68.1, numpy 2.4.6, mujoco 4.0.0) against the
goldens made with older releases: up to 2.2e-10 of peak (the multi-DOF part's reference),
4.4e-11 (the linear part on the platform), 2.2e-12 (the platform's leg forces). A change of
physics, a convention or a step order shows at 1e-6 and above."""


@pytest.mark.parametrize("name", sorted(golden.cases()))
def test_record_equals_golden(name):
    """Every column of every record of the case equals the golden one (module docstring),
    and status, stop reason and length are the same."""
    want = np.load(golden.DATA / f"{name}.npz")
    got = golden.to_arrays(golden.run_case(name))
    assert sorted(k for k in want if "/#" in k) == sorted(k for k in got if "/#" in k)
    peak: dict[str, float] = {}
    for key in want:
        if "/#" not in key:
            family = key.split(".")[0]
            peak[family] = max(peak.get(family, 0.0), float(np.max(np.abs(want[key]))))
    rel = max(MUJOCO_PART.get(name, REL), TOOLCHAIN)
    for key in want:
        if "/#" in key:
            assert str(got[key]) == str(want[key]), key
            continue
        assert key in got, f"{name}: column {key} missing"
        a, b = got[key], want[key]
        assert a.shape == b.shape, f"{name}: {key} has {a.shape[0]} rows, golden {b.shape[0]}"
        err = float(np.max(np.abs(a - b))) / max(peak[key.split(".")[0]], 1e-300)
        assert err <= rel, f"{name}: {key} differs by {err:.2e} of its signal's peak"
