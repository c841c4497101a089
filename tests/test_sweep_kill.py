"""`kill -9` of a sweep process takes every process it started with it, at any moment: the
Table-1 LTI sweep (13230 tests, 2 workers) killed 5 s after its start and mid-run (workers
warm and stepping their first batches; forked from the sweep process, and started from a
forkserver); 5 s later no process of its session is alive (workers, forkserver, resource
tracker). A killed process runs no clean-up: the workers go by
their lifeline and the parent-death signal (:mod:`rths3d._lifeline`)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from processes import alive_in_session  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
SPEC = ROOT / "scenes" / "sweeps" / "table1_lti.toml"

pytestmark = pytest.mark.skipif(not os.path.isdir("/proc") or not SPEC.exists(),
                                reason="reads /proc; needs scenes/sweeps/table1_lti.toml")


@pytest.mark.parametrize("when, start", [("5s", "auto"), ("mid-run", "auto"),
                                         ("mid-run", "forkserver")])
def test_kill_9_of_the_table1_sweep_leaves_no_process(tmp_path, when, start) -> None:
    """SIGKILL to the sweep process alone (not its group) at 5 s, or once its two workers
    are up (forked from the warm sweep process; or, started from a forkserver, with the
    forkserver and the resource tracker) and have run 3 s: within 5 s every process of its
    session has gone."""
    cmd = [sys.executable, "-m", "rths3d", "sweep", str(SPEC), "--out", str(tmp_path / "o"),
           "--workers", "2", "--quiet"]
    env = {**os.environ, "PYTHONPATH": str(ROOT), "RTHS3D_START_METHOD": start}
    up = 5 if start == "forkserver" else 3  # with the sweep process itself
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            start_new_session=True, cwd=ROOT, env=env)
    left: list[tuple[int, str]] = []
    try:
        t0 = time.time()
        if when == "5s":
            time.sleep(5.0)
        else:
            while time.time() < t0 + 120 and proc.poll() is None \
                    and len(alive_in_session(proc.pid)) < up:
                time.sleep(0.05)
            assert len(alive_in_session(proc.pid)) >= up, "the workers never came up"
            time.sleep(3.0)
        assert proc.poll() is None, "the sweep ended before it could be killed"
        os.kill(proc.pid, signal.SIGKILL)
        proc.wait()
        killed = time.time()
        while alive_in_session(proc.pid) and time.time() < killed + 5.0:
            time.sleep(0.05)
        left = alive_in_session(proc.pid)
    finally:
        for pid, _ in alive_in_session(proc.pid):
            os.kill(pid, signal.SIGKILL)
    assert left == [], left
