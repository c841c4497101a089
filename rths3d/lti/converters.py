"""A/D and D/A converter models: quantisation (halves away from zero) and saturation.

Quantisation to interval ``q`` gives ``q·round(u/q)`` with halves rounded away from zero
(MATLAB/Simulink ``round``), unlike numpy's round-half-to-even.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError

__all__ = ["Converter", "quantize", "round_half_away", "saturate"]


def round_half_away(x: float | np.ndarray) -> float | np.ndarray:
    """Round to the nearest integer, halves away from zero (MATLAB ``round``)."""
    if isinstance(x, np.ndarray):
        return np.sign(x) * np.floor(np.abs(x) + 0.5)
    return math.copysign(math.floor(abs(x) + 0.5), x)


def quantize(u: float | np.ndarray, q: float) -> float | np.ndarray:
    """``q·round(u/q)`` with halves away from zero; ``q`` is the interval (units of u)."""
    if isinstance(u, np.ndarray):
        return q * (np.sign(u) * np.floor(np.abs(u) / q + 0.5))
    return q * math.copysign(math.floor(abs(u) / q + 0.5), u)


def saturate(u: float | np.ndarray, lo: float, hi: float) -> float | np.ndarray:
    """Clip ``u`` to ``[lo, hi]``."""
    if isinstance(u, np.ndarray):
        return np.clip(u, lo, hi)
    return lo if u < lo else (hi if u > hi else u)


@dataclass(frozen=True)
class Converter:
    """An A/D (saturate, then quantise) or D/A (quantise, then saturate) converter.

    Attributes
    ----------
    q:
        Quantisation interval in the signal's units (0 disables quantisation).
    lo, hi:
        Saturation limits in the signal's units.
    kind:
        ``"ad"`` or ``"da"``: the order of the two operations, as in the RTHS benchmark's
        Simulink model.
    """

    q: float
    lo: float = -math.inf
    hi: float = math.inf
    kind: str = "ad"

    def __post_init__(self) -> None:
        if not (self.q >= 0.0):
            raise ConfigError("converter.q", self.q, "quantisation interval must be ≥ 0")
        if not (self.lo < self.hi):
            raise ConfigError("converter.lo", self.lo, f"must be < hi = {self.hi}")
        if self.kind not in ("ad", "da"):
            raise ConfigError("converter.kind", self.kind, "must be 'ad' or 'da'")

    @classmethod
    def from_bits(cls, bits: int, lo: float, hi: float, kind: str = "ad") -> Converter:
        """An n-bit converter spanning [lo, hi]: ``q = (hi − lo)/2ⁿ``."""
        if int(bits) < 1:
            raise ConfigError("converter.bits", bits, "must be ≥ 1")
        return cls((hi - lo) / 2 ** int(bits), lo, hi, kind)

    def __call__(self, u: float | np.ndarray) -> float | np.ndarray:
        if self.kind == "ad":
            u = saturate(u, self.lo, self.hi)
            return quantize(u, self.q) if self.q > 0.0 else u
        u = quantize(u, self.q) if self.q > 0.0 else u
        return saturate(u, self.lo, self.hi)
