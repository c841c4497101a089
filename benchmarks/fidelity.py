"""Benchmark: the surrogate reference of one 10 s record (identify the part, couple it).

Run ``python benchmarks/fidelity.py [--quick]``; prints ONE JSON line:

``surrogate_10s_s``
    median wall time (s) of :class:`rths3d.surrogate.SurrogateReference` ``.fit`` on a 10 s,
    1 kHz record of the paper's contact test (switched part, 6 ms actuator delay, made by the
    closed vRTHS loop): every candidate model fitted and validated on held-out blocks, the
    members (the best model, its refits on each half, a second class when it validates
    alike) coupled to the numerical substructure with exact compatibility and equilibrium.
    Floor: 2 s.
``surrogate_10s_linear_s``
    the same on the paper's linear test (Table 2 system, 4 ms delay).
``surrogate_10s_cpu_s``, ``surrogate_10s_linear_cpu_s``, ``surrogate_10s_chain_cpu_s``
    their processor times (s): what the estimate costs whatever else a shared machine runs.
``identify_10s_s``, ``couple_10s_s``
    the two parts of ``surrogate_10s_s``, measured in the same run.
``running_rms_update_us``
    cost of one :meth:`rths3d.surrogate.RunningRMS.update` (one sample, one DOF, 0.25 s
    window at 1 kHz), µs: what a per-step monitor adds to each loop step for its window.
``per_step_monitor_overhead``
    1 + the processor time the online fidelity monitor (``safety.fidelity_limit``, 2 s
    warm-up) spends in its block updates (its record metadata ``fidelity.cpu_s``, the one
    identification after the warm-up, ``monitor_identify_cpu_s``, taken out) over the
    processor time of the same 10 s ``paper_contact`` test through the Stewart platform (6 ms
    delay) without it: what the monitor costs per step. Floor 1.10. Measured inside the run
    because the ratio of two whole runs' times, ``per_step_monitor_overhead_ratio``
    (processor time, timed alternately; ``per_step_monitor_overhead_wall``: wall time),
    scatters by ±10 % between repeats on a shared machine, more than the monitor costs.
    Processor time of this one process (BLAS on one thread) does not count what other
    processes take from a shared machine. The direct measure leaves out the loop's return
    to Python at every monitor block (50 ms): negligible through the Stewart platform
    (≈ 220 µs per step), dominant in the compiled 1-D LTI loop, where the ratio is the
    figure to read.
``monitor_total_overhead``
    the same ratio with the identification left in.
``surrogate_10s_chain_s``
    as ``surrogate_10s_s`` on a 10 s record of a 2-DOF chain (contact part at its upper
    mass) under a ground acceleration (sines written here, 1 ms delay): the contact classes
    on a system unlike the paper's.
``per_step_monitor_overhead_lti``, ``monitor_total_overhead_lti``
    the same through the compiled 1-D LTI loop (≈ 4 µs per step: the monitor's block updates
    and its step are a large share of so short a step).
``e_rel_ref``, ``e_rel_ref_hat``
    the contact record's true and estimated reference error (the benchmark's sanity check).

Medians of ``repeats`` runs after one warm-up (which also compiles the numba kernels). BLAS
threads are pinned to one before numpy loads ("on one core").
"""

from __future__ import annotations

import os

for _var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402


def _record(scene: str, overrides: dict):
    from pathlib import Path

    from rths3d.loop import run, scene_with
    from rths3d.scene import load_scene

    root = Path(__file__).resolve().parents[1]
    s = scene_with(load_scene(root / "scenes" / f"{scene}.toml"), {"duration": 10.0,
                                                                   **overrides})
    return run(s).record


CPU: dict[str, float] = {}
"""Median processor times (s) of the last :func:`_median` calls, by key."""


