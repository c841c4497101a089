"""Speed of the vRTHS loop on the paper's contact test (10 s simulated, ΔT = 1 ms).

Prints ONE JSON line:
  rtf_stewart        one test on the MuJoCo Stewart platform (simulated s per wall s)
  rtf_stewart_implicitfast  the same with ``transfer.integrator = "implicitfast"`` (first
                     order; the default RK4 costs about 2.5× per physics step), alternated
                     with it in one run
  stewart_over_bare  wall time of that whole loop over bare mj_step of the same model
  rtf_lti            one test on the 1-D LTI path (LTI actuator + numpy specimen)
  rtf_reference      the reference solution z^r of one test
  batch_rtf_stewart  K_stewart tests stepped together on the platform (aggregate)
  batch_rtf_lti      K_lti tests stepped together on the LTI path (aggregate)
  bare_rtf_stewart, batch_bare_rtf_stewart   the machine's limits measured in the same run:
                     bare mj_step of the model, and raw mujoco.batch stepping of K_stewart,
                     both along the test's motion (the servo set-point rates of its
                     commanded poses written each step: the part meets its contact as in
                     the test) for the test's whole length
  batch_stewart_over_bare   batch_rtf_stewart over batch_bare_rtf_stewart, the median of
                     pairs measured back to back (floor 0.95)
  first_runs_s       wall time of the first (tiny) single and batch runs of both paths in the
                     process: loading the compiled kernels, excluded from the figures above
  ats_over_none_time loop wall time of one test with the ATS compensator over the same test
                     without compensation, on the Stewart path (the MuJoCo platform, where
                     the platform dominates the step; 5 ms actuator delay, ATS per interface
                     DOF from the predicted delay), runs alternated side by side; floor 1.15
  ats_legs_over_none_time  the same with ATS on each of the six legs (transfer.compensate =
                     "legs": the platform's leg hook)
  rls_legs_over_none_time  the same with RLS on each of the six legs; floor 1.2
  ats_loop, ats_legs_loop, rls_legs_loop  the loop those compensated tests took (record
                     meta "loop": compiled or python)
  batch_ats_over_none_rtf  K_stewart compensated tests (ATS per interface DOF, the same
                     5 ms actuator delay) stepped together: their aggregate real-time factor
                     over the uncompensated batch's, the median of pairs measured back to
                     back; floor 0.9
Medians over repeats; ratios measured side by side in one run. ``--quick``: 2 s tests, one
repeat (figures noisier).
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def leg_rates(transfer, record, dt: float):
    """(N, 6) servo set-point rates (m/s) that move the legs along a record's commanded poses
    (``pose_cmd.*``, inverse kinematics of the transfer's platform): a bare step's controls
    for the same motion as the test's."""
    import numpy as np

    from rths3d.platform.kinematics import inverse_kinematics
    from rths3d.record import DOFS

    poses = np.column_stack([record.columns[f"pose_cmd.{c}"] for c in DOFS])
    L = inverse_kinematics(transfer.sim.config.geometry, poses)
    return np.diff(L, axis=0, append=L[-1:]) / dt


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="2 s tests, one repeat")
    ap.add_argument("--k-stewart", type=int, default=64)
    ap.add_argument("--k-lti", type=int, default=512)
    args = ap.parse_args()

    import mujoco

    from rths3d.loop import run, run_batch
    from rths3d.reference import reference_solution
    from rths3d.scene import load_scene, scene_with

    duration = 2.0 if args.quick else 10.0
    reps = 1 if args.quick else 3
    sc = load_scene(REPO / "scenes" / "paper_contact.toml", [f"duration={duration}"])
    med = statistics.median
    # the first run of each path in a process loads its compiled kernels (numba's on-disk
    # cache; compiled on the machine's first run): measured apart, then excluded
    warm = load_scene(REPO / "scenes" / "paper_contact.toml", ["duration=0.1"])
    t0 = time.perf_counter()
    for kind in ("lti", "stewart"):
        run(warm, kind, reference=False)
        run_batch(warm, [{"numerical.k": 1e3}, {"numerical.k": 2e3}], kind, reference=False)
    first_runs = time.perf_counter() - t0
    comp = {name: load_scene(REPO / "scenes" / "paper_contact.toml", [
        f"duration={duration}", "transfer.kind='stewart'", "transfer.delay=0.005",
        f"transfer.compensation='{c}'", f"transfer.compensate='{where}'"])
        for name, c, where in (("none", "none", "interface"), ("ats", "ats", "interface"),
                               ("ats_legs", "ats", "legs"), ("rls_legs", "rls", "legs"))}
    for sc_c in comp.values():  # the compensator's kernels load on its first run
        run(scene_with(sc_c, {"duration": 0.1}), reference=False)

    rtf_st, ratio, rtf_lti, bare_rtf, rtf_if = [], [], [], [], []
    fast = scene_with(sc, {"transfer.integrator": "implicitfast"})
    run(scene_with(fast, {"duration": 0.1}), "stewart", reference=False)
    for _ in range(reps):
        r = run(sc, "stewart", reference=False)
        motion = r.record  # the test's commanded poses, for the bare steps' controls
        rtf_st.append(r.rtf)
        rtf_if.append(run(fast, "stewart", reference=False).rtf)
        # bare mj_step of the same model along the same motion, measured right after: the
        # servo set-point rates that move the legs along the test's commanded poses, so that
        # the part meets its contact as in the test (from rest, the bare model never would)
        from rths3d.transfer import StewartTransfer

        tr = StewartTransfer([sc.with_transfer("stewart")])
        m, d = tr.sim.model, tr.sim.batch.d
        rates = leg_rates(tr, motion, sc.dt)
        a0, sub = tr.sim._a0, sc.transfer.substeps
        ctrl = d.ctrl
        t0 = time.perf_counter()
        step = mujoco.mj_step
        for k in range(sc.n_steps * sub):
            ctrl[a0:a0 + 6] = rates[k // sub]
            step(m, d)
        bare = time.perf_counter() - t0
        ratio.append(r.wall / bare)
        bare_rtf.append(sc.duration / bare)
        rtf_lti.append(run(sc, "lti", reference=False).rtf)
    # the compensator's cost on the Stewart path: the same test with and without, alternated
    walls: dict[str, list[float]] = {k: [] for k in comp}
    loops: dict[str, str] = {}
    for _ in range(max(reps, 3)):
        for name, sc_c in comp.items():
            r = run(sc_c, reference=False)
            assert r.status == "ok", r.reason
            walls[name].append(r.wall)
            loops[name] = r.record.meta["loop"]
    t0 = time.perf_counter()
    reference_solution([sc])
    rtf_ref = sc.duration / (time.perf_counter() - t0)

    def batch(kind: str, K: int) -> float:
        sets = [{"numerical.k": 1e3 + 100.0 * i} for i in range(K)]
        t0 = time.perf_counter()
        res = run_batch(sc, sets, kind, reference=False, max_k=K)
        wall = time.perf_counter() - t0
        assert all(x.status == "ok" for x in res), [x.reason for x in res if x.reason][:1]
        return K * sc.duration / wall

    # the machine's limit for that batch: raw mujoco.batch stepping of the same model, no
    # loop, alternated with the loop's batch (this machine's speed drifts by tens of % within
    # a minute: each ratio is of a pair measured back to back)
    from mujoco.batch import Batch

    from rths3d.transfer import StewartTransfer

    tr = StewartTransfer([sc.with_transfer("stewart")])
    raw = Batch(tr.sim.model, args.k_stewart, nthread=2)
    raw_ctrl = raw.bind("ctrl")
    rates = leg_rates(tr, motion, sc.dt)  # the single test's motion, for every test
    a0, sub = tr.sim._a0, sc.transfer.substeps
    nraw = sc.n_steps * sub
    raw_state = raw.bind("qpos").copy(), raw.bind("qvel").copy(), raw.bind("act").copy()

    def raw_rtf() -> float:
        for name, x in zip(("qpos", "qvel", "act"), raw_state, strict=True):
            raw.bind(name)[:] = x  # from rest again
        t0 = time.perf_counter()
        for k in range(nraw):
            raw_ctrl[:, a0:a0 + 6] = rates[k // sub]
            raw.step()
        return args.k_stewart * nraw * sc.dt / sub / (time.perf_counter() - t0)

    pairs = [(batch("stewart", args.k_stewart), raw_rtf()) for _ in range(reps)]
    b_st = med([a for a, _ in pairs])
    b_bare = med([r for _, r in pairs])
    b_ratio = med([a / r for a, r in pairs])
    b_lti = med([batch("lti", args.k_lti) for _ in range(reps)])

    def comp_batch(name: str) -> float:
        sets = [{"numerical.k": 1e3 + 100.0 * i} for i in range(args.k_stewart)]
        t0 = time.perf_counter()
        res = run_batch(comp[name], sets, "stewart", reference=False, max_k=args.k_stewart)
        wall = time.perf_counter() - t0
        assert all(x.status == "ok" for x in res), [x.reason for x in res if x.reason][:1]
        return args.k_stewart * comp[name].duration / wall

    comp_pairs = [(comp_batch("ats"), comp_batch("none")) for _ in range(reps)]
    print(json.dumps({
        "rtf_stewart": round(med(rtf_st), 2),
        "rtf_stewart_implicitfast": round(med(rtf_if), 2),
        "stewart_over_bare": round(med(ratio), 3),
        "rtf_lti": round(med(rtf_lti), 2),
        "rtf_reference": round(rtf_ref, 2),
        "batch_rtf_stewart": round(b_st, 1),
        "bare_rtf_stewart": round(med(bare_rtf), 2),
        "batch_bare_rtf_stewart": round(b_bare, 1),
        "batch_stewart_over_bare": round(b_ratio, 3),
        "batch_rtf_lti": round(b_lti, 1),
        "first_runs_s": round(first_runs, 2),
        "ats_over_none_time": round(med(walls["ats"]) / med(walls["none"]), 3),
        "ats_legs_over_none_time": round(med(walls["ats_legs"]) / med(walls["none"]), 3),
        "ats_path": "stewart",
        "ats_loop": loops["ats"], "ats_legs_loop": loops["ats_legs"],
        "rls_legs_over_none_time": round(med(walls["rls_legs"]) / med(walls["none"]), 3),
        "rls_legs_loop": loops["rls_legs"],
        "batch_ats_over_none_rtf": round(med([a / b for a, b in comp_pairs]), 3),
        "batch_rtf_ats": round(med([a for a, _ in comp_pairs]), 1),
        "k_stewart": args.k_stewart, "k_lti": args.k_lti, "duration_s": duration,
        "quick": args.quick,
    }))


if __name__ == "__main__":
    main()
