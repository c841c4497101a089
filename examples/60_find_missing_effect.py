"""Find the physical effect a bench model is missing, add it, watch the error fall.

A measurement is made the way a bench makes it: ``rths3d run`` of the six-DOF bench test
``bench6`` (closed loop with its numerical substructure) on a platform with two effects its
model does not have — Coulomb friction in leg 3 and a force-sensor low-pass — four physics
substeps per sample and measurement noise on every channel. The diagnosis sees only the
saved file (whose metadata names the nominal bench): it replays the measured pose commands
through the bench, ranks every candidate effect (each effect on each leg and axis, the
kinematic and FTS calibrations) by its held-out error reduction, accepts the best, refits,
and repeats until only noise remains; then it writes the calibrated scene and runs it, so the
hybrid test's tracking error and FEI delay can be compared. The report (Markdown + plots), a
replay with ``model.<column>`` and ``residual.<column>`` columns for the viewer and
``calibrated.toml`` are written to ``out/60_diagnosis``.

Run: ``python examples/60_find_missing_effect.py [--duration S]`` (a few minutes).
The same from the command line::

    rths3d diagnose out/60_diagnosis/measurement.parquet --auto --report DIR \\
        --save-scene calibrated.toml --hybrid
"""

from __future__ import annotations

import argparse
from pathlib import Path

OUT = Path("out") / "60_diagnosis"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=3.0, help="record length (s)")
    args = ap.parse_args()
    from rths3d.diagnose import Diagnosis, load_measurement, measure
    from rths3d.diagnose.report import hybrid_figures, write_report
    from rths3d.scene import load_scene, scene_to_toml

    hidden = {"coulomb_friction.leg3": 30.0, "fts_lowpass": 0.003}  # N, s
    scene = load_scene("bench6", [f"duration={args.duration}"])
    path = measure(scene, hidden, seed=5).save(OUT / "measurement.parquet")
    rec, channels, warnings = load_measurement(path)
    diag = Diagnosis(rec)
    rounds = diag.auto(max_rounds=4)
    for k, r in enumerate(rounds, 1):
        p = r.proposal
        if p is None:
            print(f"round {k}: {r.status.replace('_', ' ')}")
        else:
            print(f"round {k}: {r.status.replace('_', ' ')}: {p.effect} ({p.param} = "
                  f"{p.value:.4g} {p.unit}), validation error {p.error_before:.2f} → "
                  f"{p.error_after:.2f} noise units")
    print("waterfall (RMS error in noise units, 1 = only noise):")
    for step in diag.waterfall:
        print(f"  {step['step']:<50s} training {step['error_train']:7.3f}   "
              f"validation {step['error_val']:7.3f}")
    print("hidden:", hidden, "\nfound: ", {k: round(v, 5) for k, v in diag.accepted.items()})
    (OUT / "calibrated.toml").write_text(scene_to_toml(diag.calibrated_scene()))
    hyb = hybrid_figures(diag)
    for name, h in hyb.items():
        print(f"hybrid test, {name:<12s} e_rel,track {100 * h['e_rel_track']:.4f} %, FEI delay "
              f"{1e3 * h['fei_d']:.4f} ms")
    report = write_report(diag, rounds[-1], OUT, warnings, first_round=rounds[0], hybrid=hyb)
    print(f"report: {report}")


if __name__ == "__main__":
    main()
