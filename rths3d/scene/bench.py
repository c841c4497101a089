"""The bench tables of a scene: ``[platform]`` (the Stewart platform) and ``[controller]``
(the leg controller's conventions, gains, lag and delay).

Both are optional and default to today's bench, so a scene that says nothing new reads,
runs and writes as before. :func:`platform_table` and :func:`controller_table` validate the
raw tables (every mistake a :class:`~rths3d.errors.ConfigError` naming the field, the value
and the limit); :func:`platform_dict` and :func:`controller_dict` write them back
(:func:`rths3d.scene.scene_to_dict`). Docs: docs/scenes.md, docs/bench.md.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..config import (
    CONTROLLER_KEYS,
    SERVO_CONVENTIONS,
    SERVO_RANGES,
    ControllerConfig,
    PlatformDescription,
    check_plate_inertial,
    check_servo_number,
)
from ..errors import ConfigError
from ..platform.calibrate.kinematic import CalibratedGeometry, load_geometry
from ..platform.geometry import DEFAULT_GEOMETRY, StewartGeometry
from ..record import DOFS

__all__ = ["CONTROLLER_KEYS", "PLATFORM_KEYS", "bench_origin", "bench_scene_text",
           "controller_dict", "controller_table", "experiment_extra", "platform_dict",
           "platform_geometry", "platform_table"]

PATTERN = ("base_radius", "top_radius", "base_gap", "top_gap", "base_angle")
"""Geometry parameters of the parametric anchor pattern."""
SCALARS = tuple(f.name for f in dataclasses.fields(StewartGeometry))
"""Every StewartGeometry field (m, rad, kg, N, m/s)."""
PLATFORM_KEYS = (*SCALARS, "base_anchors", "top_anchors", "geometry_file", "fts_pose",
                 "plate_inertia", "plate_com")


def _number(field: str, v: Any, unit: str) -> float:
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise ConfigError(field, v, f"must be a finite number in {unit}")
    return float(v)


def _anchors(field: str, v: Any) -> np.ndarray:
    try:
        a = np.array(v, dtype=float)
    except (TypeError, ValueError):
        a = np.zeros(0)
    if a.shape != (6, 3) or not np.all(np.isfinite(a)):
        raise ConfigError(field, v, "need six [x, y, z] anchor points in m, leg order")
    if np.max(np.abs(a)) > 10.0:
        raise ConfigError(field, v, "anchor coordinates must be within 10 m")
    return a


def _renamed(exc: ConfigError) -> ConfigError:
    """A geometry error named as the scene's field (``platform.<key>``)."""
    f = exc.field.replace("geometry.", "platform.").replace("actuator.", "platform.")
    f = f.replace("base_anchor_xyz", "base_anchors").replace("top_anchor_xyz", "top_anchors")
    return ConfigError(f, exc.value, exc.limit)


