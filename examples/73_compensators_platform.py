"""Every compensator on the MuJoCo Stewart platform, per interface DOF and per leg: the
paper's contact, linear and multi-DOF tests through the platform with a 5 ms transport delay
in its leg actuators, scored against the reference solution.

For each scene and compensator (``transfer.compensation``) and where it acts
(``transfer.compensate = interface | legs``) the table gives e_rel,ref (eq. 1 with z^r) and
its ratio to no compensation, the FEI delay d (s) and amplitude A (eq. 8) of z' against z,
and the stability margin reached: τ_ratio,max = d / τ_max (eq. 14; < 1: inside the margin)
and τ_max − d, the delay margin the compensated test has left. τ_max is the delay margin of
the scene's interface loop (the record's phase margin over its crossover, the part as built:
a mass behind its spring, contact open), PSI = log10(τ_max / 1 ms). Settings:
the adaptive and model-based compensators start from the platform's predicted delay
(``transfer.comp_init = "predicted"``), velocity and polynomial use τ_c = that delay, RLS
taps are 4 ms apart. ``multidof_uneven`` runs multidof on a platform whose legs lag
differently (set-point filter time constants 1…6 ms instead of 3 ms, written into the
compiled MuJoCo model): the bench where per-leg compensation pays.

Run: ``python examples/73_compensators_platform.py [--scenes S,…] [--compensators C,…]
[--duration S] [--json table.json] [--plot legs.png]`` (the full table: 4 scenes × 15 runs,
a few minutes on two cores).
"""

from __future__ import annotations

import argparse
import json
import math
import sys

DELAY = 0.005  # s, transport delay of the leg actuators
SCENES = ("paper_contact", "paper_linear", "multidof", "multidof_uneven")
LEG_TIMECONST = (0.001, 0.002, 0.003, 0.004, 0.005, 0.006)  # s, the uneven bench's legs
UNEVEN = "stewart_uneven_legs"


def register_uneven_legs() -> None:
    """Register the transfer system ``stewart_uneven_legs``: the platform with leg servos
    that differ, leg i's set-point filter time constant LEG_TIMECONST[i] written into the
    compiled MuJoCo model (one test at a time). Imported here, after the arguments are
    checked, so that ``--help`` and a mistake answer at once."""
    from rths3d.errors import ConfigError
    from rths3d.transfer import TRANSFERS, StewartTransfer, register_transfer

    if UNEVEN in TRANSFERS:
        return

    @register_transfer
    class UnevenLegs(StewartTransfer):
        kind = UNEVEN

        def __init__(self, scenes, nthread=0):
            super().__init__(scenes, nthread)
            if self.K != 1:
                raise ConfigError("tests", self.K, "the uneven platform runs one test")
            for i, a in enumerate(self.sim.ids.act):
                self.sim.model.actuator_dynprm[a, 0] = LEG_TIMECONST[i]
            self.sim.reset()


def scene_of(name: str, compensation: str, where: str, duration: float | None):
    """The scene on the platform with the compensator's settings (module docstring)."""
    from rths3d.platform.model import predicted_delay
    from rths3d.scene import load_scene
    from rths3d.transfer.stewart import platform_config

    base = "multidof" if name == "multidof_uneven" else name
    over = {"transfer.kind": "stewart", "transfer.delay": DELAY,
            "transfer.compensation": compensation, "transfer.compensate": where,
            "transfer.compensator.rls.spacing": 0.004}
    if duration:
        over["duration"] = duration
    sc = load_scene(base, over)
    d = predicted_delay(platform_config(sc), 1.0)
    if compensation in ("velocity", "polynomial"):
        sc = load_scene(base, {**over, "transfer.comp_time": round(d, 6)})
    return sc.with_transfer(UNEVEN) if name == "multidof_uneven" else sc


def one_row(name: str, compensation: str, where: str, duration: float | None) -> dict:
    from rths3d.loop import run
    from rths3d.metrics import compute_measures

    res = run(scene_of(name, compensation, where, duration))
    m = compute_measures(res.record)
    per = m["dofs"] if "dofs" in m else {"z": m}
    system = m.get("aggregate", m)
    row = {"scene": name, "compensator": compensation, "compensate": where,
           "status": res.status, "reason": res.reason, "dofs": list(per)}
    for key in ("e_rel_ref", "e_rel_track", "fei_d", "fei_A"):
        row[key] = [float(v.get(key, math.nan)) for v in per.values()]
    tau = float(system.get("tau_max", math.nan))
    d = max(row["fei_d"]) if row["fei_d"] else math.nan  # the most delayed DOF
    row.update(tau_max=tau, psi=math.log10(tau / 1e-3) if tau > 0 else -math.inf,
               tau_ratio_max=d / tau, margin_left=tau - d)
    row["coefficients"] = {c: float(v[-1]) for c, v in res.record.columns.items()
                           if c.startswith("comp.")}
    row["_record"] = res.record
    return row


def fmt(values: list[float], scale: float, digits: int) -> str:
    return " / ".join("—" if not math.isfinite(v) else f"{v * scale:.{digits}f}"
                      for v in values)


