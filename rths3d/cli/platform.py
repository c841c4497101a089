"""CLI commands: ``rths3d platform track``, ``identify``, ``info`` and ``calibrate``.

Heavy imports (mujoco, matplotlib) stay inside the command functions so ``rths3d --help``
stays fast.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import typer

from ..config import TransferConfig
from ..figures import check_output, new_figure, png_path, save_figure
from ._app import app
from ._output import Keeper, write_text

platform_app = typer.Typer(
    name="platform",
    help="The simulated Stewart platform: pose-tracking demo, heave identification and "
         "kinematic calibration.",
    no_args_is_help=True,
)
app.add_typer(platform_app, name="platform")


def _config(kp: float, kv: float, timeconst: float, delay: float, ff: bool, substeps: int):
    from ..platform import ActuatorConfig, PlatformConfig

    return PlatformConfig(actuator=ActuatorConfig(kp=kp, kv=kv, timeconst=timeconst,
                                                  delay=delay, velocity_ff=ff),
                          substeps=substeps)


def _payload(mass: float) -> str | None:
    if mass < 0:
        from ..errors import ConfigError

        raise ConfigError("--payload-mass", mass, "must be >= 0 kg")
    if mass == 0:
        return None
    return (f'<body name="payload"><geom type="box" size="0.08 0.08 0.04" pos="0 0 0.04" '
            f'mass="{mass:.12g}" rgba="0.2 0.5 0.8 1"/></body>')


def plot_tracking(record, dof: str, path: Path, title: str) -> Path:
    """PNG: commanded vs achieved motion, the tracking error and the SSP (z vs z')."""
    import numpy as np

    t = record.t
    c = record.columns[f"pose_cmd.{dof}"]
    m = record.columns[f"pose_meas.{dof}"]
    unit, scale = ("mrad", 1e3) if dof.startswith("r") else ("mm", 1e3)
    fig = new_figure((11, 6.5))
    gs = fig.add_gridspec(2, 2, width_ratios=(2.2, 1))
    ax1 = fig.add_subplot(gs[0, 0])
    ax2 = fig.add_subplot(gs[1, 0], sharex=ax1)
    ax3 = fig.add_subplot(gs[:, 1])
    ax1.plot(t, c * scale, label=f"commanded {dof}", lw=1.6)
    ax1.plot(t, m * scale, "--", label=f"achieved {dof}'", lw=1.4)
    ax1.set_ylabel(f"{dof} ({unit})")
    ax1.legend(loc="upper right", fontsize=8)
    ax1.set_title(title, fontsize=10)
    ax2.plot(t, (m - c) * scale * 1e3, color="C3", lw=1.0)
    ax2.set_ylabel(f"{dof}' − {dof} (µ{unit[1:] if unit == 'mm' else 'rad'})")
    ax2.set_xlabel("t (s)")
    lim = float(np.max(np.abs(c))) * scale * 1.1
    ax3.plot(c * scale, m * scale, lw=1.0)
    ax3.plot([-lim, lim], [-lim, lim], "k:", lw=0.8, label="perfect tracking")
    ax3.set_xlabel(f"commanded {dof} ({unit})")
    ax3.set_ylabel(f"achieved {dof}' ({unit})")
    ax3.set_title("Synchronization subspace plot", fontsize=10)
    ax3.set_aspect("equal")
    ax3.legend(fontsize=8, loc="upper left")
    for ax in (ax1, ax2, ax3):
        ax.grid(True, alpha=0.3)
    return save_figure(fig, path)


@platform_app.command()
def track(
    dof: str = typer.Option("z", help="DOF to move: x, y, z (m) or rx, ry, rz (rad)."),
    amplitude: float = typer.Option(0.005, help="Sine amplitude (m or rad)."),
    frequency: float = typer.Option(1.0, help="Sine frequency (Hz)."),
    duration: float = typer.Option(5.0, help="Test duration (s)."),
    ramp: float = typer.Option(0.5, help="Raised-cosine fade-in of the amplitude (s)."),
    velocity_ff: bool = typer.Option(True, "--ff/--no-ff", help="Velocity feed-forward."),
    kp: float = typer.Option(TransferConfig.kp, help="Leg servo position gain (N/m)."),
    kv: float = typer.Option(TransferConfig.kv, help="Leg servo velocity gain (N·s/m)."),
    timeconst: float = typer.Option(0.003, help="First-order set-point lag (s)."),
    delay: float = typer.Option(0.001, help="Transport delay of the set-point (s)."),
    substeps: int = typer.Option(1, help="Physics steps per 1 ms interface step."),
    payload_mass: float = typer.Option(0.0, help="Box payload on the FTS (kg); 0: none."),
    out: Path = typer.Option(Path("out/platform_track"), help="Output directory."),
    as_json: bool = typer.Option(False, "--json", help="Print the figures as one JSON line."),
) -> None:
    """Track a sine in one DOF; write a plot (command vs achieved + SSP) and the record.

    Prints the achieved delay (and what the actuator settings predict), the relative RMS
    tracking error and the parasitic motion in the other five DOF.
    """
    from ..errors import ConfigError
    from ..platform import PlatformSim, sine_trajectory, tracking_figures
    from ..platform import track as run_track

    if ramp < 0:
        raise ConfigError("--ramp", ramp, "must be >= 0 s")
    check_output(out, "--out", folder=True)
    cfg = _config(kp, kv, timeconst, delay, velocity_ff, substeps)
    poses = sine_trajectory(dof, amplitude, frequency, duration, cfg.dt, ramp=ramp)
    sim = PlatformSim(cfg, payload_xml=_payload(payload_mass))
    rec = run_track(poses, sim=sim, progress=not as_json)
    rec.meta["scene"] = f"platform sine {dof}"
    rec.meta["params"] = {"dof": dof, "amplitude": amplitude, "frequency": frequency,
                          "duration": duration, "payload_mass": payload_mass}
    keeper = Keeper()  # what --out refuses now is kept in a temporary folder

    def write(fn):
        return keeper.write(fn, out, "--out", folder=True)

    rec_path = write(lambda d: rec.save(d / "track.parquet"))
    if rec.meta["status"] != "ok":
        keeper.finish()
        typer.echo(f"stopped: {rec.meta['reason']} (partial record: {rec_path})", err=True)
        raise typer.Exit(2)
    skip = min(max(ramp, 1.0 / frequency), 0.5 * duration)
    fig = tracking_figures(rec, dof, frequency, cfg, skip=skip)
    rot = dof.startswith("r")
    title = (f"{dof} sine {amplitude * 1e3:g} {'mrad' if rot else 'mm'}, {frequency:g} Hz, "
             f"{'with' if velocity_ff else 'without'} velocity FF: delay "
             f"{fig.delay * 1e3:.2f} ms (predicted {fig.predicted_delay * 1e3:.2f} ms), "
             f"NRMS {100 * fig.nrms_error:.2f} %")
    png = write(lambda d: plot_tracking(rec, dof, d / "track.png", title))
    figures = fig.as_dict()
    figures.update({"plot": str(png), "record": str(rec_path)})
    write(lambda d: write_text(d / "figures.json", json.dumps(figures, indent=1)))
    if as_json:
        typer.echo(json.dumps(figures))
        keeper.finish()
        return
    typer.echo(f"delay            {fig.delay * 1e3:8.3f} ms  (settings predict "
               f"{fig.predicted_delay * 1e3:.3f} ms)")
    typer.echo(f"amplitude ratio  {fig.amplitude_ratio:8.4f}")
    typer.echo(f"NRMS error       {100 * fig.nrms_error:8.3f} %")
    typer.echo(f"parasitic motion {fig.parasitic_translation * 1e6:8.3f} µm, "
               f"{fig.parasitic_rotation * 1e6:.3f} µrad (other five DOF)")
    typer.echo(f"equality gap     {fig.max_eq_gap * 1e6:8.3f} µm (max)")
    typer.echo(f"plot             {png}")
    typer.echo(f"record           {rec_path}")
    keeper.finish()


@platform_app.command()
def identify(
    out: str = typer.Option(None, help="TF file to write, or a folder to write "
                                       "platform_heave_tf.json in (default: "
                                       "platform_heave_tf.json in the current folder; the "
                                       "LTI transfer system reads the repository's "
                                       "assets/platform_heave_tf.json, which only an explicit "
                                       "--out replaces)."),
    plot: Path = typer.Option(None, help="Bode plot PNG (default: beside the TF file)."),
    n_num: int = typer.Option(1, help="Numerator order of the fitted TF."),
    n_den: int = typer.Option(2, help="Denominator order of the fitted TF."),
    velocity_ff: bool = typer.Option(True, "--ff/--no-ff", help="Velocity feed-forward."),
    kp: float = typer.Option(TransferConfig.kp, help="Leg servo position gain (N/m)."),
    kv: float = typer.Option(TransferConfig.kv, help="Leg servo velocity gain (N·s/m)."),
    timeconst: float = typer.Option(0.003, help="First-order set-point lag (s)."),
    delay: float = typer.Option(0.001, help="Transport delay of the set-point (s)."),
    substeps: int = typer.Option(1, help="Physics steps per 1 ms interface step."),
    quick: bool = typer.Option(False, help="Fewer lines and a 5 s period (0.2–50 Hz)."),
) -> None:
    """Identify the heave frequency response (multisine 0.1–50 Hz at five poses) and fit a
    low-order transfer function with delay; write the TF JSON and a Bode plot."""
    from ..errors import ConfigError
    from ..platform.calibrate.heave import DEFAULT_TF_PATH, identify_heave

    if n_num < 0 or n_den < 1 or n_num > n_den:
        raise ConfigError("--n-num/--n-den", (n_num, n_den), "need 0 <= n_num <= n_den, n_den >= 1")
    # by default into the current folder: the repository's own file is replaced only when
    # --out names it
    tf_path = Path(out) if out else Path(DEFAULT_TF_PATH.name)
    if out and (tf_path.is_dir() or out.endswith(("/", os.sep))):
        tf_path = tf_path / DEFAULT_TF_PATH.name
    check_output(tf_path, "--out")
    png_out = png_path(plot or tf_path.with_name(tf_path.stem.replace("_tf", "") + "_bode.png"))
    check_output(png_out, "--plot")
    keeper = Keeper()
    cfg = _config(kp, kv, timeconst, delay, velocity_ff, substeps)
    kw = {"f_min": 0.2, "period": 5.0, "n_lines": 20} if quick else {}
    res = identify_heave(cfg, n_num=n_num, n_den=n_den, progress=True, **kw)
    path = keeper.write(res.save, tf_path, "--out")
    png = keeper.write(res.bode_plot, png_out, "--plot")
    tf = res.tf
    typer.echo(f"num   {list(tf.num)}")
    typer.echo(f"den   {list(tf.den)}")
    typer.echo(f"delay {tf.delay * 1e3:.3f} ms; phase delay at 1 Hz "
               f"{tf.phase_delay(1.0) * 1e3:.3f} ms; fit error {100 * tf.fit_error:.2f} %")
    for label, err in res.pose_errors.items():
        typer.echo(f"  {label:<16s} fit error {100 * err:.2f} %")
    typer.echo(f"TF file {path}")
    typer.echo(f"Bode plot {png}")
    keeper.finish()


@platform_app.command()
def info(
    payload_mass: float = typer.Option(0.0, help="Box payload on the FTS (kg); 0: none."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON line."),
) -> None:
    """Print the default platform: geometry, limits, Jacobian condition at home, static
    leg forces and the delay the default actuator settings predict."""
    import numpy as np

    from ..platform import DEFAULT_GEOMETRY, PlatformConfig, PlatformSim, jacobian
    from ..platform.model import predicted_delay

    g = DEFAULT_GEOMETRY
    J = jacobian(g, np.zeros(6))
    Js = J.copy()
    Js[:, 3:] /= g.top_radius
    cfg = PlatformConfig()
    sim = PlatformSim(cfg, payload_xml=_payload(payload_mass), settle=0.0)
    figures = {
        "base_radius_m": g.base_radius, "top_radius_m": g.top_radius,
        "home_height_m": g.home_height, "home_leg_length_m": float(g.home_leg_lengths()[0]),
        "stroke_m": g.stroke, "leg_velocity_limit_m_s": g.leg_velocity_limit,
        "leg_force_limit_n": g.leg_force_limit,
        "jacobian_cond_home": float(np.linalg.cond(J)),
        "jacobian_cond_home_scaled": float(np.linalg.cond(Js)),
        "static_leg_force_n": [round(float(f), 4) for f in sim.static.leg_forces],
        "payload_mass_kg": sim.static.payload_mass,
        "predicted_delay_1hz_s": predicted_delay(cfg, 1.0),
        "model_nq": int(sim.model.nq), "model_nv": int(sim.model.nv),
    }
    if as_json:
        typer.echo(json.dumps(figures))
        return
    for k, v in figures.items():
        typer.echo(f"{k:28s} {v}")


def _mm(v: float) -> str:
    return f"{v * 1e3:+9.4f}" if v == v and abs(v) < 1e9 else "      inf"


@platform_app.command()
def calibrate(
    poses: Path = typer.Argument(..., help="Measurements (.csv or .parquet): columns "
                                           "pose_meas.x … pose_meas.rz (absolute measured "
                                           "pose relative to home, m and rad) and leg_len.0 "
                                           "… leg_len.5 (encoder lengths, m); a track "
                                           "record works too."),
    out: Path = typer.Option(None, "--out", help="Write the calibrated geometry here (.json; "
                                                 "load with rths3d.platform.calibrate.kinematic."
                                                 "load_geometry)."),
    nominal: Path = typer.Option(None, "--nominal", help="Nominal geometry (.json, as "
                                                         "written by --out); default: the "
                                                         "default platform."),
    tolerance: float = typer.Option(1.0e-4, help="Largest standard deviation (m) for which "
                                                 "a parameter counts as identified."),
    as_json: bool = typer.Option(False, "--json", help="Print the figures as one JSON line."),
) -> None:
    """Kinematic calibration: fit the 42 parameters (base and top anchors, leg offsets) to
    measured poses and leg lengths, and report what the pose set can identify.

    Prints each parameter's deviation from nominal and its standard deviation (mm), the RMS
    leg-length residual of the nominal and of the calibrated geometry, and the
    identifiability report (condition number, parameters the poses cannot see, rigid
    motions of the frames they do not pin). The frames are those of the pose measurement.
    """
    from ..errors import ConfigError
    from ..platform import DEFAULT_GEOMETRY
    from ..platform.calibrate.kinematic import KinematicCalibration, load_geometry
    from ..platform.calibrate.poses import load_pose_table
    from ._app import json_line

    if out is not None:
        if out.suffix.lower() != ".json":
            raise ConfigError("--out", str(out), "the geometry file must end in .json")
        check_output(out, "--out")
    if not (tolerance > 0 and tolerance < 1):
        raise ConfigError("--tolerance", tolerance, "must be in (0, 1) m")
    geom = load_geometry(nominal) if nominal is not None else DEFAULT_GEOMETRY
    q, L = load_pose_table(poses)
    cal = KinematicCalibration(geom, tolerance=tolerance).fit(q, L)
    summary = cal.summary()
    if out is not None:
        data = cal.geometry_.to_dict()
        data["calibration"] = {k: v for k, v in summary.items() if k != "geometry"}
        data["calibration"]["source"] = str(poses)
        tmp = out.with_name(out.name + ".tmp")
        tmp.write_text(json_line(data, indent=1))
        os.replace(tmp, out)
        summary["geometry_file"] = str(out)
    if as_json:
        summary.pop("geometry")
        typer.echo(json_line(summary))
        return
    rep = cal.report_
    typer.echo(f"poses {rep.n_poses}; RMS leg-length residual: nominal "
               f"{cal.nominal_rms_ * 1e6:.2f} µm, calibrated {cal.rms_ * 1e6:.2f} µm")
    typer.echo(f"{'parameter':<20s} {'deviation mm':>12s} {'std mm':>9s}")
    for row in summary["parameters"]:
        flag = "" if row["identified"] else "  not identified"
        typer.echo(f"{row['name']:<20s} {_mm(row['deviation_m']):>12s} "
                   f"{_mm(row['std_m']).replace('+', ' '):>9s}{flag}")
    for line in rep.lines():
        typer.echo(line)
    typer.echo(f"geometry {out}" if out is not None else
               "geometry not saved (use --out FILE.json)")
