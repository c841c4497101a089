"""Speed of the RTHS benchmark reproduction: one 41.18 s El Centro case at 4096 Hz.

Prints ONE JSON line:

* ``elcentro_case_s`` — wall time (median of repeats) of ``run_case`` for case 1, nominal
  plant, noise on: build, 168 674 loop steps, reference response and J1–J9 (floor: < 10 s
  on one core)
* ``loop_us_per_step`` — the same run's time per loop step (µs)
* ``rtf`` — simulated seconds per wall second of the whole case
* ``trial_s`` — wall time per perturbed trial when 4 trials run through ``run_trials``
* ``max_abs_dev_published`` — largest |J − Table 3| over J2–J9 of the timed case
* ``repeats``

``--quick`` uses one repeat and two trials.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one repeat, fewer trials")
    args = ap.parse_args()

    from rths3d.rthsbench import (
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
    print(json.dumps({
        "elcentro_case_s": round(t_case, 4),
        "loop_us_per_step": round(1e6 * t_case / res.t.size, 3),
        "rtf": round(float(res.t[-1]) / t_case, 2),
        "trial_s": round(t_trial, 4),
        "max_abs_dev_published": round(dev, 4),
        "steps": int(res.t.size),
        "repeats": repeats,
    }))


if __name__ == "__main__":
    main()
