"""Screening and accepting revisions of the description inside a diagnosis
(:class:`~rths3d.diagnose.engine.Diagnosis`): each revision is replayed once with the
accepted effects; accepting one rewrites the diagnosis' scene and replay."""

from __future__ import annotations

from typing import Any

import numpy as np

from ...bench import BenchReplay
from ...config import EffectConfig, Scene
from ...effects import parse_label
from ...errors import ConfigError
from . import PREFIX, Revision, current, revised_scene, revisions

__all__ = ["revise", "screen_revisions"]


def _effects(diag: Any) -> list[EffectConfig]:
    out = []
    for label, v in {**diag.base_effects, **diag.accepted}.items():
        name, leg, axis = parse_label(label)
        out.append(EffectConfig(name, float(v), leg, axis))
    return out


def _replay(diag: Any, scene: Scene) -> BenchReplay:
    return BenchReplay(scene, diag._inp, substeps=diag._substeps, nthread=diag._nthread)


def screen_revisions(diag: Any) -> list[tuple[str, Revision, dict[str, np.ndarray]]]:
    """(label, revision, replayed channels) of every revision the candidates propose for
    the diagnosis' scene and measurement; a revision the scene cannot take is left out
    with a warning."""
    if diag.descriptions == ():
        return []
    out = []
    effects = _effects(diag)
    for rev in revisions(diag.scene, diag.measured, diag.dt, diag.descriptions):
        lab = PREFIX + rev.label
        try:
            res = _replay(diag, revised_scene(diag.scene, rev.changes)).run([effects])[0]
        except ConfigError as exc:
            msg = f"revision {rev.label} not screened: {exc}"
            if msg not in diag.warnings:
                diag.warnings.append(msg)
            continue
        diag.nsim += 1
        diag._revs[lab] = rev
        out.append((lab, rev, res))
    return out


def revise(diag: Any, label: str) -> Revision:
    """Rewrite the diagnosis' scene with the revision ``label`` (screened, or proposed for
    the scene now), rebuild its replay and log the change in ``diag.revisions``."""
    rev = diag._revs.get(label)
    if rev is None:
        found = {PREFIX + r.label: r for r in revisions(diag.scene, diag.measured, diag.dt,
                                                        diag.descriptions)}
        rev = found.get(label)
        if rev is None:
            raise ConfigError("add", label, "a revision proposed for this bench: " +
                              (", ".join(found) or "none"))
    old = {k: current(diag.scene, k) for k in rev.changes}
    diag.scene = revised_scene(diag.scene, rev.changes)
    diag.base_effects = {e.label: e.value for e in diag.scene.effects
                         if e.name != "sensor_noise"}
    diag.replay = _replay(diag, diag.scene)
    diag._cache.clear()
    diag._revs.clear()
    diag.revisions.append({"label": rev.label, "changes": {
        k: {"stated": old[k], "revised": v} for k, v in rev.changes.items()}})
    return rev
