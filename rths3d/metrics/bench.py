"""Bench load of a test: how close it came to the limits of the bench that would run it.

The paper chose its tests "with the conditions that the maximum force of the used FTS was not
exceeded and that the tests stayed within the limits of actuator stroke and maximum
velocity". These peaks let a sweep table answer that question for any bench after the fact
(compare them with its ratings, e.g. :class:`~rths3d.scene.SafetyLimits`):

- ``stroke_peak`` = max |z| of the command (m, or rad for a rotation DOF);
- ``velocity_peak`` = max |ż| of the command (m/s or rad/s), by central differences of the
  recorded command (the loop's own velocity stop uses the numerical substructure's exact
  velocity; at 1 kHz the two agree to the sampling of the fastest oscillation);
- ``force_peak`` = max |F'_m| (N or N·m), the measured interface force the FTS must carry.

They are not accuracy measures: a test can be accurate at any load.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ._signals import as_signal, check_dt, out, peak


def stroke_peak(z: ArrayLike) -> float | np.ndarray:
    """Peak commanded displacement max |z| (m or rad), per DOF for (N, ndof)."""
    x, one = as_signal(z, "z", min_samples=1)
    return out(peak(x), one)


def velocity_peak(z: ArrayLike, dt: float) -> float | np.ndarray:
    """Peak commanded velocity max |ż| (m/s or rad/s) by central differences, step ``dt`` (s)."""
    x, one = as_signal(z, "z")
    dt = check_dt(dt)
    return out(peak(np.gradient(x, dt, axis=0)), one)


def force_peak(f_meas: ArrayLike) -> float | np.ndarray:
    """Peak measured interface force max |F'_m| (N or N·m), per DOF for (N, ndof)."""
    x, one = as_signal(f_meas, "f_meas", min_samples=1)
    return out(peak(x), one)
