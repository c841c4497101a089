"""Reading a scene: TOML (or its mapping) → the frozen, validated :class:`Scene`.

A scene names the numerical substructure (``M, C, K`` and the interface map Γ), its
excitation, the experimental part, the transfer system, the force sensor and the safety
limits. Everything is SI (m, rad, s, kg, N, N·m). ``load_scene(path, overrides)`` reads a
TOML file, applies ``key=value`` overrides (dotted keys, e.g. ``numerical.k=5000``) and
returns a :class:`Scene`; every mistake raises :class:`~rths3d.errors.ConfigError` naming
the field, the value and the limit.

Single-DOF substructures may give scalars ``m, c, k`` instead of matrices ``M, C, K``.
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import fields, replace
from pathlib import Path
from typing import Any

import numpy as np

from ..compensation import COMPENSATORS, compensator_names, config_from_dict
from ..config import (
    COMP_INIT,
    COMPENSATE,
    NUMERICAL_EXTRA,
    SERVO_RANGES,
    EffectConfig,
    ExcitationConfig,
    ExperimentConfig,
    Matrix,
    NetworkConfig,
    NumericalConfig,
    SafetyLimits,
    Scene,
    SensorConfig,
    TransferConfig,
    check_servo_number,
)
from ..errors import ConfigError
from ..experiment import part_class, part_kinds
from ..numerical import numerical_class
from ..record import DOFS
from ..transfer import transfer_class, transfer_kinds
from ..transfer.commands import compensator_params
from .bench import (
    controller_table,
    experiment_extra,
    platform_geometry,
    platform_table,
)
from .checks import check_coupled_stability, check_reach

__all__ = ["apply_overrides", "load_scene", "scene_from_dict", "transfer_kinds"]

EXCITATION_KINDS = ("none", "force", "support", "ground")
SIGNALS = ("sine", "raised_cosine", "file", "array")
INTEGRATORS = ("exact", "central_difference", "newmark")
SENSOR_KINDS = ("ideal", "first_order")

def _num(field_name: str, value: Any, *, lo: float | None = None, lo_open: bool = False,
         hi: float | None = None, unit: str = "") -> float:
    """Check that ``value`` is a finite real number in the given range; return it as float."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ConfigError(field_name, value, f"must be a number{(' in ' + unit) if unit else ''}")
    v = float(value)
    if not math.isfinite(v):
        raise ConfigError(field_name, value, "must be finite")
    u = f" {unit}" if unit else ""
    if lo is not None and (v <= lo if lo_open else v < lo):
        raise ConfigError(field_name, value, f"must be {'>' if lo_open else '>='} {lo:g}{u}")
    if hi is not None and v > hi:
        raise ConfigError(field_name, value, f"must be <= {hi:g}{u}")
    return v


def _choice(field_name: str, value: Any, choices: Sequence[str]) -> str:
    if value not in choices:
        raise ConfigError(field_name, value, f"must be one of {', '.join(choices)}")
    return str(value)


def _matrix(field_name: str, value: Any, shape: tuple[int, int] | None = None) -> Matrix:
    try:
        a = np.array(value, dtype=float)
    except (TypeError, ValueError):
        raise ConfigError(field_name, value, "must be a number or a matrix of numbers") from None
    if a.ndim == 0:
        a = a.reshape(1, 1)
    if a.ndim != 2:
        raise ConfigError(field_name, value, "must be a 2-D matrix (list of rows)")
    if shape is not None and a.shape != shape:
        raise ConfigError(field_name, value, f"must have shape {shape[0]}×{shape[1]}, "
                          f"has {a.shape[0]}×{a.shape[1]}")
    if not np.all(np.isfinite(a)):
        raise ConfigError(field_name, value, "must be finite")
    return tuple(tuple(float(x) for x in row) for row in a)


