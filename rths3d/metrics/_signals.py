"""Input checks and small numeric helpers shared by the measures (not public API).

Every measure accepts one signal as a 1-D array (N,) or several interface DOFs as an (N, ndof)
array and returns a float or an (ndof,) array accordingly. Bad input raises
:class:`rths3d.errors.RecordError` naming the signal, the value and the limit; a measure whose
normaliser is zero (e.g. a zero command) is undefined and returned as NaN, as documented in
each function.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import RecordError

MIN_SAMPLES = 4
"""Fewest samples a measure accepts (a shorter array raises :class:`RecordError`)."""


def as_signal(x: Any, name: str, min_samples: int = MIN_SAMPLES) -> tuple[np.ndarray, bool]:
    """Return ``x`` as a float (N, ndof) array and whether it was 1-D.

    Raises :class:`RecordError` for more than two dimensions, fewer than ``min_samples``
    samples, or any NaN/inf (naming the first bad sample).
    """
    arr = np.asarray(x, dtype=float)
    one_d = arr.ndim == 1
    if one_d:
        arr = arr[:, None]
    elif arr.ndim != 2:
        raise RecordError(f"signal {name!r}: shape {arr.shape} is not (N,) or (N, ndof)")
    n = arr.shape[0]
    if n < min_samples:
        raise RecordError(f"signal {name!r}: {n} samples is too short "
                          f"(at least {min_samples} needed)")
    if arr.shape[1] == 0:
        raise RecordError(f"signal {name!r}: no DOF columns")
    finite = np.isfinite(arr)
    if not finite.all():
        bad = np.argwhere(~finite)[0]
        raise RecordError(f"signal {name!r}: value {arr[bad[0], bad[1]]!r} at sample "
                          f"{int(bad[0])} (column {int(bad[1])}) is not finite")
    return arr, one_d


def as_pair(a: Any, b: Any, names: tuple[str, str],
            min_samples: int = MIN_SAMPLES) -> tuple[np.ndarray, np.ndarray, bool]:
    """Check two signals of identical shape; return both as (N, ndof) and the 1-D flag."""
    x, one_x = as_signal(a, names[0], min_samples)
    y, one_y = as_signal(b, names[1], min_samples)
    if x.shape != y.shape:
        sx = x.shape[0] if one_x else x.shape
        sy = y.shape[0] if one_y else y.shape
        raise RecordError(f"signals {names[0]!r} and {names[1]!r} differ in shape "
                          f"({sx} vs {sy}): they must cover the same samples and DOFs")
    return x, y, one_x and one_y


def out(values: np.ndarray, one_d: bool) -> float | np.ndarray:
    """A float for 1-D input, the (ndof,) array otherwise."""
    return float(values[0]) if one_d else values


def ratio(num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """num / den with NaN wherever den is zero (the measure is undefined there)."""
    num = np.asarray(num, dtype=float)
    den = np.asarray(den, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        r = num / den
    return np.where(den != 0.0, r, np.nan)


def rms(x: np.ndarray) -> np.ndarray:
    """Root mean square along axis 0: RMS(ξ) = √(Σ ξ_i² / N) (paper, after eq. 3)."""
    return np.sqrt(np.einsum("ij,ij->j", x, x) / x.shape[0])


def peak(x: np.ndarray) -> np.ndarray:
    """max |ξ| along axis 0."""
    # reductions along axis 0 of an (N, ndof) array are slow in numpy; a transposed copy is not
    xt = np.ascontiguousarray(x.T)
    return np.maximum(xt.max(axis=1), -xt.min(axis=1))


def col_mean(x: np.ndarray) -> np.ndarray:
    """Mean along axis 0 of (N, ndof) (as ones @ x: fast for this layout)."""
    return np.ones(x.shape[0]) @ x / x.shape[0]


def dominant_dof(z: np.ndarray, f: np.ndarray | None) -> int:
    """The DOF exchanging the most interface power, largest std(z)·std(F) over columns
    (N, n_dof); a static offset (a preload, a held position) exchanges none, so means are
    removed."""
    zc = z - col_mean(z)
    power = np.sqrt(np.einsum("ij,ij->j", zc, zc))
    if f is not None:
        fc = f - col_mean(f)
        power = power * np.sqrt(np.einsum("ij,ij->j", fc, fc))
    return int(np.argmax(power))


def check_dt(dt: float) -> float:
    """A positive, finite sample interval (s)."""
    try:
        v = float(dt)
    except (TypeError, ValueError) as exc:
        raise RecordError(f"dt: {dt!r} is not a number (sample interval in s)") from exc
    if not np.isfinite(v) or v <= 0.0:
        raise RecordError(f"dt: {v!r} s is out of range (must be finite and > 0)")
    return v
