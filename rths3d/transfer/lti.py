"""The 1-D LTI transfer system: the platform's identified heave model (or a user's G(s))
after a pure delay, per interface DOF."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..config import Scene
from ..effects.blocks import DelayBlock, LTIBlock
from ..kernels import Block, Chain
from .actuators import (
    default_transfer_function,
    default_transport_delay,
    delay_estimate,
    discretise_tf,
    follow_servo_settings,
)
from .base import register_transfer
from .chain import ChainTransfer

__all__ = ["LTITransfer", "lti_model"]


def lti_model(scene: Scene) -> tuple[list[float], list[float], float]:
    """(num, den, pure delay) of the ``lti`` transfer system of ``scene``: ``transfer.num``/
    ``den`` after ``transfer.delay``, or, when they are empty, the platform's identified heave
    model with its transport delay (:func:`~rths3d.transfer.actuators.default_transport_delay`)
    and the scene's leg-servo lags in place of the identification run's
    (:func:`~rths3d.transfer.actuators.follow_servo_settings`)."""
    tr = scene.transfer
    if tr.num:
        return list(tr.num), list(tr.den), tr.delay
    num, den = default_transfer_function()[:2]
    delay = default_transport_delay(scene.dt, tr.delay)
    return follow_servo_settings(num, den, delay, tr.timeconst, tr.velocity_ff, tr.kp, tr.kv,
                                 scene.dt)


def lti_meta(num: Sequence[float], den: Sequence[float], delay: float, dt: float
             ) -> dict[str, Any]:
    """Transfer metadata of an LTI actuator: its model and the delay it predicts (s)."""
    meta: dict[str, Any] = {"num": list(map(float, num)), "den": list(map(float, den)),
                            "delay": delay}
    try:
        # low-frequency delay of z' behind z: G's group delay, the pure delay, and the
        # half-step lead of holding z_{n+1} over [t_n, t_{n+1}] — which only the dynamic
        # part of G sees: its feedthrough D (the share D/G(0) of the DC gain) reads z_{n+1}
        # at t_{n+1}, without a lead
        d = discretise_tf(num, den, dt)[3]
        dc = float(num[-1] / den[-1]) if den[-1] != 0 else math.inf
        share = d / dc if d else 0.0
        meta["predicted_delay"] = delay_estimate(num, den) + delay - (1.0 - share) * 0.5 * dt
    except (ValueError, ZeroDivisionError):
        meta["predicted_delay"] = math.nan
    return meta


@register_transfer
class LTITransfer(ChainTransfer):
    """A pure delay then G(s) per interface DOF (zero-order hold); model and delay may
    differ test by test (servo lag, feed-forward, actuator delay, a user's G)."""

    kind = "lti"

    @classmethod
    def actuator_chain(cls, scenes: Sequence[Scene], n: int
                       ) -> tuple[Chain, list[dict[str, Any]]]:
        K = len(scenes)
        dt = scenes[0].dt
        # tests of one batch mostly share their actuator: one model per distinct setting
        by_setting: dict[tuple, tuple] = {}
        models = []
        for s in scenes:
            t = s.transfer
            key = (t.num, t.den, t.delay, t.timeconst, t.velocity_ff, t.kp, t.kv)
            if key not in by_setting:
                by_setting[key] = lti_model(s)
            models.append(by_setting[key])
        cache: dict[str, tuple] = {}
        rows, metas = [], []
        for num, den, delay in models:
            key = repr((num, den, delay))
            if key not in cache:
                cache[key] = (discretise_tf(num, den, dt), lti_meta(num, den, delay, dt))
            ss, meta = cache[key]
            rows.extend([ss] * n)
            metas.append(meta)
        delays = np.repeat([m[2] for m in models], n)
        blocks: list[Block] = []
        if delays.max() > 0:
            blocks.append(DelayBlock(K, n, delays, dt))
        blocks.append(LTIBlock(K, n, rows))
        return Chain(K, n, blocks), metas
