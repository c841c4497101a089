"""How much RoDeAC's offline calibration (θ₀, P₀) depends on the sensor-noise realisation
(docs/marths.md, "RoDeAC's initial parameters").

Repeats :func:`rths3d.community.marths.offline_calibration` (99 runs: 3 records × {0.2,
0.4, 0.6} × [nominal + 10 perturbed plants, seed 123]) for noise seeds 0 … N−1 (one
independent sequence per plant, as the package does) and prints, per seed, the largest
relative difference of θ₀ and of each actuator's P₀ entries from the benchmark's stored
values, then per entry the mean and standard deviation over the seeds (JSON lines).

Needs the maRTHS benchmark folder beside the repository (or RTHS3D_MARTHS_DIR).

Run: ``python examples/76_rodeac_noise_seeds.py [--seeds 20]``.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np


def main(argv: list[str] | None = None) -> int:
    from rths3d.community.marths import offline_calibration
    from rths3d.community.marths.data import data_dir
    from rths3d.errors import RthsError

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20, help="noise seeds 0 … N−1")
    a = ap.parse_args(argv)
    if a.seeds < 2:
        ap.exit(2, f"error: --seeds: {a.seeds} (must be >= 2)\n")
    try:
        folder = data_dir(None)
    except RthsError as exc:
        ap.exit(2, f"error: {exc}\n")
    stored = json.loads((folder / "data" / "controller_rodeac.json").read_text())
    th0 = np.array([stored["theta0_act1"], stored["theta0_act2"]])
    P0 = np.array([stored["P0_act1"], stored["P0_act2"]])
    rel = []
    for s in range(a.seeds):
        cal = offline_calibration(noise_seed=s)
        r = cal.P_mean / P0 - 1.0
        rel.append(r)
        print(json.dumps({"seed": s,
                          "theta_max_rel_pct": float(100 * np.abs(cal.theta_mean / th0 - 1).max()),
                          "P_act1_max_rel_pct": float(100 * np.abs(r[0]).max()),
                          "P_act2_max_rel_pct": float(100 * np.abs(r[1]).max())}), flush=True)
    R = 100 * np.array(rel)
    print(json.dumps({"P_rel_pct_mean": R.mean(0).round(3).tolist(),
                      "P_rel_pct_std": R.std(0, ddof=1).round(3).tolist(),
                      "seeds_all_P_within_1pct": int((np.abs(R).max(axis=(1, 2, 3)) < 1).sum())}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
