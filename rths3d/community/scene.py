"""Benchmark scenes: a :class:`BenchmarkConfig` from a TOML file or a mapping.

A scene file has up to five tables; every key is optional and defaults to the published
benchmark setting::

    [benchmark]            # case (1–4), excitation (ElCentro|Kobe|Morgan), intensity,
    case = 4               # dt (s), t_end (s), force_limit (N), convention (code|paper)
    excitation = "ElCentro"

    [plant]                # PlantParams: gain, a1_beta0, beta1, beta2, a2, a3, m_e, k_e,
    k_e = 1.25e6           # zeta_e (SI)

    [controller]           # kp, ki, phase_lead, lead_num, lead_den — or any discrete
    tracking = { type = "pi", kp = 2.5, ki = 120.0 }   # controller of order ≤ 1 given as
    lead = { type = "tf", num = [40.0, 8000.0], den = [1.0, 8000.0] }  # lti.controller_from_dict

    [io]                   # noise, noise_generator, noise_seed, noise_cov_d (m²·s),
    noise = false          # noise_cov_f (N²·s), noise_shared, force_delay, quantize, q, sat

    [model]                # derivative (simulink|exact), ground_interp
    derivative = "simulink"  # (linear|hold|record_hold), reference (foh|zoh)

Unknown tables or keys raise :class:`~rths3d.errors.ConfigError` naming them.
"""

from __future__ import annotations

import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import fields, replace
from numbers import Integral
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..lti import controller_from_dict
from ..lti.controllers import number_field, numbers_field
from .config import BenchmarkConfig, ControllerParams
from .plant import PlantParams

__all__ = ["config_from_dict", "load_benchmark_scene"]

_TABLES = {
    "benchmark": ("case", "excitation", "intensity", "dt", "t_end", "force_limit",
                  "convention"),
    "io": ("noise", "noise_generator", "noise_seed", "noise_cov_d", "noise_cov_f",
           "noise_shared", "force_delay", "quantize", "q", "sat"),
    "model": ("derivative", "ground_interp", "reference"),
}


def _check_keys(table: str, data: Mapping[str, Any], allowed: Sequence[str]) -> None:
    for k in data:
        if k not in allowed:
            raise ConfigError(f"{table}.{k}", data[k], f"unknown key (allowed: "
                              f"{', '.join(allowed)})")


_INTS = ("case", "noise_seed")
_BOOLS = ("noise", "noise_shared", "force_delay", "quantize", "phase_lead")
_STRINGS = ("excitation", "noise_generator", "derivative", "ground_interp", "reference",
            "convention")
_LISTS = ("lead_num", "lead_den")


def _convert(field: str, value: Any) -> Any:
    """One scene value converted to its field's type; ConfigError naming the field if not."""
    key = field.rpartition(".")[2]
    if key in _INTS:
        if isinstance(value, bool) or not isinstance(value, Integral):
            raise ConfigError(field, value, "must be an integer")
        return int(value)
    if key in _BOOLS:
        if not isinstance(value, bool | np.bool_):
            raise ConfigError(field, value, "must be a bool, true or false")
        return bool(value)
    if key in _STRINGS:
        if not isinstance(value, str):
            raise ConfigError(field, value, "must be a string")
        return value
    if key in _LISTS:
        return numbers_field(field, value)
    return number_field(field, value)


def config_from_dict(raw: Mapping[str, Any]) -> BenchmarkConfig:
    """Validate a scene mapping (as read from TOML) into a :class:`BenchmarkConfig`."""
    known = (*_TABLES, "plant", "controller")
    for t, v in raw.items():
        if t not in known:
            raise ConfigError(t, None, f"unknown table (allowed: {', '.join(known)})")
        if not isinstance(v, Mapping):
            raise ConfigError(t, v, "must be a table")
    kw: dict[str, Any] = {}
    for table, keys in _TABLES.items():
        data = raw.get(table, {})
        _check_keys(table, data, keys)
        kw.update({k: _convert(f"{table}.{k}", v) for k, v in data.items()})
    dt = kw.get("dt", BenchmarkConfig.dt)
    plant_raw = raw.get("plant", {})
    _check_keys("plant", plant_raw, [f.name for f in fields(PlantParams)])
    ctrl_raw = dict(raw.get("controller", {}))
    _check_keys("controller", ctrl_raw, [f.name for f in fields(ControllerParams)])
    for key, value in ctrl_raw.items():
        if key in ("tracking", "lead"):
            if not isinstance(value, Mapping):
                raise ConfigError(f"controller.{key}", value, "must be a table with a type")
            ctrl_raw[key] = controller_from_dict(value, dt, field=f"controller.{key}")
        else:
            ctrl_raw[key] = _convert(f"controller.{key}", value)
    try:
        plant = PlantParams(**{k: number_field(f"plant.{k}", v) for k, v in plant_raw.items()})
        ctrl = replace(ControllerParams(), **ctrl_raw)
        return BenchmarkConfig(plant=plant, controller=ctrl, **kw)
    except (TypeError, ValueError) as exc:
        if isinstance(exc, ConfigError):
            raise
        raise ConfigError("scene", message=f"scene: {exc}") from exc


def load_benchmark_scene(path: str | Path, overrides: Sequence[str] | Mapping[str, Any] = ()
                         ) -> BenchmarkConfig:
    """Read a benchmark scene from TOML, apply ``key=value`` overrides (dotted keys)."""
    from ..scene import apply_overrides

    p = Path(path)
    if not p.exists():
        raise ConfigError("scene", str(p), "file not found")
    if not p.is_file():
        raise ConfigError("scene", str(p), "not a text TOML file")
    try:
        raw = tomllib.loads(p.read_text(encoding="utf-8"))
    except UnicodeDecodeError:
        raise ConfigError("scene", str(p), "not a text TOML file") from None
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError("scene", str(p), f"not valid TOML ({exc})") from exc
    return config_from_dict(apply_overrides(raw, overrides))
