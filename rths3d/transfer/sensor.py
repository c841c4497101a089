"""The force-torque sensor between F_m and F'_m, as a chain of effect blocks.

A scene's ``[sensor]`` table (:class:`~rths3d.config.SensorConfig`) and its sensor-stage
effects become, in this order: first-order dynamics (``first_order``, time constant τ_f),
the ``fts_lowpass`` effect, gain, offset, white noise (std ``noise_std`` combined with the
``sensor_noise`` effect's level × the nominal σ of each interface DOF, seeded per test) and a
delay — :mod:`rths3d.effects.blocks`. Blocks at their off value are left out; their values
may differ test by test (their presence may not: :func:`~rths3d.transfer.base.sensor_key`).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from ..config import Scene
from ..effects.blocks import (
    DelayBlock,
    GainBlock,
    LagBlock,
    NoiseBlock,
    OffsetBlock,
)
from ..kernels import Block, Chain

__all__ = ["sensor_chain"]


def sensor_chain(scenes: Sequence[Scene], n: int) -> Chain:
    """The sensor chain of K tests (one scene each) over their n interface DOFs."""
    K = len(scenes)
    dt = scenes[0].dt
    sen = [s.sensor for s in scenes]

    def rows(name: str) -> np.ndarray:
        return np.repeat(np.array([float(getattr(x, name)) for x in sen]), n)

    from ..effects.library import noise_sigma

    def effect(name: str) -> float:
        # any test's (a batch shares the structure; a replay unites the variants')
        return float(max(sum(e.value for e in s.effects if e.name == name) for s in scenes))

    def effect_rows(name: str) -> np.ndarray:
        return np.repeat([sum(e.value for e in s.effects if e.name == name) for s in scenes], n)

    first = sen[0]
    blocks: list[Block] = []
    if first.kind == "first_order":
        blocks.append(LagBlock(K, n, rows("time_constant"), dt))
    if effect("fts_lowpass") > 0:
        blocks.append(LagBlock(K, n, effect_rows("fts_lowpass"), dt))
    if first.gain != 1.0:
        blocks.append(GainBlock(K, n, rows("gain")))
    if first.offset != 0.0:
        blocks.append(OffsetBlock(K, n, rows("offset")))
    if first.noise_std > 0.0 or effect("sensor_noise") > 0.0:
        # one generator per test: a test's noise depends on its own seed alone
        sig = np.array([noise_sigma(f"f_meas.{d}") for d in scenes[0].dofs])
        lev = effect_rows("sensor_noise") * np.tile(sig, K)
        std = np.sqrt(rows("noise_std") ** 2 + lev ** 2)
        blocks.append(NoiseBlock(K, n, std, [x.seed for x in sen]))
    if first.delay > 0.0:
        blocks.append(DelayBlock(K, n, rows("delay"), dt))
    return Chain(K, n, blocks)
