"""Measurements with hidden effects, made the way a bench makes them: the closed vRTHS loop.

:func:`measure` runs a scene through ``rths3d.run`` on the Stewart platform with effects
declared in its bench but *hidden* from the record (its metadata describes the nominal
bench, as the metadata of a real bench would), with a finer physics step than the diagnosis'
replay uses and seeded measurement noise on every channel. Tests, examples and the benchmark
hand only the resulting file to the diagnosis.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

from ..config import EffectConfig, Scene
from ..effects import parse_label
from ..record import Record

__all__ = ["hide_effects", "measure"]


def _effects(effects: Mapping[str, float] | Sequence[EffectConfig]) -> list[EffectConfig]:
    if isinstance(effects, Mapping):
        out = []
        for label, v in effects.items():
            name, leg, axis = parse_label(label)
            out.append(EffectConfig(name, float(v), leg, axis))
        return out
    return list(effects)


def hide_effects(rec: Record, nominal: Scene) -> Record:
    """The record with metadata of the ``nominal`` bench: its scene definition and flat
    parameters without the hidden effects."""
    from ..scene import scene_to_dict

    meta = dict(rec.meta)
    meta["scene_def"] = scene_to_dict(nominal)
    meta["params"] = {k: v for k, v in dict(meta.get("params", {})).items()
                      if not k.startswith("effect.")}
    tm = dict(meta.get("transfer_meta", {}))
    tm.pop("bench", None)
    meta["transfer_meta"] = tm
    return Record(rec.t, rec.columns, meta)


def measure(scene: Scene, effects: Mapping[str, float] | Sequence[EffectConfig] = (), *,
            noise: float = 1.0, substeps: int = 4, seed: int = 0,
            duration: float | None = None, reference: bool = False) -> Record:
    """A record of ``scene`` run closed loop on the Stewart platform with hidden ``effects``
    (label → value, or :class:`~rths3d.config.EffectConfig`), ``substeps`` physics steps per
    sample and white measurement noise (``noise`` × the nominal σ of each channel, seed
    ``seed``). The record's metadata describes ``scene`` itself (the nominal bench)."""
    from ..loop import run

    tr = dataclasses.replace(scene.transfer, kind="stewart")
    nominal = dataclasses.replace(scene, transfer=tr,
                                  duration=scene.duration if duration is None else duration)
    hidden = _effects(effects)
    if noise:
        hidden.append(EffectConfig("sensor_noise", float(noise)))
    truth = dataclasses.replace(
        nominal, transfer=dataclasses.replace(tr, substeps=substeps),
        sensor=dataclasses.replace(scene.sensor, seed=int(seed)),
        effects=tuple(scene.effects) + tuple(hidden))
    rec = run(truth, reference=reference).record
    return hide_effects(rec, nominal)
