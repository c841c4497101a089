"""``model_based``: inverse-model feed-forward plus feedback on the tracking error (after
Phillips & Spencer 2013, model-based servo-hydraulic control for RTHS: a feed-forward inverse
of the identified actuator model and a feedback loop on the remaining error).

    u_k = u_ff,k + u_fb,k
    u_ff = the ``inverse`` compensator's command (same model, delay, filter; :mod:`.inverse`)
    e_k  = z_{k−1} − z_meas,k            (the last target against its measurement)
    u_fb = k_p ē_k + k_i Σ ē dt,         ē = e low-passed at ``fb_hz`` (first order)

The feed-forward does the work where the model is right; the feedback corrects what it is
not (a perturbed plant's gain, a drift of the operating point). Phillips & Spencer used an
LQG regulator for the feedback; a PI on the filtered error is the simplest stand-in with the
same role. Keep its bandwidth well below 1/(the loop's delay): the feedback acts through the
whole transfer system.

Drift safety: |u_fb| above ``fb_limit`` (the feedback doing more than a correction: integral
wind-up, a plant far from its model) or an oscillating command stops the test. Coefficients
reported: ``u_fb`` (the current feedback correction, channel units).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from .base import (
    WATCH_STATES,
    BaseCompensator,
    WatchConfig,
    butter_sos,
    check,
    register,
    watch_step,
)
from .inverse import InverseCore, InverseModel


@dataclass(frozen=True)
class ModelBasedConfig(InverseModel, WatchConfig):
    """The inverse model's fields (:class:`~.inverse.InverseModel`: num, den, delay,
    delay_order, filter_order, filter_hz), then the feedback:

    Attributes
    ----------
    kp: proportional gain on the filtered tracking error (-), 0.
    ki: integral gain (1/s), 10.
    fb_hz: corner of the first-order low-pass on the error (Hz), 10.
    fb_limit: largest |u_fb| before the test stops (channel units), 0.005 (5 mm).
    osc_*: the command-oscillation watch (:class:`~.base.WatchConfig`).
    """

    kp: float = 0.0
    ki: float = 10.0
    fb_hz: float = 10.0
    fb_limit: float = 0.005

    def __post_init__(self) -> None:
        self.check_model("model_based")
        check("model_based.kp", self.kp, math.isfinite(self.kp) and 0 <= self.kp < 1,
              "must be in [0, 1)")
        check("model_based.ki", self.ki, math.isfinite(self.ki) and self.ki >= 0,
              "must be ≥ 0 (1/s)")
        check("model_based.fb_hz", self.fb_hz, self.fb_hz > 0, "must be > 0 Hz")
        check("model_based.fb_limit", self.fb_limit, self.fb_limit > 0, "must be > 0")


@njit(cache=True, nogil=True)
def _feedback_step(z, zm, u, fb, state, watch, hp, wp, stopped, code, ev_val, ev_lim, prm):
    """Add the PI feedback to the feed-forward already in ``u``. ``state`` (K, n, 3): the
    last target, the filtered error, the integral. ``prm`` = [kp, ki·dt, filter α,
    fb_limit]; ``wp``: the watch's parameters."""
    kp, kidt, beta, limit = prm[0], prm[1], prm[2], prm[3]
    K, n = z.shape
    event = False
    for k in range(K):
        if stopped[k]:
            continue
        for j in range(n):
            s = state[k, j]
            e = s[0] - zm[k, j]
            s[1] += beta * (e - s[1])
            s[2] += kidt * s[1]
            c = kp * s[1] + s[2]
            fb[k, j] = c
            s[0] = z[k, j]
            uk = u[k, j] + c
            u[k, j] = uk
            if abs(c) > limit and code[k, j] == 0:
                code[k, j] = 1
                ev_val[k, j] = abs(c)
                ev_lim[k, j] = limit
                event = True
            osc, ru, lim = watch_step(hp, watch[k, j], uk, z[k, j], wp)
            if osc and code[k, j] == 0:
                code[k, j] = 2
                ev_val[k, j] = ru
                ev_lim[k, j] = lim
                event = True
        if code[k].any():
            stopped[k] = True
    return event


LABELS = ("feedback correction |u_fb| (channel {ch})",
          "command oscillation (channel {ch}, high-pass RMS)")
UNITS = ("", "")


@register
class ModelBasedCompensator(BaseCompensator):
    """Inverse-model feed-forward + PI feedback on the tracking error (module docstring)."""

    name = "model_based"
    rank = 70
    Config = ModelBasedConfig

    def __init__(self, config: ModelBasedConfig, K: int, n: int, dt: float):
        super().__init__(config, K, n, dt)
        c = config
        c.check_watch("model_based", dt)
        self.core = InverseCore(c, K, n, dt, "model_based")
        self.hp = butter_sos(2, c.osc_corner, dt, "highpass")
        self.prm = np.array([c.kp, c.ki * dt, -math.expm1(-2 * math.pi * c.fb_hz * dt),
                             c.fb_limit])
        self.wp = c.watch_params(dt)
        self.fb = np.zeros((K, n))
        self.state = np.zeros((K, n, 3))
        self.watch = np.zeros((K, n, WATCH_STATES))
        self.code = np.zeros((K, n), dtype=np.int64)
        self.ev_val = np.zeros((K, n))
        self.ev_lim = np.zeros((K, n))
        self._held = np.zeros((K, n))

    def reset(self) -> None:
        super().reset()
        self.core.reset()
        for arr in (self.fb, self.state, self.watch, self.ev_val, self.ev_lim):
            arr[:] = 0.0
        self.code[:] = 0

    def command(self, z: np.ndarray, zdot: np.ndarray, z_meas: np.ndarray) -> np.ndarray:
        any_stopped = self.stopped.any()
        if any_stopped:  # stopped tests keep their last command
            np.copyto(self._held, self.u)
        self.core(z, zdot, self.u)
        if _feedback_step(z, z_meas, self.u, self.fb, self.state, self.watch, self.hp, self.wp,
                          self.stopped, self.code, self.ev_val, self.ev_lim, self.prm):
            self._events(self.code, self.ev_val, self.ev_lim, LABELS, UNITS)
        if any_stopped:
            self.u[self.stopped] = self._held[self.stopped]
        self.calls += 1
        return self.u

    def coefficients(self) -> dict[str, np.ndarray]:
        return {"u_fb": self.fb}

    def history(self) -> np.ndarray:
        return self.fb[..., None]

    prior_keys = ("delay",)

    def start_from_delay(self, delay: np.ndarray) -> bool:
        """The model's pure delay T = what the model leaves of ``delay`` (per test; see
        :meth:`InverseCore.start_from_delay`)."""
        self.core.start_from_delay(delay)
        self.reset()
        return True
