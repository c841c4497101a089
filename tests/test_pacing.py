"""`rths3d run --realtime`: every step paced on the wall clock at the interface rate, the
jitter, latency and overruns in the record's meta and the run summary, the overrun policy
(count, or stop safely at the N-th with the partial record), no allocation in the pacer, and
a paced loopback test against `rths3d serve` that holds 1 kHz with < 0.1 % overruns under
the real-time scheduler.

The references come from outside the pacer: the test's own clock (time.monotonic, not the
pacer's perf_counter) for the wall time, the unpaced compiled loop for the record."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
import tracemalloc
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))
from netproc import ENV, ROOT, port_listeners, serve  # noqa: E402

from rths3d.loop import LoopControl, run  # noqa: E402
from rths3d.network.pacing import Pacer  # noqa: E402
from rths3d.record import Record  # noqa: E402
from rths3d.scene import load_scene  # noqa: E402

SCENE = """
name = "paced"
dofs = ["z"]
dt = 0.001
duration = {duration}
[numerical]
m = 9.62
c = 100.0
k = 10000.0
[excitation]
kind = "support"
signal = "raised_cosine"
frequency = 0.5
overtravel = 0.005
[experiment]
kind = "linear"
m = 0.38
k = 8650.0
d = 5.0
[transfer]
kind = "ideal"
[network]
port = 0
timeout = 2.0
element_map = [[1.0]]
"""

STATS = ("rate_hz", "steps", "overruns", "overrun_fraction", "first_overrun", "max_overruns",
         "jitter_mean_s", "jitter_p99_s", "jitter_max_s", "latency_mean_s", "latency_p99_s",
         "latency_max_s", "warmup_s", "priority")


def scene(tmp_path: Path, duration: float = 1.5) -> Path:
    p = tmp_path / "paced.toml"
    p.write_text(SCENE.format(duration=duration))
    return p


def can_fifo() -> bool:
    try:
        before = (os.sched_getscheduler(0), os.sched_getparam(0))
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))
        os.sched_setscheduler(0, *before)
    except (PermissionError, AttributeError, OSError):
        return False
    return True


def rths3d(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "rths3d", *args], capture_output=True,
                          text=True, cwd=ROOT, env=ENV, timeout=timeout)


def test_paced_run_takes_wall_time_and_keeps_the_record(tmp_path) -> None:
    """1.5 s at 1 kHz paced: the loop takes at least 1.499 s of the test's own clock (the
    unpaced run of the same scene takes < 0.5 s), the record equals the unpaced compiled
    run to 1e-12 of its peaks (pacing moves no number), the meta carries the statistics:
    1500 steps, mean step latency below the 1 ms slot."""
    sc = load_scene(scene(tmp_path))
    free = run(sc, reference=False, progress=False)
    t = time.monotonic()
    free = run(sc, reference=False, progress=False)
    t_free = time.monotonic() - t
    pacer = Pacer(sc.dt, sc.n_steps)
    t = time.monotonic()
    paced = run(sc, reference=False, control=LoopControl(pacer=pacer), progress=False)
    wall = time.monotonic() - t
    assert t_free < 0.5
    assert wall >= 1.499  # steps 1 … 1500 each start ≥ 1 ms after the one before
    assert paced.status == free.status == "ok"
    assert paced.record.meta["loop"] == "python" and free.record.meta["loop"] == "compiled"
    assert paced.record.n == free.record.n == 1501
    for col in ("z_cmd.z", "z_meas.z", "f_meas.z", "x_num.0"):
        a, b = paced.record.columns[col], free.record.columns[col]
        assert np.max(np.abs(a - b)) <= 1e-12 * np.max(np.abs(b)), col
    st = paced.record.meta["pacing"]
    assert set(STATS) <= set(st)
    assert st["steps"] == 1500 and st["rate_hz"] == pytest.approx(1000.0)
    assert 0 < st["latency_mean_s"] < 1e-3
    # (the mean may exceed the p99 when one step in a hundred is late by far: not ordered)
    assert 0 <= st["jitter_p99_s"] <= st["jitter_max_s"]
    assert 0 <= st["jitter_mean_s"] <= st["jitter_max_s"]
    assert 0 <= st["overruns"] <= st["steps"]
    # the pacer's own clock agrees with the test's: 1500 slots, plus the overruns' delays
    assert wall >= 1500 * 1e-3 - 1e-3


def test_cli_summary_and_meta(tmp_path) -> None:
    """`rths3d run --realtime --json --out` (1 s): the summary's `pacing` and the written
    record's meta carry the same statistics; the text summary has the `paced` line; a
    negative --max-overruns is one error line, exit code 2."""
    sc = scene(tmp_path, 1.0)
    rec = tmp_path / "paced.parquet"
    res = rths3d("run", str(sc), "--realtime", "--no-reference", "--json", "--out", str(rec))
    assert res.returncode == 0, res.stderr
    summary = json.loads(res.stdout.strip().splitlines()[-1])
    st = summary["pacing"]
    assert st["steps"] == 1000 and set(STATS) <= set(st)
    assert Record.load(rec).meta["pacing"] == st
    res = rths3d("run", str(sc), "--realtime", "--no-reference")
    assert res.returncode == 0, res.stderr
    assert "  paced        : 1000 Hz, jitter p99" in res.stdout
    for opt, val in (("--max-overruns", "-1"), ("--rt-priority", "100")):
        res = rths3d("run", str(sc), "--realtime", opt, val)
        lines = res.stderr.strip().splitlines()
        assert res.returncode == 2 and len(lines) == 1, res.stderr
        assert lines[0].startswith(f"error: {opt}: {val}") and "Traceback" not in res.stderr


def test_stop_after_n_overruns_keeps_the_partial_record(tmp_path) -> None:
    """Forced to overrun: at 100 kHz (dt = 10 µs) a step takes longer than its slot;
    `--max-overruns 5` stops the test safely at the 5th overrun: status stopped, the reason
    says real time was lost, the record is written with the steps done, exit code 0; without
    a limit the overruns are only counted (and warned about)."""
    sc = scene(tmp_path, 1.0)
    rec = tmp_path / "partial.parquet"
    res = rths3d("run", str(sc), "--realtime", "--no-reference", "--json", "--set", "dt=1e-5",
                 "--set", "duration=0.05", "--max-overruns", "5", "--out", str(rec))
    assert res.returncode == 0, res.stderr
    s = json.loads(res.stdout.strip().splitlines()[-1])
    assert s["status"] == "stopped", s
    assert "real time lost (5 steps overran their 0.01 ms, limit 5)" in s["reason"]
    st = s["pacing"]
    assert st["overruns"] == 5 and st["max_overruns"] == 5 and st["steps"] < 100
    r = Record.load(rec)
    assert r.meta["status"] == "stopped" and 2 <= r.n <= st["steps"] + 1
    assert np.all(np.isfinite(r.columns["z_cmd.z"]))
    res = rths3d("run", str(sc), "--realtime", "--no-reference", "--json", "--set", "dt=1e-5",
                 "--set", "duration=0.02")
    assert res.returncode == 0, res.stderr
    s = json.loads(res.stdout.strip().splitlines()[-1])
    assert s["status"] == "ok" and s["pacing"]["overruns"] > 100  # counted, not stopped
    assert "steps overran their 0.01 ms slot" in res.stderr


def test_pacer_allocates_nothing() -> None:
    """500 paced waits at 10 kHz after the warm-up: the blocks the pacer holds afterwards
    (tracemalloc, filtered on pacing.py) do not grow with the steps: its per-step arrays
    are preallocated, only Python floats come and go."""
    p = Pacer(1e-4, 1000, spin=5e-5)
    p.start()
    for n in range(1, 10):
        p.wait(n)
    tracemalloc.start()
    try:
        before = tracemalloc.take_snapshot()
        for n in range(10, 510):
            p.wait(n)
        after = tracemalloc.take_snapshot()
    finally:
        tracemalloc.stop()
    flt = [tracemalloc.Filter(True, "*pacing.py")]
    diff = after.filter_traces(flt).compare_to(before.filter_traces(flt), "lineno")
    # nothing grows with the steps: at most the few floats its attributes hold now
    # (t0, the last step's start) were created inside the window
    assert sum(d.count_diff for d in diff) <= 3 and sum(d.size_diff for d in diff) <= 3 * 32
    assert p.steps == 509


@pytest.mark.skipif(not can_fifo(), reason="needs the real-time scheduler (root)")
def test_paced_loopback_holds_1khz(tmp_path) -> None:
    """`rths3d run --transfer remote --realtime --rt-priority 10` against `rths3d serve
    --rt-priority 10` on loopback for 3 s at 1 kHz: every step paced and counted, the round
    trip's p99 under the 1 ms slot, both sides end, nothing listens. The floor itself (< 0.1 %
    overruns) is a speed figure, measured by benchmarks/network.py (`paced_overrun_fraction`,
    60 s): here a broken pacer (most steps late) fails, the suite's own load (another test
    process on the second core) does not (measured 0–4 of 3000)."""
    sc = scene(tmp_path, 3.0)
    server, port = serve(sc, "--json", "--rt-priority", "10")
    try:
        res = rths3d("run", str(sc), "--transfer", "remote", "--set", f"network.port={port}",
                     "--realtime", "--rt-priority", "10", "--no-reference", "--json")
        code, err = server.finish(60)
    finally:
        server.kill()
    assert res.returncode == 0, res.stderr
    assert code == 0, err
    s = json.loads(res.stdout.strip().splitlines()[-1])
    st = s["pacing"]
    load = os.getloadavg()[0]
    assert s["status"] == "ok" and st["steps"] == 3000 and st["priority"] == 10
    assert st["overrun_fraction"] < 0.02, (st, load)
    assert st["latency_p99_s"] < 1e-3, (st, load)
    assert server.json["steps"] == 3000
    assert server.left() == [] and port_listeners(port) == []


def test_overrun_stop_of_a_remote_test_ends_both_sides(tmp_path) -> None:
    """A paced remote test against `rths3d serve` forced to overrun (10 µs slots, a loopback
    round trip takes ~0.1 ms): `--max-overruns 3` stops it at the 3rd overrun, the record
    keeps the steps done, the client sends DIE so the served test ends with the same steps;
    both processes gone, nothing listening."""
    sc = scene(tmp_path, 1.0)
    server, port = serve(sc, "--json")
    rec = tmp_path / "partial.parquet"
    try:
        res = rths3d("run", str(sc), "--transfer", "remote", "--set", f"network.port={port}",
                     "--set", "dt=1e-5", "--set", "duration=0.01", "--realtime",
                     "--max-overruns", "3", "--no-reference", "--json", "--out", str(rec))
        code, err = server.finish(60)
    finally:
        server.kill()
    assert res.returncode == 0, res.stderr
    assert code == 0, err
    s = json.loads(res.stdout.strip().splitlines()[-1])
    assert s["status"] == "stopped" and "real time lost" in s["reason"], s
    r = Record.load(rec)
    assert r.meta["status"] == "stopped" and r.n == s["pacing"]["steps"] + 1
    # the site executed every step the client sent (one per paced step, warm-up included)
    assert server.json["steps"] == s["pacing"]["steps"], (server.json, s["pacing"])
    assert server.left() == [] and port_listeners(port) == []


class TracedPacer(Pacer):
    """The pacer, noting the memory the process holds (tracemalloc) before each wait."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.mem = np.zeros(len(self.jitter))

    def wait(self, n: int) -> bool:
        self.mem[n] = tracemalloc.get_traced_memory()[0]
        return super().wait(n)


def test_paced_loop_holds_no_more_memory_per_step(tmp_path) -> None:
    """The whole paced path — the loop's step from Python, the record's rows, the live
    buffers, the pacer — over 1300 steps at 1 kHz: the memory Python holds (tracemalloc)
    grows by < 1 kB (measured 160 bytes: a couple of floats; 1 kB would be < 1 byte a step),
    i.e. nothing is kept per step."""
    sc = load_scene(scene(tmp_path, 1.5))
    p = TracedPacer(sc.dt, sc.n_steps)
    tracemalloc.start()
    try:
        res = run(sc, reference=False, control=LoopControl(pacer=p), progress=False)
    finally:
        tracemalloc.stop()
    assert res.status == "ok" and p.steps == 1500
    assert p.mem[200] > 0
    assert abs(p.mem[1500] - p.mem[200]) < 1024
