"""Benchmark: the SimApp loopback round trip per step, and a paced 1 kHz remote test.

Run ``python benchmarks/network.py [--quick]``; prints ONE JSON line:

``server_step_us_p50``, ``server_step_us_p99``
    one step of an OpenSees ``genericClient`` (actions 3, 13, 14, 10, 14, 3, 5: seven
    messages of 256 float64, four answered) against ``rths3d serve`` (ideal transfer, the
    linear part) on loopback, timed at a client written here, µs.
``client_step_us_p50``, ``client_step_us_p99``
    one step of rths3d's ``remote`` transfer system (trial, commit, getDaqResponse) against
    ``rths3d serve`` of the same scene, µs.
``inprocess_step_us_p50``, ``inprocess_step_us_p99``
    the same step of the served lab called in-process (no network), µs: what the network
    adds is the difference.
``round_trip_priority``
    the three above run under the real-time FIFO scheduler at this priority (both ends).
``paced_seconds``, ``paced_jitter_p99_us``, ``paced_jitter_max_us``, ``paced_overruns``,
``paced_overrun_fraction``, ``paced_latency_mean_us``, ``paced_latency_p99_us``,
``paced_priority``, ``paced_load_average``
    ``rths3d run --transfer remote --realtime`` against ``rths3d serve`` at 1 kHz for 60 s
    (``--quick``: 10 s), both under the real-time FIFO scheduler at ``--rt-priority``
    (default 10 when the process may use it, else 0): the step starts' jitter (start −
    deadline), the steps that overran their 1 ms slot (floor: < 0.1 %), the step's latency
    (the round trip with the loop's work), the 1-minute load average when it ended.
``normal_*``
    the same paced test on the normal scheduler for 10 s (``--quick``: 3 s): what the
    real-time scheduler buys on a loaded machine.
``load_average``
    the machine's 1-minute load average when the run ended (2 cores, shared).

Both server processes run in their own sessions and are killed at the end.
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from rths3d.network.pacing import realtime_priority

ROOT = Path(__file__).resolve().parents[1]
ENV = {**os.environ, "PYTHONPATH": str(ROOT)}

SCENE = """
name = "bench_network"
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
timeout = 5.0
element_map = {emap}
"""


def start_server(scene: Path, priority: int = 0) -> tuple[subprocess.Popen, int]:
    p = subprocess.Popen([sys.executable, "-m", "rths3d", "serve", str(scene), "--json",
                          "--rt-priority", str(priority)],
                         stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True,
                         start_new_session=True, cwd=ROOT, env=ENV)
    assert p.stdout is not None
    line = p.stdout.readline()
    if not line.startswith("listening on "):
        os.killpg(p.pid, signal.SIGKILL)
        raise RuntimeError(f"serve did not start: {line!r}")
    return p, int(line.rsplit(":", 1)[1])


def stop(p: subprocess.Popen) -> None:
    try:
        p.wait(timeout=30)
    except subprocess.TimeoutExpired:
        pass
    try:
        os.killpg(p.pid, signal.SIGKILL)
    except ProcessLookupError:
        pass
    p.wait()


def generic_client_steps(port: int, steps: int) -> np.ndarray:
    """Per-step wall time (s) of a genericClient's message sequence against the server."""
    from rths3d.network.simapp import Header, connect

    ch = connect("127.0.0.1", port, Header((2, 2, 2, 0, 1), (0, 0, 0, 2, 0), 256), 5.0)
    buf = ch.send_buf
    out = np.zeros(steps)
    buf[:] = 0.0
    try:
        for n in range(steps):
            t0 = time.perf_counter()
            u = 1e-3 * np.sin(2 * np.pi * 0.5 * n * 1e-3)
            # the step's first trial repeats the committed displacement (new time)
            buf[0], buf[7] = 3, (n + 1) * 1e-3
            ch.send()
            for a in (13, 14, 10, 14):
                buf[0] = a
                ch.send()
                ch.recv()
            buf[0], buf[2] = 3, u
            ch.send()
            buf[0] = 5
            ch.send()
            out[n] = time.perf_counter() - t0
        buf[0] = 99
        ch.send()
    finally:
        ch.close()
    return out


def remote_steps(scene_path: Path, port: int, steps: int) -> np.ndarray:
    from rths3d.scene import load_scene
    from rths3d.transfer import build_transfer

    sc = load_scene(scene_path, [f"network.port={port}", "transfer.kind=remote"])
    tr = build_transfer(sc, 1)
    tr.reset()
    z, zd = np.zeros((1, 1)), np.zeros((1, 1))
    out = np.zeros(steps)
    try:
        for n in range(steps):
            z[0, 0] = 1e-3 * np.sin(2 * np.pi * 0.5 * n * 1e-3)
            t0 = time.perf_counter()
            tr.step(z, zd)
            out[n] = time.perf_counter() - t0
    finally:
        tr.close()
    return out


