"""The force-torque sensor between F_m and F'_m, as a chain of effect blocks.

A scene's ``[sensor]`` table (:class:`~rths3d.config.SensorConfig`) becomes, in this order:
first-order dynamics (``first_order``, time constant τ_f), gain, offset, white noise (std,
seeded per test) and a delay — the :mod:`rths3d.effects.blocks` that the diagnosis' sensor
effects apply too. Blocks at their off value are left out; their values may differ test by
test (their presence may not: :func:`~rths3d.transfer.base.sensor_key`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..config import Scene
from ..effects.blocks import (
    Block,
    Chain,
    DelayBlock,
    GainBlock,
    LagBlock,
    NoiseBlock,
    OffsetBlock,
)

__all__ = ["sensor_chain"]


def sensor_chain(scenes: Sequence[Scene], n: int) -> Chain:
    """The sensor chain of K tests (one scene each) over their n interface DOFs."""
    K = len(scenes)
    dt = scenes[0].dt
    sen = [s.sensor for s in scenes]

    def rows(name: str) -> np.ndarray:
        return np.repeat(np.array([float(getattr(x, name)) for x in sen]), n)

    first = sen[0]
    blocks: list[Block] = []
    if first.kind == "first_order":
        blocks.append(LagBlock(K, n, rows("time_constant"), dt))
    if first.gain != 1.0:
        blocks.append(GainBlock(K, n, rows("gain")))
    if first.offset != 0.0:
        blocks.append(OffsetBlock(K, n, rows("offset")))
    if first.noise_std > 0.0:
        # one generator per test: a test's noise depends on its own seed alone
        blocks.append(NoiseBlock(K, n, rows("noise_std"), [x.seed for x in sen]))
    if first.delay > 0.0:
        blocks.append(DelayBlock(K, n, rows("delay"), dt))
    return Chain(K, n, blocks)
