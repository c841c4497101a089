"""CLI command: ``rths3d bench init`` writes a commented scene for a user's bench."""

from __future__ import annotations

import os
from pathlib import Path

import typer

from ._app import app
from ._output import write_text

bench_app = typer.Typer(
    name="bench",
    help="Describe your own Stewart-platform bench: `rths3d bench init` writes its scene.",
    no_args_is_help=True,
)
app.add_typer(bench_app, name="bench")


def _numbers(option: str, text: str | None, counts: tuple[int, ...]) -> list[float] | None:
    from ..errors import ConfigError

    if text is None:
        return None
    try:
        out = [float(v) for v in text.replace(" ", "").split(",") if v != ""]
    except ValueError:
        raise ConfigError(option, text, "must be comma-separated numbers") from None
    if len(out) not in counts:
        raise ConfigError(option, text, f"need {' or '.join(map(str, counts))} "
                          "comma-separated numbers")
    return out


def _rel(path: Path, folder: Path) -> str:
    """``path`` relative to the scene's folder when it can be (a scene names its files
    beside itself), else absolute."""
    try:
        return os.path.relpath(path.resolve(), folder.resolve())
    except ValueError:
        return str(path.resolve())


@bench_app.command("init")
def init(
    out: Path = typer.Argument(..., help="The scene to write (.toml)."),
    name: str = typer.Option("", help="Scene name (default: the file's stem)."),
    base_radius: float = typer.Option(None, help="Base-anchor circle radius (m)."),
    top_radius: float = typer.Option(None, help="Top-anchor circle radius (m)."),
    base_gap: float = typer.Option(None, help="Angle between a base anchor pair (rad)."),
    top_gap: float = typer.Option(None, help="Angle between a top anchor pair (rad)."),
    base_angle: float = typer.Option(None, help="Rotation of the anchor pattern (rad)."),
    home_height: float = typer.Option(None, help="Plate height above the base at home (m)."),
    geometry_file: Path = typer.Option(None, "--geometry-file",
                                       help="The calibrated geometry (.json) `rths3d "
                                            "platform calibrate --out` wrote, instead of "
                                            "the geometry numbers."),
    stroke: float = typer.Option(None, help="Total leg stroke (m)."),
    leg_velocity_limit: float = typer.Option(None, help="Leg speed limit (m/s)."),
    leg_force_limit: float = typer.Option(None, help="Leg force limit (N)."),
    plate_mass: float = typer.Option(None, help="Top plate mass (kg)."),
    fts_pose: str = typer.Option(None, help="FTS mounting pose on the plate: "
                                            "x,y,z,rx,ry,rz (m, rad)."),
    kp: float = typer.Option(None, help="Leg servo position gain (N/m)."),
    kv: float = typer.Option(None, help="Leg servo velocity gain (N·s/m)."),
    timeconst: float = typer.Option(None, help="Servo lag time constant (s), where --lag "
                                               "says."),
    delay: float = typer.Option(None, help="Set-point transport delay (s)."),
    hold: str = typer.Option(None, help="Set-point hold over a step: ramp | zoh."),
    sample: str = typer.Option(None, help="When channels are sampled: end | start."),
    feedforward: str = typer.Option(None, help="Velocity feed-forward: backward | central "
                                               "| none."),
    gravity: str = typer.Option(None, help="Gravity compensation: nominal | measured | none."),
    lag: str = typer.Option(None, help="Where the timeconst lag sits: setpoint (a digital "
                                       "filter before the hold) | servo (continuous, after "
                                       "the hold)."),
    valve_hz: float = typer.Option(None, "--valve-hz", help="Servo-valve natural frequency "
                                   "(Hz): a second-order response after the hold; 0: "
                                   "none."),
    valve_damping: float = typer.Option(None, "--valve-damping",
                                        help="Servo-valve damping ratio (default 0.7)."),
    mass: float = typer.Option(None, help="Rigid payload mass (kg; default 1)."),
    com: str = typer.Option(None, help="Payload centre of mass x,y,z from the FTS origin, "
                                       "sensor frame (m)."),
    inertia: str = typer.Option(None, help="Payload inertia about its centre of mass: one "
                                           "number or Ixx,Iyy,Izz,Ixy,Ixz,Iyz (kg·m²)."),
    part_file: Path = typer.Option(None, "--part-file",
                                   help="Your part as an MJCF file (mounted on the FTS site; "
                                        "world_* bodies fixed to the world), instead of the "
                                        "rigid payload."),
    dofs: str = typer.Option("x,y,z,rx,ry,rz", help="Interface DOFs the part is tested "
                                                    "through."),
    force: bool = typer.Option(False, "--force", help="Overwrite an existing file."),
) -> None:
    """Write a commented scene for your bench from a few flags (omitted ones keep today's
    bench), check that it loads, and print its path. `rths3d run` it as written (its
    numerical substructure and excitation are placeholders), or diagnose a measurement
    with it (`rths3d diagnose FILE --scene SCENE`)."""
    from ..errors import ConfigError
    from ..figures import check_output
    from ..scene import load_scene
    from ..scene.bench import bench_scene_text

    if out.suffix.lower() != ".toml":
        raise ConfigError("OUT", str(out), "the scene must end in .toml")
    if out.exists() and not force:
        raise ConfigError("OUT", str(out), "exists (use --force to overwrite)")
    check_output(out, "OUT")
    folder = out.parent
    plat: dict[str, object] = {}
    if geometry_file is not None:
        if not geometry_file.is_file():
            raise ConfigError("--geometry-file", str(geometry_file), "file not found")
        plat["geometry_file"] = _rel(geometry_file, folder)
    for key, v in (("base_radius", base_radius), ("top_radius", top_radius),
                   ("base_gap", base_gap), ("top_gap", top_gap), ("base_angle", base_angle),
                   ("home_height", home_height), ("stroke", stroke),
                   ("leg_velocity_limit", leg_velocity_limit),
                   ("leg_force_limit", leg_force_limit), ("plate_mass", plate_mass)):
        if v is not None:
            plat[key] = v
    pose = _numbers("--fts-pose", fts_pose, (6,))
    if pose is not None:
        plat["fts_pose"] = pose
    ctl = {k: v for k, v in (("kp", kp), ("kv", kv), ("timeconst", timeconst),
                             ("delay", delay), ("hold", hold), ("sample", sample),
                             ("feedforward", feedforward), ("gravity", gravity),
                             ("lag", lag), ("valve_hz", valve_hz),
                             ("valve_damping", valve_damping))
           if v is not None}
    dof_list = tuple(d.strip() for d in dofs.split(",") if d.strip())
    if part_file is not None:
        if any(v is not None for v in (mass, com, inertia)):
            raise ConfigError("--part-file", str(part_file), "give the part as an MJCF file "
                              "or as --mass/--com/--inertia, not both")
        if not part_file.is_file():
            raise ConfigError("--part-file", str(part_file), "file not found")
        part: dict[str, object] = {"kind": "mjcf", "file": _rel(part_file, folder),
                                   "dofs": list(dof_list)}
    else:
        part = {"kind": "rigid", "m": 1.0 if mass is None else mass}
        c = _numbers("--com", com, (3,))
        if c is not None:
            part["com"] = c
        i = _numbers("--inertia", inertia, (1, 6))
        if i is not None:
            part["inertia"] = i[0] if len(i) == 1 else i
        if dof_list != ("x", "y", "z", "rx", "ry", "rz"):
            raise ConfigError("--dofs", dofs, "a rigid payload is tested through all six "
                              "DOFs x,y,z,rx,ry,rz")
    text = bench_scene_text(name or out.stem, dofs=dof_list, platform=plat, controller=ctl,
                            part=part)
    # check before writing: the scene must load (every mistake one line naming the key)
    tmp = out.with_name(f".{out.name}.check{os.getpid()}.toml")
    try:
        tmp.write_text(text)
        load_scene(tmp)
    finally:
        tmp.unlink(missing_ok=True)
    write_text(out, text)
    typer.echo(f"scene {out}")
    if feedforward == "central":
        typer.echo("note: a central feed-forward needs the next set-point: the scene "
                   "describes a bench for the diagnosis' replay, not for a closed-loop run")
