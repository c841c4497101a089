"""The golden-record cases: every shipped scene × transfer system, single and batch, with
sensor noise, compensation and safety stops.

``python tests/golden/cases.py`` (re)writes ``tests/golden/data/*.npz`` from the code as it
is; ``tests/test_golden.py`` compares today's records with them. The files were made before
the loop ⇄ transfer ⇄ experiment re-seam, so the test shows that the re-seam kept behaviour.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

DATA = Path(__file__).resolve().parent / "data"

SCENES = {"paper_contact": 2.5, "paper_linear": 2.0, "multidof": 1.5}
"""Shipped scenes and the duration (s) each golden record covers."""

TRANSFERS = {
    "ideal": [],
    "delay": ["transfer.delay=0.004"],
    "lti": [],
    "stewart": [],
}

_GROWTH = ["transfer.delay=0.008", "numerical.m=4.81", "numerical.c=20", "numerical.k=100000",
           "safety.velocity=50", "safety.stroke=0.05", "safety.divergence=2",
           "safety.force=5000", "safety.growth=1.05", "safety.growth_window=0.05"]

BATCHES = {
    # name: (scene, transfer, common overrides, per-test parameter sets)
    "contact_lti_mixed": ("paper_contact", "lti", [], [
        {"numerical.k": 5e3},
        {"numerical.k": 2e4, "transfer.delay": 0.002},
        {"transfer.compensation": "velocity", "transfer.comp_time": 0.004},
        {"transfer.timeconst": 0.0, "transfer.velocity_ff": False},
    ]),
    "contact_delay_mixed": ("paper_contact", "delay", [], [
        {"transfer.delay": 0.001},
        {"transfer.delay": 0.0035},
        {"transfer.delay": 0.006, "transfer.compensation": "velocity",
         "transfer.comp_time": 0.006},
    ]),
    "contact_stewart": ("paper_contact", "stewart", [], [
        {"numerical.k": 5e3},
        {"transfer.kp": 3e5, "experiment.h0": 0.003},
        {"transfer.velocity_ff": False},
    ]),
    "linear_ideal_noise": ("paper_linear", "ideal",
                           ["sensor.noise_std=0.05", "sensor.kind=first_order",
                            "sensor.time_constant=0.002"], [
        {"sensor.seed": 1}, {"sensor.seed": 2, "numerical.c": 50.0},
    ]),
    "multidof_lti_batch": ("multidof", "lti", [], [{"numerical.C": [[100.0, 0.0], [0.0, 2.0]]},
                                             {"transfer.delay": 0.001}]),
    "multidof_stewart_batch": ("multidof", "stewart", [], [{}, {"transfer.kp": 3e5}]),
    "contact_stops": ("paper_contact", "lti", [], [
        {},                                   # runs through
        {"safety.velocity": 0.012},           # velocity stop
        {"safety.force": 3.0},                # FTS range stop
        {"transfer.delay": 0.03, "numerical.k": 2e5, "numerical.c": 0.0},  # velocity
    ]),
    "linear_growth_batch": ("paper_linear", "delay", _GROWTH, [
        {}, {"transfer.delay": 0.001}, {"safety.growth_windows": 0, "safety.force": 400.0},
    ]),
}

SINGLES_EXTRA = {
    # name: (scene, transfer, overrides)
    "contact_lti_noise": ("paper_contact", "lti",
                          ["sensor.noise_std=0.02", "sensor.gain=1.01", "sensor.offset=0.01",
                           "sensor.delay=0.001", "sensor.seed=7"]),
    "contact_stewart_noise": ("paper_contact", "stewart", ["sensor.noise_std=0.02",
                                                           "sensor.seed=3"]),
    "contact_lti_polynomial": ("paper_contact", "lti", ["transfer.compensation=polynomial",
                                                        "transfer.comp_time=0.003",
                                                        "transfer.poly_order=2"]),
    "contact_delay_velocity": ("paper_contact", "delay", ["transfer.delay=0.004",
                                                          "transfer.compensation=velocity",
                                                          "transfer.comp_time=0.004"]),
    "contact_velocity_stop": ("paper_contact", "lti", ["safety.velocity=0.012"]),
    "contact_stop_velocity_big": ("paper_contact", "delay", ["transfer.delay=0.03",
                                                             "numerical.k=200000",
                                                             "numerical.c=0"]),
    "linear_growth_stop": ("paper_linear", "delay", _GROWTH),
    "contact_stewart_stop": ("paper_contact", "stewart", ["safety.force=3.0"]),
    "contact_mujoco_part": ("paper_contact", "lti", []),  # run with specimen="mujoco"
}


def cases() -> dict[str, tuple]:
    """name → (kind, scene, transfer, overrides, param_sets or None, specimen)."""
    out: dict[str, tuple] = {}
    for sc in SCENES:
        for tr, ov in TRANSFERS.items():
            out[f"{sc}_{tr}"] = ("single", sc, tr, ov, None, "auto")
    for name, (sc, tr, ov) in SINGLES_EXTRA.items():
        out[name] = ("single", sc, tr, ov, None,
                     "mujoco" if name == "contact_mujoco_part" else "auto")
    for name, (sc, tr, ov, sets) in BATCHES.items():
        out[name] = ("batch", sc, tr, ov, sets, "auto")
    return out


def run_case(name: str) -> list:
    """The records of one case (one for a single test, K for a batch)."""
    import rths3d

    kind, sc, tr, ov, sets, specimen = cases()[name]
    scene = rths3d.load_scene(sc, [*ov, f"duration={SCENES[sc]}"])
    if kind == "single":
        return [rths3d.run(scene, transfer=tr, specimen=specimen).record]
    return [r.record for r in rths3d.run_batch(scene, sets, transfer=tr, specimen=specimen)]


def to_arrays(records: list) -> dict[str, np.ndarray]:
    out: dict[str, np.ndarray] = {}
    for k, rec in enumerate(records):
        out[f"{k}/t"] = np.asarray(rec.t)
        for c, v in rec.columns.items():
            out[f"{k}/{c}"] = np.asarray(v)
        out[f"{k}/#status"] = np.array(rec.meta.get("status", ""))
        out[f"{k}/#reason"] = np.array(rec.meta.get("reason", ""))
    return out


def main(names: list[str]) -> None:
    DATA.mkdir(parents=True, exist_ok=True)
    for name in names or list(cases()):
        arrays = to_arrays(run_case(name))
        np.savez_compressed(DATA / f"{name}.npz", **arrays)
        print(name, len([k for k in arrays if k.endswith("/t")]), "record(s)")


if __name__ == "__main__":
    main(sys.argv[1:])
