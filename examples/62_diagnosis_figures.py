"""The diagnosis' figures beyond the effect matrix: null records, out-of-library effects and
the hybrid test level, each measured with ``rths3d run`` (closed loop, 4 physics substeps,
noise on every channel) and handed to the diagnosis as a file.

* null: ``paper_contact``, ``paper_linear``, ``multidof`` and ``bench6`` through the Stewart
  platform without any effect — the verdict and the validation error (noise units);
* out of library: a hardening spring and a 45 Hz, 1 % fixture resonance, both made at the
  MJCF level (a test-only part) — the verdict of every round and where the residual remains;
* hybrid level: three effects hidden on three legs of a ``paper_contact`` bench — diagnosis,
  acceptance and ``rths3d run`` of the calibrated scene against the record: e_rel,track and
  FEI delay, measured vs uncalibrated vs calibrated.

Prints one JSON object and writes it to ``--out`` (default
``out/examples/62_diagnosis_figures.json``).

Run: ``python examples/62_diagnosis_figures.py [--duration S] [--out FILE]``
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=3.0, help="record length (s)")
    ap.add_argument("--out", type=Path,
                    default=Path("out/examples/62_diagnosis_figures.json"))
    args = ap.parse_args()
    from rths3d.config import EffectConfig
    from rths3d.diagnose import Diagnosis, hide_effects, measure
    from rths3d.diagnose.report import hybrid_figures
    from rths3d.experiment import ContactPart, register_part
    from rths3d.experiment.base import PARTS
    from rths3d.loop import run
    from rths3d.scene import load_scene

    D = args.duration
    out: dict = {"duration_s": D, "null": {}, "out_of_library": {}}
    for k, name in enumerate(("paper_contact", "paper_linear", "multidof", "bench6")):
        sc = load_scene(name, [f"duration={D}", "transfer.kind='stewart'"])
        res = Diagnosis(measure(sc, {}, seed=300 + k)).run()
        out["null"][name] = {"status": res.status, "error_val": res.error_val,
                             "error_train": res.error_train,
                             "best": res.candidates[0].effect,
                             "best_error_after": res.candidates[0].error_after}
        print(name, out["null"][name], flush=True)

    class Hardening(ContactPart):
        kind = "fig_hardening"

        def payload_xml(self) -> str:
            k = self.cfg.k
            return super().payload_xml().replace(
                'armature="0"/>', f'armature="0" range="-0.001 0.001" limited="true" '
                f'solreflimit="{-4 * k / self.cfg.m:.6g} -2" solimplimit="0.01 0.01 0.001"/>')

    class Resonant(ContactPart):
        kind = "fig_resonant"

        def payload_xml(self) -> str:
            m_f = 0.3
            k_f = m_f * (2 * math.pi * 45.0) ** 2
            c_f = 2 * 0.01 * math.sqrt(k_f * m_f)
            return (f'<body name="fixture"><joint name="fixture_z" type="slide" '
                    f'axis="0 0 1" stiffness="{k_f:.6g}" damping="{c_f:.6g}"/><geom '
                    f'type="box" size="0.03 0.03 0.002" mass="{m_f}" contype="0" '
                    f'conaffinity="0"/>{super().payload_xml()}</body>')

    for part in (Hardening, Resonant):
        register_part(part)
        try:
            nominal = load_scene("paper_contact", [f"duration={D}", "transfer.kind='stewart'",
                                                   "excitation.frequency=1.0"])
            truth = dataclasses.replace(
                nominal, experiment=dataclasses.replace(nominal.experiment, kind=part.kind),
                transfer=dataclasses.replace(nominal.transfer, substeps=4),
                effects=(EffectConfig("sensor_noise", 1.0),))
            rec = hide_effects(run(truth, reference=False).record, nominal)
        finally:
            PARTS.pop(part.kind)
        diag = Diagnosis(rec)
        rounds = diag.auto(max_rounds=3)
        out["out_of_library"][part.__name__] = {
            "rounds": [{"status": r.status, "error_val": r.error_val,
                        "proposal": r.proposal.effect if r.proposal else None,
                        "after": r.proposal.error_after if r.proposal else None,
                        "remaining": r.remaining} for r in rounds]}
        print(part.__name__, [(r.status, r.proposal.effect if r.proposal else None,
                               round(r.error_val, 2)) for r in rounds], flush=True)

    sc = load_scene("paper_contact", [f"duration={D}", "transfer.kind='stewart'",
                                      "excitation.frequency=1.0"])
    hidden = {"delay.leg1": 0.004, "coulomb_friction.leg3": 30.0, "actuator_lag.leg5": 0.006}
    diag = Diagnosis(measure(sc, hidden, seed=21))
    rounds = diag.auto(max_rounds=5)
    h = hybrid_figures(diag)
    out["hybrid"] = {"hidden": hidden, "found": dict(diag.accepted),
                     "rounds": [r.status for r in rounds], **h}
    print("hybrid", json.dumps(out["hybrid"]), flush=True)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(out, indent=1, default=float))
    print(json.dumps(out, default=float))


if __name__ == "__main__":
    main()
