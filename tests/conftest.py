"""Shared test configuration: headless plotting and the location of shared reference data."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")

REPO = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("RTHS3D_SHARED") or REPO.parent / "shared")
"""Reference material kept beside the repository (paper, community benchmark data);
``RTHS3D_SHARED`` points elsewhere."""


SHARED_SKIP = ("needs the RTHS benchmark's published records beside the clone "
               "(../shared/external/rths-benchmark, not redistributable); the engine itself "
               "is tested on a generated record in tests/test_rthsbench_offline.py")


@pytest.fixture(scope="session")
def shared_dir() -> Path:
    """The shared reference folder beside the repository; skips the test when absent."""
    if not SHARED.is_dir():
        pytest.skip(SHARED_SKIP)
    return SHARED


@pytest.fixture(scope="session")
def rths_benchmark_dir(shared_dir: Path) -> Path:
    """The community RTHS benchmark specification and data; skips when absent."""
    path = shared_dir / "external" / "rths-benchmark"
    if not (path / "data").is_dir():
        pytest.skip(SHARED_SKIP)
    return path


def pytest_terminal_summary(terminalreporter, exitstatus, config) -> None:
    """At the end: how many tests were skipped, grouped by why, so that a smaller suite (a
    clone without the shared folder, a machine without Chromium) is never silent."""
    from collections import Counter

    skipped = terminalreporter.stats.get("skipped", [])
    if not skipped:
        return
    why: dict[str, Counter[str]] = {}
    for rep in skipped:
        reason = rep.longrepr[2] if isinstance(rep.longrepr, tuple) else str(rep.longrepr)
        where = rep.nodeid.split("::")[0]
        why.setdefault(str(reason).removeprefix("Skipped: "), Counter())[where] += 1
    terminalreporter.write_sep("-", f"{len(skipped)} test{'s' if len(skipped) > 1 else ''} "
                                    "skipped")
    for reason, files in sorted(why.items(), key=lambda kv: -sum(kv[1].values())):
        places = ", ".join(f"{f} ({n})" for f, n in files.most_common())
        terminalreporter.write_line(f"{sum(files.values()):4d} × {reason}: {places}")


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
