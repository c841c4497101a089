"""Heave identification: measure the platform's frequency response and fit a TF with delay.

Runs a multisine (0.2–50 Hz) at two operating poses, fits ``num/den · exp(−sT)``, prints
the coefficients and the phase delay at 1 Hz, and writes the TF file and a Bode plot to the
output directory (the repository's own file is made by ``rths3d platform identify``).

Run: ``python examples/11_platform_identify.py [--out DIR]``
"""

from __future__ import annotations

import argparse
from pathlib import Path

from rths3d.platform import PlatformConfig, predicted_delay
from rths3d.platform.calibrate.heave import identify_heave, load_heave_tf


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("out/examples/11_platform_identify"))
    args = ap.parse_args()
    from rths3d.figures import check_output

    check_output(args.out, "--out", folder=True)
    cfg = PlatformConfig()
    res = identify_heave(cfg, poses={"home": (0,) * 6, "raised 25 mm": (0, 0, 0.025, 0, 0, 0)},
                         f_min=0.2, period=5.0, n_lines=24, progress=True)
    path = res.save(args.out / "platform_heave_tf.json")
    png = res.bode_plot(args.out / "platform_heave_bode.png")
    tf = load_heave_tf(path)
    print(f"G(s) = {list(tf.num)} / {list(tf.den)} · exp(−s·{tf.delay * 1e3:.3f} ms)")
    print(f"phase delay at 1 Hz: fit {tf.phase_delay(1.0) * 1e3:.3f} ms, actuator settings "
          f"predict {predicted_delay(cfg, 1.0) * 1e3:.3f} ms; fit error "
          f"{100 * tf.fit_error:.2f} %")
    print(f"TF file {path}\nBode plot {png}")


if __name__ == "__main__":
    import sys

    from rths3d.errors import RthsError

    try:
        main()
    except RthsError as exc:  # a user mistake (flag, file, output folder): no traceback
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
