"""The outcome of a diagnosis round: :class:`Candidate` and :class:`RoundResult`."""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field
from typing import Any

from ..config import EffectConfig
from ..effects import get_effect, parse_label
from .candidates import is_revision

__all__ = ["MULTI", "NOISE_LIKE", "Candidate", "RoundResult", "effect_configs"]

MULTI = ("kinematic_calibration", "fts_calibration")
"""Multi-parameter candidates (fitted from the measured channels, not from a probe)."""

NOISE_LIKE = 1.2
"""Validation error (noise units) at or below which a residual counts as noise."""


@dataclass
class Candidate:
    """One candidate after screening (and refitting, if it was among the best).

    ``value`` is the fitted parameter (SI unit of the effect; NaN for a calibration, whose
    fitted effects are ``values``), ``ci`` its 95 % interval; ``error_before`` /
    ``error_after`` are validation errors in noise units (1 = only noise); ``score`` the
    held-out ΔIC (higher is better; > 0 favours the effect).
    """

    effect: str
    param: str
    unit: str
    share: float = 0.0
    value: float = float("nan")
    values: dict[str, float] = field(default_factory=dict)
    k: int = 1
    ci: tuple[float, float] = (float("nan"), float("nan"))
    score: float = float("-inf")
    error_before: float = float("nan")
    error_after: float = float("nan")
    train_before: float = float("nan")
    train_after: float = float("nan")
    fitted: bool = False
    significant: bool = False
    note: str = ""
    channel_share: dict[str, float] = field(default_factory=dict)
    detail: list[str] = field(default_factory=list)
    """Further facts (e.g. the kinematic calibration's identifiability report)."""
    changes: dict[str, Any] = field(default_factory=dict)
    """A revision of the description: its changes of the scene (dotted key → value)."""
    evidence: str = ""
    """A revision that contradicts the scene's statements: what was stated, what the
    measurement says and by how much ("contradicts your description: …")."""

    @property
    def leg(self) -> int:
        """The leg the candidate acts on (−1: none or all)."""
        if self.effect in MULTI or is_revision(self.effect):
            return -1
        return parse_label(self.effect)[1]

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready dict with the interface keys effect, params, score, error_before,
        error_after."""
        d = asdict(self)
        d["params"] = dict(self.changes) if is_revision(self.effect) else \
            {self.param: self.value} if self.effect not in MULTI else dict(self.values)
        d["ci"] = list(self.ci)
        return d


@dataclass
class RoundResult:
    """Outcome of one diagnosis round."""

    candidates: list[Candidate]
    accepted: dict[str, float]
    noise_only: bool
    proposal: Candidate | None
    confounded: list[tuple[str, str, float]]
    error_train: float
    error_val: float
    channel_rms: dict[str, float]
    noise_sigma: dict[str, float]
    whiteness: dict[str, float] = field(default_factory=dict)
    partly: bool = False
    """Structure remains after the best candidate (or the accepted effects)."""
    remaining: dict[str, Any] = field(default_factory=dict)
    """Where the residual left by the proposal (or the current model) sits."""
    detection_limit: float = float("nan")
    """With an unexplained residual (status ``unexplained``): the smallest effect, as the
    RMS of its signature on the validation blocks in noise units, that the diagnosis could
    still tell apart from it (:func:`~.rounds.detection_limit`); NaN otherwise."""
    absorbed: dict[str, float] = field(default_factory=dict)
    """Candidates that would absorb part of an unexplained residual (not proposed): label →
    the share of the excess over noise each removes."""
    seconds: dict[str, float] = field(default_factory=dict)
    """Wall time of the round (s): ``screen`` (the calibrations and the batched replay of
    every candidate at its probe value), ``refit`` (the two batched secant steps), ``rank``
    and ``round`` (all of it); ``simulations`` replays and ``threads`` they ran on."""

    @property
    def systematic_sigma(self) -> float:
        """The residual's excess over noise, √(e² − 1) of the validation error e (noise
        units: the RMS of what is not noise)."""
        return math.sqrt(max(self.error_val ** 2 - 1.0, 0.0))

    @property
    def status(self) -> str:
        """``effect_proposed``, ``partly_explained``, ``noise_only`` or ``unexplained``."""
        if self.partly:
            return "partly_explained"
        if self.proposal is not None:
            return "effect_proposed"
        return "noise_only" if self.noise_only else "unexplained"

    def as_dict(self) -> dict[str, Any]:
        """JSON-ready summary (keys ``candidates``, ``accepted``, ``noise_only`` ...)."""
        return {
            "candidates": [c.as_dict() for c in self.candidates],
            "accepted": [{"effect": k, "params": {_param(k): v}}
                         for k, v in self.accepted.items()],
            "noise_only": self.noise_only,
            "status": self.status,
            "whiteness": self.whiteness,
            "proposal": self.proposal.effect if self.proposal else None,
            "confounded": [{"a": a, "b": b, "cos": c} for a, b, c in self.confounded],
            "error_train": self.error_train,
            "error_val": self.error_val,
            "channel_rms": self.channel_rms,
            "noise_sigma": self.noise_sigma,
            "remaining": self.remaining,
            "systematic_sigma": self.systematic_sigma,
            "detection_limit": (None if math.isnan(self.detection_limit)
                                else self.detection_limit),
            "absorbed": self.absorbed,
            "seconds": self.seconds,
        }


def _param(label: str) -> str:
    return get_effect(label.split(".")[0]).param.name


def effect_configs(effects: Mapping[str, float]) -> list[EffectConfig]:
    """Effect labels and values as the bench's effect tables."""
    out = []
    for label, v in effects.items():
        name, leg, axis = parse_label(label)
        out.append(EffectConfig(name, float(v), leg, axis))
    return out
