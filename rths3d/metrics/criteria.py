"""The RTHS benchmark evaluation criteria J1–J9 (Silva et al., benchmark control problem).

Signals (all displacements in m, on one uniform grid of period ``dt`` s):

* ``x_cmd``  — desired interface displacement, the numerical substructure's output y_n = x_n1
* ``x_meas`` — measured interface displacement x_m (with sensor noise)
* ``x_num``  — numerical-substructure floor displacements, shape (N, n_floors), floor 1 first
* ``x_ref``  — reference (monolithic, exact) floor displacements, (N,) or (N, n_floors)

Criteria, in the order of the benchmark's evaluation code (``F4_evaluation.m``) and of the
paper's Table 3 (``convention="code"``, the default):

====  =========================================================  =====
J1    tracking delay: lag maximising the Pearson correlation of   s
      x_m shifted back against x_cmd (lags 0 … max_lag−1 samples)
J2    std(x_m − x_cmd) / std(x_cmd)                               %
J3    pk(x_m − x_cmd) / pk(x_cmd)                                 %
J4    std(x_m − x_r1) / std(x_r1)                                 %
J5    pk(x_m − x_r1) / pk(x_r1)                                   %
J6    std(x_n2 − x_r2) / std(x_r2)                                %
J7    std(x_n3 − x_r3) / std(x_r3)                                %
J8    pk(x_n2 − x_r2) / pk(x_r2)                                  %
J9    pk(x_n3 − x_r3) / pk(x_r3)                                  %
====  =========================================================  =====

with std the sample standard deviation (mean removed, N − 1) and pk(v) = max|v|. The code
rounds J1 to 0.1 ms and J2–J9 to 0.01 % with MATLAB ``round`` (halves away from zero).

``convention="paper"`` follows the paper's equations 15–20 instead: RMS without mean removal,
J4, J5, J6 the RMS errors of floors 1, 2, 3 and J7, J8, J9 their peak errors, no rounding.
(The paper's Eq. 17 writes y_r where y_n is meant, and its J1 text says "sampling frequency"
where the sampling period is meant; both are read as intended.)

Keys of the returned dict are ``j1`` (in **s**) and ``j2`` … ``j9`` (in **%**); a criterion
whose signals are not given is NaN. :func:`benchmark_row` converts to the benchmark's table
units (``J1`` in ms).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import ConfigError

__all__ = ["CONVENTIONS", "benchmark_row", "j_criteria", "peak_error", "std_error",
           "tracking_delay"]

CONVENTIONS = ("code", "paper")
KEYS = tuple(f"j{i}" for i in range(1, 10))


def _round_half_away(x: float) -> float:
    return math.copysign(math.floor(abs(x) + 0.5), x)


def _vec(name: str, v: object) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    if a.ndim != 1:
        raise ConfigError(name, a.shape, "must be a 1-D series")
    if a.size < 2:
        raise ConfigError(name, a.size, "needs at least 2 samples")
    return a


def tracking_delay(x_cmd: np.ndarray, x_meas: np.ndarray, dt: float, max_lag: int = 50
                   ) -> float:
    """Delay of ``x_meas`` behind ``x_cmd`` (s) by Pearson correlation per lag (J1).

    For lag L = 0 … max_lag − 1 samples, r_L is the Pearson correlation of
    ``x_meas[L:]`` with ``x_cmd[:N−L]``; the delay is ``L*·dt`` for the first L maximising r_L.
    Pearson normalisation matters: a plain cross-correlation is biased toward zero lag. NaN
    when no lag has a correlation (a constant signal has no variance to correlate).
    """
    a, b = _vec("x_cmd", x_cmd), _vec("x_meas", x_meas)
    if a.size != b.size:
        raise ConfigError("x_meas", b.size, f"length must equal x_cmd's ({a.size})")
    if not (dt > 0.0):
        raise ConfigError("dt", dt, "must be > 0 s")
    max_lag = int(max_lag)
    if not (1 <= max_lag < a.size - 1):
        raise ConfigError("max_lag", max_lag, f"must be in [1, {a.size - 2}] samples")
    # Per-lag sums from cumulative sums (the global means are removed first so the
    # one-pass covariance formula does not cancel); one dot product per lag, no copies.
    a = a - a.mean()
    b = b - b.mean()
    N = a.size
    ca, ca2 = np.cumsum(a), np.cumsum(a * a)
    cb, cb2 = np.cumsum(b), np.cumsum(b * b)
    r = np.full(max_lag, -np.inf)
    for L in range(max_lag):
        n = N - L
        sa, saa = ca[n - 1], ca2[n - 1]
        sb = cb[-1] - (cb[L - 1] if L else 0.0)
        sbb = cb2[-1] - (cb2[L - 1] if L else 0.0)
        cov = float(b[L:] @ a[:n]) - sa * sb / n
        var = (saa - sa * sa / n) * (sbb - sb * sb / n)
        if var > 0.0:
            r[L] = cov / math.sqrt(var)
    if not np.isfinite(r).any():
        return math.nan  # argmax of all −inf would report a made-up delay of 0 s
    return int(np.argmax(r)) * float(dt)


def std_error(x: np.ndarray, ref: np.ndarray, rms: bool = False) -> float:
    """``std(x − ref)/std(ref)`` (mean removed, N − 1), or RMS ratio with ``rms=True``; in %."""
    e = np.asarray(x, float) - np.asarray(ref, float)
    r = np.asarray(ref, float)
    if rms:
        den = math.sqrt(float(np.mean(r * r)))
        num = math.sqrt(float(np.mean(e * e)))
    else:
        den, num = float(np.std(r, ddof=1)), float(np.std(e, ddof=1))
    return 100.0 * num / den if den > 0.0 else math.nan


def peak_error(x: np.ndarray, ref: np.ndarray) -> float:
    """``max|x − ref| / max|ref|`` in %."""
    r = np.asarray(ref, float)
    den = float(np.max(np.abs(r)))
    e = float(np.max(np.abs(np.asarray(x, float) - r)))
    return 100.0 * e / den if den > 0.0 else math.nan


def j_criteria(x_cmd: np.ndarray, x_meas: np.ndarray, x_num: np.ndarray | None = None,
               x_ref: np.ndarray | None = None, *, dt: float, convention: str = "code",
               max_lag: int = 50, rounded: bool | None = None) -> dict[str, float]:
    """The benchmark criteria J1–J9 (see the module docstring for formulas and units).

    Parameters
    ----------
    x_cmd, x_meas:
        Desired and measured interface displacement (m), length N.
    x_num:
        Numerical floor displacements (N, n_floors) with the interface floor first; needed
        for J6–J9 (floors 2 and 3).
    x_ref:
        Reference displacements, (N,) for the interface floor only (J4, J5) or
        (N, n_floors ≥ 3) for all of J4–J9.
    dt:
        Sample period (s).
    convention:
        ``"code"`` (F4 order, std, rounding — the published table) or ``"paper"``
        (equations' order, RMS, no rounding).
    max_lag:
        Number of lags (samples) searched for J1; 50 in the benchmark code.
    rounded:
        Override the convention's rounding.

    Returns
    -------
    dict with ``j1`` in s and ``j2`` … ``j9`` in %, NaN where inputs are missing.
    """
    if convention not in CONVENTIONS:
        raise ConfigError("convention", convention, f"must be one of {CONVENTIONS}")
    xc, xm = _vec("x_cmd", x_cmd), _vec("x_meas", x_meas)
    N = xc.size
    if xm.size != N:
        raise ConfigError("x_meas", xm.size, f"length must equal x_cmd's ({N})")
    paper = convention == "paper"
    rnd = (not paper) if rounded is None else bool(rounded)
    out = dict.fromkeys(KEYS, math.nan)
    out["j1"] = tracking_delay(xc, xm, dt, max_lag)
    out["j2"] = std_error(xm, xc, rms=paper)
    out["j3"] = peak_error(xm, xc)

    ref = None if x_ref is None else np.asarray(x_ref, dtype=float)
    num = None if x_num is None else np.asarray(x_num, dtype=float)
    for name, arr in (("x_ref", ref), ("x_num", num)):
        if arr is not None and (arr.shape[0] != N or arr.ndim > 2):
            raise ConfigError(name, arr.shape, f"must have {N} rows (samples)")
    if ref is not None:
        r = ref if ref.ndim == 2 else ref[:, None]
        rms1, pk1 = std_error(xm, r[:, 0], rms=paper), peak_error(xm, r[:, 0])
        rms_f, pk_f = {1: rms1}, {1: pk1}
        if num is not None and num.ndim == 2 and r.shape[1] >= 3 and num.shape[1] >= 3:
            for f in (2, 3):
                rms_f[f] = std_error(num[:, f - 1], r[:, f - 1], rms=paper)
                pk_f[f] = peak_error(num[:, f - 1], r[:, f - 1])
        if paper:
            order = {"j4": rms_f.get(1), "j5": rms_f.get(2), "j6": rms_f.get(3),
                     "j7": pk_f.get(1), "j8": pk_f.get(2), "j9": pk_f.get(3)}
        else:
            order = {"j4": rms_f.get(1), "j5": pk_f.get(1), "j6": rms_f.get(2),
                     "j7": rms_f.get(3), "j8": pk_f.get(2), "j9": pk_f.get(3)}
        for k, v in order.items():
            if v is not None:
                out[k] = v
    if rnd:
        if not math.isnan(out["j1"]):
            out["j1"] = _round_half_away(10000.0 * out["j1"]) / 10.0 / 1000.0
        for k in KEYS[1:]:
            if not math.isnan(out[k]):
                out[k] = _round_half_away(100.0 * out[k]) / 100.0
    return out


def benchmark_row(j: dict[str, float]) -> dict[str, float]:
    """The benchmark's table units: ``J1`` in ms (0.1 ms resolution kept), ``J2``…``J9`` in %."""
    row = {"J1": round(1000.0 * j["j1"], 6)}
    for i in range(2, 10):
        row[f"J{i}"] = j[f"j{i}"]
    return row