def platform_table(sec: Any) -> PlatformDescription:
    """Validate the raw ``[platform]`` table (paths already resolved by the loader)."""
    if sec is None:
        return PlatformDescription()
    if not isinstance(sec, Mapping):
        raise ConfigError("platform", sec, "must be a table")
    for key in sec:
        if key not in PLATFORM_KEYS:
            raise ConfigError(f"platform.{key}", sec[key],
                              f"unknown field (known: {', '.join(PLATFORM_KEYS)})")
    if not sec:
        return PlatformDescription()
    kw = {k: _number(f"platform.{k}", sec[k], "SI units") for k in SCALARS if k in sec}
    fts_pose: tuple[float, ...] = ()
    if "fts_pose" in sec:
        v = sec["fts_pose"]
        if not isinstance(v, list | tuple) or len(v) != 6:
            raise ConfigError("platform.fts_pose", v, "need [x, y, z, rx, ry, rz] (m, rad)")
        fts_pose = tuple(_number(f"platform.fts_pose[{i}]", x, "m or rad")
                         for i, x in enumerate(v))
        if not 0 < fts_pose[2] <= 1.0:
            raise ConfigError("platform.fts_pose[2]", fts_pose[2], "the sensor's height above "
                              "the plate must be in (0, 1] m")
        if max(abs(a) for a in fts_pose[3:]) > math.pi:
            raise ConfigError("platform.fts_pose", list(v), "angles must be within ±pi rad")
        if "fts_height" in kw and kw["fts_height"] != fts_pose[2]:
            raise ConfigError("platform.fts_height", kw["fts_height"], f"differs from "
                              f"fts_pose z = {fts_pose[2]:g} m (give one of them)")
        kw["fts_height"] = fts_pose[2]
    inertial: tuple[tuple[float, ...], tuple[float, ...]] = ((), ())
    if "plate_inertia" in sec:
        inertial = check_plate_inertial(sec["plate_inertia"], sec.get("plate_com", ()))
    elif "plate_com" in sec:
        raise ConfigError("platform.plate_com", sec["plate_com"], "needs plate_inertia (the "
                          "moments about that centre)")
    explicit = "base_anchors" in sec or "top_anchors" in sec
    gfile = sec.get("geometry_file", "")
    if not isinstance(gfile, str):
        raise ConfigError("platform.geometry_file", gfile, "must be a path (string)")
    if explicit and not ("base_anchors" in sec and "top_anchors" in sec):
        missing = "top_anchors" if "base_anchors" in sec else "base_anchors"
        raise ConfigError(f"platform.{missing}", None, "required with explicit anchors "
                          "(six base and six top anchors)")
    if gfile and (explicit or any(k in sec for k in (*PATTERN, "home_height"))):
        clash = next(k for k in ("base_anchors", "top_anchors", *PATTERN, "home_height")
                     if k in sec)
        raise ConfigError(f"platform.{clash}", sec[clash], "give the geometry one way: the "
                          "calibrated geometry_file already sets the anchors and home height")
    if explicit and any(k in sec for k in ("base_gap", "top_gap", "base_angle")):
        clash = next(k for k in ("base_gap", "top_gap", "base_angle") if k in sec)
        raise ConfigError(f"platform.{clash}", sec[clash], "give the geometry one way: "
                          "explicit anchors or the parametric pattern")
    try:
        if gfile:
            if not Path(gfile).is_file():
                raise ConfigError("platform.geometry_file", gfile, "file not found")
            try:
                geom: StewartGeometry = load_geometry(gfile)
            except ConfigError as exc:
                raise ConfigError("platform.geometry_file", gfile, str(exc)) from None
            if kw:
                geom = dataclasses.replace(geom, **kw)
        elif explicit:
            b = _anchors("platform.base_anchors", sec["base_anchors"])
            p = _anchors("platform.top_anchors", sec["top_anchors"])
            # the drawing's radii (plate and base meshes, viewer) from the anchors
            kw.setdefault("base_radius", float(np.mean(np.hypot(b[:, 0], b[:, 1]))))
            kw.setdefault("top_radius", float(np.mean(np.hypot(p[:, 0], p[:, 1]))))
            geom = CalibratedGeometry.from_nominal(StewartGeometry(**kw), b, p, np.zeros(6))
        else:
            geom = StewartGeometry(**kw)
    except ConfigError as exc:
        if exc.field.startswith("platform."):
            raise
        raise _renamed(exc) from None
    return PlatformDescription(geometry=geom, fts_pose=fts_pose, plate_inertia=inertial[0],
                               plate_com=inertial[1],
                               geometry_file=gfile, given=tuple(k for k in PLATFORM_KEYS
                                                                 if k in sec))


def experiment_extra(sec: dict[str, Any], dofs: tuple[str, ...]) -> dict[str, Any]:
    """Take the fields a shipped part does not use out of the raw ``[experiment]`` table
    (edited in place): ``com`` (m), ``inertia`` as a tensor (kg·m²), ``file``, ``dofs``
    (the scene's ``dofs`` for a part that is tested through any, when not given)."""
    out: dict[str, Any] = {}
    if "com" in sec:
        v = sec.pop("com")
        if not isinstance(v, list | tuple) or len(v) != 3:
            raise ConfigError("experiment.com", v, "need [x, y, z] in m (sensor frame)")
        out["com"] = tuple(_number(f"experiment.com[{i}]", x, "m") for i, x in enumerate(v))
    for key in ("inertia", "inertia_tensor"):
        if isinstance(sec.get(key), list | tuple):
            v = sec.pop(key)
            out["inertia_tensor"] = tuple(_number(f"experiment.inertia[{i}]", x, "kg·m²")
                                          for i, x in enumerate(v))
    if "file" in sec:
        v = sec.pop("file")
        if not isinstance(v, str) or not v:
            raise ConfigError("experiment.file", v, "must be a path (string)")
        out["file"] = v
    v = sec.pop("dofs", list(dofs))
    if isinstance(v, str):
        v = [v]
    if not isinstance(v, list | tuple) or any(not isinstance(d, str) for d in v):
        raise ConfigError("experiment.dofs", v, f"must be a list of DOFs from {', '.join(DOFS)}")
    if v:
        out["dofs"] = tuple(d for d in DOFS if d in v) if all(d in DOFS for d in v) \
            else tuple(v)
    return out


def platform_geometry(desc: PlatformDescription) -> StewartGeometry:
    """The platform's geometry (today's default when the scene gives none)."""
    return desc.geometry if desc.geometry is not None else DEFAULT_GEOMETRY


