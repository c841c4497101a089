"""The compensator of a transfer system, from its scenes' settings.

A scene names its compensator with ``transfer.compensation`` (any registered in
:mod:`rths3d.compensation`) and sets it with ``transfer.comp_time`` (τ_c, s),
``transfer.poly_order`` and the table ``[transfer.compensator]`` (the compensator's own
parameters, e.g. ``window`` for ``ats``; see docs/compensation.md). Tests without
compensation and with velocity feed-forward of any τ_c step together (``none`` is
``velocity`` with τ_c = 0, bit for bit); other compensators step together when all their
settings agree.
"""

from __future__ import annotations

from collections.abc import Hashable, Mapping, Sequence
from typing import Any

from ..compensation import BaseCompensator, build
from ..config import Scene

__all__ = ["compensator_key", "compensator_of"]

_PER_TEST = ("none", "velocity")


def compensator_of(scenes: Sequence[Scene], n: int) -> BaseCompensator:
    """The compensator of K tests (one scene each) over n channels."""
    base = scenes[0]
    K, dt = len(scenes), base.dt
    tr = base.transfer
    if tr.compensation in _PER_TEST:
        taus = tuple(s.transfer.comp_time if s.transfer.compensation == "velocity" else 0.0
                     for s in scenes)
        return build("velocity", K, n, dt, {"tau": taus})
    params = dict(tr.compensator)
    if tr.compensation == "polynomial":
        params = {"tau": tr.comp_time, "order": tr.poly_order, **params}
    return build(tr.compensation, K, n, dt, params, field="transfer.compensator")


def compensator_key(settings: Mapping[str, Any]) -> Hashable:
    """What of the compensation must be equal for tests stepped together."""
    name = settings.get("transfer.compensation", "none")
    if name in _PER_TEST:
        return ("velocity",)
    return (name, settings.get("transfer.comp_time", 0.0),
            settings.get("transfer.poly_order", 2),
            tuple(sorted(dict(settings.get("transfer.compensator", ())).items())))
