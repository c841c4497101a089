"""Cost and accuracy of cheaper platform models: integrator, physics substeps and solver
settings, each against a fine-step solution of the same bench.

One test of the six-DOF bench (``scenes/bench6.toml``: its part on the FTS) tracks a 1 s
six-DOF multisine (2–11 Hz, a few mm and mrad) in compiled ranges
(:func:`rths3d.platform.ranges.track_batch`, every channel each step). The reference is RK4
with 16 physics substeps per 1 ms. For each setting: µs of wall time per simulated ms (median
of ``--repeats``, all settings alternated in each repeat, with ``cost_over_default`` the
ratio to the default RK4/1 measured side by side) and the largest deviation from the
reference over the run of the plate position (µm), its rotation (µrad), the FTS force (N)
and the leg forces (N). The solver settings change ``MjModel.opt`` of the compiled model.

Prints ONE JSON line: ``{"settings": {name: {...}}, "reference": ..., ...}``.
Usage: ``python benchmarks/platform_models.py [--quick]``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="0.5 s runs, 2 repeats")
    ap.add_argument("--repeats", type=int, default=None)
    args = ap.parse_args()

    import mujoco
    import numpy as np

    from rths3d.bench import Bench
    from rths3d.platform.model import build_model
    from rths3d.platform.ranges import track_batch
    from rths3d.platform.sim import PlatformBatch
    from rths3d.scene import load_scene

    duration = 0.5 if args.quick else 1.0
    repeats = args.repeats or (2 if args.quick else 5)
    sc = load_scene(REPO / "scenes" / "bench6.toml", [f"duration={duration}"])
    bench = Bench.from_scene(sc)
    base = bench.platform
    n = int(round(duration / base.dt)) + 1
    t = np.arange(n) * base.dt
    fade = np.minimum(1.0, t / 0.1)
    P = np.zeros((n, 6))
    for j, (a, f) in enumerate(((0.002, 2.0), (0.0015, 3.0), (0.003, 5.0), (0.003, 7.0),
                                (0.002, 9.0), (0.004, 11.0))):
        P[:, j] = a * fade * np.sin(2 * np.pi * f * t + j)
    idx = np.arange(6, dtype=np.int64)

    def opt(**o):
        return o

    settings = {
        "RK4/1 (default)": (dict(integrator="RK4", substeps=1), opt()),
        "RK4/2": (dict(integrator="RK4", substeps=2), opt()),
        "implicitfast/1": (dict(integrator="implicitfast", substeps=1), opt()),
        "implicitfast/2": (dict(integrator="implicitfast", substeps=2), opt()),
        "implicitfast/4": (dict(integrator="implicitfast", substeps=4), opt()),
        "RK4/1 iterations=3": (dict(integrator="RK4", substeps=1), opt(iterations=3)),
        "RK4/1 CG": (dict(integrator="RK4", substeps=1),
                     opt(solver=int(mujoco.mjtSolver.mjSOL_CG))),
        "RK4/1 dense": (dict(integrator="RK4", substeps=1),
                        opt(jacobian=int(mujoco.mjtJacobian.mjJAC_DENSE))),
        "implicitfast/1 iterations=3": (dict(integrator="implicitfast", substeps=1),
                                        opt(iterations=3)),
    }

    def make(cfg_kw: dict, options: dict) -> PlatformBatch:
        cfg = dataclasses.replace(base, **cfg_kw)
        m = build_model(cfg, *bench.fragments)
        for k, v in options.items():
            setattr(m.opt, k, v)
        return PlatformBatch(cfg, models=[m])

    def run(sim: PlatformBatch) -> tuple[float, object]:
        sim.reset()
        t0 = time.perf_counter()
        rec = track_batch(sim, P, idx, lazy=False, compiled=True)
        return (time.perf_counter() - t0) / (n - 1) * 1e6, rec

    ref_sim = make(dict(integrator="RK4", substeps=16), opt())
    run(ref_sim)
    ref_us, ref = run(ref_sim)
    sims = {name: make(*s) for name, s in settings.items()}
    for sim in sims.values():
        run(sim)  # compiled kernels loaded, caches warm
    cost: dict[str, list[float]] = {k: [] for k in sims}
    ratio: dict[str, list[float]] = {k: [] for k in sims}
    recs = {}
    for _ in range(repeats):
        d0, _ = run(sims["RK4/1 (default)"])
        for name, sim in sims.items():
            us, recs[name] = run(sim)
            cost[name].append(us)
            ratio[name].append(us / d0)
    out = {}
    for name, rec in recs.items():
        ok = bool(np.all(rec.stop == n))
        dq = np.abs(rec.q - ref.q)
        out[name] = {
            "us_per_ms": round(statistics.median(cost[name]), 2),
            "cost_over_default": round(statistics.median(ratio[name]), 3),
            "pos_err_um": round(float(dq[..., :3].max()) * 1e6, 4) if ok else None,
            "rot_err_urad": round(float(np.abs(rec.z[..., 3:] - ref.z[..., 3:]).max()) * 1e6,
                                  4) if ok else None,
            "fts_force_err_N": round(float(np.abs(rec.fts[..., :3] - ref.fts[..., :3]).max()),
                                     5) if ok else None,
            "leg_force_err_N": round(float(np.abs(rec.legs_f - ref.legs_f).max()), 5)
            if ok else None,
            "ran_through": ok,
        }
    peaks = {"pos_um": round(float(np.abs(ref.z[..., :3]).max()) * 1e6, 1),
             "fts_force_N": round(float(np.abs(ref.fts[..., :3] - ref.fts[0, :, :3]).max()), 2),
             "leg_force_N": round(float(np.abs(ref.legs_f - ref.legs_f[0]).max()), 2)}
    print(json.dumps({"settings": out, "reference": "RK4/16", "reference_us_per_ms":
                      round(ref_us, 2), "signal_peaks": peaks, "duration_s": duration,
                      "repeats": repeats, "quick": bool(args.quick)}))


if __name__ == "__main__":
    main()
