"""The compensator of a transfer system, from its scenes' settings.

A scene names its compensator with ``transfer.compensation`` (any registered in
:mod:`rths3d.compensation`) and sets it with ``transfer.comp_time`` (τ_c, s),
``transfer.poly_order`` and the table ``[transfer.compensator]`` (the compensator's own
parameters, e.g. ``window`` for ``ats``; a sub-table named after a compensator, e.g.
``[transfer.compensator.ats]``, applies only when that one is chosen, so that a sweep may
vary ``transfer.compensation`` with each compensator's own settings; see
docs/compensation.md). ``transfer.compensate`` says where it acts — ``interface`` (one
channel per interface DOF) or ``legs`` (one channel per leg of the Stewart platform,
:mod:`rths3d.transfer.legs`) — and ``transfer.comp_init`` how the adaptive and model-based
ones start: ``predicted`` (default; from each test's predicted delay in its transfer
metadata, :meth:`~rths3d.compensation.BaseCompensator.start_from_delay`, unless the table
sets those initial values) or ``given`` (the compensator's defaults and table).

Tests without compensation and with velocity feed-forward of any τ_c step together (``none``
is ``velocity`` with τ_c = 0, bit for bit); other compensators step together when all their
settings agree.
"""

from __future__ import annotations

from collections.abc import Hashable, Mapping, Sequence
from typing import Any

import numpy as np

from ..compensation import COMPENSATORS, BaseCompensator, build
from ..config import Scene
from ..errors import ConfigError
from .base import RecordSignal

__all__ = ["build_compensator", "coefficient_signal", "compensation_record", "compensator_key",
           "compensator_meta", "compensator_of", "compensator_params"]

_PER_TEST = ("none", "velocity")


def compensator_params(name: str, table: Mapping[str, Any] | Sequence[tuple[str, Any]]
                       ) -> dict[str, Any]:
    """The parameters of compensator ``name`` from a ``[transfer.compensator]`` table: its
    plain keys, then its own sub-table (``[transfer.compensator.<name>]``) over them; the
    other compensators' sub-tables are left out."""
    items = dict(table)
    out = {k: v for k, v in items.items() if k not in COMPENSATORS}
    own = items.get(name)
    if own is not None:
        out.update(dict(own))
    return out


def build_compensator(scenes: Sequence[Scene], n: int,
                      delays: Sequence[float] | None = None) -> BaseCompensator:
    """The compensator of K tests (one scene each) over n channels (interface DOFs or legs).

    ``delays``: each test's predicted delay (s) from command to measurement (its transfer
    metadata ``predicted_delay``); with ``transfer.comp_init = "predicted"`` the adaptive
    and model-based compensators start from it, unless the table sets their initial values
    (:attr:`~rths3d.compensation.BaseCompensator.prior_keys`)."""
    base = scenes[0]
    K, dt = len(scenes), base.dt
    tr = base.transfer
    if tr.compensation in _PER_TEST:
        taus = tuple(s.transfer.comp_time if s.transfer.compensation == "velocity" else 0.0
                     for s in scenes)
        return build("velocity", K, n, dt, {"tau": taus})
    params = compensator_params(tr.compensation, tr.compensator)
    if tr.compensation == "polynomial":
        params = {"tau": tr.comp_time, "order": tr.poly_order, **params}
    comp = build(tr.compensation, K, n, dt, params, field="transfer.compensator")
    if tr.comp_init == "predicted" and delays is not None \
            and not set(params) & set(comp.prior_keys):
        d = np.asarray(delays, dtype=float)
        if d.shape == (K,) and np.all(np.isfinite(d)):
            comp.start_from_delay(np.maximum(d, 0.0))
    return comp


def compensator_of(scenes: Sequence[Scene], n: int,
                   delays: Sequence[float] | None = None) -> BaseCompensator:
    """The interface compensator of K tests over their n interface DOFs (see
    :func:`build_compensator`); a scene asking for per-leg compensation on a transfer system
    without legs is refused."""
    tr = scenes[0].transfer
    if tr.compensate != "interface":
        raise ConfigError("transfer.compensate", tr.compensate, "per-leg compensation needs "
                          f"a transfer system with legs, e.g. transfer.kind = 'stewart' "
                          f"(this test: {tr.kind!r})")
    return build_compensator(scenes, n, delays)


def compensator_key(settings: Mapping[str, Any]) -> Hashable:
    """What of the compensation must be equal for tests stepped together: where it acts, and
    the compensator with its settings (velocity feed-forward and none: any τ_c)."""
    name = settings.get("transfer.compensation", "none")
    where = settings.get("transfer.compensate", "interface")
    if name in _PER_TEST:
        return ("velocity", where)
    table = compensator_params(name, settings.get("transfer.compensator", ()))
    return (name, where, settings.get("transfer.comp_init", "predicted"),
            settings.get("transfer.comp_time", 0.0), settings.get("transfer.poly_order", 2),
            repr(sorted(table.items())))


def compensator_meta(scene: Scene, comp: Any, k: int,
                     channels: Sequence[str]) -> dict[str, Any]:
    """Test k's ``transfer_meta["compensator"]``: name, where it acts, the channels, how it
    started and its initial coefficients per channel (units of the coefficient)."""
    tr = scene.transfer
    name = tr.compensation
    return {"name": name, "compensate": tr.compensate, "channels": list(channels),
            "init": tr.comp_init if name not in _PER_TEST else "given",
            "initial": {} if name == "none" else
            {c: [float(v) for v in a[k]] for c, a in comp.coefficients().items()}}


def coefficient_signal(comp: Any, channels: Sequence[str]) -> RecordSignal | None:
    """The record signal ``comp.<coefficient>.<channel>`` of a compensator's coefficients over
    time (None for one without coefficients). Its source is the compensator's live state
    (:meth:`~rths3d.compensation.BaseCompensator.history`), copied after every step; the
    coefficients are made from the copies when the record is written, so the step itself
    only copies. Fixed schemes (constant coefficients) fill every row with their values."""
    st = comp.history()
    if st is None:
        return None
    K, n, w = st.shape
    if n != len(channels):
        raise ValueError(f"{n} compensator channels for {len(channels)} names")
    src = st.reshape(K, n * w)
    if not np.shares_memory(src, st):  # a programming error: history() must be a live view
        raise ValueError(f"{comp.name}: history() is not reshapeable without a copy")
    names = list(comp.history_coefficients(st[None]))
    labels = tuple(f"{c}.{ch}" for c in names for ch in channels)

    def convert(block: np.ndarray) -> np.ndarray:
        rows = block.shape[0]
        coefs = comp.history_coefficients(block.reshape(rows, K, n, w))
        return np.concatenate([coefs[c] for c in names], axis=-1)

    return RecordSignal("comp", labels, src, convert, src.copy())



def compensation_record(scenes: Sequence[Scene], comp: Any, channels: Sequence[str],
                        metas: Sequence[dict[str, Any]]) -> tuple[RecordSignal, ...]:
    """What a transfer system records of its compensator: each test's
    ``metas[k]["compensator"]`` (:func:`compensator_meta`) and the record signal of the
    coefficients over time (:func:`coefficient_signal`; none when no test of the batch
    compensates: tests without compensation run as velocity feed-forward with τ_c = 0)."""
    for k, m in enumerate(metas):
        m["compensator"] = compensator_meta(scenes[k], comp, k, channels)
    if all(s.transfer.compensation == "none" for s in scenes):
        return ()
    sig = coefficient_signal(comp, channels)
    return (sig,) if sig is not None else ()
