"""Scenes: the frozen, validated description of one vRTHS test, loaded from TOML.

A scene names the numerical substructure (``M, C, K`` and the interface map Γ), its
excitation, the experimental part, the transfer system, the force sensor, the safety limits
and, for a Stewart bench, its ``[platform]`` and ``[controller]`` tables. Everything is SI (m,
rad, s, kg, N, N·m). ``load_scene(path, overrides)`` reads a TOML file, applies
``key=value`` overrides (dotted keys, e.g. ``numerical.k=5000``) and returns a
:class:`Scene`; every mistake raises :class:`~rths3d.errors.ConfigError` naming the field,
the value and the limit.

- :mod:`~rths3d.scene.reader`: TOML → :class:`Scene` (validation of every table);
- :mod:`~rths3d.scene.writer`: :class:`Scene` → mapping or TOML, :func:`scene_with`;
- :mod:`~rths3d.scene.bench`: the bench's ``[platform]`` and ``[controller]`` tables and the
  ``rths3d bench init`` scene text;
- :mod:`~rths3d.scene.checks`: the checks across tables (coupled stability, reach).

The frozen dataclasses themselves are :mod:`rths3d.config`.
"""

from ..config import (
    EffectConfig,
    ExcitationConfig,
    ExperimentConfig,
    NumericalConfig,
    SafetyConfig,
    Scene,
    SensorConfig,
    TransferConfig,
)
from .reader import apply_overrides, load_scene, scene_from_dict, transfer_kinds
from .writer import scene_to_dict, scene_to_toml, scene_with

__all__ = [
    "EffectConfig",
    "ExcitationConfig",
    "ExperimentConfig",
    "NumericalConfig",
    "SafetyConfig",
    "Scene",
    "SensorConfig",
    "TransferConfig",
    "apply_overrides",
    "load_scene",
    "scene_from_dict",
    "scene_to_dict",
    "scene_to_toml",
    "scene_with",
    "transfer_kinds",
]
