"""Running accuracy measures over the view's window, from :mod:`rths3d.metrics`.

The view shows the relative RMS tracking error e_rel,track (paper eq. 1), the FEI delay d
(eq. 8) and the energy measure HSEM^S (eq. 11) of the samples in its window, recomputed at
most twice a second in the view's thread. The measures themselves live in rths3d.metrics;
this module only finds them and formats their values. A measure the metrics package does not
(yet) provide, or that cannot be computed on the window (too short, zero signal), shows "—".
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from .stream import Channels

MIN_WINDOW = 32
"""Fewest samples a running measure is computed on."""


def _find(*candidates: str) -> Callable[..., Any] | None:
    """First importable ``module:function`` among ``candidates`` (None if none is)."""
    for cand in candidates:
        mod, _, name = cand.partition(":")
        try:
            fn = getattr(importlib.import_module(mod), name, None)
        except ImportError:
            fn = None
        if callable(fn):
            return fn
    return None


class RunningMeasures:
    """Tracking error, FEI delay and HSEM^S of a window of samples.

    Parameters
    ----------
    meta:
        Stream metadata; ``meta['experiment']['k_exp']`` (N/m) gives E_strain for HSEM^S.
    """

    def __init__(self, meta: dict[str, Any]):
        self.meta = meta
        self._e_rel = _find("rths3d.metrics:e_rel_track", "rths3d.metrics.tracking:e_rel_track")
        self._fei = _find("rths3d.metrics:fei", "rths3d.metrics.frequency:fei",
                          "rths3d.metrics.fei:fei")
        self._hsem = _find("rths3d.metrics:hsem", "rths3d.metrics.energy:hsem")
        exp = meta.get("experiment") or {}
        k = exp.get("k_exp") if isinstance(exp, dict) else None
        self.k_exp = None if k is None else np.atleast_2d(np.asarray(k, dtype=float))

    def compute(self, data: np.ndarray, ch: Channels, i0: int, i1: int) -> dict[str, float]:
        """Measures of rows ``[i0, i1)``: ``e_rel_track`` (–), ``fei_delay`` (s), ``hsem_s``
        (–); NaN where not computable."""
        out = {"e_rel_track": math.nan, "fei_delay": math.nan, "hsem_s": math.nan}
        if i1 - i0 < MIN_WINDOW or ch.z_cmd < 0 or ch.z_meas < 0:
            return out
        z = data[i0:i1, ch.z_cmd]
        zm = data[i0:i1, ch.z_meas]
        t = data[i0:i1, ch.t]
        dt = float(t[1] - t[0])
        out["e_rel_track"] = self._call(self._e_rel, z, zm)
        fei = self._call_raw(self._fei, z, zm, dt)
        out["fei_delay"] = _delay_of(fei)
        if ch.f_meas >= 0 and self._hsem is not None:
            f = data[i0:i1, ch.f_meas]
            kw = {}
            if self.k_exp is not None:
                kw["k_exp"] = float(self.k_exp[-1, -1])
            out["hsem_s"] = self._call(self._hsem, f, z, zm, **kw)
        return out

    @staticmethod
    def _call_raw(fn: Callable[..., Any] | None, *args: Any, **kw: Any) -> Any:
        if fn is None:
            return None
        try:
            return fn(*args, **kw)
        except Exception:  # a window the measure cannot handle (e.g. zero signal)
            return None

    def _call(self, fn: Callable[..., Any] | None, *args: Any, **kw: Any) -> float:
        v = self._call_raw(fn, *args, **kw)
        try:
            return float(getattr(v, "hsem_s", v))
        except (TypeError, ValueError):
            return math.nan

    @staticmethod
    def markdown(values: dict[str, float] | None) -> str:
        """The measures as a small markdown table."""
        v = values or {}

        def fmt(x: float | None, scale: float, unit: str) -> str:
            return "—" if x is None or not math.isfinite(x) else f"{x * scale:.3g} {unit}"

        return ("| measure (window) | value |\n|---|---|\n"
                f"| tracking error e_rel,track (eq. 1) | {fmt(v.get('e_rel_track'), 100, '%')} |\n"
                f"| FEI delay d (eq. 8) | {fmt(v.get('fei_delay'), 1e3, 'ms')} |\n"
                f"| HSEM^S (eq. 11) | {fmt(v.get('hsem_s'), 1, '')} |")


def _delay_of(fei: Any) -> float:
    """The delay d (s) out of whatever the FEI function returned."""
    if fei is None:
        return math.nan
    for name in ("delay", "d"):
        if hasattr(fei, name):
            try:
                return float(getattr(fei, name))
            except (TypeError, ValueError):
                return math.nan
    if isinstance(fei, dict):
        for name in ("delay", "d"):
            if name in fei:
                return float(fei[name])
    return math.nan