def controller_table(sec: Any, transfer: dict[str, Any]) -> ControllerConfig:
    """Validate the raw ``[controller]`` table and move its gains, lag and delay into the
    raw ``[transfer]`` table ``transfer`` (edited in place), where every consumer reads them.

    ``[controller]`` wins over today's ``[transfer]`` keys; the same key set in both to
    different values is an error, and so is ``transfer.velocity_ff = false`` with a
    feed-forward form other than ``none``."""
    if sec is None:
        sec = {}
    if not isinstance(sec, Mapping):
        raise ConfigError("controller", sec, "must be a table")
    for key in sec:
        if key not in CONTROLLER_KEYS:
            raise ConfigError(f"controller.{key}", sec[key],
                              f"unknown field (known: {', '.join(CONTROLLER_KEYS)})")
    for key in SERVO_RANGES:  # today's [transfer] table has them too
        if key not in sec:
            continue
        v = sec[key]
        check_servo_number(f"controller.{key}", key, v)
        if key in transfer and transfer[key] != v:
            raise ConfigError(f"controller.{key}", v, f"differs from transfer.{key} = "
                              f"{transfer[key]!r} (set it in one table)")
        transfer[key] = v
    kw: dict[str, str] = {}
    for key, allowed in SERVO_CONVENTIONS.items():
        if key in sec:
            v = sec[key]
            if v not in allowed:
                raise ConfigError(f"controller.{key}", v, "must be one of "
                                  + " | ".join(allowed))
            kw[key] = v
    if transfer.get("valve_hz", 0.0) > 0 and kw.get("lag") == "servo" and \
            transfer.get("timeconst", 0.0) > 0:
        raise ConfigError("controller.valve_hz", transfer["valve_hz"], "", message=(
            f"controller.valve_hz: {transfer['valve_hz']!r} Hz with lag = 'servo': state the "
            "servo's continuous dynamics after the hold as one, the valve or the lag "
            "(lag = 'setpoint' keeps the set-point filter)"))
    vff = transfer.get("velocity_ff", True)
    if vff is False:
        if kw.get("feedforward", "none") != "none":
            raise ConfigError("controller.feedforward", kw["feedforward"], "differs from "
                              "transfer.velocity_ff = false (no feed-forward; set it in one "
                              "table)")
        kw["feedforward"] = "none"
    elif kw.get("feedforward") == "none":
        transfer["velocity_ff"] = False
    return ControllerConfig(**kw, given=tuple(k for k in CONTROLLER_KEYS if k in sec))


def platform_dict(desc: PlatformDescription) -> dict[str, Any]:
    """The ``[platform]`` table of a description: the keys it was given ({} for none)."""
    g = desc.geometry
    if g is None or not desc.given:
        return {}
    out: dict[str, Any] = {}
    for key in desc.given:
        if key == "geometry_file":
            out[key] = desc.geometry_file
        elif key in ("fts_pose", "plate_inertia", "plate_com"):
            out[key] = list(getattr(desc, key))
        elif key == "base_anchors":
            out[key] = g.base_anchors().tolist()
        elif key == "top_anchors":
            out[key] = g.top_anchors().tolist()
        else:
            out[key] = getattr(g, key)
    return out


def controller_dict(ctl: ControllerConfig) -> dict[str, Any]:
    """The ``[controller]`` conventions that differ from today's bench ({} for none); the
    gains, lag and delay are written in ``[transfer]``."""
    out: dict[str, Any] = {}
    for f in dataclasses.fields(ControllerConfig):
        v = getattr(ctl, f.name)
        if f.name != "given" and v != f.default:
            out[f.name] = v
    return out


# ---------------------------------------------------------------------------- bench init
_TRANS = {"M": 12.0, "C": 60.0, "K": 2.0e4, "f": 50.0}
_ROT = {"M": 0.3, "C": 1.0, "K": 600.0, "f": 1.5}
"""Placeholder numerical substructure per DOF (kg, N·s/m, N/m, N; kg·m², N·m·s/rad, N·m/rad,
N·m): modes of 6–7 Hz, a few mm and mrad of motion under the placeholder sine."""


def _toml(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, list | tuple):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    return repr(float(v)) if isinstance(v, float) else str(v)


