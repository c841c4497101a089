"""The paper's contact test (Fig. 4) on the simulated Stewart platform, against its reference.

Runs the test with the ideal, the 1-D LTI and the Stewart transfer systems, prints the
relative RMS reference error e_rel,ref (paper eq. 1 with z^r) of each, and writes a plot of
z, z', z^r and the SSP of the Stewart run to ``out/20_contact_test.png``.

    python examples/20_contact_test.py [--duration 4]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from rths3d.loop import run
from rths3d.scene import load_scene

REPO = Path(__file__).resolve().parents[1]


def e_rel(z: np.ndarray, zr: np.ndarray) -> float:
    """RMS(z − z^r) / RMS(z^r)."""
    return float(np.sqrt(np.mean((z - zr) ** 2) / np.mean(zr**2)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=4.0, help="simulated time (s)")
    ap.add_argument("--out", default="out", help="output folder")
    args = ap.parse_args()
    from rths3d.figures import check_output

    check_output(args.out, "--out", folder=True)
    scene = load_scene(REPO / "scenes" / "paper_contact.toml", [f"duration={args.duration}"])
    for kind in ("ideal", "lti", "stewart"):
        res = run(scene, kind)
        rec = res.record
        err = e_rel(rec.columns["z_cmd.z"], rec.columns["z_ref.z"])
        peak = rec.columns["f_meas.z"].max()
        print(f"{kind:8s} status={res.status:7s} e_rel,ref={err:.4f}  peak F'_m={peak:6.1f} N"
              f"  RTF={res.rtf:6.1f}")
    from rths3d.cli.run import _plot

    path = _plot(rec, Path(args.out) / "20_contact_test.png")
    print(f"plot → {path}")


if __name__ == "__main__":
    import sys

    from rths3d.errors import RthsError

    try:
        main()
    except RthsError as exc:  # a user mistake (flag, file, output folder): no traceback
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
