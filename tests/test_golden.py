"""Golden records: today's loop reproduces the records made before the loop ⇄ transfer ⇄
experiment re-seam (every shipped scene × transfer system, single and batch, with sensor noise,
compensation and safety stops) to ≤ 1e-12 relative per column."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent / "golden"))
import cases as golden  # noqa: E402

REL = 1e-12


@pytest.mark.parametrize("name", sorted(golden.cases()))
def test_record_equals_golden(name):
    """Every column of every record of the case equals the golden one (≤ 1e-12 of the
    column's peak), and status, stop reason and length are the same."""
    path = golden.DATA / f"{name}.npz"
    want = np.load(path)
    got = golden.to_arrays(golden.run_case(name))
    assert sorted(k for k in want if "/#" in k) == sorted(k for k in got if "/#" in k)
    for key in want:
        if "/#" in key:
            assert str(got[key]) == str(want[key]), key
            continue
        assert key in got, f"{name}: column {key} missing"
        a, b = got[key], want[key]
        assert a.shape == b.shape, f"{name}: {key} has {a.shape[0]} rows, golden {b.shape[0]}"
        scale = max(float(np.max(np.abs(b))), 1e-300)
        err = float(np.max(np.abs(a - b))) / scale
        assert err <= REL, f"{name}: {key} differs by {err:.2e} of its peak"