# ---------------------------------------------------------------------------- loading
def _section(raw: Mapping[str, Any], name: str, cls: type, *, required: bool = False,
             rename: Mapping[str, str] | None = None) -> dict[str, Any]:
    sec = raw.get(name)
    if sec is None:
        if required:
            raise ConfigError(name, None, "section is required")
        return {}
    if not isinstance(sec, Mapping):
        raise ConfigError(name, sec, "must be a table")
    known = {f.name for f in fields(cls)} | set(rename or {})
    for key in sec:
        if key not in known:
            raise ConfigError(f"{name}.{key}", sec[key],
                              f"unknown field (known: {', '.join(sorted(known))})")
    return dict(sec)


def _numerical(raw: Mapping[str, Any], n_if: int, dofs: tuple[str, ...],
               source: str = "") -> NumericalConfig:
    kind = raw.get("numerical", {}).get("kind", "linear") if isinstance(
        raw.get("numerical"), Mapping) else "linear"
    if kind != "linear":  # a registered kind validates its own table
        return numerical_class(kind).config(raw["numerical"], dofs, source)
    sec = _section(raw, "numerical", NumericalConfig, required=True,
                   rename={"m": "M", "c": "C", "k": "K"})
    for key in set(sec) & set(NUMERICAL_EXTRA[1:]):
        raise ConfigError(f"numerical.{key}", sec[key], "only for another numerical.kind")
    mats = {}
    for big, small in (("M", "m"), ("C", "c"), ("K", "k")):
        if big in sec and small in sec:
            raise ConfigError(f"numerical.{small}", sec[small], f"give {big} or {small}, not both")
        val = sec.get(big, sec.get(small))
        if val is None:
            if big == "C":
                val = 0.0
            else:
                raise ConfigError(f"numerical.{small if n_if == 1 else big}", None,
                                  "required (mass matrix M / stiffness matrix K)")
        mats[big] = val
    # errors name the key the user wrote (numerical.k for a scalar k, numerical.K for K)
    given = {big: f"numerical.{small if small in sec else big}"
             for big, small in (("M", "m"), ("C", "c"), ("K", "k"))}
    M = np.array(_matrix(given["M"], mats["M"]))
    n = M.shape[0]
    if M.shape != (n, n):
        raise ConfigError(given["M"], mats["M"], "must be square")
    C = np.array(_matrix(given["C"], mats["C"])) if np.ndim(mats["C"]) else \
        np.eye(n) * _num(given["C"], mats["C"]) if n == 1 else np.zeros((n, n))
    if np.ndim(mats["C"]) == 0 and n > 1 and _num(given["C"], mats["C"]) != 0.0:
        raise ConfigError(given["C"], mats["C"], f"must be a {n}×{n} matrix")
    C = np.array(_matrix(given["C"], C, (n, n)))
    K = np.array(_matrix(given["K"], mats["K"], (n, n)))
    label = "m" if n == 1 and "m" in sec else "M"
    if n == 1 and M[0, 0] <= 0:
        raise ConfigError(f"numerical.{label}", float(M[0, 0]), "mass must be > 0 kg")
    for name, A, strict in (("M", M, True), ("K", K, False), ("C", C, False)):
        if n == 1:
            if A[0, 0] < 0:
                raise ConfigError(f"numerical.{name.lower() if label == 'm' else name}",
                                  float(A[0, 0]), "must be >= 0")
            continue
        if not np.allclose(A, A.T, rtol=1e-10, atol=1e-12):
            raise ConfigError(f"numerical.{name}", A.tolist(), "must be symmetric")
        ev = np.linalg.eigvalsh(A)
        if (strict and ev.min() <= 0) or (not strict and ev.min() < -1e-9 * max(1.0, ev.max())):
            lab = label if name == "M" else name
            what = ("positive definite (masses > 0 kg)" if strict
                    else "positive semi-definite (>= 0)")
            raise ConfigError(f"numerical.{lab}", A.tolist() if n > 1 else float(A[0, 0]),
                              f"must be {what}")
    if "gamma" in sec:
        G = _matrix("numerical.gamma", sec["gamma"], (n, n_if))
    else:
        if n < n_if:
            raise ConfigError("numerical.gamma", None,
                              f"required: {n} numerical DOFs cannot default to {n_if} "
                              f"interface DOFs {list(dofs)}")
        G = tuple(tuple(1.0 if i == j else 0.0 for j in range(n_if)) for i in range(n))
    integ = _choice("numerical.integrator", sec.get("integrator", "exact"), INTEGRATORS)
    return NumericalConfig(M=_matrix("M", M), C=_matrix("C", C), K=_matrix("K", K), gamma=G,
                           integrator=integ)


