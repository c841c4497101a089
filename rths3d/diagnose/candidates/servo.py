"""The leg servo's dynamics as description candidates: where its first-order lag sits
(``controller.lag``: a set-point filter before the hold, or the servo's continuous dynamics
after it), the lag's time constant, the transport delay and a stated servo-valve's
frequency, each revised in BOTH directions from what the scene states, one revision each
(k = 1). A valve the scene does not state is not screened: its frequency has no neutral
value to step from (state it: ``rths3d bench init --valve-hz``).

A description that overstates a lag or a delay is then corrected (the revision down), not
papered over by gains and added effects, which can only add lag (``actuator_lag``,
``delay``). A numeric revision is a step from the statement (half the stated value down,
half of it or half a sample up); the screening refines it along that line (one secant step,
up to twice the step: down to zero, up to twice the statement plus a sample)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

import numpy as np

from ...config import LAG, Scene
from ...transfer import transfer_class
from .base import Revision, current, register_description


def _steps(stated: float, floor: float) -> list[float]:
    """Revised values of a stated time (s): half of it (down, when it is > 0) and
    ``stated + max(stated/2, floor)`` (up), rounded to 0.1 µs."""
    out = [round(0.5 * stated, 7)] if stated > 0 else []
    out.append(round(stated + max(0.5 * stated, floor), 7))
    return out


@register_description
class ServoDynamics:
    """The lag's place, the lag's value, the delay's value and a stated valve's frequency,
    each revised both ways."""

    name: ClassVar[str] = "servo"

    def revisions(self, scene: Scene, measured: Mapping[str, np.ndarray], dt: float
                  ) -> list[Revision]:
        if not getattr(transfer_class(scene.transfer.kind), "replays_bench", False):
            return []  # no leg servos to revise
        out = []
        tau = float(current(scene, "transfer.timeconst") or 0.0)
        delay = float(current(scene, "transfer.delay") or 0.0)
        place = current(scene, "controller.lag")  # stated, else the default
        if tau > 0:  # the place of a stated lag
            for other in LAG:
                if other != place:
                    out.append(Revision(f"controller.lag={other}", {"controller.lag": other}, 1))
        for v in _steps(tau, 0.5 * dt):
            out.append(Revision(f"transfer.timeconst={v:g}", {"transfer.timeconst": v}, 1,
                                refine=True))
        for v in _steps(delay, 0.5 * dt):
            out.append(Revision(f"transfer.delay={v:g}", {"transfer.delay": v}, 1,
                                refine=True))
        hz = float(current(scene, "transfer.valve_hz") or 0.0)
        if hz > 0:  # a stated servo-valve: its frequency, both ways (two thirds, 1.5 times)
            for v in (round(hz / 1.5, 3), round(hz * 1.5, 3)):
                out.append(Revision(f"transfer.valve_hz={v:g}", {"transfer.valve_hz": v}, 1,
                                    refine=True, reciprocal=True))
        return out
