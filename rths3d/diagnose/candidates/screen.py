"""Screening and accepting revisions of the description inside a diagnosis
(:class:`~rths3d.diagnose.engine.Diagnosis`): each revision is replayed once with the
accepted effects; accepting one rewrites the diagnosis' scene and replay."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from ...bench import BenchReplay
from ...config import EffectConfig, Scene
from ...effects import bench_effects, parse_label
from ...errors import ConfigError
from .base import PREFIX, Revision, current, revised_scene, revisions

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
    the diagnosis' scene and measurement, replayed on the diagnosis' threads (one revised
    bench each); a revision the scene cannot take is left out with a warning."""
    if diag.descriptions == ():
        return []
    todo: list[tuple[str, Revision, Scene]] = []
    for rev in revisions(diag.scene, diag.measured, diag.dt, diag.descriptions):
        try:
            todo.append((PREFIX + rev.label, rev, revised_scene(diag.scene, rev.changes)))
        except ConfigError as exc:
            msg = f"revision {rev.label} not screened: {exc}"
            if msg not in diag.warnings:
                diag.warnings.append(msg)
    if not todo:
        return []
    effects = _effects(diag)

    def one(item: tuple[str, Revision, Scene]) -> dict[str, np.ndarray] | None:
        try:
            return BenchReplay(item[2], diag._inp, substeps=diag._substeps,
                               nthread=1).run([effects])[0]
        except ConfigError as exc:
            msg = f"revision {item[1].label} not screened: {exc}"
            if msg not in diag.warnings:
                diag.warnings.append(msg)
            return None

    res = _run_all(diag, todo, one)
    # a numeric revision (the payload's identified values) is refined along the line from
    # what the scene states to what it proposes: one secant step on the training residual
    # (an estimate biased by the bench's conventions is pulled onto the replay's optimum)
    r0 = diag._vec(diag._res(diag.predict()), diag.train)
    again: list[tuple[int, tuple[str, Revision, Scene]]] = []
    for i, ((_, rev, _), r) in enumerate(zip(todo, res, strict=True)):
        if r is None or not (rev.std or rev.refine):
            continue
        d = diag._vec(diag._res(r), diag.train) - r0
        dd = float(np.dot(d, d))
        if not (np.all(np.isfinite(d)) and dd > 0):
            continue
        alpha = float(np.clip(-float(np.dot(r0, d)) / dd, 0.0, 2.0))
        moved = rev.along(diag.scene, alpha) if abs(alpha - 1.0) > 0.02 else None
        if moved is not None:
            try:
                again.append((i, (PREFIX + moved.label, moved,
                                  revised_scene(diag.scene, moved.changes))))
            except ConfigError:
                continue
    if again:
        res2 = _run_all(diag, [item for _, item in again], one)
        diag.nsim += len(again)
        for (i, item), r in zip(again, res2, strict=True):
            if r is None or res[i] is None:
                continue
            e1 = diag._vec(diag._res(res[i]), diag.train)
            e2 = diag._vec(diag._res(r), diag.train)
            if np.all(np.isfinite(e2)) and float(np.dot(e2, e2)) < float(np.dot(e1, e1)):
                todo[i], res[i] = item, r
    out = []
    for (lab, rev, _), r in zip(todo, res, strict=True):
        if r is None:
            continue
        diag.nsim += 1
        diag._revs[lab] = rev
        out.append((lab, rev, r))
    return out


def _run_all(diag: Any, items: list, one) -> list:
    T = max(1, min(diag.threads, len(items)))
    if T > 1:
        with ThreadPoolExecutor(T, thread_name_prefix="rths3d-revision") as pool:
            return list(pool.map(one, items))
    return [one(item) for item in items]


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
    diag.base_effects = bench_effects(diag.scene)
    diag.replay = _replay(diag, diag.scene)
    diag._cache.clear()
    diag._revs.clear()
    entry: dict[str, Any] = {"label": rev.label, "changes": {
        k: {"stated": old[k], "revised": v} for k, v in rev.changes.items()}}
    if diag._evidence.get(label):  # it contradicted a statement of the scene
        entry["evidence"] = diag._evidence[label]
    diag.revisions.append(entry)
    return rev