_BUILT: dict[tuple, Any] = {}
"""Sections already validated (a batch's scenes share most): key → the frozen section."""


def _build(cls: type, name: str, sec: Mapping[str, Any], checks: Mapping[str, dict]) -> Any:
    # the same raw section (each value's type and exact repr) validates to the same section
    key = (cls, name, tuple((k, type(v), repr(v)) for k, v in sec.items()))
    if key not in _BUILT:
        if len(_BUILT) > 4096:
            _BUILT.clear()
        _BUILT[key] = _build_section(cls, name, sec, checks)
    return _BUILT[key]


def _build_section(cls: type, name: str, sec: Mapping[str, Any],
                   checks: Mapping[str, dict]) -> Any:
    kwargs: dict[str, Any] = {}
    defaults = cls()
    for f in fields(cls):
        if f.name not in sec:
            continue
        v = sec[f.name]
        d = getattr(defaults, f.name)
        fname = f"{name}.{f.name}"
        if isinstance(d, str):
            if not isinstance(v, str):
                raise ConfigError(fname, v, "must be a string")
        elif isinstance(d, bool):
            if not isinstance(v, bool):
                raise ConfigError(fname, v, "must be true or false")
        elif isinstance(d, int):
            if isinstance(v, bool) or not isinstance(v, int):
                raise ConfigError(fname, v, "must be an integer")
        elif isinstance(d, float):
            v = _num(fname, v, **checks.get(f.name, {}))
        elif isinstance(d, tuple):
            if not isinstance(v, list | tuple):
                raise ConfigError(fname, v, "must be a list of numbers")
            v = tuple(_num(f"{fname}[{i}]", x) for i, x in enumerate(v))
        kwargs[f.name] = v
    return cls(**kwargs)


