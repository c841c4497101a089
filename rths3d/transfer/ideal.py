"""The ideal transfer system: z' = z, the part moved exactly as commanded."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from ..config import Scene
from ..kernels import Chain
from .base import register_transfer
from .chain import ChainTransfer


@register_transfer
class IdealTransfer(ChainTransfer):
    """No actuator dynamics: the only error left in the loop is the partitioned exchange
    itself (the force held over a step)."""

    kind = "ideal"

    @classmethod
    def actuator_chain(cls, scenes: Sequence[Scene], n: int
                       ) -> tuple[Chain, list[dict[str, Any]]]:
        return Chain(len(scenes), n, []), [{"predicted_delay": 0.0} for _ in scenes]
