"""Excitation of the numerical substructure: the load history p(t) on the time grid.

``force``: p = a(t)·direction (N); ``support``: p = k_s u(t) + c_s u̇(t) with k_s = K·1,
c_s = C·1 (the suspension motion z_d of paper Fig. 4 drives the numerical mass through
k_NUM and d_NUM); ``ground``: p = −M·1·ü_g(t). Recorded signals (arrays or CSV files with a
``t`` column) are interpolated linearly and are zero outside their time range.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..config import ExcitationConfig
from ..errors import ConfigError


def excitation_signal(exc: ExcitationConfig, t: np.ndarray, h0: float = float("nan")
                      ) -> tuple[np.ndarray, np.ndarray]:
    """The scalar signal a(t) and its time derivative on the grid ``t`` (s).

    ``h0`` (m) is the contact gap, used when a raised cosine is given by its overtravel
    Δz_d (peak = h0 + Δz_d, paper Fig. 4).
    """
    t = np.asarray(t, float)
    s = exc.scale
    if exc.signal == "sine":
        w = 2 * math.pi * exc.frequency
        a = s * exc.amplitude * np.sin(w * t + exc.phase)
        da = s * exc.amplitude * w * np.cos(w * t + exc.phase)
    elif exc.signal == "raised_cosine":
        peak = exc.amplitude if math.isnan(exc.overtravel) else h0 + exc.overtravel
        if math.isnan(peak):
            raise ConfigError("excitation.overtravel", exc.overtravel,
                              "needs an experiment with a contact gap h0")
        w = 2 * math.pi * exc.frequency
        a = s * 0.5 * peak * (1.0 - np.cos(w * t))
        da = s * 0.5 * peak * w * np.sin(w * t)
    else:
        if exc.signal == "file":
            ts, vs = _read_csv(exc.file, exc.column)
        else:
            ts, vs = np.asarray(exc.times, float), np.asarray(exc.values, float)
        if np.any(np.diff(ts) <= 0):
            raise ConfigError("excitation.times", ts.tolist()[:5],
                              "must be strictly increasing")
        a = s * np.interp(t, ts, vs, left=0.0, right=0.0)
        slope = np.diff(vs) / np.diff(ts)
        idx = np.clip(np.searchsorted(ts, t, side="right") - 1, 0, len(slope) - 1)
        da = s * np.where((t >= ts[0]) & (t < ts[-1]), slope[idx], 0.0)
    return a, da


def _read_csv(path: str, column: str) -> tuple[np.ndarray, np.ndarray]:
    import pandas as pd

    p = Path(path)
    if not p.exists():
        raise ConfigError("excitation.file", path, "file not found")
    try:
        frame = pd.read_csv(p)
    except (OSError, ValueError) as exc:  # pandas' ParserError and EmptyDataError included
        raise ConfigError("excitation.file", path,
                          f"unreadable CSV: {str(exc).strip().splitlines()[0]}") from None
    for c in ("t", column):
        if c not in frame.columns:
            raise ConfigError("excitation.column" if c == column else "excitation.file",
                              c, f"column missing in {path} (columns: {list(frame.columns)})")
    out = []
    for c in ("t", column):
        try:
            a = frame[c].to_numpy(float)
        except (TypeError, ValueError):
            raise ConfigError("excitation.file", path,
                              f"column {c!r} must hold numbers only") from None
        if not np.all(np.isfinite(a)):
            row = int(np.flatnonzero(~np.isfinite(a))[0])
            raise ConfigError("excitation.file", path,
                              f"column {c!r} must be finite (empty or NaN/inf at data row "
                              f"{row})")
        out.append(a)
    if out[0].size < 2:
        raise ConfigError("excitation.file", path, "need >= 2 samples")
    return out[0], out[1]


def load_history(exc: ExcitationConfig, M: np.ndarray, C: np.ndarray, K: np.ndarray,
                 t: np.ndarray, h0: float = float("nan"),
                 signal: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Load vector p(t_k) on the grid, shape (len(t), n) in N (or N·m). ``signal``:
    :func:`excitation_signal` of ``exc`` on ``t`` when the caller has it (tests that share
    an excitation)."""
    M, C, K = (np.atleast_2d(np.asarray(a, float)) for a in (M, C, K))
    n = M.shape[0]
    if exc.kind == "none":
        return np.zeros((len(t), n))
    a, da = excitation_signal(exc, t, h0) if signal is None else signal
    ones = np.ones(n)
    if exc.kind == "force":
        d = np.asarray(exc.direction, float) if exc.direction else ones
        return a[:, None] * d[None, :]
    if exc.kind == "support":
        d = np.asarray(exc.direction, float) if exc.direction else ones
        return a[:, None] * (K @ d)[None, :] + da[:, None] * (C @ d)[None, :]
    d = np.asarray(exc.direction, float) if exc.direction else ones
    return -a[:, None] * (M @ d)[None, :]