def scene_from_dict(raw: Mapping[str, Any], *, name: str = "scene", source: str = "") -> Scene:
    """Validate a raw (TOML-shaped) mapping and build a :class:`Scene`."""
    top = {"name", "dofs", "dt", "duration", "numerical", "experiment", "excitation",
           "transfer", "sensor", "safety", "effect", "platform", "controller", "network"}
    for key in raw:
        if key not in top:
            raise ConfigError(key, raw[key], f"unknown field (known: {', '.join(sorted(top))})")
    dofs = raw.get("dofs", ["z"])
    if isinstance(dofs, str):
        dofs = [dofs]
    if not isinstance(dofs, list | tuple) or not dofs or any(d not in DOFS for d in dofs) \
            or len(set(dofs)) != len(dofs):
        raise ConfigError("dofs", dofs, f"must be a non-empty list of distinct DOFs from "
                          f"{', '.join(DOFS)}")
    dofs = tuple(d for d in DOFS if d in dofs)
    dt = _num("dt", raw.get("dt", 1e-3), lo=1e-6, hi=0.01, unit="s")
    duration = _num("duration", raw.get("duration", 10.0), lo=10 * dt, hi=3600.0, unit="s")
    steps = duration / dt
    if abs(steps - round(steps)) > 1e-9 * steps:
        raise ConfigError("duration", raw.get("duration", 10.0),
                          f"must be a multiple of dt = {dt:g} s")
    num = _numerical(raw, len(dofs), dofs, source)
    exp_sec = _section(raw, "experiment", ExperimentConfig, required=True)
    if "kind" not in exp_sec:
        raise ConfigError("experiment.kind", None,
                          f"required: one of {', '.join(part_kinds())}")
    _choice("experiment.kind", exp_sec["kind"], part_kinds())
    part_cls = part_class(exp_sec["kind"])
    if part_cls.dofs and "dofs" in exp_sec:
        raise ConfigError("experiment.dofs", exp_sec["dofs"], f"the {exp_sec['kind']} part "
                          f"is tested through {list(part_cls.dofs)}: set the scene's dofs")
    extra = experiment_extra(exp_sec, dofs if not part_cls.dofs else ())
    pos = {"lo": 0.0, "lo_open": True}
    nonneg = {"lo": 0.0}
    exp = _build(ExperimentConfig, "experiment", exp_sec, {
        "m": {**pos, "unit": "kg"}, "k": {**pos, "unit": "N/m"}, "d": {**nonneg, "unit": "N·s/m"},
        "h0": {**pos, "unit": "m"}, "k_contact": {**pos, "unit": "N/m"},
        "d_contact": {**nonneg, "unit": "N·s/m"}, "inertia": {**pos, "unit": "kg·m²"},
        "k_rot": {**pos, "unit": "N·m/rad"}, "d_rot": nonneg, "arm": {**pos, "unit": "m"}})
    exp = replace(exp, **extra)
    if exp.substeps < 1 or exp.substeps > 64:
        raise ConfigError("experiment.substeps", exp.substeps, "must be in 1…64")
    part_cls.validate(exp)
    need = part_cls.interface_dofs(exp)
    if tuple(dofs) != need:
        raise ConfigError("dofs", list(dofs), f"the {exp.kind} experiment has interface DOFs "
                          f"{list(need)}")
    exc_sec = _section(raw, "excitation", ExcitationConfig)
    exc = _build(ExcitationConfig, "excitation", exc_sec, {
        "frequency": {**nonneg, "unit": "Hz"}, "overtravel": nonneg})
    _choice("excitation.kind", exc.kind, EXCITATION_KINDS)
    _choice("excitation.signal", exc.signal, SIGNALS)
    if exc.kind != "none":
        if exc.signal in ("sine", "raised_cosine") and exc.frequency <= 0:
            raise ConfigError("excitation.frequency", exc.frequency, "must be > 0 Hz")
        if exc.signal == "file" and not exc.file:
            raise ConfigError("excitation.file", None, "required for signal = 'file'")
        if exc.signal == "array" and (len(exc.times) < 2 or len(exc.times) != len(exc.values)):
            raise ConfigError("excitation.values", list(exc.values),
                              "need >= 2 samples and as many times as values")
        if exc.direction and len(exc.direction) != num.n:
            raise ConfigError("excitation.direction", list(exc.direction),
                              f"must have {num.n} entries (one per numerical DOF)")
    tr_sec = _section(raw, "transfer", TransferConfig)
    controller = controller_table(raw.get("controller"), tr_sec)
    platform = platform_table(raw.get("platform"))
    comp_table = tr_sec.pop("compensator", {})
    if not isinstance(comp_table, Mapping):
        raise ConfigError("transfer.compensator", comp_table, "must be a table of the "
                          "compensator's parameters")
    for key in SERVO_RANGES:  # the leg servo's numbers: one validation (rths3d.config)
        if key in tr_sec:
            check_servo_number(f"transfer.{key}", key, tr_sec[key])
    tr = _build(TransferConfig, "transfer", tr_sec, {
        "comp_time": {**nonneg, "hi": 0.1, "unit": "s"}})
    transfer_class(tr.kind)  # a ConfigError naming the registered kinds
    _choice("transfer.compensation", tr.compensation, compensator_names())
    _choice("transfer.compensate", tr.compensate, COMPENSATE)
    _choice("transfer.comp_init", tr.comp_init, COMP_INIT)
    if tr.compensate == "legs" and not getattr(transfer_class(tr.kind), "leg_compensation",
                                               False):
        raise ConfigError("transfer.compensate", tr.compensate, "per-leg compensation needs "
                          f"a transfer system with legs, e.g. transfer.kind = 'stewart' "
                          f"(this scene: {tr.kind!r})")
    if comp_table:
        # checked by the compensator's own configuration (names, types, ranges); a sub-table
        # named after a compensator holds that one's settings (used when it is chosen)
        items = []
        for key, value in sorted(comp_table.items()):
            if key in COMPENSATORS:
                if not isinstance(value, Mapping):
                    raise ConfigError(f"transfer.compensator.{key}", value, "must be a table "
                                      f"of the {key!r} compensator's parameters")
                config_from_dict(key, value, field=f"transfer.compensator.{key}")
                value = tuple(sorted(value.items()))
            items.append((key, value))
        config_from_dict(tr.compensation, compensator_params(tr.compensation, comp_table),
                         field="transfer.compensator")
        tr = replace(tr, compensator=tuple(items))
    if tr.substeps < 1 or tr.substeps > 100:
        raise ConfigError("transfer.substeps", tr.substeps, "must be in 1…100")
    _choice("transfer.integrator", tr.integrator, ("RK4", "implicitfast"))
    if tr.poly_order < 1 or tr.poly_order > 4:
        raise ConfigError("transfer.poly_order", tr.poly_order, "must be in 1…4")
    if bool(tr.num) != bool(tr.den):
        raise ConfigError("transfer.den" if tr.num else "transfer.num", None,
                          "give both num and den of the transfer function")
    if tr.den and (len(tr.den) < len(tr.num) or tr.den[0] == 0):
        raise ConfigError("transfer.den", list(tr.den), "must be proper (deg den >= deg num, "
                          "leading coefficient != 0)")
    sen = _build(SensorConfig, "sensor", _section(raw, "sensor", SensorConfig), {
        "time_constant": nonneg, "noise_std": nonneg, "delay": {**nonneg, "hi": 0.5}})
    _choice("sensor.kind", sen.kind, SENSOR_KINDS)
    if sen.seed < 0:
        raise ConfigError("sensor.seed", sen.seed, "must be >= 0")
    if sen.kind == "first_order" and sen.time_constant <= 0:
        raise ConfigError("sensor.time_constant", sen.time_constant, "must be > 0 s for "
                          "a first-order sensor")
    saf = _build(SafetyLimits, "safety", _section(raw, "safety", SafetyLimits),
                 {**{k: pos for k in ("stroke", "rotation", "velocity", "force", "torque",
                                      "divergence", "growth_window")},
                  "growth": {"lo": 1.0, "lo_open": True}})
    if saf.growth_windows < 0:
        raise ConfigError("safety.growth_windows", saf.growth_windows, "must be >= 0 (0: off)")
    if not saf.fidelity_limit >= 0:
        raise ConfigError("safety.fidelity_limit", saf.fidelity_limit,
                          "must be >= 0 m or rad (0: off)")
    _choice("safety.fidelity_action", saf.fidelity_action, ("warn", "stop"))
    if not saf.fidelity_warmup > 0 or (saf.fidelity_limit > 0
                                        and not saf.fidelity_warmup < duration):
        raise ConfigError("safety.fidelity_warmup", saf.fidelity_warmup,
                          f"must be > 0 s and shorter than the test ({duration:g} s)")
    check_reach(saf, exc, exp, platform_geometry(platform).stroke)
    if num.integrator == "central_difference":
        check_coupled_stability(num, exp, dofs, dt)
    sname = raw.get("name", name)
    if not isinstance(sname, str):
        raise ConfigError("name", sname, "must be a string")
    effects = _effects(raw.get("effect", []))
    return Scene(name=sname, dofs=dofs, numerical=num, experiment=exp, excitation=exc,
                 transfer=tr, sensor=sen, safety=saf, dt=dt, duration=duration, source=source,
                 effects=effects, platform=platform, controller=controller,
                 network=_network(raw, len(dofs)))


