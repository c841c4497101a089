"""The maRTHS evaluation criteria J1–J10 (24 numbers), as the benchmark's ``S5_Evaluation.m``
computes them (Condori Uribe et al. 2023).

Signals of one run, all of length N on the grid t_k = k/fs:

====  ====================================================================  =====
J1    finddelay(xa_t, xa_m)/fs for actuators 1, 2                            ms
J2    std(xa_m − xa_t)/std(xa_t) for actuators 1, 2                          %
J3    pk(xa_m − xa_t)/pk(xa_t) for actuators 1, 2                            %
J4    identical to J1 (the code copies it)                                   ms
J5    std(x̂ − x_num)/std(x_num) for x, θ                                     %
J6    pk(x̂ − x_num)/pk(x_num) for x, θ                                       %
J7    std(x̂ − x_ref)/std(x_ref) for x, θ                                     %
J8    std(num − ref)/std(ref) for x 2nd story, θ 2nd, x 3rd, θ 3rd           %
J9    pk(x̂ − x_ref)/pk(x_ref) for x, θ                                       %
J10   pk(num − ref)/pk(ref) for the four J8 signals                          %
====  ====================================================================  =====

std is the sample standard deviation (N − 1) and pk(v) = max|v| (the single-actuator
benchmark's :func:`~rths3d.metrics.criteria.std_error`, :func:`~rths3d.metrics.criteria.
peak_error`); finddelay is MATLAB's (:func:`find_delay`). The benchmark reports
``round(J, 1)`` (halves away from zero), of one run or of the mean over perturbed trials
(:func:`report`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from ...metrics.criteria import peak_error, std_error

__all__ = ["J_COUNTS", "J_LABELS", "find_delay", "flat_keys", "marths_criteria", "report"]

J_COUNTS = {"J1": 2, "J2": 2, "J3": 2, "J4": 2, "J5": 2, "J6": 2, "J7": 2, "J8": 4, "J9": 2,
            "J10": 4}
J_LABELS = {
    "J1": ("act1", "act2"), "J2": ("act1", "act2"), "J3": ("act1", "act2"),
    "J4": ("act1", "act2"), "J5": ("x", "theta"), "J6": ("x", "theta"), "J7": ("x", "theta"),
    "J8": ("x2", "theta2", "x3", "theta3"), "J9": ("x", "theta"),
    "J10": ("x2", "theta2", "x3", "theta3"),
}
UNITS = {"J1": "ms", "J4": "ms"}


def flat_keys() -> list[str]:
    """The 24 numbers' names in the code's order, e.g. ``J1.act1`` … ``J10.theta3``."""
    return [f"{j}.{lab}" for j, labs in J_LABELS.items() for lab in labs]


def find_delay(x: np.ndarray, y: np.ndarray) -> int:
    """MATLAB ``finddelay(x, y)``: the lag (samples) maximising |Σ x[n] y[n + L]| over
    L = −(N−1) … N−1 (the normalisation is one constant); positive when y lags x; among
    equal maxima the smallest |L| (then the positive one)."""
    import scipy.signal

    a = np.asarray(x, dtype=float)
    b = np.asarray(y, dtype=float)
    c = np.abs(scipy.signal.correlate(b, a, mode="full", method="fft"))
    lags = scipy.signal.correlation_lags(b.size, a.size, mode="full")
    top = c.max()
    if not top > 0.0:
        return 0
    cand = lags[c >= top * (1.0 - 1e-12)]
    best = cand[np.argmin(np.abs(cand) * 2 - (cand > 0))]
    return int(best)


def marths_criteria(xa_t: np.ndarray, xa_m: np.ndarray, x_hat: np.ndarray, num: np.ndarray,
                    ref: np.ndarray, fs: float) -> dict[str, list[float]]:
    """J1–J10 of one run (unrounded). ``xa_t``, ``xa_m`` (N, 2) target and measured actuator
    displacements (mm); ``x_hat`` (N, 2) [x̂ (mm), θ̂ (rad)] from the measurements; ``num``,
    ``ref`` (N, ≥ 6) numerical and reference [x (mm), θ (rad), x 2nd (m), θ 2nd (rad), x 3rd
    (m), θ 3rd (rad)]; ``fs`` (Hz). Returns ``{"J1": [a1, a2], …, "J10": [4 values]}``."""
    j1 = [1000.0 * find_delay(xa_t[:, i], xa_m[:, i]) / fs for i in range(2)]
    out: dict[str, list[float]] = {
        "J1": j1,
        "J2": [std_error(xa_m[:, i], xa_t[:, i]) for i in range(2)],
        "J3": [peak_error(xa_m[:, i], xa_t[:, i]) for i in range(2)],
        "J4": list(j1),
        "J5": [std_error(x_hat[:, i], num[:, i]) for i in range(2)],
        "J6": [peak_error(x_hat[:, i], num[:, i]) for i in range(2)],
        "J7": [std_error(x_hat[:, i], ref[:, i]) for i in range(2)],
        "J8": [std_error(num[:, i], ref[:, i]) for i in range(2, 6)],
        "J9": [peak_error(x_hat[:, i], ref[:, i]) for i in range(2)],
        "J10": [peak_error(num[:, i], ref[:, i]) for i in range(2, 6)],
    }
    return out


def _round1(v: float) -> float:
    if not math.isfinite(v):
        return v
    return math.copysign(math.floor(abs(v) * 10.0 + 0.5), v) / 10.0


def report(runs: Sequence[dict[str, list[float]]]) -> dict[str, list[float]]:
    """The benchmark's reported J: ``round(J, 1)`` of one run, or of the mean over several
    (the perturbed trials; the nominal one is not passed)."""
    if not runs:
        raise ValueError("no runs to report")
    return {k: [_round1(float(np.mean([r[k][i] for r in runs]))) for i in range(n)]
            for k, n in J_COUNTS.items()}
