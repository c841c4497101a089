"""Benchmark: diagnosis of 5 s and 10 s measurements with every candidate effect.

Prints ONE JSON line. ``diagnose_6dof_5s_s``: as the next, for a 5 s record (floor 15 s,
``floor_6dof_5s_s``), with its round's stages ``diagnose_6dof_5s_screen_s``, ``…_refit_s``,
``…_rank_s`` (``RoundResult.seconds``) and the ``threads`` they ran on;
``diagnose_6dof_5s_rk4_screen_s`` (and ``…_found``, ``…_screen_s``) the same with the
screening's probes replayed through RK4 too (``screen_integrator="RK4"``; the default screens
them with ``implicitfast``), alternated with it.
``diagnose_6dof_10s_s``: median wall time (s) to load a 10 s measurement of the six-DOF
bench test (scene ``bench6``, made closed loop with a hidden Coulomb friction on leg 2, 4
substeps, noise), replay the bench, screen *every* candidate (each effect on each leg and
axis, the kinematic and FTS calibrations), refit the best ``refit`` and rank them.
``diagnose_10s_s``: the same for a heave test (``paper_contact`` through the Stewart
platform, hidden friction on leg 4). ``found`` says whether the hidden
effect ranked first in both; ``replay_10s_s`` is one 10 s replay alone, ``replay_batch_s``
the screening batch alone (all physics candidates in one ``platform_batch``, 2 threads),
``per_sim_step_us`` its cost per simulated step and candidate. ``--quick``: one repetition.
Floors from the issue: 6 DOF < 60 s on the 2-core machine (``floor_6dof_s``), heave < 120 s.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one repetition")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
    from rths3d.diagnose import Diagnosis, load_measurement, measure
    from rths3d.scene import load_scene

    reps = 1 if args.quick else args.repeat
    out: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        for key, scene, hidden, dur in (
                ("diagnose_6dof_5s_s", "bench6", "coulomb_friction.leg2", 5.0),
                ("diagnose_6dof_10s_s", "bench6", "coulomb_friction.leg2", 10.0),
                ("diagnose_10s_s", "paper_contact", "coulomb_friction.leg4", 10.0)):
            sc = load_scene(scene, [f"duration={dur}", "transfer.kind='stewart'"])
            path = measure(sc, {hidden: 30.0}, seed=7).save(Path(tmp) / f"{key}.parquet")
            times, found = [], []
            rk4_times, rk4_found = [], []
            for _ in range(reps):
                if dur == 5.0:
                    # the screening's probes through RK4 as well (the former convention),
                    # alternated with the default's runs
                    t0 = time.perf_counter()
                    rec, _, _ = load_measurement(path)
                    res = Diagnosis(rec, screen_integrator="RK4").run()
                    rk4_times.append(time.perf_counter() - t0)
                    rk4_found.append(res.candidates[0].effect == hidden)
                    rk4_seconds = res.seconds
                t0 = time.perf_counter()
                rec, _, _ = load_measurement(path)
                diag = Diagnosis(rec)
                res = diag.run()
                times.append(time.perf_counter() - t0)
                found.append(res.candidates[0].effect == hidden)
            out[key] = round(statistics.median(times), 3)
            out[key.replace("_s", "_found")] = all(found)
            out[key.replace("_s", "_candidates")] = len(diag.candidate_names)
            out[key.replace("_s", "_simulations")] = diag.nsim
            if dur == 5.0:
                for stage in ("screen", "refit", "rank"):
                    out[f"{key[:-2]}_{stage}_s"] = round(res.seconds[stage], 3)
                out["threads"] = int(res.seconds["threads"])
                out["diagnose_6dof_5s_rk4_screen_s"] = round(statistics.median(rk4_times), 3)
                out["diagnose_6dof_5s_rk4_screen_found"] = all(rk4_found)
                out["diagnose_6dof_5s_rk4_screen_screen_s"] = round(rk4_seconds["screen"], 3)
                continue
            if scene == "bench6":
                # the physics alone: one replay, and the screening batch
                from rths3d.diagnose.engine import MULTI

                labs = [n for n in diag.candidate_names if n not in MULTI]
                probe = [{n: diag._probe(n)} for n in labs]
                diag._cache.clear()
                t0 = time.perf_counter()
                diag.outputs([{}])
                one = time.perf_counter() - t0
                diag._cache.clear()
                t0 = time.perf_counter()
                diag.outputs(probe)
                batch = time.perf_counter() - t0
                out["replay_10s_s"] = round(one, 3)
                out["replay_batch_s"] = round(batch, 3)
                out["replay_batch_size"] = len(probe)
                out["per_sim_step_us"] = round(1e6 * batch / (len(probe) * rec.n), 2)
    out.update({"samples": rec.n, "repeat": reps, "floor_6dof_s": 60.0, "floor_s": 120.0,
                "floor_6dof_5s_s": 15.0})
    print(json.dumps(out))


if __name__ == "__main__":
    main()