def _network(raw: Mapping[str, Any], n_if: int) -> NetworkConfig:
    """The ``[network]`` table (docs/network.md), checked."""
    sec = _section(raw, "network", NetworkConfig)
    emap = sec.pop("element_map", ())
    if not isinstance(sec.get("host", ""), str) or not sec.get("host", "x"):
        raise ConfigError("network.host", sec.get("host"), "must be a host name or address")
    net = _build(NetworkConfig, "network", sec, {
        "timeout": {"lo": 0.0, "lo_open": True, "hi": 3600.0, "unit": "s"},
        "first_timeout": {"lo": 0.0, "lo_open": True, "hi": 3600.0, "unit": "s"}})
    _choice("network.site", net.site, ("lab", "adapter"))
    if not 0 <= net.port <= 65535:
        raise ConfigError("network.port", net.port, "must be in 0…65535 (0: any free port)")
    if emap is not None and len(emap):
        m = _matrix("network.element_map", emap)
        if len(m) != n_if:
            raise ConfigError("network.element_map", emap, f"needs {n_if} rows (one per "
                              f"interface DOF), has {len(m)}")
        if len(m[0]) > 64 or not np.any(np.asarray(m)):
            raise ConfigError("network.element_map", emap, "must have 1…64 columns and a "
                              "non-zero entry")
        net = replace(net, element_map=m)
    return net



