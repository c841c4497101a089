"""Heave frequency response of the platform and its fit by a low-order transfer function.

The platform is excited in heave (z) by a periodic multisine (0.1–50 Hz, Schroeder phases,
amplitudes limited to a constant velocity at high frequency) about several operating poses;
the frequency response ``H(jω) = Z'(jω)/Z(jω)`` (achieved over commanded heave) is taken at
the excited lines of the last period. A transfer function with delay

    G(s) = (b_m s^m + … + b_0) / (a_n s^n + … + a_1 s + 1) · exp(−s·T)

is fitted to the pose-averaged response by nonlinear least squares on the complex error.
This is the 1-D "measured transfer function" the paper used as its actuator model.

File format (``assets/platform_heave_tf.json``, JSON, SI units)::

    {
      "format": "rths3d.platform_heave_tf/1",
      "num": [b_m, ..., b_0],          # numerator, descending powers of s
      "den": [a_n, ..., a_1, 1.0],     # denominator, descending powers of s
      "delay": T,                      # transport delay (s), G(s) = num/den · exp(−sT)
      "dt": 0.001,                     # interface step of the identification run (s)
      "fit_error": e,                  # RMS |G − H| / RMS |H| over all poses and lines
      "frequency_range": [0.1, 50.0],  # Hz
      "conditions": [                  # one per operating pose
        {"label": "home", "pose": [x, y, z, rx, ry, rz], "fit_error": e_k,
         "delay_1hz": d, "gain_1hz": g}, ...],
      "frequencies": [...],            # excited lines (Hz)
      "response": {"home": {"re": [...], "im": [...]}, ...},   # measured H per pose
      "platform": {...}                # actuator settings and substeps used
    }

``num``/``den`` follow ``scipy.signal`` conventions, so
``scipy.signal.TransferFunction(num, den)`` (plus the delay) reproduces the fit.
"""

from __future__ import annotations

import cmath
import contextlib
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...errors import ConfigError
from ...figures import new_figure, save_figure
from ...lti.identify import _tf_eval, fit_transfer_function, multisine
from ..model import PlatformConfig
from ..single import PlatformSim

__all__ = [
    "DEFAULT_TF_PATH",
    "HeaveTF",
    "IdentifyResult",
    "fit_transfer_function",
    "heave_response",
    "identify_heave",
    "load_heave_tf",
    "multisine",
]

DEFAULT_TF_PATH = Path(__file__).resolve().parents[3] / "assets" / "platform_heave_tf.json"
"""Where the repository keeps the identified heave transfer function."""

FORMAT = "rths3d.platform_heave_tf/1"

