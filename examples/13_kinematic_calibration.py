"""Kinematic calibration of the Stewart platform from measured poses and leg lengths.

Builds a platform whose real anchors are off their drawing (σ = 1 mm) and whose leg encoders
carry offsets (σ = 0.5 mm) by editing the MuJoCo model, drives it to poses chosen for
identifiability (D-optimal out of random workspace poses) and to other poses for validation,
and reads it as a bench does: plate pose from an absolute pose measurement (5 µm / 20 µrad
noise) and encoder lengths (1 µm noise). Then it fits the 42 parameters, prints the
identifiability report, compares the forward kinematics of the nominal and the calibrated
geometry on the validation poses, writes the measurements as a CSV that
``rths3d platform calibrate`` reads, the calibrated geometry (JSON) and a plot.

Run: ``python examples/13_kinematic_calibration.py [--out DIR] [--poses N] [--seed S]``
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

from rths3d.platform import (
    DEFAULT_GEOMETRY,
    ActuatorConfig,
    CalibratedGeometry,
    KinematicCalibration,
    PlatformConfig,
    build_spec,
    check_workspace,
    inverse_kinematics,
    select_poses,
)
from rths3d.platform.sim import plate_pose

G = DEFAULT_GEOMETRY


def workspace_poses(rng: np.random.Generator, n: int) -> np.ndarray:
    """n random poses the nominal platform reaches with 5 mm of stroke to spare."""
    lo, hi = G.leg_length_limits()
    span = np.array([0.04, 0.04, 0.03, 0.2, 0.2, 0.25])
    out = []
    while len(out) < n:
        q = rng.uniform(-1, 1, 6) * span
        try:
            L = check_workspace(G, q)
        except Exception:
            continue
        if np.all(L > lo + 0.005) and np.all(L < hi - 0.005):
            out.append(q)
    return np.array(out)


def measure(model, targets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drive the platform to each pose (0.2 s set-point ramp, 0.15 s hold) and read the
    plate pose and the encoder lengths at rest."""
    import mujoco

    data = mujoco.MjData(model)
    dt = model.opt.timestep
    home = G.home_leg_lengths()
    slide = [model.jnt_qposadr[model.joint(f"leg{i}_slide").id] for i in range(6)]
    act = [model.actuator(f"leg{i}").id for i in range(6)]
    aadr = model.actuator_actadr[act]
    free = model.jnt_qposadr[model.joint("plate_free").id]
    for _ in range(int(0.2 / dt)):
        mujoco.mj_step(model, data)
    prev = np.zeros(6)
    nr, nh = int(0.2 / dt), int(0.15 / dt)
    poses, lengths = [], []
    for q in targets:
        s = inverse_kinematics(G, q) - home
        for j in range(nr + nh):
            a = 0.5 - 0.5 * math.cos(math.pi * min(1.0, (j + 1) / nr))
            # the servo's set-point is its activation (the control is its rate)
            data.act[aadr] = prev + a * (s - prev)
            mujoco.mj_step(model, data)
        prev = s
        poses.append(plate_pose(data.qpos[free:free + 7].copy(), G.home_height))
        lengths.append(home + data.qpos[slide])
    return np.array(poses), np.array(lengths)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, default=Path("out/examples/13_kinematic_calibration"))
    ap.add_argument("--poses", type=int, default=50, help="calibration poses (>= 7)")
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    from rths3d.errors import ConfigError
    from rths3d.figures import check_output, new_figure, save_figure

    if args.poses < 7:
        raise ConfigError("--poses", args.poses, "need at least 7 poses (7 parameters per leg)")
    check_output(args.out, "--out", folder=True)
    rng = np.random.default_rng(args.seed)

    # the real platform: anchors and tip sites moved in the MuJoCo model
    db, dp = rng.normal(0, 1e-3, (6, 3)), rng.normal(0, 1e-3, (6, 3))
    dtip = rng.normal(0, 0.5e-3, 6)
    spec = build_spec(PlatformConfig(actuator=ActuatorConfig(delay=0.0, timeconst=0.0)))
    for i in range(6):
        spec.body(f"leg{i}_cyl").pos = spec.body(f"leg{i}_cyl").pos + db[i]
        spec.site(f"plate_anchor{i}").pos = spec.site(f"plate_anchor{i}").pos + dp[i]
        spec.site(f"leg{i}_tip").pos = spec.site(f"leg{i}_tip").pos + [0, 0, dtip[i]]
    model = spec.compile()

    cand = workspace_poses(rng, 1000)
    pick = select_poses(G, cand, args.poses)
    rest = np.setdiff1d(np.arange(len(cand)), pick)
    valid = cand[rng.choice(rest, 50, replace=False)]
    print(f"measuring {args.poses} calibration and 50 validation poses in MuJoCo …")
    q_cal, L_cal = measure(model, cand[pick])
    q_val, L_val = measure(model, valid)
    noise = np.r_[[5e-6] * 3, [20e-6] * 3]
    q_cal_m = q_cal + rng.normal(0, 1, q_cal.shape) * noise
    L_cal_m = L_cal + rng.normal(0, 1e-6, L_cal.shape)
    L_val_m = L_val + rng.normal(0, 1e-6, L_val.shape)

    import pandas as pd

    table = {f"pose_meas.{d}": q_cal_m[:, j]
             for j, d in enumerate(("x", "y", "z", "rx", "ry", "rz"))}
    table.update({f"leg_len.{i}": L_cal_m[:, i] for i in range(6)})
    csv = args.out / "poses.csv"
    pd.DataFrame(table).to_csv(csv, index=False, float_format="%.17g")

    cal = KinematicCalibration().fit(q_cal_m, L_cal_m)
    for line in cal.report_.lines():
        print(line)
    truth = np.concatenate([(G.base_anchors() + db).ravel(), (G.top_anchors() + dp).ravel(),
                            -dtip])
    err = np.abs(cal.params_ - truth)
    print(f"RMS leg-length residual: nominal {cal.nominal_rms_ * 1e6:.1f} µm, calibrated "
          f"{cal.rms_ * 1e6:.2f} µm; parameter error vs the MJCF edits: max "
          f"{err.max() * 1e3:.3f} mm, within 3 std for {np.mean(err < 3 * cal.std_):.0%}")

    fk_nom = CalibratedGeometry().pose_from_encoders(L_val_m)
    fk_cal = cal.predict_pose(L_val_m)
    figs = {}
    for name, fk in (("nominal", fk_nom), ("calibrated", fk_cal)):
        e = fk - q_val
        figs[name] = (float(np.sqrt(np.mean(e[:, :3] ** 2))),
                      float(np.sqrt(np.mean(e[:, 3:] ** 2))))
        print(f"validation FK pose error ({name:>10s}): {figs[name][0] * 1e6:8.2f} µm, "
              f"{figs[name][1] * 1e6:8.2f} µrad RMS")

    path = args.out / "calibrated_geometry.json"
    path.write_text(json.dumps(cal.geometry_.to_dict(), indent=1))
    fig = new_figure((11, 4.2))
    ax1, ax2 = fig.subplots(1, 2)
    r_nom = (CalibratedGeometry().encoder_lengths(q_cal_m) - L_cal_m) * 1e6
    for i in range(6):
        ax1.scatter(np.full(len(r_nom), i - 0.12), r_nom[:, i], s=6, color="C3",
                    label="nominal" if i == 0 else None)
        ax1.scatter(np.full(len(r_nom), i + 0.12), cal.residuals_[:, i] * 1e6, s=6,
                    color="C0", label="calibrated" if i == 0 else None)
    ax1.set_xlabel("leg")
    ax1.set_ylabel("leg-length residual (µm)")
    ax1.set_yscale("symlog", linthresh=10)
    ax1.legend(fontsize=8)
    ax1.set_title("calibration poses", fontsize=10)
    x = np.arange(2)
    ax2.bar(x - 0.18, [figs["nominal"][0] * 1e6, figs["calibrated"][0] * 1e6], 0.36,
            label="translation (µm)")
    ax2.bar(x + 0.18, [figs["nominal"][1] * 1e6, figs["calibrated"][1] * 1e6], 0.36,
            label="rotation (µrad)")
    ax2.axhline(15, color="C0", ls=":", lw=1.0, label="3 × translation noise")
    ax2.axhline(60, color="C1", ls=":", lw=1.0, label="3 × rotation noise")
    ax2.set_xticks(x, ["nominal", "calibrated"])
    ax2.set_yscale("log")
    ax2.set_ylabel("RMS pose error from encoders (FK)")
    ax2.legend(fontsize=8)
    ax2.set_title("50 validation poses", fontsize=10)
    for ax in (ax1, ax2):
        ax.grid(True, alpha=0.3)
    png = save_figure(fig, args.out / "calibration.png",
                      title="Kinematic calibration: 42 parameters from measured poses")
    print(f"measurements {csv}  (rths3d platform calibrate {csv})\ngeometry {path}\nplot {png}")


if __name__ == "__main__":
    import sys

    from rths3d.errors import RthsError

    try:
        main()
    except RthsError as exc:  # a user mistake (flag, output folder): no traceback
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