EFFECT_KEYS = ("name", "value", "leg", "axis")


def _effects(raw: Any) -> tuple[EffectConfig, ...]:
    """The ``[[effect]]`` tables: name, value (SI unit of the effect), leg, axis."""
    from ..effects import get_effect

    if isinstance(raw, Mapping):
        raw = [raw]
    if not isinstance(raw, list | tuple):
        raise ConfigError("effect", raw, "must be a list of [[effect]] tables")
    out: list[EffectConfig] = []
    seen: set[str] = set()
    for i, tab in enumerate(raw):
        where = f"effect[{i}]"
        if not isinstance(tab, Mapping):
            raise ConfigError(where, tab, "must be a table with name and value")
        for key in tab:
            if key not in EFFECT_KEYS:
                raise ConfigError(f"{where}.{key}", tab[key],
                                  f"unknown field (known: {', '.join(EFFECT_KEYS)})")
        name = tab.get("name")
        if not isinstance(name, str):
            raise ConfigError(f"{where}.name", name, "required: the effect's name (rths3d "
                              "effects lists them)")
        eff = get_effect(name)
        if "value" not in tab:
            raise ConfigError(f"{where}.value", None, f"required: {eff.param.name} in "
                              f"{eff.param.unit}")
        value = eff.param.check(tab["value"], f"{where}.{name}")
        leg = tab.get("leg", -1)
        if isinstance(leg, bool) or not isinstance(leg, int):
            raise ConfigError(f"{where}.leg", leg, "must be an integer 0…5 (or -1: all legs)")
        if eff.per_leg and leg == -1 and not eff.all_legs:
            raise ConfigError(f"{where}.leg", None, f"required: {name} acts on one leg (0…5)")
        axis = tab.get("axis", "")
        if not isinstance(axis, str):
            raise ConfigError(f"{where}.axis", axis, "must be a string")
        try:
            eff.check_target(leg, axis)
        except ConfigError as exc:
            raise ConfigError(f"{where}.{exc.field.split('.')[-1]}", exc.value,
                              exc.limit) from None
        e = EffectConfig(name, value, leg, axis)
        if e.label in seen:
            raise ConfigError(f"{where}", e.label, "declared twice (one [[effect]] per "
                              "effect, leg and axis)")
        seen.add(e.label)
        out.append(e)
    return tuple(out)


