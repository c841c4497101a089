"""Plot data for the live panels: the SSP, the time histories and the compensator's
coefficients, as plain array functions.

The panels show a sliding window of the stream ending at the current sample. uPlot draws
series against a sorted x: the time histories use t; the synchronization subspace plot (SSP,
z' against z) is drawn as a point cloud with its samples sorted by z, so each dot is still one
(z, z') pair and the loop opens into an ellipse when z' lags z (and collapses onto the unit-
slope line for perfect tracking).
"""

from __future__ import annotations

import math

import numpy as np

from .stream import Channels

MAX_POINTS = 400
"""Most points sent per series and update (keeps each update small at 30 per second)."""


def window(t: np.ndarray, i_now: int, span: float) -> tuple[int, int]:
    """Rows ``[i0, i1)`` of the ``span`` seconds of samples ending at row ``i_now``."""
    i1 = int(i_now) + 1
    i0 = int(np.searchsorted(t[:i1], t[i_now] - span, side="left"))
    return i0, i1


def stride(i0: int, i1: int, max_points: int = MAX_POINTS) -> slice:
    """Slice of rows ``[i0, i1)`` decimated to at most ``max_points`` rows, newest kept."""
    step = max(1, -(-(i1 - i0) // max_points))
    start = i1 - 1 - ((i1 - 1 - i0) // step) * step
    return slice(start, i1, step)


def _col(data: np.ndarray, rows: slice, col: int) -> np.ndarray:
    if col < 0:
        return np.full(len(range(*rows.indices(data.shape[0]))), np.nan)
    return np.ascontiguousarray(data[rows, col])


def history_data(data: np.ndarray, ch: Channels, rows: slice
                 ) -> tuple[tuple[np.ndarray, ...], tuple[np.ndarray, ...]]:
    """Displacement and force histories over ``rows``.

    Returns ``((t, z, z', z^r[, z'_model]), (t, F'_m[, F'_m,model]))`` (s, m or rad, N or N·m);
    absent signals are NaN (uPlot leaves a gap).
    """
    t = _col(data, rows, ch.t)
    disp = [t, _col(data, rows, ch.z_cmd), _col(data, rows, ch.z_meas), _col(data, rows, ch.z_ref)]
    force = [t, _col(data, rows, ch.f_meas)]
    if ch.has_model:
        disp.append(_col(data, rows, ch.model_z_meas))
        force.append(_col(data, rows, ch.model_f_meas))
    return tuple(disp), tuple(force)


def ssp_data(data: np.ndarray, ch: Channels, rows: slice) -> tuple[np.ndarray, ...]:
    """SSP point cloud over ``rows``: ``(z, z', z[, z'_model])`` sorted by z.

    The third series is the unit-slope line z' = z (perfect tracking).
    """
    z = _col(data, rows, ch.z_cmd)
    zm = _col(data, rows, ch.z_meas)
    order = np.argsort(z, kind="stable")
    out = [z[order], zm[order], z[order]]
    if ch.has_model:
        out.append(_col(data, rows, ch.model_z_meas)[order])
    return tuple(out)


COEF_UNITS = {"a0": "-", "a1": "s", "a2": "s²", "tau": "s", "gain": "-", "lead": "s",
              "u_fb": "m or rad"}
"""Units of the compensators' coefficients (docs/compensation.md); RLS taps θ_i are -."""


def coefficient_unit(coef: str) -> str:
    """The unit of a compensator coefficient (``theta<i>``: -, unknown: "")."""
    return COEF_UNITS.get(coef, "-" if coef.startswith("theta") else "")


def coefficient_data(data: np.ndarray, t_col: int, cols: list[tuple[str, int]], rows: slice
                     ) -> tuple[np.ndarray, ...]:
    """One coefficient over ``rows`` for each channel: ``(t, c_channel0, c_channel1, …)``."""
    return (_col(data, rows, t_col), *(_col(data, rows, c) for _, c in cols))


def leg_columns(index: dict[str, int]) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """Columns of a diagnosis replay's legs: measured ``leg_force.<i>``, ``model.leg_force.<i>``
    and the residual ``residual.leg_force.<i>`` (noise units), six each; None without a model.
    """
    cols = [[index.get(f"{p}leg_force.{i}", -1) for i in range(6)]
            for p in ("", "model.", "residual.")]
    if min(cols[0]) < 0 or min(cols[1]) < 0:
        return None
    return tuple(np.array(c) for c in cols)  # type: ignore[return-value]


def leg_data(data: np.ndarray, t_col: int, meas: int, model: int, rows: slice
             ) -> tuple[np.ndarray, ...]:
    """One leg's force, measured and model, over ``rows``: ``(t, F_meas, F_model)`` (s, N)."""
    return (_col(data, rows, t_col), _col(data, rows, meas), _col(data, rows, model))


def leg_residual_data(data: np.ndarray, t_col: int, res: np.ndarray, rows: slice
                      ) -> tuple[np.ndarray, ...]:
    """The six legs' force residuals (noise units) over ``rows``: ``(t, r_0, …, r_5)``."""
    return (_col(data, rows, t_col), *(_col(data, rows, int(c)) for c in res))


def fidelity_cols(index: dict[str, int], dof: str) -> tuple[int, int, int] | None:
    """Columns of the estimated error's running RMS of ``dof`` in a record with the surrogate
    reference's columns (``rths3d metrics --save-estimate``): ``e_hat_rms``, ``e_hat_rms_lo``
    and ``e_hat_rms_hi`` (−1 for a missing band edge); None without them."""
    c = index.get(f"e_hat_rms.{dof}", -1)
    if c < 0:
        return None
    return c, index.get(f"e_hat_rms_lo.{dof}", -1), index.get(f"e_hat_rms_hi.{dof}", -1)


def fidelity_data(data: np.ndarray, t_col: int, cols: tuple[int, int, int], rows: slice,
                  limit: float = math.nan) -> tuple[np.ndarray, ...]:
    """``(t, ê_RMS, band low, band high, limit)`` over ``rows`` (s, m or rad): the estimated
    error's running RMS, the members' spread as a band, and the monitor's limit as a line
    (NaN: none)."""
    t = _col(data, rows, t_col)
    c, lo, hi = cols
    mid = _col(data, rows, c)
    return (t, mid, _col(data, rows, lo) if lo >= 0 else mid,
            _col(data, rows, hi) if hi >= 0 else mid, np.full(t.shape, limit))
