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
``identify_10s_s``, ``couple_10s_s``
    the two parts of ``surrogate_10s_s``, measured in the same run.
``running_rms_update_us``
    cost of one :meth:`rths3d.surrogate.RunningRMS.update` (one sample, one DOF, 0.25 s
    window at 1 kHz), µs: what a per-step monitor adds to each loop step for its window.
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


def _median(fn, repeats: int) -> float:
    fn()
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


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
    z, f = contact.signal("z_meas"), contact.signal("f_meas")
    ident = identify(z, f)
    res = {
        "surrogate_10s_s": _median(lambda: SurrogateReference().fit(contact), repeats),
        "surrogate_10s_linear_s": _median(lambda: SurrogateReference().fit(linear), repeats),
        "identify_10s_s": _median(lambda: identify(z, f), repeats),
        "couple_10s_s": _median(lambda: couple_members([contact], [ident.members]), repeats),
    }
    mon = RunningRMS(1, 250)
    e = np.zeros(1)
    n = 20000 if args.quick else 100000
    t0 = time.perf_counter()
    for i in range(n):
        e[0] = 1e-4 * (i % 7)
        mon.update(e)
    res["running_rms_update_us"] = (time.perf_counter() - t0) / n * 1e6
    res["e_rel_ref"] = compute_measures(contact)["e_rel_ref"]
    res["e_rel_ref_hat"] = SurrogateReference().fit(contact).estimates_["e_rel_ref"]
    res["members"] = len(ident.members)
    res["repeats"] = repeats
    res["quick"] = bool(args.quick)
    print(json.dumps(res))


if __name__ == "__main__":
    main()