def inprocess_steps(scene_path: Path, steps: int) -> np.ndarray:
    from rths3d.network.server import Lab
    from rths3d.network.simapp import Header
    from rths3d.scene import load_scene

    lab = Lab(load_scene(scene_path, ["duration=120.0"]))
    h = Header((1, 1, 0, 0, 0), (1, 0, 0, 1, 0), 256)
    msg, out_buf = np.zeros(256), np.zeros(256)
    out = np.zeros(steps)
    for n in range(steps):
        msg[0], msg[1] = 3, 1e-3 * np.sin(2 * np.pi * 0.5 * n * 1e-3)
        t0 = time.perf_counter()
        lab.trial(msg, h)
        lab.commit()
        lab.reply(6, out_buf, h)
        out[n] = time.perf_counter() - t0
    return out


def can_fifo() -> bool:
    try:
        before = (os.sched_getscheduler(0), os.sched_getparam(0))
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(1))
        os.sched_setscheduler(0, *before)
    except (PermissionError, AttributeError, OSError):
        return False
    return True


def paced_run(d: Path, name: str, seconds: float, priority: int) -> dict:
    """``rths3d run --transfer remote --realtime`` against ``rths3d serve`` (its statistics
    under ``name``_…)."""
    pr = d / f"{name}.toml"
    pr.write_text(SCENE.format(duration=seconds, emap="[[1.0]]"))
    p, port = start_server(pr, priority)
    try:
        res = subprocess.run([sys.executable, "-m", "rths3d", "run", str(pr), "--transfer",
                              "remote", "--set", f"network.port={port}", "--realtime",
                              "--rt-priority", str(priority), "--no-reference", "--json"],
                             capture_output=True, text=True, cwd=ROOT, env=ENV,
                             timeout=seconds * 3 + 120)
    finally:
        stop(p)
    if res.returncode != 0:
        raise RuntimeError(f"paced run failed: {res.stderr.strip()}")
    pac = json.loads(res.stdout.strip().splitlines()[-1])["pacing"]
    return {f"{name}_seconds": seconds, f"{name}_priority": priority,
            f"{name}_steps": pac["steps"],
            f"{name}_jitter_p99_us": round(pac["jitter_p99_s"] * 1e6, 1),
            f"{name}_jitter_max_us": round(pac["jitter_max_s"] * 1e6, 1),
            f"{name}_overruns": pac["overruns"],
            f"{name}_overrun_fraction": pac["overrun_fraction"],
            f"{name}_latency_mean_us": round(pac["latency_mean_s"] * 1e6, 1),
            f"{name}_latency_p99_us": round(pac["latency_p99_s"] * 1e6, 1),
            f"{name}_load_average": os.getloadavg()[0]}


def us(a: np.ndarray, q: float) -> float:
    return round(float(np.percentile(a[len(a) // 10:], q)) * 1e6, 1)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--rt-priority", type=int, default=None,
                    help="real-time priority of the paced run (default 10 when allowed)")
    args = ap.parse_args()
    steps = 2000 if args.quick else 20000
    paced = 10.0 if args.quick else 60.0
    out: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        g = d / "generic.toml"
        g.write_text(SCENE.format(duration=steps * 1e-3 + 1, emap="[]"))
        r = d / "remote.toml"
        r.write_text(SCENE.format(duration=max(paced, steps * 1e-3) + 1, emap="[[1.0]]"))
        prio = args.rt_priority if args.rt_priority is not None else \
            (10 if can_fifo() else 0)
        out["round_trip_priority"] = prio
        with realtime_priority(prio):  # both ends, as in the paced run
            p, port = start_server(g, prio)
            try:
                s = generic_client_steps(port, steps)
            finally:
                stop(p)
            out["server_step_us_p50"], out["server_step_us_p99"] = us(s, 50), us(s, 99)
            p, port = start_server(r, prio)
            try:
                s = remote_steps(r, port, steps)
            finally:
                stop(p)
            out["client_step_us_p50"], out["client_step_us_p99"] = us(s, 50), us(s, 99)
            s = inprocess_steps(r, steps)
            out["inprocess_step_us_p50"], out["inprocess_step_us_p99"] = us(s, 50), us(s, 99)
        out.update(paced_run(d, "paced", paced, prio))
        out.update(paced_run(d, "normal", 3.0 if args.quick else 10.0, 0))
    out["load_average"] = os.getloadavg()[0]
    out["quick"] = args.quick
    print(json.dumps(out))


if __name__ == "__main__":
    socket.setdefaulttimeout(None)
    main()
