"""Ground-motion records: acceleration time histories read from CSV, linearly interpolated.

A record is two columns, time (s) and ground acceleration ẍ_g (m/s²), with a header line
(e.g. ``t_s,accel_mps2``). Between samples the acceleration is linearly interpolated (as a
Simulink From File block with linear interpolation does); outside the record it is zero.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import ConfigError, RecordError

__all__ = ["GroundMotion", "load_ground_motion"]


@dataclass(frozen=True, eq=False)
class GroundMotion:
    """A ground-acceleration record ẍ_g(t) scaled by ``scale``.

    Attributes
    ----------
    t:
        Sample times in s, strictly increasing.
    accel:
        Unscaled acceleration in m/s².
    scale:
        Intensity factor applied to every value (e.g. 0.4 in the RTHS benchmark).
    name:
        Label of the record.
    """

    t: np.ndarray
    accel: np.ndarray
    scale: float = 1.0
    name: str = ""

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=float)
        a = np.asarray(self.accel, dtype=float)
        if t.ndim != 1 or a.shape != t.shape or t.size < 2:
            raise ConfigError("ground_motion", (t.shape, a.shape),
                              "t and accel must be 1-D of equal length ≥ 2")
        if not np.all(np.diff(t) > 0.0):
            raise ConfigError("ground_motion.t", self.name, "times must be strictly increasing")
        if not (np.all(np.isfinite(a)) and np.isfinite(self.scale)):
            raise ConfigError("ground_motion.accel", self.name, "values must be finite")
        object.__setattr__(self, "t", t)
        object.__setattr__(self, "accel", a)

    @property
    def t_end(self) -> float:
        """Last time stamp (s)."""
        return float(self.t[-1])

    @property
    def pga(self) -> float:
        """Peak ground acceleration of the scaled record (m/s²)."""
        return float(np.max(np.abs(self.accel))) * abs(self.scale)

    def __call__(self, t: float | np.ndarray) -> np.ndarray:
        """Scaled ẍ_g at times ``t`` (s), linear interpolation, zero outside the record."""
        return self.scale * np.interp(t, self.t, self.accel, left=0.0, right=0.0)

    def held(self, t: float | np.ndarray) -> np.ndarray:
        """Scaled ẍ_g at ``t`` with the record held between its samples (zero-order hold)."""
        tt = np.asarray(t, dtype=float)
        i = np.searchsorted(self.t, tt, side="right") - 1
        inside = (i >= 0) & (tt <= self.t[-1])
        return self.scale * np.where(inside, self.accel[np.clip(i, 0, self.t.size - 1)], 0.0)

    def sample(self, dt: float, n: int | None = None, offset: float = 0.0) -> np.ndarray:
        """Scaled ẍ_g on the grid ``offset + k·dt``, k = 0 … n−1 (n defaults to the record)."""
        if n is None:
            n = int(np.floor(self.t_end / dt + 1e-9)) + 1
        return self(offset + dt * np.arange(int(n)))

    def scaled(self, scale: float) -> GroundMotion:
        """The same record with another intensity factor."""
        return GroundMotion(self.t, self.accel, float(scale), self.name)


def load_ground_motion(path: str | Path, scale: float = 1.0, name: str | None = None
                       ) -> GroundMotion:
    """Read a two-column CSV (time in s, acceleration in m/s², one header line)."""
    p = Path(path)
    if not p.is_file():
        raise RecordError(f"ground motion file not found: {p}")
    try:
        data = np.loadtxt(p, delimiter=",", skiprows=1, ndmin=2)
    except ValueError as exc:
        raise RecordError(f"{p}: not a two-column numeric CSV ({exc})") from exc
    if data.shape[1] < 2:
        raise RecordError(f"{p}: expected columns time (s), acceleration (m/s²)")
    label = name if name is not None else p.stem.removeprefix("ground_motion_")
    return GroundMotion(data[:, 0], data[:, 1], float(scale), label)
