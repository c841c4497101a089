"""Running accuracy measures over the view's window, computed with :mod:`rths3d.metrics`.

The view shows the relative RMS tracking error e_rel,track (paper eq. 1), the FEI delay d
(eq. 8) and the energy measure HSEM^S (eq. 11) of the samples in its window, recomputed at
most twice a second in the view's thread (never in the loop). A measure that cannot be
computed on the window (too short, zero signal, no k_EXP in the metadata) shows "—".
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from ..errors import RthsError
from ..metrics import e_rel_track, fei, hsem
from .stream import Channels

MIN_WINDOW = 32
"""Fewest samples a running measure is computed on."""


class RunningMeasures:
    """Tracking error, FEI delay and HSEM^S of a window of samples.

    Parameters
    ----------
    meta:
        Stream metadata; ``meta['experiment']['k_exp']`` (N/m, scalar or matrix over
        ``meta['dofs']``) gives E_strain for HSEM^S (the diagonal entry of the DOF shown).
    """

    def __init__(self, meta: dict[str, Any]):
        self.dofs = list(meta.get("dofs") or [])
        exp = meta.get("experiment") or {}
        k = exp.get("k_exp") if isinstance(exp, dict) else None
        try:
            kk = None if k is None else np.atleast_2d(np.asarray(k, dtype=float))
        except (TypeError, ValueError):
            kk = None
        self.k_exp = None if kk is None or not np.all(np.isfinite(kk)) else kk

    def compute(self, data: np.ndarray, ch: Channels, i0: int, i1: int) -> dict[str, float]:
        """Measures of rows ``[i0, i1)``: ``e_rel_track`` (–), ``fei_delay`` d (s),
        ``hsem_s`` (–); NaN where not computable."""
        out = {"e_rel_track": math.nan, "fei_delay": math.nan, "hsem_s": math.nan}
        if i1 - i0 < MIN_WINDOW or ch.z_cmd < 0 or ch.z_meas < 0:
            return out
        z = data[i0:i1, ch.z_cmd]
        zm = data[i0:i1, ch.z_meas]
        dt = float(data[i0 + 1, ch.t] - data[i0, ch.t])
        out["e_rel_track"] = _safe(lambda: float(e_rel_track(z, zm)))
        out["fei_delay"] = _safe(lambda: float(fei(z, zm, dt).d))
        k = self._stiffness(ch.dof)
        if ch.f_meas >= 0 and k is not None:
            f = data[i0:i1, ch.f_meas]
            kz = k
            out["hsem_s"] = _safe(lambda: float(hsem(f, z, zm, kz)))
        return out

    def _stiffness(self, dof: str) -> float | None:
        """k_EXP of interface DOF ``dof`` (diagonal entry; N/m or N·m/rad), if known."""
        k = self.k_exp
        if k is None:
            return None
        if k.size == 1:
            return float(k.reshape(-1)[0])
        if dof in self.dofs and len(self.dofs) == k.shape[0]:
            j = self.dofs.index(dof)
            return float(k[j, j])
        return None

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


def _safe(fn: Any) -> float:
    """The measure's value, or NaN when the window does not allow it."""
    try:
        return fn()
    except (RthsError, ValueError, ZeroDivisionError, FloatingPointError):
        return math.nan
