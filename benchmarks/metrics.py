"""Benchmark: every accuracy measure of a 60 s, 1 kHz, 6-DOF record on one core.

Run ``python benchmarks/metrics.py [--quick]``; prints ONE JSON line:

``all_measures_60s_6dof_s``
    median wall time (s) of :func:`rths3d.metrics.compute_measures` on a 60 s, 1 kHz record
    with all six interface DOFs, forces, external forces, a reference and the numerical and
    experimental model in the metadata (so PSI and the τ-ratios are computed too). Floor: 0.5 s.
``all_measures_60s_1dof_s``
    the same for one DOF.
``fei_60s_6dof_s``, ``paei_60s_6dof_s``, ``interface_loop_6dof_s``
    the parts that cost the most, measured in the same run.
``criteria_included``
    whether J1–J9 were part of the measured call.

Figures are medians of ``repeats`` runs after one warm-up call. BLAS threads are pinned to one
before numpy loads ("on one core").
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

from rths3d.metrics import compute_measures, fei, interface_loop, paei  # noqa: E402
from rths3d.record import DOFS, Record  # noqa: E402


def make_record(seconds: float = 60.0, dt: float = 1e-3, dofs=DOFS, seed: int = 0) -> Record:
    """A realistic record: multi-tone commands, lagged/scaled/noisy measurements per DOF."""
    rng = np.random.default_rng(seed)
    n = int(round(seconds / dt))
    t = np.arange(n) * dt
    cols: dict[str, np.ndarray] = {}
    for j, d in enumerate(dofs):
        f1, f2 = 0.3 + 0.2 * j, 2.1 + 0.3 * j
        scale = 0.01 if d in ("x", "y", "z") else 0.02
        tau = 0.004 + 0.001 * j
        z = scale * (np.sin(2 * np.pi * f1 * t) + 0.2 * np.sin(2 * np.pi * f2 * t + 0.4))
        zp = 0.97 * scale * (np.sin(2 * np.pi * f1 * (t - tau))
                             + 0.2 * np.sin(2 * np.pi * f2 * (t - tau) + 0.4))
        zp += 1e-5 * rng.standard_normal(n)
        cols[f"z_cmd.{d}"] = z
        cols[f"z_meas.{d}"] = zp
        cols[f"f_meas.{d}"] = 8650.0 * zp + 0.05 * rng.standard_normal(n)
        cols[f"f_ext.{d}"] = 20.0 * np.sin(2 * np.pi * 0.5 * t + j)
        cols[f"z_ref.{d}"] = 1.01 * z
    nd = len(dofs)
    meta = {"experiment": {"m_exp": (np.eye(nd) * 0.38).tolist(),
                           "k_exp": (np.eye(nd) * 8650.0).tolist()},
            "numerical": {"M": (np.eye(nd) * 9.62).tolist(), "C": (np.eye(nd) * 100.0).tolist(),
                          "K": (np.eye(nd) * 1e4).tolist(), "gamma": np.eye(nd).tolist()}}
    return Record(t, cols, meta)


def median_time(fn, repeats: int) -> float:
    fn()  # warm-up (imports, FFT plans)
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="fewer repeats (3 instead of 9)")
    args = parser.parse_args()
    repeats = 3 if args.quick else 9
    rec6 = make_record()
    rec1 = make_record(dofs=("z",))
    z, zp = rec6.signal("z_cmd"), rec6.signal("z_meas")
    m = compute_measures(rec6)
    nd = len(DOFS)
    eye = np.eye(nd)
    result = {
        "all_measures_60s_6dof_s": median_time(lambda: compute_measures(rec6), repeats),
        "all_measures_60s_1dof_s": median_time(lambda: compute_measures(rec1), repeats),
        "fei_60s_6dof_s": median_time(lambda: fei(z, zp, rec6.dt), repeats),
        "paei_60s_6dof_s": median_time(lambda: paei(z, zp), repeats),
        "interface_loop_6dof_s": median_time(
            lambda: interface_loop(9.62 * eye, 100.0 * eye, 1e4 * eye, 0.38 * eye, 0 * eye,
                                   8650.0 * eye, eye), repeats),
        "criteria_included": "j1" in m["aggregate"],
        "floor_s": 0.5,
        "samples": rec6.n,
        "dofs": nd,
        "repeats": repeats,
    }
    print(json.dumps(result))


if __name__ == "__main__":
    main()