def table(rows: list[dict]) -> str:
    """The scenes' delay margins, then one row per run (markdown)."""
    out = ["| scene | τ_max (ms) | PSI |", "|---|---|---|"]
    for name in dict.fromkeys(r["scene"] for r in rows):
        r = next(r for r in rows if r["scene"] == name)
        out.append(f"| {name} | {r['tau_max'] * 1e3:.2f} | {r['psi']:.2f} |")
    out += ["", "| scene | compensator | acts on | e_rel,ref (%) | ÷ none | FEI d (ms) | "
            "FEI A | d/τ_max | τ_max − d (ms) |", "|---|---|---|---|---|---|---|---|---|"]
    none = {r["scene"]: r for r in rows if r["compensator"] == "none"}
    for r in rows:
        if r["status"] != "ok":
            out.append(f"| {r['scene']} | {r['compensator']} | {r['compensate']} | "
                       f"stopped: {r['reason']} | | | | | |")
            continue
        base = none.get(r["scene"])
        ratio = fmt([a / b for a, b in zip(r["e_rel_ref"], base["e_rel_ref"], strict=True)],
                    1.0, 3) if base else "—"
        out.append(
            f"| {r['scene']} | {r['compensator']} | {r['compensate']} | "
            f"{fmt(r['e_rel_ref'], 100, 3)} | {ratio} | {fmt(r['fei_d'], 1e3, 2)} | "
            f"{fmt(r['fei_A'], 1, 4)} | {r['tau_ratio_max']:.2f} | "
            f"{r['margin_left'] * 1e3:.2f} |")
    return "\n".join(out)


def plot_legs(rows: list[dict], path: str) -> None:
    """Per-leg a1 over time (ATS on each leg, uneven bench) and the pitch error of the
    per-DOF and the per-leg ATS."""
    from rths3d.figures import new_figure, save_figure

    pick = {r["compensate"]: r for r in rows
            if r["scene"] == "multidof_uneven" and r["compensator"] == "ats"}
    if set(pick) != {"interface", "legs"}:
        print("(no plot: needs multidof_uneven with ats)")
        return
    fig = new_figure((9, 6))
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    rec = pick["legs"]["_record"]
    for i in range(6):
        ax1.plot(rec.t, 1e3 * rec.columns[f"comp.a1.leg{i}"], lw=1.2,
                 label=f"leg {i} (τ = {LEG_TIMECONST[i] * 1e3:.0f} ms)")
    ax1.set_ylabel("ATS a1 (ms)")
    ax1.legend(ncol=3, fontsize=8, loc="upper left")
    for where, r in pick.items():
        rc = r["_record"]
        ax2.plot(rc.t, 1e3 * (rc.columns["z_meas.ry"] - rc.columns["z_ref.ry"]), lw=0.8,
                 label=f"ATS per {'leg' if where == 'legs' else 'DOF'}")
    ax2.set_ylabel("z'_ry − z^r_ry (mrad)")
    ax2.set_xlabel("t (s)")
    ax2.legend(fontsize=8)
    print("wrote", save_figure(fig, path))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", default=",".join(SCENES), help="comma-separated scenes")
    ap.add_argument("--compensators", default="all", help="comma-separated, or all")
    ap.add_argument("--duration", type=float, default=0.0,
                    help="simulated s per test (default: the scene's)")
    ap.add_argument("--json", default="", help="write the rows as JSON")
    ap.add_argument("--plot", default="", help="PNG: per-leg a1 on the uneven bench")
    args = ap.parse_args()
    scenes = [s for s in args.scenes.split(",") if s]
    from rths3d.compensation import compensator_names

    names = tuple(compensator_names())
    comps = list(names) if args.compensators == "all" else \
        [c for c in args.compensators.split(",") if c]
    for opt, values, allowed in (("scenes", scenes, SCENES), ("compensators", comps, names)):
        bad = [v for v in values if v not in allowed]
        if bad or not values:
            print(f"error: --{opt}: {bad[0] if bad else ''!r} (one of {', '.join(allowed)})",
                  file=sys.stderr)
            sys.exit(2)
    if args.duration < 0 or (args.duration and args.duration < 0.5):
        print(f"error: --duration: {args.duration} (must be ≥ 0.5 s)", file=sys.stderr)
        sys.exit(2)
    for opt, ext in (("plot", ".png"), ("json", ".json")):
        v = getattr(args, opt)
        if v and not v.endswith(ext):
            print(f"error: --{opt}: {v!r} (must end in {ext})", file=sys.stderr)
            sys.exit(2)
    if "none" not in comps:
        comps = ["none", *comps]
    register_uneven_legs()
    rows = []
    for name in scenes:
        for comp in comps:
            # without a compensator both modes are the same run
            for where in (("interface",) if comp == "none" else ("interface", "legs")):
                rows.append(one_row(name, comp, where, args.duration or None))
                r = rows[-1]
                print(f"{name:16s} {comp:12s} {where:9s} {r['status']:8s} e_rel,ref "
                      f"{fmt(r['e_rel_ref'], 100, 3)} %", flush=True)
    print()
    print(f"Stewart platform, transport delay {DELAY * 1e3:g} ms "
          "(multi-DOF: z / ry per cell):")
    print(table(rows))
    if args.json:
        with open(args.json, "w") as f:
            json.dump([{k: v for k, v in r.items() if k != "_record"} for r in rows], f,
                      indent=1)
        print("wrote", args.json)
    if args.plot:
        plot_legs(rows, args.plot)


if __name__ == "__main__":
    main()
