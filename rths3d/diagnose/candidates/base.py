"""The description candidates' protocol, registry and revisions (the package docstring)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol

import numpy as np

from ...config import SERVO_RANGES, Scene
from ...experiment import part_class

__all__ = ["DECISIVE", "DESCRIPTIONS", "PREFIX", "DescriptionCandidate", "Revision",
           "contradicted", "current", "is_revision", "register_description", "revised_scene",
           "revisions"]

DECISIVE = 0.75
"""A revision that contradicts what the scene states is accepted only when it removes at
least this share of the validation error's excess over noise (``(e0 − e1)/(e0 − 1)``, noise
units; docs/diagnosis.md): it must take the record most of the way to noise."""


PREFIX = "scene:"
"""Label prefix of a description revision among the candidates (``scene:controller.hold=zoh``)."""


def is_revision(label: str) -> bool:
    """True for the label of a description revision (not an effect)."""
    return label.startswith(PREFIX)


@dataclass(frozen=True)
class Revision:
    """One alternative description of the bench.

    ``changes``: dotted scene keys → new values (SI units, as the scene writes them);
    ``k``: the number of parameters it fits (0 for a discrete choice); ``std``: standard
    deviations of numeric changes where the candidate estimated them (the revision counts as
    significant only if each change exceeds 1.96 of them); ``detail``: report lines (e.g. the
    payload identification's condition number and what it cannot see); ``refine``: a
    numeric revision without an estimate (a step from the statement): the screening refines
    it along the line from the statement, as one with ``std``; ``reciprocal``: that line runs
    in 1/value (a frequency, whose effect on the record goes as its period)."""

    label: str
    changes: Mapping[str, Any]
    k: int = 0
    std: Mapping[str, float] = field(default_factory=dict)
    detail: tuple[str, ...] = ()
    refine: bool = False
    reciprocal: bool = False

    def along(self, scene: Scene, alpha: float) -> Revision | None:
        """The revision moved to ``stated + alpha·(revised − stated)`` on every key (numbers
        or lists of numbers), or None when a key is not numeric or the scene states none."""
        changes: dict[str, Any] = {}
        for key, new in self.changes.items():
            old = current(scene, key)
            try:
                a = np.asarray(old, dtype=float)
                b = np.asarray(new, dtype=float)
                if a.shape != b.shape or not (np.all(np.isfinite(a)) and
                                              np.all(np.isfinite(b))):
                    return None
            except (TypeError, ValueError):
                return None
            if self.reciprocal:
                if not (np.all(a > 0) and np.all(b > 0)):
                    return None
                v = 1.0 / (1.0 / a + alpha * (1.0 / b - 1.0 / a))
                if not np.all(v > 0):
                    return None
            else:
                v = a + alpha * (b - a)
            changes[key] = round(float(v), 6) if v.ndim == 0 else [round(float(x), 7)
                                                                    for x in v]
        label = self.label
        if len(changes) == 1 and "=" in label:
            (key, v), = changes.items()
            label = f"{key}=" + (f"{v:g}" if isinstance(v, float) else
                                 "[" + ", ".join(f"{x:g}" for x in v) + "]")
        return Revision(label, changes, self.k, dict(self.std), self.detail, self.refine,
                        self.reciprocal)

    def excludes_current(self, scene: Scene) -> bool:
        """Whether every numeric change is larger than 1.96 of its standard deviation."""
        for key, sd in self.std.items():
            old = current(scene, key)
            new = self.changes.get(key)
            try:
                d = np.abs(np.asarray(new, dtype=float) - np.asarray(old, dtype=float))
            except (TypeError, ValueError):
                continue
            if not np.any(d > 1.96 * np.asarray(sd, dtype=float)):
                return False
        return True


class DescriptionCandidate(Protocol):
    """What a candidate offers: its ``name`` and the revisions of a scene it proposes for a
    measurement (``measured``: channel → samples, ``dt`` the interface step, s)."""

    name: ClassVar[str]

    def revisions(self, scene: Scene, measured: Mapping[str, np.ndarray], dt: float
                  ) -> list[Revision]: ...


DESCRIPTIONS: dict[str, DescriptionCandidate] = {}
"""Registered description candidates by name."""


def register_description(cls: type) -> type:
    """Class decorator: add one instance of ``cls`` to :data:`DESCRIPTIONS`."""
    DESCRIPTIONS[cls.name] = cls()
    return cls


def current(scene: Scene, key: str) -> Any:
    """The value of a dotted key for the scene: as the scene writes it, else the value its
    configuration holds by default (``controller.hold`` → ``"ramp"``; a rigid part's
    unstated centre of mass → its default place on the axis); ``None`` when neither."""
    from ...scene import scene_to_dict

    node: Any = scene_to_dict(scene)
    for part in key.split("."):
        if not isinstance(node, Mapping) or part not in node:
            node = None
            break
        node = node[part]
    if node is not None:
        return node
    sec, _, leaf = key.partition(".")
    if key == "experiment.com" and part_class(scene.experiment.kind).rigid_payload and \
            not scene.experiment.com:
        from ...experiment.mjcf import MASS_HEIGHT

        return [0.0, 0.0, MASS_HEIGHT]
    v = getattr(getattr(scene, sec, None), leaf, None)
    if isinstance(v, tuple):
        return list(v) if v else None
    return v


def contradicted(scene: Scene, changes: Mapping[str, Any]) -> dict[str, tuple[Any, Any]]:
    """The keys of ``changes`` that contradict a statement of the scene: (stated, revised)
    per key. Statements are the keys the scene's ``[controller]`` table sets (its
    conventions, and the servo's ``kp``, ``kv``, ``timeconst``, ``delay``, which the
    revisions name ``transfer.*``); what the scene leaves to today's defaults is no
    statement."""
    given = set(scene.controller.given)
    out = {}
    for key, new in changes.items():
        sec, _, leaf = key.partition(".")
        if (sec == "controller" and leaf in given) or \
                (sec == "transfer" and leaf in SERVO_RANGES and leaf in given):
            old = current(scene, key)
            if old != new:
                out[key] = (old, new)
    return out


def revised_scene(scene: Scene, changes: Mapping[str, Any]) -> Scene:
    """The scene with the dotted-key ``changes`` (validated like a scene file)."""
    from ...scene import scene_with

    return scene_with(scene, dict(changes))


def revisions(scene: Scene, measured: Mapping[str, np.ndarray], dt: float,
              names: Sequence[str] | None = None) -> list[Revision]:
    """Every revision the registered candidates (or ``names``) propose, those that would
    change nothing left out."""
    out: list[Revision] = []
    for name, cand in DESCRIPTIONS.items():
        if names is not None and name not in names:
            continue
        for rev in cand.revisions(scene, measured, dt):
            if any(current(scene, k) != v for k, v in rev.changes.items()):
                out.append(rev)
    return out
