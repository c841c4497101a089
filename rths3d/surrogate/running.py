"""Fidelity at every time step: the running RMS of an error signal.

The per-step fidelity of a test is the running RMS over a window of T_w = 0.25 s of the
estimated reference error ê(t) = z'(t) − ẑ^r(t),

    ê_RMS(t_n) = sqrt( (1/W) Σ_{i=n−W+1}^{n} ê_i² ),   W = round(T_w / ΔT),

over the samples available at the start (i ≥ 0, divided by their number). The whole-record
e_rel,ref is RMS(ê)/RMS(ẑ^r) over all samples.

:class:`RunningRMS` computes it one sample at a time with a ring buffer and a running sum
(O(d) per sample, no allocation), as an online monitor inside a 1 kHz loop would;
:func:`running_rms` is the same for a whole signal at once.
"""

from __future__ import annotations

import numpy as np

from . import _kernels

WINDOW = 0.25
"""Default window T_w of the running RMS (s)."""


def window_samples(window: float, dt: float) -> int:
    """W = round(T_w / ΔT), at least 1."""
    if not (window > 0 and dt > 0):
        from ..errors import ConfigError

        raise ConfigError("window", window, f"s; must be > 0 (ΔT = {dt} s)")
    return max(1, int(round(window / dt)))


def running_rms(e: np.ndarray, dt: float, window: float = WINDOW) -> np.ndarray:
    """Running RMS of ``e`` (N,) or (N, d) over ``window`` seconds (see module docstring)."""
    x = np.asarray(e, dtype=float)
    one = x.ndim == 1
    x2 = (x[:, None] if one else x) ** 2
    W = window_samples(window, dt)
    c = np.cumsum(x2, axis=0)
    s = c.copy()
    s[W:] -= c[:-W]
    cnt = np.minimum(np.arange(1, len(x2) + 1), W)[:, None]
    r = np.sqrt(np.maximum(s, 0.0) / cnt)
    return r[:, 0] if one else r


class RunningRMS:
    """Online running RMS over the last W samples, one sample per :meth:`update`.

    ``RunningRMS(n_dof, window_samples)``; ``update(e)`` takes the newest error sample (an
    (n_dof,) float array, or a float for one DOF; e.g. z'_n − ẑ^r_n in m/rad) and returns the
    running RMS as a read-only (n_dof,) view that stays valid (updated in place). No
    allocation per sample: a compiled kernel over a ring buffer of squares and a running sum,
    re-summed exactly once per window so that round-off cannot drift. ``reset()`` starts
    again. ``value`` is the latest running RMS.
    """

    __slots__ = ("_buf", "_sum", "_out", "_e", "_state", "W", "value")

    def __init__(self, n_dof: int, window_samples: int):
        self.W = int(window_samples)
        if self.W < 1 or int(n_dof) < 1:
            raise ValueError("RunningRMS needs n_dof >= 1 and window_samples >= 1")
        self._buf = np.zeros((self.W, int(n_dof)))
        self._sum = np.zeros(int(n_dof))
        self._out = np.zeros(int(n_dof))
        self._e = np.zeros(int(n_dof))
        self._state = np.zeros(2, dtype=np.int64)
        self.value = self._out.view()
        self.value.flags.writeable = False

    def reset(self) -> None:
        self._buf[:] = 0.0
        self._sum[:] = 0.0
        self._out[:] = 0.0
        self._state[:] = 0

    def update(self, e) -> np.ndarray:
        """Add one sample; return the running RMS (n_dof,) view."""
        if isinstance(e, np.ndarray) and e.dtype == np.float64 and e.shape == self._e.shape:
            x = e
        else:
            self._e[:] = e
            x = self._e
        _kernels.rms_update(self._buf, self._sum, self._out, x, self._state)
        return self.value
