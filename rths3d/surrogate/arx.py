"""Linear ARX model of the experimental part: F_n = Θ r_n (one regime).

The class that needs nothing beyond linearity: ``nb`` displacement taps and ``na`` force
lags, fitted by least squares on the one-step equation error (on backward differences of the
taps, see :func:`~rths3d.surrogate.base.lstsq_fit`). A linear mass–spring–damper part driven
through its mount is exactly ARX(4, 2); a part with more internal modes needs 2 force lags
per mode.
"""

from __future__ import annotations

import numpy as np

from .base import NO_SWITCH, LagModel, check_signals, delta_matrix, lag_matrix


class ARX(LagModel):
    """Linear ARX part model (MIMO: every force component on every DOF's lags).

    Parameters: ``nb`` displacement taps (z_n … z_{n−nb+1}), ``na`` force lags.
    Fitted: ``theta_lo_`` = ``theta_hi_`` (d, p), ``switch_`` (none), ``residual_``.
    """

    name = "arx"

    def fit(self, z: np.ndarray, f: np.ndarray, rows: np.ndarray | None = None) -> ARX:
        z, f = check_signals(z, f)
        R, Y, _ = lag_matrix(z, f, self.nb, self.na)
        if rows is not None:
            R, Y = R[rows], Y[rows]
        T = delta_matrix(self.nb, self.na, z.shape[1])
        self.switch_ = NO_SWITCH
        self._fit_regimes(R, Y, None, T)
        return self
