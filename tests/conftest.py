"""Shared test configuration: headless plotting and the location of shared reference data."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")

REPO = Path(__file__).resolve().parents[1]
SHARED = REPO.parent / "shared"
"""Reference material kept beside the repository (paper, community benchmark data)."""


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    """The shared reference folder beside the repository; skips the test when absent."""
    if not SHARED.is_dir():
        pytest.skip(f"shared reference data not found at {SHARED}")
    return SHARED


@pytest.fixture(scope="session")
def rths_benchmark_dir(shared_dir: Path) -> Path:
    """The community RTHS benchmark specification and data; skips when absent."""
    path = shared_dir / "external" / "rths-benchmark"
    if not (path / "data").is_dir():
        pytest.skip(f"RTHS benchmark data not found at {path}")
    return path


def _peak_bytes(f, n: int = 10) -> int:
    """Peak memory traced (numpy's arrays included) over n calls of f after a warm-up."""
    import tracemalloc

    for _ in range(3):
        f()
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        base = tracemalloc.get_traced_memory()[0]
        for _ in range(n):
            f()
        return tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()


@pytest.fixture
def peak_bytes():
    """``peak_bytes(f, n=10)``: bytes allocated at peak by n calls of f (hot-path checks)."""
    return _peak_bytes
