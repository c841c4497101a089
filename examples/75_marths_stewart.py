"""The maRTHS partitioned frame through the MuJoCo Stewart platform (docs/marths.md).

Runs ``scenes/marths_stewart.toml`` (El Centro from its onset, × 0.02) with the Stewart
transfer system, solves the benchmark's 29-DOF reference structure under the same ground
motion (trapezoidal rule, its CSVs) and plots, for x and θ (= ry): the benchmark's
reference, the loop's reference solution z^r, the commanded and the measured platform
motion, and the six leg forces. Prints one JSON line of peaks and errors.

Needs the maRTHS benchmark folder beside the repository (or RTHS3D_MARTHS_DIR).

Run: ``python examples/75_marths_stewart.py [--duration 4] [--set transfer.kp=1e6 ...]
[--plot docs/img/marths_stewart.png]``.
"""

from __future__ import annotations

import argparse
import json
import sys

import numpy as np
import scipy.linalg


def reference_structure(data, t: np.ndarray, intensity: float) -> np.ndarray:
    """U (N, 29) of the benchmark's reference structure from rest (trapezoidal rule)."""
    csv = lambda n: np.loadtxt(data / "data" / n, delimiter=",")  # noqa: E731
    M, C, K = csv("reference_M.csv"), csv("reference_C.csv"), csv("reference_K.csv")
    rec = np.loadtxt(data / "data" / "ground_motion_ElCentro.csv", delimiter=",", skiprows=1)
    t0 = rec[np.flatnonzero(rec[:, 1])[0] - 1, 0]
    ag = intensity * np.interp(t + t0, rec[:, 0], rec[:, 1])
    n, dt = K.shape[0], float(t[1] - t[0])
    l = np.zeros(n)  # noqa: E741
    l[[12, 25, 26]] = 1.0
    E = scipy.linalg.block_diag(np.eye(n), M)
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-K, -C]])
    lu = scipy.linalg.lu_factor(E - 0.5 * dt * A)
    Bp = E + 0.5 * dt * A
    z, prev, out = np.zeros(2 * n), np.zeros(2 * n), np.empty((t.size, n))
    for k in range(t.size):
        load = np.zeros(2 * n)
        load[n:] = -ag[k] * (M @ l)
        z = scipy.linalg.lu_solve(lu, Bp @ z + 0.5 * dt * (prev + load))
        prev = load
        out[k] = z[:n]
    return out


def main(argv: list[str] | None = None) -> int:
    from rths3d.community.marths.data import data_dir
    from rths3d.errors import RthsError
    from rths3d.figures import new_figure, save_figure
    from rths3d.loop import run
    from rths3d.scene import load_scene

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=4.0, help="test duration (s)")
    ap.add_argument("--set", action="append", default=[], help="scene override key=value")
    ap.add_argument("--plot", default=None, help="PNG to write")
    a = ap.parse_args(argv)
    try:
        sc = load_scene("marths_stewart", [f"duration={a.duration}", *a.set])
        data = data_dir(None)
        res = run(sc, "stewart")
    except RthsError as exc:
        ap.exit(2, f"error: {exc}\n")
    rec = res.record
    t = np.asarray(rec.t)
    U = reference_structure(data, t, sc.excitation.scale)
    bench = {"x": U[:, 26], "ry": -U[:, 20]}
    out = {"status": res.status, "reason": res.reason, "duration_s": float(t[-1])}
    for d in ("x", "ry"):
        zr, zm, zc = (np.asarray(rec.columns[f"{s}.{d}"]) for s in ("z_ref", "z_meas", "z_cmd"))
        pk = float(np.abs(bench[d]).max())
        out[f"peak_reference_{d}"] = pk
        out[f"zref_vs_reference_{d}"] = float(np.abs(zr - bench[d]).max() / pk)
        out[f"peak_cmd_{d}"] = float(np.abs(zc).max())
        out[f"peak_meas_{d}"] = float(np.abs(zm).max())
    out["peak_leg_force_N"] = float(max(np.abs(np.asarray(rec.columns[f"leg_force.{i}"])).max()
                                        for i in range(6)))
    print(json.dumps(out))
    if a.plot:
        fig = new_figure((9.0, 7.5))
        ax = fig.subplots(3, 1, sharex=True)
        for i, (d, unit, sc_) in enumerate((("x", "mm", 1e3), ("ry", "mrad", 1e3))):
            ax[i].plot(t, bench[d] * sc_, "k", lw=2.2, alpha=0.35,
                       label="benchmark reference structure")
            ax[i].plot(t, np.asarray(rec.columns[f"z_ref.{d}"]) * sc_, "C0", lw=1.2,
                       label="z^r: numerical + frame, ideal interface")
            ax[i].plot(t, np.asarray(rec.columns[f"z_cmd.{d}"]) * sc_, "C1--", lw=1.0,
                       label="commanded (Stewart)")
            ax[i].plot(t, np.asarray(rec.columns[f"z_meas.{d}"]) * sc_, "C3", lw=1.0,
                       label="measured (Stewart)")
            ax[i].set_ylabel(f"{'x' if d == 'x' else 'θ = ry'} ({unit})")
        ax[0].legend(fontsize=7, loc="upper left")
        for k in range(6):
            ax[2].plot(t, np.asarray(rec.columns[f"leg_force.{k}"]), lw=0.8, label=f"leg {k}")
        ax[2].set_ylabel("leg force (N)")
        ax[2].set_xlabel("t (s) from the record's onset")
        ax[2].legend(fontsize=7, ncol=6, loc="upper left")
        save_figure(fig, a.plot, title="maRTHS frame through the Stewart platform, "
                    f"El Centro × {sc.excitation.scale:g}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