def bench_scene_text(name: str, *, dofs: tuple[str, ...] = ("x", "y", "z", "rx", "ry", "rz"),
                     platform: Mapping[str, Any] | None = None,
                     controller: Mapping[str, Any] | None = None,
                     part: Mapping[str, Any] | None = None, dt: float = 1.0e-3,
                     duration: float = 10.0) -> str:
    """A commented scene (TOML text) for a user's bench: its ``[platform]``, ``[controller]``
    and part (``part``: the ``[experiment]`` table, default a 1 kg rigid payload), with a
    placeholder numerical substructure (one spring-mass per interface DOF) and a gentle sine
    force, so that it runs as written (``rths3d run``). Keys as in docs/bench.md."""
    part = dict(part or {"kind": "rigid", "m": 1.0})
    diag = [_ROT if d.startswith("r") else _TRANS for d in dofs]
    n = len(dofs)

    def mat(key: str) -> list[list[float]]:
        return [[diag[i][key] if i == j else 0.0 for j in range(n)] for i in range(n)]

    L = [f"# rths3d scene {name!r}, written by `rths3d bench init`: your bench, SI units "
         "(m, rad, s, kg, N).",
         "# Edit freely; docs/bench.md explains every key. The numerical substructure and the",
         "# excitation are placeholders: put your test's there.",
         f"name = {_toml(name)}", f"dofs = {_toml(list(dofs))}", f"dt = {dt!r}",
         f"duration = {duration!r}", "",
         "# placeholder numerical substructure: one spring-mass per interface DOF",
         "[numerical]", f"M = {_toml(mat('M'))}", f"C = {_toml(mat('C'))}",
         f"K = {_toml(mat('K'))}", "",
         "# placeholder excitation: a 2 Hz sine force along every interface DOF",
         "[excitation]", 'kind = "force"', 'signal = "sine"', "amplitude = 1.0",
         "frequency = 2.0", f"direction = {_toml([d['f'] for d in diag])}", "",
         "# the part on the force-torque sensor"
         + (" (your MJCF file, mounted on the FTS site; world_* bodies fixed to the world)"
            if part.get("kind") == "mjcf" else
            " (a rigid payload: mass kg, centre of mass m from the FTS origin in the sensor "
            "frame, inertia kg·m² about it)"),
         "[experiment]"]
    L += [f"{k} = {_toml(v)}" for k, v in part.items()]
    L += ["", "# the Stewart platform (omitted keys: today's default platform; docs/bench.md)",
          "[platform]"]
    L += [f"{k} = {_toml(v)}" for k, v in (platform or {}).items()]
    L += ["", "# the leg controller: servo gains N/m and N·s/m, lag and delay s; conventions",
          "# hold ramp|zoh, sample end|start, feedforward backward|central|none, gravity "
          "nominal|measured|none,",
          "# lag setpoint|servo (the timeconst lag: a set-point filter before the hold, or the",
          "# servo's continuous dynamics after it); valve_hz Hz and valve_damping: a "
          "servo-valve's",
          "# second-order response after the hold (0 Hz: none)",
          "[controller]"]
    L += [f"{k} = {_toml(v)}" for k, v in (controller or {}).items()]
    L += ["", "[transfer]", 'kind = "stewart"', ""]
    return "\n".join(L)


_ORIGIN_DEFAULT = "today's default"


def bench_origin(scene: Any, source: str) -> list[str]:
    """Lines naming which parts of ``scene``'s bench came from the scene and which from
    defaults (``rths3d diagnose`` prints them first); ``source``: where the scene came from
    (a file, the record's ``scene_def``, or a default scene when neither was there)."""
    p, c = scene.platform, scene.controller
    if p.geometry_file:
        geo = f"calibrated geometry file {p.geometry_file}"
    elif "base_anchors" in p.given:
        geo = "explicit anchors"
    elif any(k in p.given for k in (*PATTERN, "home_height")):
        geo = "parameters " + ", ".join(k for k in (*PATTERN, "home_height") if k in p.given)
    else:
        geo = _ORIGIN_DEFAULT
    rest = [k for k in p.given if k not in (*PATTERN, "home_height", "base_anchors",
                                             "top_anchors", "geometry_file")]
    conv = ", ".join(f"{k} = {getattr(c, k)}" for k in ("hold", "sample", "feedforward",
                                                         "gravity", "lag"))
    t = scene.transfer
    ctl_given = [k for k in c.given]
    part = scene.experiment
    what = part.kind + (f" file {part.file}" if part.file else "")
    return [
        f"bench from {source}",
        f"  platform geometry: {geo}; limits, masses, FTS pose: "
        + (", ".join(rest) + " from the scene, the rest default" if rest else
           _ORIGIN_DEFAULT),
        f"  controller: {conv} ("
        + (", ".join(ctl_given) + " from the scene's [controller]" if ctl_given else
           "conventions today's default") + f"); kp = {t.kp:g} N/m, kv = {t.kv:g} N·s/m, "
        f"timeconst = {t.timeconst:g} s, delay = {t.delay:g} s"
        + (f", servo-valve {t.valve_hz:g} Hz, damping {t.valve_damping:g}" if t.valve_hz
           else ""),
        f"  part: {what}; effects: "
        + (", ".join(e.label for e in scene.effects) if scene.effects else "none"),
    ]
