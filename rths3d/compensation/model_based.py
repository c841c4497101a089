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
wind-up, a plant far from its model) or an oscillating command stops the test; from the next
call on its command holds. Coefficients reported: ``u_fb`` (the current feedback correction,
channel units).

The whole step is one compiled kernel (:func:`model_based_kernel`: the inverse's
:func:`~.inverse.inverse_row`, then the feedback, the limit and the watch per channel), run
by the compiled loops and by :meth:`ModelBasedCompensator.command` alike.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .base import (
    WATCH_STATES,
    BaseCompensator,
    WatchConfig,
    butter_sos,
    check,
    comp_kernel,
    comp_ready,
    register,
    watch_row,
)
from .inverse import InverseCore, InverseModel, inverse_row


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


# the per-row parameters (``p`` of the kernel, (R, P)): the feedback's scalars, the number
# of channels per test, the watch's parameters, its high-pass section, then the inverse's
# columns (:mod:`.inverse`, the ``_I_*`` offsets from ``_P_INV``)
_P_KP, _P_KIDT, _P_BETA, _P_LIMIT, _P_N = range(5)
_P_WP, _P_HP, _P_INV = 5, 10, 16
# the per-row state (``s`` of the kernel, (R, S)): the last target, the filtered error, the
# integral, the feedback correction u_fb, the event (code, value, limit), the stop flag
# (the test's first row), the watch, then the inverse's state
_S_LAST, _S_ERR, _S_INT, _S_FB, _S_CODE, _S_VAL, _S_LIM, _S_STOP = range(8)
_S_WATCH = 8
_S_INV = _S_WATCH + WATCH_STATES


@comp_kernel
def model_based_kernel(p, s, z, zd, zm, u):
    """One call of the ``model_based`` compensator for R = K·n rows (test-major; layout: the
    ``_P_*``, ``_S_*`` offsets): per channel the inverse feed-forward
    (:func:`~.inverse.inverse_row`) plus the PI feedback on the low-passed error
    z_{k−1} − z_meas,k, the |u_fb| limit and the oscillation watch. A stopped test is
    skipped (its command holds). Returns True when a new safety event was raised."""
    n = int(p[0, _P_N])
    K = z.shape[0] // n
    event = False
    for k in range(K):
        h0 = k * n
        if s[h0, _S_STOP] != 0.0:
            continue
        stop = False
        for j in range(n):
            r = h0 + j
            pr = p[r]
            sr = s[r]
            uff = inverse_row(pr, _P_INV, sr, _S_INV, z[r], zd[r])
            e = sr[_S_LAST] - zm[r]
            sr[_S_ERR] += pr[_P_BETA] * (e - sr[_S_ERR])
            sr[_S_INT] += pr[_P_KIDT] * sr[_S_ERR]
            c = pr[_P_KP] * sr[_S_ERR] + sr[_S_INT]
            sr[_S_FB] = c
            sr[_S_LAST] = z[r]
            uk = uff + c
            u[r] = uk
            limit = pr[_P_LIMIT]
            if abs(c) > limit and sr[_S_CODE] == 0.0:
                sr[_S_CODE] = 1.0
                sr[_S_VAL] = abs(c)
                sr[_S_LIM] = limit
                event = True
            osc, ru, lim = watch_row(pr, _P_WP, _P_HP, sr, _S_WATCH, uk, z[r])
            if osc and sr[_S_CODE] == 0.0:
                sr[_S_CODE] = 2.0
                sr[_S_VAL] = ru
                sr[_S_LIM] = lim
                event = True
            if sr[_S_CODE] != 0.0:
                stop = True
        if stop:
            s[h0, _S_STOP] = 1.0
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
    adaptive = True
    event_labels = LABELS
    event_units = UNITS

    def __init__(self, config: ModelBasedConfig, K: int, n: int, dt: float):
        super().__init__(config, K, n, dt)
        c = config
        c.check_watch("model_based", dt)
        self.core = core = InverseCore(c, K, n, dt, "model_based")
        comp_ready(model_based_kernel)
        self.hp = butter_sos(2, c.osc_corner, dt, "highpass")
        self.wp = c.watch_params(dt)
        R = K * n
        # the kernel's arrays (rows test-major, row = k·n + j): its parameters ...
        p = np.zeros((R, _P_INV + core.P))
        p[:, :_P_WP] = [c.kp, c.ki * dt, -math.expm1(-2 * math.pi * c.fb_hz * dt),
                        c.fb_limit, n]
        p[:, _P_WP:_P_HP] = self.wp
        p[:, _P_HP:_P_INV] = self.hp[0]
        core.fill(p, _P_INV)
        self.params = p
        # ... and its state; the Python object reads views of them
        self.state = s = np.zeros((R, _S_INV + core.S))
        self.fb = s[:, _S_FB].reshape(K, n)
        """The feedback correction u_fb (K, n) (a view of the kernel's state)."""
        self.code = s[:, _S_CODE].reshape(K, n)
        self.ev_val = s[:, _S_VAL].reshape(K, n)
        self.ev_lim = s[:, _S_LIM].reshape(K, n)

    def reset(self) -> None:
        super().reset()
        self.state[:] = 0.0

    def command(self, z: np.ndarray, zdot: np.ndarray, z_meas: np.ndarray) -> np.ndarray:
        if model_based_kernel(self.params, self.state, np.ascontiguousarray(z).reshape(-1),
                              np.ascontiguousarray(zdot).reshape(-1),
                              np.ascontiguousarray(z_meas).reshape(-1), self.u.reshape(-1)):
            self.events()
        self.calls += 1
        return self.u


    def compiled(self):
        return (model_based_kernel,), self.params, self.state

    def coefficients(self) -> dict[str, np.ndarray]:
        return {"u_fb": self.fb}

    def history(self) -> np.ndarray:
        return self.state[:, _S_FB:_S_FB + 1].reshape(self.K, self.n, 1)

    prior_keys = ("delay",)

    def start_from_delay(self, delay: np.ndarray) -> bool:
        """The model's pure delay T = what the model leaves of ``delay`` (per test; see
        :meth:`InverseCore.start_from_delay`)."""
        self.core.start_from_delay(delay, self.params, _P_INV)
        self.reset()
        return True
