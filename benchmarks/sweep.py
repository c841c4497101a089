"""Benchmark: sweep throughput (1 vs 2 workers), the paper's sweeps, and LM vs Adam.

Run ``python benchmarks/sweep.py [--quick]``; prints ONE JSON line:

``tests_per_s_1worker``, ``tests_per_s_2workers``, ``parallel_efficiency``
    the same LTI sweep (256 tests of the Table-1 grid in 4 batches; ``--quick`` 64) run with
    1 and with 2 local worker processes, side by side (efficiency = rate₂ / (2 rate₁)). Each
    run is a fresh Python process, as from the command line, timed from its start to its
    end: both pay the interpreter's start, the imports and the compiled kernels' loading once
    (the 1-worker run in its own process, held to one core with ``RTHS3D_THREADS=1`` as each
    pool worker is; the 2-worker run in the sweep process, whose workers are forked from it
    warm). ``parallel_efficiency_1024`` (full run only): the same for 1024 tests.
``machine_parallel_efficiency``
    the machine's own ceiling for that figure, measured in the same run: a compiled
    arithmetic loop (no memory traffic, no GIL) on one thread, then on two at once
    (rate₂ / (2 rate₁)); a sweep cannot scale better than its cores do.
``paper280_stewart_s``
    wall time of the paper's 280-test contact sweep on the MuJoCo Stewart platform (2 workers;
    floor < 120 s). With ``--quick`` 20 tests (one transfer setting, 2 batches) are timed and
    scaled to 280 tests.
``table1_grid_lti_s``
    wall time of the full Table-1 grid (13230 tests) with the 1-D LTI transfer (floor < 300 s).
    With ``--quick`` 512 tests in 2 batches of 256 (the full sweep's batch size) are timed and
    scaled.
``table1_grid_lti_with_surrogate_s``
    the same grid with the surrogate reference's estimate in every row (the spec leaves it
    out, ``[sweep] surrogate = false``; a sweep carries it by default): a subset of 128
    tests (256 without ``--quick``) timed with and without it side by side, the grid's time
    scaled by their ratio; ``surrogate_cost_ratio`` is that ratio.
``paper280_lti_s``
    wall time of the paper's 280-test contact sweep with the 1-D LTI transfer (2 workers);
    its transfer settings are drawn per test, and the loop steps them together. With
    ``--quick`` 120 tests of one setting, not scaled (the LM-vs-Adam data).
``lti_mixed_batch_speedup``
    side by side, one process: ``lti_mixed_batch_tests`` tests spread over that sweep (one
    batch's worth, ``lti_transfer_settings`` transfer settings among them) run as one batch,
    against the same tests run one batch per transfer setting (how the sweep ran before the
    LTI path took its actuator settings per test); time per-setting / time mixed.
    ``lti_mixed_batch_max_diff``: the largest difference of e_rel,ref between the two
    (rounding).
``lm_over_adam_time``
    (LM wall time to a validation MSE) / (Adam wall time to the same MSE), the MSE being the
    median of LM's best over 5 seeds, restarts charged (see :func:`lm_vs_adam`); on the
    280-test contact data with feature set 2 (``--quick``: 120 of them). < 1: LM is faster.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import statistics
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SWEEPS = REPO / "scenes" / "sweeps"


def _timed_cli_sweep(n: int, out: Path, workers: int) -> float:
    """Wall time (s) of a fresh process that runs ``n`` tests of the Table-1 LTI grid (4
    batches) with ``workers`` local workers (1: in that process, on one core)."""
    import subprocess

    env = dict(os.environ)
    if workers == 1:
        env["RTHS3D_THREADS"] = "1"  # one worker, one core (as each pool worker)
    shutil.rmtree(out, ignore_errors=True)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, __file__, "--subset-run", str(n), str(workers), str(out)],
                   check=True, env=env)
    return time.perf_counter() - t0


def _subset_run(n: int, workers: int, out: str) -> None:
    from rths3d.dataset import load_spec, run_sweep

    spec = _subset(load_spec(SWEEPS / "table1_lti.toml"), n, n_batches=4)
    run_sweep(spec, out, workers=workers, progress=False)


def _timed_sweep(spec, out: Path, workers: int) -> tuple[float, object]:
    from rths3d.dataset import run_sweep

    shutil.rmtree(out, ignore_errors=True)
    t0 = time.perf_counter()
    frame = run_sweep(spec, out, workers=workers, progress=False)
    return time.perf_counter() - t0, frame


def machine_parallel_efficiency(seconds: float = 0.4) -> float:
    """rate on two threads / (2 × rate on one) of a compiled arithmetic loop (the cores'
    ceiling for any parallel work here, measured rather than assumed)."""
    import threading

    import numba

    @numba.njit(nogil=True, cache=False)
    def spin(n):
        x = 0.0
        for i in range(n):
            x += (i % 7) * 1.0000001
        return x

    spin(10)
    n = 1_000_000
    t0 = time.perf_counter()
    spin(n)
    n = max(n, int(n * seconds / max(time.perf_counter() - t0, 1e-6)))
    t0 = time.perf_counter()
    spin(n)
    one = time.perf_counter() - t0
    threads = [threading.Thread(target=spin, args=(n,)) for _ in range(2)]
    t0 = time.perf_counter()
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    two = time.perf_counter() - t0
    return one / two


def _subset(spec, n: int, n_batches: int = 2):
    """A random ``n`` of the spec's tests that all share one transfer setting (the first
    value of every random choice), cut into ``n_batches`` batches.

    One shared setting lets the loop step a whole batch together, as it does in the full
    sweeps (whose tests are ordered by transfer setting, so batches are homogeneous); at least
    one batch per worker, else a 2-worker run would have nothing to share.
    """
    fams = []
    for f in spec.families:
        sample = {k: v for k, v in f.sample.items() if v[0] != "choice"}
        fixed = dict(f.fixed) | {k: v[1][0] for k, v in f.sample.items() if v[0] == "choice"}
        fams.append(replace(f, subset=n, sample=sample, fixed=fixed,
                            n_sample=f.n_sample if sample else 0))
    return replace(spec, families=tuple(fams), name=f"{spec.name}_sub{n}",
                   batch_size=max(1, math.ceil(n / n_batches)))


def mixed_vs_per_setting(spec, n: int) -> dict:
    """Time ``n`` tests of ``spec`` run as one batch and as one batch per transfer setting."""
    import itertools

    import numpy as np

    from rths3d.dataset.runner import run_rows

    every = spec.tests()  # ordered by transfer setting: take every m-th test for a spread
    tests = every[::max(1, len(every) // n)][:n]

    def setting(t):
        return json.dumps(sorted((k, v) for k, v in t["params"].items()
                                 if k.startswith("transfer.")))

    run_rows(spec, tests[:2])  # imports and caches out of the timing
    t0 = time.perf_counter()
    mixed = run_rows(spec, tests)
    t1 = time.perf_counter()
    groups = [list(g) for _, g in itertools.groupby(sorted(tests, key=setting), key=setting)]
    per = {r["test_id"]: r for g in groups for r in run_rows(spec, g)}
    t2 = time.perf_counter()
    diff = [abs(r["target.e_rel_ref"] - per[r["test_id"]]["target.e_rel_ref"])
            for r in mixed if r["status"] == "ok"]
    return {"lti_mixed_batch_speedup": (t2 - t1) / (t1 - t0),
            "lti_mixed_batch_s": t1 - t0, "lti_per_setting_batches_s": t2 - t1,
            "lti_mixed_batch_tests": len(tests), "lti_transfer_settings": len(groups),
            "lti_mixed_batch_max_diff": float(np.max(diff)) if diff else math.nan}


def lm_vs_adam(X, y, seeds=(0, 1, 2, 3, 4), hidden=(5,), adam_cap_s: float = 30.0) -> dict:
    """Wall time for LM and for Adam to reach the same validation MSE, as a practitioner would.

    The target is the median over seeds of LM's best validation MSE. Each method trains from
    seed after seed (restarting when a run stops without reaching the target) and is charged
    the time until the target is first reached; one figure per starting seed, medians reported.
    Adam runs are capped at ``adam_cap_s`` each (a capped total is a lower bound for Adam).
    """
    from rths3d.ann import (
        AdamConfig,
        MinMax,
        Topology,
        split_indices,
        time_to_val_mse,
        train_adam,
        train_lm,
    )

    x = X.to_numpy(dtype=float) if hasattr(X, "to_numpy") else X
    xn = MinMax.fit(x).transform(x)
    tn = MinMax.fit(y[:, None]).transform(y[:, None])[:, 0]
    s = split_indices(len(y), seed=0)
    topo = Topology(x.shape[1], tuple(hidden))
    args = (topo, xn[s["train"]], tn[s["train"]], xn[s["val"]], tn[s["val"]])
    lm_runs = {seed: train_lm(*args, seed=seed) for seed in seeds}
    target = statistics.median(r.val_mse for r in lm_runs.values())

    def charged(runs: dict) -> list[float]:
        out = []
        order = list(seeds)
        for i in range(len(order)):
            total = 0.0
            for seed in order[i:] + order[:i]:
                t = time_to_val_mse(runs[seed], target)
                if math.isfinite(t):
                    total += t
                    break
                total += runs[seed].seconds
            else:
                total = math.inf
            out.append(total)
        return out

    adam_runs = {seed: train_adam(*args, seed=seed,
                                  config=AdamConfig(target_val_mse=target, time_limit=adam_cap_s,
                                                    max_fail=10**9, epochs=10**9))
                 for seed in seeds}
    t_lm = charged(lm_runs)
    t_ad = charged(adam_runs)
    reached = sum(math.isfinite(time_to_val_mse(r, target)) for r in adam_runs.values())
    t_ad = [t if math.isfinite(t) else sum(r.seconds for r in adam_runs.values())
            for t in t_ad]
    ratios = [a / max(b, 1e-9) for a, b in zip(t_lm, t_ad, strict=True)]
    return {"lm_over_adam_time": statistics.median(ratios),
            "lm_time_to_mse_s": statistics.median(t_lm),
            "adam_time_to_mse_s": statistics.median(t_ad),
            "adam_runs_reaching_target": reached / len(seeds),
            "target_val_mse_normalised": target}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="short version (subsets, scaled)")
    ap.add_argument("--subset-run", nargs=3, metavar=("N", "WORKERS", "OUT"),
                    help=argparse.SUPPRESS)  # one timed run of the throughput figures
    args = ap.parse_args()
    if args.subset_run:
        n, workers, out = args.subset_run
        _subset_run(int(n), int(workers), out)
        return
    from rths3d.dataset import load_spec, training_data

    res: dict = {"quick": bool(args.quick), "cpus": os.cpu_count()}
    tmp = Path(tempfile.mkdtemp(prefix="rths3d_bench_"))
    try:
        lti = load_spec(SWEEPS / "table1_lti.toml")
        stew = load_spec(SWEEPS / "paper280_stewart.toml")
        # throughput: the same LTI subset with 1 and 2 workers, side by side, each a fresh
        # process as from the command line
        n_small = 64 if args.quick else 256
        t1 = _timed_cli_sweep(n_small, tmp / "w1", 1)
        t2 = _timed_cli_sweep(n_small, tmp / "w2", 2)
        res["machine_parallel_efficiency"] = machine_parallel_efficiency()
        res["tests_per_s_1worker"] = n_small / t1
        res["tests_per_s_2workers"] = n_small / t2
        res["parallel_efficiency"] = t1 / (2.0 * t2)
        res["throughput_tests"] = n_small
        if not args.quick:
            t1 = _timed_cli_sweep(1024, tmp / "w1", 1)
            t2 = _timed_cli_sweep(1024, tmp / "w2", 2)
            res["parallel_efficiency_1024"] = t1 / (2.0 * t2)
        # the paper's 280-test sweep on the Stewart platform
        n280 = len(stew.tests())
        if args.quick:
            sub = _subset(stew, 20)
            ts, _ = _timed_sweep(sub, tmp / "stew", 2)
            res["paper280_stewart_s"] = ts * n280 / len(sub.tests())
            res["paper280_stewart_scaled_from"] = len(sub.tests())
        else:
            ts, _ = _timed_sweep(stew, tmp / "stew", 2)
            res["paper280_stewart_s"] = ts
        # the full Table-1 grid with the LTI transfer
        n_grid = len(lti.tests())
        if args.quick:
            sub = _subset(lti, 512)
            tg, _ = _timed_sweep(sub, tmp / "grid", 2)
            res["table1_grid_lti_s"] = tg * n_grid / len(sub.tests())
            res["table1_grid_lti_scaled_from"] = len(sub.tests())
        else:
            tg, _ = _timed_sweep(lti, tmp / "grid", 2)
            res["table1_grid_lti_s"] = tg
        res["table1_grid_tests"] = n_grid
        # the same with the surrogate estimate in every row, side by side on a subset
        sub = _subset(lti, 128 if args.quick else 256, n_batches=2)
        t_off, _ = _timed_sweep(sub, tmp / "grid_off", 2)
        t_on, _ = _timed_sweep(replace(sub, surrogate=True), tmp / "grid_on", 2)
        res["surrogate_cost_ratio"] = t_on / t_off
        res["table1_grid_lti_with_surrogate_s"] = res["table1_grid_lti_s"] * t_on / t_off
        # LM vs Adam on contact data (the 280-test LTI subset of the paper)
        paper = load_spec(SWEEPS / "paper280_lti.toml")
        res.update(mixed_vs_per_setting(paper, 12 if args.quick else paper.batch_size))
        if args.quick:
            paper = _subset(paper, 120)
        tp, frame = _timed_sweep(paper, tmp / "paper", 2)
        res["paper280_lti_s"] = tp
        X, y, _ = training_data(frame, 2)
        res.update(lm_vs_adam(X, y, seeds=(0, 1, 2, 3, 4),
                              adam_cap_s=10.0 if args.quick else 30.0))
        res["lm_vs_adam_samples"] = int(len(y))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    print(json.dumps(res))
    sys.stdout.flush()


if __name__ == "__main__":
    main()