DEFAULT_POSES: dict[str, tuple[float, ...]] = {
    "home": (0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
    "raised 25 mm": (0.0, 0.0, 0.025, 0.0, 0.0, 0.0),
    "lowered 25 mm": (0.0, 0.0, -0.025, 0.0, 0.0, 0.0),
    "surge 20 mm": (0.02, 0.0, 0.0, 0.0, 0.0, 0.0),
    "rolled 0.05 rad": (0.0, 0.0, 0.0, 0.05, 0.0, 0.0),
}


def heave_response(config: PlatformConfig, pose: tuple[float, ...] = (0.0,) * 6,
                   sim: PlatformSim | None = None, periods: int = 2,
                   **multisine_kw) -> tuple[np.ndarray, np.ndarray]:
    """Measured heave response ``H(j2πf)`` (lines f in Hz, complex H) about ``pose``.

    Moves from home to ``pose`` (1 s raised-cosine ramp, then 0.5 s hold), fades the
    multisine in over its first second (raised cosine; over the first period if that is
    shorter) and evaluates the last period.
    """
    sim = sim or PlatformSim(config)
    sim.reset()
    dt = config.dt
    f, one = multisine(dt=dt, **multisine_kw)
    n = one.size
    base = np.asarray(pose, dtype=float)
    ramp = int(round(1.0 / dt))
    hold = int(round(0.5 / dt))
    step = sim.step
    for k in range(ramp + hold):
        s = min(1.0, (k + 1) / ramp)
        q = base * (0.5 - 0.5 * math.cos(math.pi * s))
        step(*q.tolist())
    z0 = float(sim.pose[2])
    x, y, zb, rx, ry, rz = base.tolist()
    total = periods * n
    fade = np.ones(total)
    nf = min(n, int(round(1.0 / dt)))
    fade[:nf] = 0.5 - 0.5 * np.cos(np.pi * np.arange(1, nf + 1) / nf)
    cmd = np.tile(one, periods) * fade
    meas = np.empty(total)
    zcmd = (cmd + zb).tolist()
    for k in range(total):
        step(x, y, zcmd[k], rx, ry, rz)
        meas[k] = sim.pose[2]
    c = cmd[-n:]
    m = meas[-n:] - z0
    C = np.fft.rfft(c)
    M = np.fft.rfft(m - m.mean())
    idx = np.round(f * n * dt).astype(int)
    return f, M[idx] / C[idx]


def _chain_guess(config: PlatformConfig) -> tuple[np.ndarray, np.ndarray, float]:
    """Initial TF guess from the actuator chain (first-order lag × servo, leg mass ~3 kg)."""
    a = config.actuator
    m = 3.0
    tc = a.timeconst
    servo_num = np.array([a.kv / a.kp if a.velocity_ff else 0.0, 1.0])
    servo_den = np.array([m / a.kp, a.kv / a.kp, 1.0])
    den = np.polymul([tc, 1.0], servo_den) if tc > 0 else np.concatenate([[0.0], servo_den])
    return servo_num, den, a.delay


@dataclass(frozen=True)
class HeaveTF:
    """A heave transfer function with delay, ``G(s) = num(s)/den(s) · exp(−s·delay)``.

    ``num``/``den`` in descending powers of s (scipy.signal convention), delay in s.
    """

    num: tuple[float, ...]
    den: tuple[float, ...]
    delay: float
    dt: float = 1e-3
    fit_error: float = float("nan")
    meta: dict = field(default_factory=dict, compare=False)

    def frequency_response(self, f: np.ndarray) -> np.ndarray:
        """Complex G(j2πf) at frequencies f (Hz)."""
        return _tf_eval(np.array(self.num), np.array(self.den), self.delay, np.asarray(f))

    def phase_delay(self, f: float) -> float:
        """Phase delay −∠G(j2πf)/(2πf) (s) at frequency f (Hz), with the phase continuous
        from 0 Hz (unwrapped: the transport delay's −ωT plus the phase of each pole and zero
        factor), so the delay stays continuous where the principal angle would wrap at ±π.
        """
        g = complex(self.frequency_response(np.array([f]))[0])
        phase = math.atan2(g.imag, g.real)
        w = 2 * math.pi * f
        s = 1j * w
        # continuous phase: each factor (s − r) turns by ∠((s − r)/(−r)) from 0 Hz on, a
        # root at 0 by π/2; the low-frequency gain's sign sets the start (0 or π)
        num = np.trim_zeros(np.asarray(self.num, float), "f")
        den = np.trim_zeros(np.asarray(self.den, float), "f")
        c = np.trim_zeros(num, "b")[-1] / np.trim_zeros(den, "b")[-1]
        cont = -w * self.delay + (0.0 if c > 0 else math.pi)
        for coef, sign in ((num, 1.0), (den, -1.0)):
            for r in np.roots(coef):
                cont += sign * (math.pi / 2 if r == 0 else cmath.phase((s - r) / -r))
        # the exact principal angle, on the branch of the continuous one
        phase += 2 * math.pi * round((cont - phase) / (2 * math.pi))
        return -phase / w


@dataclass
class IdentifyResult:
    """Result of :func:`identify_heave`: the fit and the measured responses per pose."""

    tf: HeaveTF
    frequencies: np.ndarray
    responses: dict[str, np.ndarray]
    poses: dict[str, tuple[float, ...]]
    pose_errors: dict[str, float]

    def to_json(self) -> dict:
        """The documented file content (see the module docstring)."""
        tf = self.tf
        conds = []
        for label, H in self.responses.items():
            g1 = complex(np.interp(1.0, self.frequencies, H.real),
                         np.interp(1.0, self.frequencies, H.imag))
            conds.append({"label": label, "pose": list(self.poses[label]),
                          "fit_error": self.pose_errors[label],
                          "delay_1hz": -math.atan2(g1.imag, g1.real) / (2 * math.pi),
                          "gain_1hz": abs(g1)})
        return {
            "format": FORMAT,
            "num": list(tf.num), "den": list(tf.den), "delay": tf.delay, "dt": tf.dt,
            "fit_error": tf.fit_error,
            "frequency_range": [float(self.frequencies.min()), float(self.frequencies.max())],
            "conditions": conds,
            "frequencies": self.frequencies.tolist(),
            "response": {k: {"re": v.real.tolist(), "im": v.imag.tolist()}
                         for k, v in self.responses.items()},
            "platform": tf.meta,
        }

    def save(self, path: str | os.PathLike = DEFAULT_TF_PATH) -> Path:
        """Write the JSON file atomically; returns its path.

        A path that cannot be written (a folder, say) raises ConfigError and leaves no
        temporary file behind."""
        path = Path(path)
        tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            tmp.write_text(json.dumps(self.to_json(), indent=1))
            os.replace(tmp, path)
        except OSError as exc:
            with contextlib.suppress(OSError):
                tmp.unlink()
            raise ConfigError("out", str(path), f"cannot write the TF file: "
                                                f"{exc.strerror or exc}") from None
        return path

    def bode_plot(self, path: str | os.PathLike) -> Path:
        """Bode plot (PNG): measured response per pose (markers) and the fit (line)."""
        f = self.frequencies
        ff = np.geomspace(f.min(), f.max(), 400)
        G = self.tf.frequency_response(ff)
        fig = new_figure((8, 7))
        ax1, ax2 = fig.subplots(2, 1, sharex=True)
        for label, H in self.responses.items():
            ax1.semilogx(f, 20 * np.log10(np.abs(H)), "o", ms=3.5, label=label)
            ax2.semilogx(f, np.degrees(np.unwrap(np.angle(H))), "o", ms=3.5)
        ax1.semilogx(ff, 20 * np.log10(np.abs(G)), "k-", lw=1.5, label="fit")
        ax2.semilogx(ff, np.degrees(np.unwrap(np.angle(G))), "k-", lw=1.5)
        ax1.set_ylabel("|Z'/Z| (dB)")
        ax2.set_ylabel("phase (deg)")
        ax2.set_xlabel("frequency (Hz)")
        tf = self.tf
        ax1.set_title(f"Platform heave response and fit: delay {tf.delay * 1e3:.2f} ms, "
                      f"fit error {100 * tf.fit_error:.2f} %")
        ax1.legend(fontsize=8)
        for ax in (ax1, ax2):
            ax.grid(True, which="both", alpha=0.3)
        return save_figure(fig, path)


def identify_heave(config: PlatformConfig | None = None,
                   poses: dict[str, tuple[float, ...]] | None = None, n_num: int = 1,
                   n_den: int = 2, progress: bool = False, **multisine_kw) -> IdentifyResult:
    """Measure the heave response at several poses and fit one transfer function with delay.

    ``poses``: label → operating pose (m, rad; default: home, ±25 mm heave, 20 mm surge,
    0.05 rad roll). The fit uses the mean response over the poses; each pose's own fit
    error is reported.
    """
    config = config or PlatformConfig()
    poses = dict(poses or DEFAULT_POSES)
    sim = PlatformSim(config)
    responses: dict[str, np.ndarray] = {}
    f = np.empty(0)
    items = list(poses.items())
    if progress:
        from tqdm import tqdm

        items = tqdm(items, desc="heave response", unit="pose")
    for label, pose in items:
        f, H = heave_response(config, pose, sim=sim, **multisine_kw)
        responses[label] = H
    Hm = np.mean(np.stack(list(responses.values())), axis=0)
    num, den, d, err = fit_transfer_function(f, Hm, n_num, n_den, guess=_chain_guess(config))
    pose_err = {k: float(np.linalg.norm(_tf_eval(num, den, d, f) - H) / np.linalg.norm(H))
                for k, H in responses.items()}
    all_err = float(np.sqrt(np.mean([e ** 2 for e in pose_err.values()])))
    a = config.actuator
    meta = {"kp": a.kp, "kv": a.kv, "timeconst": a.timeconst, "delay": a.delay,
            "velocity_ff": a.velocity_ff, "gravity_comp": a.gravity_comp,
            "substeps": config.substeps, "fit_error_mean_response": err,
            "n_num": n_num, "n_den": n_den}
    tf = HeaveTF(tuple(float(v) for v in num), tuple(float(v) for v in den), float(d),
                 config.dt, all_err, meta)
    return IdentifyResult(tf, f, responses, {k: tuple(v) for k, v in poses.items()},
                          pose_err)


def load_heave_tf(path: str | os.PathLike = DEFAULT_TF_PATH) -> HeaveTF:
    """Read a heave transfer-function file (format in the module docstring).

    Raises :class:`~rths3d.errors.ConfigError` naming the file and the missing or bad key.
    """
    path = Path(path)
    if not path.exists():
        raise ConfigError("heave TF file", str(path),
                          "does not exist (run `rths3d platform identify`)")
    try:
        raw = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ConfigError("heave TF file", str(path), f"is not JSON: {exc}") from exc
    for key in ("num", "den", "delay"):
        if key not in raw:
            raise ConfigError(f"{path.name}: {key}", None, "required key missing")
    num = [float(v) for v in raw["num"]]
    den = [float(v) for v in raw["den"]]
    delay = float(raw["delay"])
    if not den or den[-1] == 0 or not all(math.isfinite(v) for v in num + den):
        raise ConfigError(f"{path.name}: den", den, "need finite coefficients, den[-1] != 0")
    if not (math.isfinite(delay) and delay >= 0):
        raise ConfigError(f"{path.name}: delay", delay, "must be >= 0 s")
    return HeaveTF(tuple(num), tuple(den), delay, float(raw.get("dt", 1e-3)),
                   float(raw.get("fit_error", float("nan"))), dict(raw.get("platform", {})))
