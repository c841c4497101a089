"""Cost of the platform's 1 kHz tracking loop against bare ``mj_step``.

Prints ONE JSON line:

* ``us_per_ms_bare``: µs of wall time per simulated 1 ms for bare ``mujoco.mj_step`` on the
  same model, replaying the controls the loop produced (control write included);
* ``us_per_ms_loop``: the same for the full loop in compiled ranges
  (:func:`rths3d.platform.ranges.track_batch`: inverse kinematics, gravity compensation,
  velocity feed-forward, set-point lag and delay, the servo's ramp, ``mj_step`` through
  MuJoCo's C API, safety checks, and every channel recorded each step: plate pose, leg
  extensions and forces, FTS, interface displacement and wrench; each step's forces read at
  its successor's start, which for the ramped set-point is the end-of-step sample);
* ``loop_over_bare``: their ratio (floor ≤ 1.15 with one substep);
* ``rtf_loop`` / ``rtf_bare``: real-time factors, simulated s per wall s (floor ≥ 30);
* ``*_implicitfast``: the same with ``integrator = "implicitfast"`` (docs/platform.md);
* ``us_per_ms_python_loop`` and ``python_loop_over_bare``: the Python driver, one
  ``PlatformSim.step`` per step with its reads of ``pose`` and ``interface_wrench`` (the
  readable reference path);
* ``us_per_ms_bare_c``: ``mj_step`` with ``nstep`` (the C loop, no Python per step);
* extras: ``us_scalar_ik`` (µs per 6-leg IK), ``us_per_ms_batch16_per_test`` and
  ``rtf_batch16_aggregate`` (16 tests in one ``PlatformBatch`` on 2 threads, Python driver).

Measured in one run, interleaved, ``--repeats`` times; medians are reported. The machine is
shared and noisy: ratios measured side by side are the figures to trust.
Usage: ``python benchmarks/platform_loop.py [--quick] [--substeps N] [--lag servo]
[--valve-hz F]``.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="short run (CI)")
    ap.add_argument("--substeps", type=int, default=1, help="physics steps per 1 ms")
    ap.add_argument("--repeats", type=int, default=None, help="timed repetitions")
    ap.add_argument("--lag", choices=("setpoint", "servo"), default="setpoint",
                    help="where the servo's 3 ms lag sits: a set-point filter before the "
                         "hold (default) or continuous after it (six more actuators)")
    ap.add_argument("--valve-hz", type=float, default=0.0,
                    help="a servo-valve after the hold (Hz; 0: none, the default): six "
                         "spools, six tendons, twelve more actuators")
    args = ap.parse_args()

    import mujoco
    import numpy as np

    from rths3d.platform import PlatformConfig, PlatformSim, ScalarIK
    from rths3d.platform.model import ActuatorConfig
    from rths3d.platform.ranges import track_batch

    n = 2000 if args.quick else 5000
    repeats = args.repeats or (5 if args.quick else 9)
    act = ActuatorConfig(lag=args.lag, valve_hz=args.valve_hz)
    cfg = PlatformConfig(substeps=args.substeps, actuator=act)
    sim = PlatformSim(cfg)
    m, d = sim.model, sim.data
    dt = cfg.dt
    # 1 Hz, 5 mm heave with a small sway and roll so that all legs move differently
    t = (np.arange(n) + 1) * dt
    fade = np.minimum(1.0, t / 0.5)
    poses = np.zeros((n, 6))
    poses[:, 2] = 0.005 * fade * np.sin(2 * math.pi * t)
    poses[:, 1] = 0.002 * fade * np.sin(2 * math.pi * 0.7 * t)
    poses[:, 3] = 0.004 * fade * np.sin(2 * math.pi * 1.3 * t)
    rows = poses.tolist()

    # the controls the loop produces, recorded once (untimed) for the bare replay
    sim.reset()
    ctrls = []
    for r in rows:
        sim.step(*r)
        ctrls.append(sim.data.ctrl.tolist())

    def run_loop() -> float:
        sim.reset()
        step = sim.step
        t0 = time.perf_counter()
        for x, y, z, rx, ry, rz in rows:
            step(x, y, z, rx, ry, rz)
            sim.pose  # noqa: B018  (the reads are part of the loop's cost)
            sim.interface_wrench  # noqa: B018
        return (time.perf_counter() - t0) / n * 1e6

    def run_bare(sim=sim, ctrls=ctrls) -> float:
        sim.reset()
        m, d = sim.model, sim.data
        ctrl = d.ctrl
        nsub = sim.config.substeps
        mj_step = mujoco.mj_step
        t0 = time.perf_counter()
        for c in ctrls:
            ctrl[:] = c
            mj_step(m, d, nsub)
        return (time.perf_counter() - t0) / n * 1e6

    def run_bare_c() -> float:
        sim.reset()
        t0 = time.perf_counter()
        mujoco.mj_step(m, d, n * cfg.substeps)
        return (time.perf_counter() - t0) / n * 1e6

    idx = np.arange(6, dtype=np.int64)
    rows0 = np.concatenate([np.zeros((1, 6)), poses])  # row 0: the state before the steps

    def run_compiled(sim=sim) -> float:
        sim.reset()
        t0 = time.perf_counter()
        track_batch(sim._b, rows0, idx, lazy=True, compiled=True)
        return (time.perf_counter() - t0) / n * 1e6

    fast = PlatformSim(PlatformConfig(substeps=args.substeps, integrator="implicitfast",
                                      actuator=act))
    fast.reset()
    fctrls = []
    for r in rows:
        fast.step(*r)
        fctrls.append(fast.data.ctrl.tolist())
    run_compiled()  # the compiled kernels load (numba's on-disk cache) outside the timing
    run_compiled(fast)

    ik = ScalarIK(cfg.geometry).ik

    def run_ik() -> float:
        t0 = time.perf_counter()
        for r in rows:
            ik(*r)
        return (time.perf_counter() - t0) / n * 1e6

    # K tests stepped together (PlatformBatch over mujoco.batch.Batch, 2 threads)
    from rths3d.platform import PlatformBatch

    K = 16
    batch = PlatformBatch(cfg, nsim=K, nthread=2)
    nb = n // 2
    bposes = [np.tile(p, (K, 1)) for p in poses[:nb]]

    def run_batch() -> float:
        batch.reset()
        t0 = time.perf_counter()
        for p in bposes:
            batch.step(p)
            batch.pose  # noqa: B018
            batch.interface_wrench  # noqa: B018
        return (time.perf_counter() - t0) / nb * 1e6 / K

    loop, bare, iks, ratios, pyloop, pyratios, barec = [], [], [], [], [], [], []
    floop, fbare, fratios = [], [], []
    for _ in range(repeats):
        b = run_bare()
        lp = run_compiled()
        loop.append(lp)
        bare.append(b)
        ratios.append(lp / b)
        b2 = run_bare()
        py = run_loop()
        pyloop.append(py)
        pyratios.append(py / b2)
        barec.append(run_bare_c())
        fb = run_bare(fast, fctrls)
        fl = run_compiled(fast)
        fbare.append(fb)
        floop.append(fl)
        fratios.append(fl / fb)
        iks.append(run_ik())
    batch_us = [run_batch() for _ in range(max(1, repeats // 2))]
    med = statistics.median
    us_loop = med(loop)
    us_bare = med(bare)
    print(json.dumps({
        "us_per_ms_bare": round(us_bare, 3),
        "us_per_ms_loop": round(us_loop, 3),
        "loop_over_bare": round(med(ratios), 4),
        "rtf_loop": round(1000.0 / us_loop, 2),
        "rtf_bare": round(1000.0 / us_bare, 2),
        "us_per_ms_bare_c": round(med(barec), 3),
        "us_per_ms_python_loop": round(med(pyloop), 3),
        "python_loop_over_bare": round(med(pyratios), 4),
        "us_per_ms_loop_implicitfast": round(med(floop), 3),
        "loop_over_bare_implicitfast": round(med(fratios), 4),
        "rtf_loop_implicitfast": round(1000.0 / med(floop), 2),
        "rtf_bare_implicitfast": round(1000.0 / med(fbare), 2),
        "us_scalar_ik": round(statistics.median(iks), 3),
        "us_per_ms_batch16_per_test": round(statistics.median(batch_us), 3),
        "rtf_batch16_aggregate": round(1000.0 / statistics.median(batch_us), 2),
        "substeps": cfg.substeps,
        "lag": args.lag,
        "valve_hz": args.valve_hz,
        "steps": n,
        "repeats": repeats,
        "quick": bool(args.quick),
    }))


if __name__ == "__main__":
    main()
