"""The suite says at its end how many tests it skipped and why (a clone on its own)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def test_skips_are_counted_by_reason_at_the_end(tmp_path) -> None:
    """Without the shared folder, the benchmark-data tests skip, and the last lines before
    the totals count them under their reason with the files they are in."""
    tests = ["tests/test_lti.py::test_benchmark_records_pga",
             "tests/test_lti.py::test_tustin_coefficients_equal_benchmark_spec",
             "tests/test_lti.py::test_pi_coefficients_are_kp_plus_minus_ki_dt_over_2"]
    # the subprocess is a plain run: options given to this run (PYTEST_ADDOPTS, a worker's
    # variables) would change its summary lines
    env = {k: v for k, v in os.environ.items()
           if k != "PYTEST_ADDOPTS" and not k.startswith("PYTEST_XDIST")}
    p = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider",
                        *tests], cwd=REPO, capture_output=True, text=True, timeout=300,
                       env={**env, "RTHS3D_SHARED": str(tmp_path / "absent")})
    assert p.returncode == 0, p.stdout + p.stderr
    lines = p.stdout.strip().splitlines()
    assert lines[-1].startswith("1 passed, 2 skipped")
    head = next(i for i, ln in enumerate(lines) if "2 tests skipped" in ln)
    assert lines[head + 1].strip().startswith("2 × needs the RTHS benchmark's published "
                                              "records")
    assert lines[head + 1].endswith("tests/test_lti.py (2)")