def _median(fn, repeats: int, key: str = "") -> float:
    fn()
    times, cpu = [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        fn()
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    if key:
        CPU[key] = statistics.median(cpu)
    return statistics.median(times)


def _monitor_overhead(repeats: int) -> dict[str, float]:
    """Loop time with the online fidelity monitor over without (see the docstring)."""
    from rths3d.loop import run
    from rths3d.scene import load_scene

    out: dict[str, float] = {}
    for kind, tail in (("stewart", ""), ("lti", "_lti")):
        ov = {"transfer.kind": kind, "duration": 10.0, "transfer.delay": 6e-3}
        plain = load_scene("paper_contact", ov)
        watched = load_scene("paper_contact", {**ov, "safety.fidelity_limit": 1.0,
                                               "safety.fidelity_warmup": 2.0})
        run(plain, reference=False)
        run(watched, reference=False)  # compiles the kernels
        t_plain, t_watch, t_id, c_plain, c_watch, c_id, c_mon = [], [], [], [], [], [], []
        for _ in range(repeats):
            t0, c0 = time.perf_counter(), time.process_time()
            run(plain, reference=False)
            t_plain.append(time.perf_counter() - t0)
            c_plain.append(time.process_time() - c0)
            t0, c0 = time.perf_counter(), time.process_time()
            rec = run(watched, reference=False).record
            t_watch.append(time.perf_counter() - t0)
            c_watch.append(time.process_time() - c0)
            t_id.append(rec.meta["fidelity"]["identify_s"])
            c_id.append(rec.meta["fidelity"]["identify_cpu_s"])
            c_mon.append(rec.meta["fidelity"]["cpu_s"] - c_id[-1])
        base, cbase = statistics.median(t_plain), statistics.median(c_plain)
        out[f"per_step_monitor_overhead{tail}"] = 1.0 + statistics.median(c_mon) / cbase
        out[f"per_step_monitor_overhead_ratio{tail}"] = statistics.median(
            [(w - i) / cbase for w, i in zip(c_watch, c_id, strict=True)])
        out[f"monitor_total_overhead{tail}"] = statistics.median(c_watch) / cbase
        out[f"per_step_monitor_overhead_wall{tail}"] = statistics.median(
            [(w - i) / base for w, i in zip(t_watch, t_id, strict=True)])
        out[f"monitor_identify_s{tail}"] = statistics.median(t_id)
        out[f"monitor_identify_cpu_s{tail}"] = statistics.median(c_id)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats (3 instead of 7)")
    args = parser.parse_args()
    repeats = 3 if args.quick else 7

    from rths3d.metrics import compute_measures
    from rths3d.surrogate import RunningRMS, SurrogateReference, identify
    from rths3d.surrogate.estimator import couple_members

    contact = _record("paper_contact", {"transfer.delay": 6e-3})
    linear = _record("paper_linear", {"transfer.delay": 4e-3})
    t = np.arange(0.0, 10.005, 0.005)
    ug = np.sin(2 * np.pi * 1.3 * t) + 0.6 * np.sin(2 * np.pi * 3.7 * t + 1.0)  # m/s²
    chain = _record("paper_contact", {
        "numerical.M": [[9.8, 0.0], [0.0, 5.5]], "numerical.C": [[238.0, -36.0], [-36.0, 36.0]],
        "numerical.K": [[7.37e4, -4.57e4], [-4.57e4, 4.57e4]], "numerical.gamma": [[0.0], [1.0]],
        "excitation.kind": "ground", "excitation.signal": "array",
        "excitation.times": t.tolist(), "excitation.values": ug.tolist(),
        "excitation.scale": 1.5, "experiment.m": 0.54, "experiment.k": 1.79e4,
        "experiment.h0": 0.004, "transfer.delay": 1e-3})
    z, f = contact.signal("z_meas"), contact.signal("f_meas")
    ident = identify(z, f)
    res = {
        "surrogate_10s_s": _median(lambda: SurrogateReference().fit(contact), repeats,
                                   "surrogate_10s_cpu_s"),
        "surrogate_10s_linear_s": _median(lambda: SurrogateReference().fit(linear), repeats,
                                          "surrogate_10s_linear_cpu_s"),
        "surrogate_10s_chain_s": _median(lambda: SurrogateReference().fit(chain), repeats,
                                         "surrogate_10s_chain_cpu_s"),
        "identify_10s_s": _median(lambda: identify(z, f), repeats),
        "couple_10s_s": _median(lambda: couple_members([contact], [ident.members]), repeats),
    }
    res.update(CPU)
    mon = RunningRMS(1, 250)
    e = np.zeros(1)
    n = 20000 if args.quick else 100000
    t0 = time.perf_counter()
    for i in range(n):
        e[0] = 1e-4 * (i % 7)
        mon.update(e)
    res["running_rms_update_us"] = (time.perf_counter() - t0) / n * 1e6
    res.update(_monitor_overhead(repeats))
    res["e_rel_ref"] = compute_measures(contact)["e_rel_ref"]
    res["e_rel_ref_hat"] = SurrogateReference().fit(contact).estimates_["e_rel_ref"]
    res["chain_e_rel_ref"] = compute_measures(chain)["e_rel_ref"]
    res["chain_e_rel_ref_hat"] = SurrogateReference().fit(chain).estimates_["e_rel_ref"]
    res["load_avg_1min"] = os.getloadavg()[0]
    res["members"] = len(ident.members)
    res["repeats"] = repeats
    res["quick"] = bool(args.quick)
    print(json.dumps(res))


if __name__ == "__main__":
    main()
