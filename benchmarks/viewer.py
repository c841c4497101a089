"""Benchmark: what watching costs the loop.

Prints ONE JSON line. ``viewer_slowdown`` is the loop's stepping time with the live view
attached as ``rths3d view SCENE`` attaches it (the loop copying new samples to shared memory
at its control checks, at most 30 times a second; the view process serving the page and
sending 30 updates per second to a connected websocket client in a third process, as to a
browser) over the stepping time
without a view: the median of the ratios of back-to-back pairs of runs of the same test (the
paper's contact scene on the Stewart platform, unpaced), the pair order alternating so that
drifting machine load cancels. Floor from the issue: ≤ 1.10. ``--quick`` runs a shorter test
and fewer pairs. ``--in-process`` measures the in-process :class:`rths3d.viz.Viewer` instead
(the view's threads then share the loop's GIL).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

CLIENT = """
import sys
from rths3d.viz.wire import HeadlessClient
client = HeadlessClient(int(sys.argv[1]), keep=False)
print("ready", flush=True)
sys.stdin.read()
client.close()
print(client.frames, flush=True)
"""
"""A websocket client in its own process: connects like a browser, counts frames until its
stdin closes, then prints the count."""


def cpu_seconds(pid: int) -> float:
    """User + system CPU time (s) of a process so far (Linux /proc; NaN elsewhere)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, IndexError, ValueError):
        return float("nan")


def plain_run(live) -> float:
    """Stepping wall time (s) of one test without a view: the same LiveRun machinery (loop
    in a worker thread, same control checks), nothing watching."""
    live.start()
    res = live.join()
    if res is None or res.status != "ok":
        raise RuntimeError(f"benchmark test failed: {live.status()}")
    return res.wall


def viewed_run(live, view, in_process: bool) -> float:
    """Stepping wall time (s) of one test of ``live`` shown by ``view``."""
    buffer = live.start()
    if in_process:
        view.set_buffer(buffer)  # a view process picks new runs up by itself
    res = live.join()
    if res is None or res.status != "ok":
        raise RuntimeError(f"benchmark test failed: {live.status()}")
    return res.wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="2 s test, 3 pairs of runs")
    ap.add_argument("--repeat", type=int, default=11, help="pairs of runs with/without view")
    ap.add_argument("--transfer", default="stewart", help="transfer system of the test")
    ap.add_argument("--rate", type=float, default=30.0, help="view updates per second")
    ap.add_argument("--in-process", action="store_true",
                    help="measure the in-process Viewer (shares the loop's GIL)")
    args = ap.parse_args()
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from rths3d.scene import scene_with
    from rths3d.viz.live import LiveRun, load_target

    duration = 2.0 if args.quick else 10.0
    reps = 3 if args.quick else args.repeat
    scene = scene_with(load_target("paper_contact"),
                       {"duration": duration}).with_transfer(args.transfer)
    # The view (server, scene, client) is set up before the timed runs, so the ratio is the
    # cost of watching only; LiveRun with speed 0 runs unpaced, like the plain runs.
    live = LiveRun(scene, speed=0.0, reference=False)
    bare = LiveRun(scene, speed=0.0, reference=False)
    if args.in_process:
        view = live.viewer(port=0, rate=args.rate).start()
    else:
        view = live.view_process(port=0, rate=args.rate).start()
    live.join()
    client = subprocess.Popen([sys.executable, "-c", CLIENT, str(view.port)],
                              stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
    if client.stdout.readline().strip() != "ready":
        raise RuntimeError("headless client could not connect")
    without, with_view, ratios = [], [], []
    t_start = time.perf_counter()
    view_pid = None if args.in_process else view._proc.pid
    cpu0 = (cpu_seconds(view_pid) if view_pid else float("nan"), cpu_seconds(client.pid))
    try:
        plain_run(bare)  # warm caches (model compile, imports) outside the figures
        for i in range(reps):
            if i % 2 == 0:
                t0 = plain_run(bare)
                t1 = viewed_run(live, view, args.in_process)
            else:
                t1 = viewed_run(live, view, args.in_process)
                t0 = plain_run(bare)
            without.append(t0)
            with_view.append(t1)
            ratios.append(t1 / t0)
    finally:
        cpu1 = (cpu_seconds(view_pid) if view_pid else float("nan"), cpu_seconds(client.pid))
        out, _ = client.communicate("", timeout=30)
        view.stop()
        live.close()
        bare.close()
    wall = time.perf_counter() - t_start
    frames = int(out.split()[-1]) if out.split() else 0
    t_without, t_with = statistics.median(without), statistics.median(with_view)
    print(json.dumps({
        "viewer_slowdown": round(statistics.median(ratios), 4),
        "ratio_of_medians": round(t_with / t_without, 4),
        "loop_s_without_view": round(t_without, 4),
        "loop_s_with_view": round(t_with, 4),
        "client_frames_per_viewed_s": round(frames / sum(with_view), 2),
        "bench_wall_s": round(wall, 1),
        "view_process_cpu_share": round((cpu1[0] - cpu0[0]) / wall, 3),
        "client_process_cpu_share": round((cpu1[1] - cpu0[1]) / wall, 3),
        "simulated_s": duration,
        "transfer": args.transfer,
        "view": "in-process" if args.in_process else "process",
        "view_rate_hz": args.rate,
        "pairs": reps,
        "pair_ratios": [round(r, 3) for r in ratios],
        "quick": args.quick,
        "load_avg_1min": round(os.getloadavg()[0], 2),
    }))


if __name__ == "__main__":
    main()
