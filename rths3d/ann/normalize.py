"""Min–max normalisation to [−1, 1] (MATLAB ``mapminmax``), and the ranges of the fit data.

``y = 2 (x − x_min) / (x_max − x_min) − 1`` per column. A constant column (x_max = x_min)
maps to 0, as mapminmax does. The stored ranges are those of all the data given to fit
(training, validation and test samples, as mapminmax on the whole data): inputs outside them
make the network extrapolate, which the estimator warns about.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError


@dataclass(frozen=True)
class MinMax:
    """Per-column ranges ``lo``, ``hi`` (units of the data) for the map to [−1, 1]."""

    lo: np.ndarray
    hi: np.ndarray

    @classmethod
    def fit(cls, x: np.ndarray, field: str = "X") -> MinMax:
        """Ranges of the columns of ``x`` (N, d); raises ConfigError on NaN/inf."""
        x = np.asarray(x, dtype=float)
        if x.ndim == 1:
            x = x[:, None]
        if x.shape[0] < 1:
            raise ConfigError(field, x.shape, "needs at least one sample")
        bad = ~np.isfinite(x)
        if bad.any():
            r, c = np.argwhere(bad)[0]
            raise ConfigError(f"{field}[{r}, {c}]", float(x[r, c]), "must be finite")
        return cls(x.min(axis=0), x.max(axis=0))

    @property
    def span(self) -> np.ndarray:
        s = self.hi - self.lo
        return np.where(s > 0, s, 1.0)

    def transform(self, x: np.ndarray) -> np.ndarray:
        """Map data to the normalised scale (constant columns → 0)."""
        x = np.asarray(x, dtype=float)
        z = 2.0 * (x - self.lo) / self.span - 1.0
        return np.where(self.hi > self.lo, z, 0.0)

    def inverse(self, z: np.ndarray) -> np.ndarray:
        """Map normalised values back to data units (a constant column gives its value)."""
        x = (np.asarray(z, dtype=float) + 1.0) * 0.5 * self.span + self.lo
        # transform sends a constant column to 0, which the span-1 map would not undo
        return np.where(self.hi > self.lo, x, self.lo)

    def outside(self, x: np.ndarray, rtol: float = 1e-9) -> np.ndarray:
        """Boolean (N, d): where ``x`` lies outside the stored ranges (extrapolation)."""
        x = np.asarray(x, dtype=float)
        tol = rtol * np.maximum(np.abs(self.hi - self.lo), np.abs(self.hi) + np.abs(self.lo))
        return (x < self.lo - tol) | (x > self.hi + tol)

    def to_dict(self) -> dict:
        return {"lo": self.lo.tolist(), "hi": self.hi.tolist()}

    @classmethod
    def from_dict(cls, d: dict) -> MinMax:
        return cls(np.asarray(d["lo"], dtype=float), np.asarray(d["hi"], dtype=float))


def split_indices(n: int, fractions: tuple[float, float, float] = (0.70, 0.15, 0.15),
                  seed: int = 0) -> dict[str, np.ndarray]:
    """Random train/validation/test split (the paper's 70 %/15 %/15 %), as stored indices.

    Deterministic per ``seed``; the indices are kept with the model so that every training
    sees the same sets. Each set gets at least one sample when ``n >= 3``.
    """
    if n < 3:
        raise ConfigError("n_samples", n, "need at least 3 samples for train/val/test")
    f = np.asarray(fractions, dtype=float)
    if f.shape != (3,) or np.any(f < 0) or not np.isclose(f.sum(), 1.0):
        raise ConfigError("split", tuple(fractions), "three fractions >= 0 summing to 1")
    perm = np.random.default_rng(seed).permutation(n)
    n_val = max(1, int(round(f[1] * n)))
    n_test = max(1, int(round(f[2] * n)))
    n_train = n - n_val - n_test
    if n_train < 1:
        raise ConfigError("split", tuple(fractions), f"leaves no training sample of {n}")
    return {"train": np.sort(perm[:n_train]),
            "val": np.sort(perm[n_train:n_train + n_val]),
            "test": np.sort(perm[n_train + n_val:])}
