"""Speed of the RTHS benchmark reproduction: one 41.18 s El Centro case at 4096 Hz.

Prints ONE JSON line:

* ``elcentro_case_s`` — wall time (median of repeats) of ``run_case`` for case 1, nominal
  plant, noise on: build, 168 674 loop steps, reference response and J1–J9 (floor: < 10 s
  on one core)
* ``loop_us_per_step`` — the same run's time per loop step (µs)
* ``rtf`` — simulated seconds per wall second of the whole case
* ``trial_s`` — wall time per perturbed trial when 4 trials run through ``run_trials``
* ``max_abs_dev_published`` — largest |J − Table 3| over J2–J9 of the timed case
* ``compensator_step_us`` — per compensator of :mod:`rths3d.compensation`, µs per
  ``command`` call for K = 1 test × n = 6 channels (the six legs) at dt = 1 ms, the answer
  fed back as the next measurement (median of repeats of 20 000 calls on a sine per channel;
  velocity and polynomial with τ_c = 4 ms)
* ``compensated_case_s`` — wall time of the same El Centro case with the calibrated ATS in
  place of the phase lead (``run_compensated``; calibration not included)
* ``marths_case_s`` — wall time of one multi-axial benchmark run (maRTHS, El Centro × 0.4,
  41.18 s at 1024 Hz, 42 169 steps, nominal plant, RoDeAC with the stored θ0/P0): reference
  and numerical Newmark, feedback force, kinematics, plant, compensator and J1–J10 (null
  without the maRTHS data folder); ``marths_us_per_step`` the same per loop step (µs)
* ``repeats``

``--quick`` uses one repeat, two trials and 5 000 compensator calls.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time


def compensator_step_us(repeats: int, calls: int) -> dict[str, float]:
    """µs per ``command`` call of every registered compensator, K = 1, n = 6, dt = 1 ms, each
    answer fed back as the next measurement (an ideal transfer system); the fixed schemes
    with τ_c = 4 ms (their τ_c = 0 default passes z through)."""
    import numpy as np

    from rths3d.compensation import build, compensator_names

    dt, n = 1e-3, 6
    t = np.arange(calls) * dt
    z = np.stack([2e-3 * np.sin(2 * np.pi * (0.5 + 0.3 * j) * t) for j in range(n)], axis=1)
    zd = np.gradient(z, dt, axis=0)
    rows = [(z[k:k + 1].copy(), zd[k:k + 1].copy()) for k in range(calls)]
    out = {}
    for name in compensator_names():
        comp = build(name, 1, n, dt, {"tau": 0.004} if name in ("velocity", "polynomial")
                     else None)
        zm = np.zeros((1, n))
        for a, b in rows[:200]:  # compile and warm
            np.copyto(zm, comp.command(a, b, zm))
        times = []
        for _ in range(repeats):
            comp.reset()
            command = comp.command
            t0 = time.perf_counter()
            for a, b in rows:
                np.copyto(zm, command(a, b, zm))
            times.append(time.perf_counter() - t0)
        out[name] = round(1e6 * statistics.median(times) / calls, 3)
    return out


def marths_case_s(repeats: int) -> tuple[float | None, float | None]:
    """Median wall time (s) of one maRTHS El Centro run with RoDeAC, and µs per step; None
    when the maRTHS data folder is absent."""
    from rths3d.community.marths import MarthsConfig, data_dir, run_marths
    from rths3d.errors import ConfigError

    try:
        data_dir()
    except ConfigError:
        return None, None
    run_marths(MarthsConfig(t_end=0.5))  # compile and load
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = run_marths(MarthsConfig())[0]
        times.append(time.perf_counter() - t0)
    t = statistics.median(times)
    return round(t, 4), round(1e6 * t / res.t.size, 3)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one repeat, fewer trials")
    args = ap.parse_args()

    from rths3d.community import (
        PUBLISHED_TABLE3,
        BenchmarkConfig,
        load_excitation,
        run_case,
        run_trials,
    )

    repeats = 1 if args.quick else 5
    n_trials = 2 if args.quick else 4
    gm = load_excitation("ElCentro")
    cfg = BenchmarkConfig(case=1)
    run_case(BenchmarkConfig(case=1, t_end=1.0), gm=gm)  # warm imports and caches
    times = []
    res = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        res = run_case(cfg, gm=gm)
        times.append(time.perf_counter() - t0)
    t_case = statistics.median(times)
    t0 = time.perf_counter()
    run_trials(cfg, n_trials=n_trials, seed=1, gm=gm)
    t_trial = (time.perf_counter() - t0) / n_trials
    row = res.table_row()
    dev = max(abs(row[k] - PUBLISHED_TABLE3[1][k]) for k in row if k != "J1")
    step_us = compensator_step_us(repeats, 5000 if args.quick else 20000)
    from rths3d.community.compensated import calibrated_config, run_compensated

    conf = calibrated_config("ats", cfg)
    run_compensated(BenchmarkConfig(case=1, t_end=1.0), "ats", conf, gm=gm)  # compile
    t0 = time.perf_counter()
    run_compensated(cfg, "ats", conf, gm=gm)
    t_comp = time.perf_counter() - t0
    t_marths, us_marths = marths_case_s(repeats)
    print(json.dumps({
        "elcentro_case_s": round(t_case, 4),
        "loop_us_per_step": round(1e6 * t_case / res.t.size, 3),
        "rtf": round(float(res.t[-1]) / t_case, 2),
        "trial_s": round(t_trial, 4),
        "max_abs_dev_published": round(dev, 4),
        "compensator_step_us": step_us,
        "compensated_case_s": round(t_comp, 4),
        "marths_case_s": t_marths,
        "marths_us_per_step": us_marths,
        "steps": int(res.t.size),
        "repeats": repeats,
    }))


if __name__ == "__main__":
    main()