def _set_effect(raw: dict[str, Any], label: str, value: Any) -> None:
    """Set (or add) the ``[[effect]]`` entry of ``label`` (``name[.leg<i>][.<axis>]``)."""
    from ..effects import parse_label

    name, leg, axis = parse_label(label)
    tables = [dict(t) for t in raw.get("effect", [])]
    for t in tables:
        if t.get("name") == name and t.get("leg", -1) == leg and t.get("axis", "") == axis:
            t["value"] = value
            break
    else:
        t = {"name": name, "value": value}
        if leg >= 0:
            t["leg"] = leg
        if axis:
            t["axis"] = axis
        tables.append(t)
    raw["effect"] = tables


def _parse_value(text: str) -> Any:
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def apply_overrides(raw: dict[str, Any], overrides: Sequence[str] | Mapping[str, Any]
                    ) -> dict[str, Any]:
    """Apply ``key=value`` overrides (dotted keys, TOML values) to a raw scene mapping.

    A mapping of dotted key → value is accepted as well (values used as given).
    """
    out = dict(raw)  # copy-on-write: only the tables on an override's path are copied
    copied: set[tuple[str, ...]] = {()}
    items: list[tuple[str, Any]] = []
    if isinstance(overrides, Mapping):
        items = list(overrides.items())
    else:
        for text in overrides:
            key, sep, val = text.partition("=")
            if not sep or not key.strip():
                raise ConfigError("--set", text, "must look like key=value, e.g. numerical.k=5000")
            items.append((key.strip(), _parse_value(val.strip())))
    for key, val in items:
        if key.startswith("effect."):
            _set_effect(out, key[len("effect."):], val)
            continue
        parts = key.split(".")
        node = out
        for i, p in enumerate(parts[:-1]):
            nxt = node.get(p)
            if nxt is None:
                nxt = {}
            if not isinstance(nxt, dict):
                raise ConfigError(key, val, f"{p!r} is not a table")
            path = tuple(parts[:i + 1])
            if path not in copied:
                nxt = dict(nxt)
                copied.add(path)
            node[p] = nxt
            node = nxt
        node[parts[-1]] = val
    return out


def load_scene(path: str | Path, overrides: Sequence[str] | Mapping[str, Any] = ()) -> Scene:
    """Read a TOML scene file, apply overrides and validate it.

    A bare name (``paper_contact``) is looked up in the repository's ``scenes/`` folder.
    """
    p = Path(path)
    if not p.exists() and p.suffix == "":
        cand = Path(__file__).resolve().parents[2] / "scenes" / f"{p.name}.toml"
        if cand.exists():
            p = cand
    if not p.exists():
        raise ConfigError("scene", str(path), "file not found")
    if not p.is_file():
        raise ConfigError("scene", str(path), "is a folder, not a TOML file")
    try:
        raw = tomllib.loads(p.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError("scene", str(p), f"invalid TOML: {exc}") from None
    except UnicodeDecodeError:
        raise ConfigError("scene", str(p), "not a text TOML file") from None
    raw = _relative_to(raw, p.parent)
    raw = apply_overrides(raw, overrides)
    return scene_from_dict(raw, name=p.stem, source=str(p))


def _relative_to(raw: dict[str, Any], folder: Path) -> dict[str, Any]:
    """``raw`` with a relative ``excitation.file``, ``experiment.file`` (an MJCF part) and
    ``platform.geometry_file`` resolved against ``folder`` (the scene file's): a scene names
    its data beside itself, wherever it is run from. A path given
    by an override (``--set excitation.file=…``) is the user's, relative to the current
    folder."""
    for sec, key in (("excitation", "file"), ("experiment", "file"),
                     ("platform", "geometry_file")):
        tab = raw.get(sec)
        if isinstance(tab, Mapping) and isinstance(tab.get(key), str) and tab[key]:
            f = Path(tab[key]).expanduser()
            if not f.is_absolute():
                raw = {**raw, sec: {**tab, key: os.path.normpath(folder.resolve() / f)}}
    return raw
