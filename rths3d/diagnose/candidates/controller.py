"""The controller's conventions as description candidates: every other choice of the set-point
hold (``ramp`` | ``zoh``), the sampling instant (``end`` | ``start``), the feed-forward's
difference form (``backward`` | ``central`` | ``none``) and the gravity compensation
(``nominal`` | ``measured`` | ``none``), each one revision.

A choice among a few discrete alternatives fits no parameter: k = 0 in the held-out ΔIC.
Where a convention and a fitted effect explain a record equally — a bench that samples at
the start of the step is indistinguishable from one that samples at the end with one more
sample of transport delay — the convention ranks first (the stated description is what is
wrong, no effect is added) and the pair is reported as confounded."""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

import numpy as np

from ...config import SERVO_CONVENTIONS, ControllerConfig, Scene
from .base import Revision, current, register_description

CONVENTIONS: dict[str, tuple[str, ...]] = {
    k: SERVO_CONVENTIONS[k] for k in ("hold", "sample", "feedforward", "gravity")}
"""The controller's discrete conventions and their choices ([controller] table; the lag's
place is revised with the servo's numbers, :mod:`.servo`). Allowed values and defaults have
one home: :data:`rths3d.config.SERVO_CONVENTIONS`, :class:`rths3d.config.ControllerConfig`."""

DEFAULTS = {k: getattr(ControllerConfig(), k) for k in CONVENTIONS}
"""Today's bench (what a scene that says nothing means)."""


@register_description
class ControllerConventions:
    """Each convention of the ``[controller]`` table set to each of its other choices."""

    name: ClassVar[str] = "controller"

    def revisions(self, scene: Scene, measured: Mapping[str, np.ndarray], dt: float
                  ) -> list[Revision]:
        out = []
        for key, choices in CONVENTIONS.items():
            now = current(scene, f"controller.{key}") or DEFAULTS[key]
            for c in choices:
                if c != now:
                    out.append(Revision(f"controller.{key}={c}", {f"controller.{key}": c}, 0))
        return out
