"""Find the physical effect a bench model is missing, add it, watch the error fall.

A "measurement" is made with two effects the nominal model does not have (Coulomb friction
in the legs and a force-sensor low-pass) plus sensor noise and saved to a file. The diagnosis
sees only that file: it replays the measured command through the model, ranks every
candidate effect by its held-out error reduction, accepts the best, refits, and repeats until
only noise remains. The report (Markdown + plots) and a replay with ``model.<column>``
columns for the viewer are written to ``out/60_diagnosis``.

Run: ``python examples/60_find_missing_effect.py`` (about 10 s).
The same from the command line::

    rths3d diagnose out/60_diagnosis/measurement.parquet --scene bench --auto --report DIR
"""

from __future__ import annotations

import argparse
from pathlib import Path

from rths3d.diagnose import Diagnosis, load_measurement, synthetic_measurement
from rths3d.diagnose.report import write_report

OUT = Path("out") / "60_diagnosis"


def main() -> None:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    hidden = {"coulomb_friction": 40.0, "fts_lowpass": 0.003}  # N, s
    path = synthetic_measurement(hidden, duration=4.0, seed=5).save(OUT / "measurement.parquet")
    rec, channels, warnings = load_measurement(path)
    diag = Diagnosis(rec)
    first = None
    for rnd in range(1, 5):
        result = diag.run()
        first = first or result
        if result.proposal is None:
            print(f"round {rnd}: {result.status.replace('_', ' ')}")
            break
        p = result.proposal
        print(f"round {rnd}: add {p.effect} ({p.param} = {p.value:.4g} {p.unit}), validation "
              f"error {p.error_before:.2f} → {p.error_after:.2f} noise units")
        diag.add(p.effect, p.value)
    print("waterfall (RMS error in noise units, 1 = only noise):")
    for step in diag.waterfall:
        print(f"  {step['step']:<45s} training {step['error_train']:7.3f}   "
              f"validation {step['error_val']:7.3f}")
    print("hidden:", hidden, "\nfound: ", {k: round(v, 5) for k, v in diag.accepted.items()})
    report = write_report(diag, result, OUT, warnings, first_round=first)
    print(f"report: {report}")


if __name__ == "__main__":
    import sys

    from rths3d.errors import RthsError

    try:
        main()
    except RthsError as exc:  # a user mistake (flag, file, output folder): no traceback
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
