"""A multi-DOF test through two platform DOFs (heave z and pitch ry) with contact.

Prints the fastest eigenfrequencies used for the τ-ratios (paper eqs. 12–13, generalised to
the fastest mode), runs the test on the Stewart platform and on the ideal transfer system, and
reports the reference error per DOF.

    python examples/21_multidof.py [--duration 3]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from rths3d.loop import run
from rths3d.scene import load_scene

REPO = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=3.0, help="simulated time (s)")
    args = ap.parse_args()
    scene = load_scene(REPO / "scenes" / "multidof.toml", [f"duration={args.duration}"])
    for kind in ("ideal", "stewart"):
        res = run(scene, kind)
        rec = res.record
        m = rec.meta
        print(f"{kind}: {res.status} {res.reason}")
        print(f"  ω_0,NUM = {m['omega_num_max']:.2f} rad/s, ω_0,DYN = {m['omega_dyn_max']:.2f} "
              "rad/s (fastest modes)")
        for d in scene.dofs:
            z, zr = rec.columns[f"z_cmd.{d}"], rec.columns[f"z_ref.{d}"]
            err = np.sqrt(np.mean((z - zr) ** 2) / np.mean(zr**2))
            unit = "rad" if d.startswith("r") else "m"
            print(f"  {d:2s}: peak |z| = {np.abs(z).max():.4g} {unit}, peak |F'_m| = "
                  f"{np.abs(rec.columns[f'f_meas.{d}']).max():.3g}, e_rel,ref = {err:.4f}")


if __name__ == "__main__":
    import sys

    from rths3d.errors import RthsError

    try:
        main()
    except RthsError as exc:  # a user mistake (flag, file, output folder): no traceback
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
