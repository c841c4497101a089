"""The pure-delay transfer system: z'(t) = z(t − τ), τ = ``transfer.delay`` per test."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ..config import Scene
from ..effects.blocks import DelayBlock
from ..kernels import Chain
from .base import register_transfer
from .chain import ChainTransfer


@register_transfer
class DelayTransfer(ChainTransfer):
    """A transport delay τ (s) between command and achieved motion, linear interpolation
    between samples for fractional delays; τ may differ test by test."""

    kind = "delay"

    @classmethod
    def actuator_chain(cls, scenes: Sequence[Scene], n: int
                       ) -> tuple[Chain, list[dict[str, Any]]]:
        K = len(scenes)
        taus = [s.transfer.delay for s in scenes]
        block = DelayBlock(K, n, np.repeat(taus, n), scenes[0].dt)
        return Chain(K, n, [block]), [{"delay": t, "predicted_delay": t} for t in taus]
