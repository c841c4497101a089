"""Where the model fails: residuals localised in time, frequency and operating condition.

Plain functions of arrays (SI units). ``r`` is a residual measured − model of one channel,
sampled at ``dt`` (s).
"""

from __future__ import annotations

import math

import numpy as np
from scipy import signal


def noise_floor(r: np.ndarray) -> float:
    """White-noise σ of a residual, robust to smooth misfit and to sparse jumps (friction
    reversals, contact): σ ≈ 1.4826·MAD(Δ²r)/√6, since Δ² of white noise has variance 6σ²
    while a smooth misfit nearly cancels in second differences. Unit of ``r``."""
    if r.size < 4:
        return 0.0
    d = np.diff(r, 2)
    return float(1.4826 * np.median(np.abs(d - np.median(d))) / math.sqrt(6.0))


def effective_samples(r: np.ndarray, max_lag: int = 500) -> float:
    """Effective number of independent samples of an autocorrelated residual,
    n / (1 + 2 Σ ρ_k), summing the autocorrelation ρ_k up to its first drop below 0.05."""
    n = r.size
    if n < 4:
        return float(n)
    x = r - r.mean()
    var = float(np.dot(x, x))
    if var == 0.0:
        return float(n)
    m = 1 << int(math.ceil(math.log2(2 * n)))
    spec = np.fft.rfft(x, m)
    acf = np.fft.irfft(spec * np.conj(spec), m)[: min(max_lag, n - 1) + 1] / var
    below = np.flatnonzero(acf[1:] < 0.05)
    k = int(below[0]) if below.size else acf.size - 1
    tau = 1.0 + 2.0 * float(np.sum(acf[1 : k + 1]))
    return float(min(n, max(1.0, n / max(tau, 1.0))))


def window_rms(r: np.ndarray, dt: float, window: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
    """RMS of ``r`` in consecutive windows of ``window`` s: (window centre times s, RMS)."""
    m = max(1, int(round(window / dt)))
    k = r.size // m
    if k == 0:
        return np.array([0.5 * r.size * dt]), np.array([math.sqrt(np.mean(r * r))])
    blocks = r[: k * m].reshape(k, m)
    return (np.arange(k) + 0.5) * m * dt, np.sqrt(np.mean(blocks * blocks, axis=1))


def residual_spectrum(r: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Welch power spectral density of the residual: (f Hz, PSD unit²/Hz)."""
    nper = min(r.size, 512)
    return signal.welch(r, fs=1.0 / dt, nperseg=nper)


def transfer_estimate(model: np.ndarray, meas: np.ndarray, dt: float
                      ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Measured-vs-model transfer H(f) = S_{model,meas} / S_{model,model} (H1 estimate) and its
    coherence: (f Hz, complex H, coherence). |H| = 1, ∠H = 0 where the model is right."""
    nper = min(model.size, 1024)
    f, pxy = signal.csd(model, meas, fs=1.0 / dt, nperseg=nper)
    _, pxx = signal.welch(model, fs=1.0 / dt, nperseg=nper)
    _, coh = signal.coherence(model, meas, fs=1.0 / dt, nperseg=nper)
    with np.errstate(divide="ignore", invalid="ignore"):
        h = np.where(pxx > 0, pxy / pxx, np.nan)
    return f, h, coh


def fei(model: np.ndarray, meas: np.ndarray, dt: float) -> dict[str, float]:
    """Frequency evaluation index of the measurement against the model,
    FEI = Σ Y_meas·conj(Y_model) / Σ |Y_model|² (sum over the DFT bins), with its amplitude A
    (1 = right gain), phase φ (rad) and the equivalent delay −φ/ω_eq (s) at the
    power-weighted mean angular frequency ω_eq (rad/s)."""
    ym = np.fft.rfft(model - model.mean())
    yz = np.fft.rfft(meas - meas.mean())
    w = 2 * math.pi * np.fft.rfftfreq(model.size, dt)
    p = np.abs(ym) ** 2
    den = float(np.sum(p))
    if den == 0.0:
        return {"amplitude": float("nan"), "phase": float("nan"), "delay": float("nan"),
                "omega_eq": float("nan")}
    val = complex(np.sum(yz * np.conj(ym)) / den)
    omega = float(np.sum(p * w) / den)
    phase = math.atan2(val.imag, val.real)
    return {"amplitude": abs(val), "phase": phase,
            "delay": -phase / omega if omega > 0 else float("nan"), "omega_eq": omega}


def condition_table(r: np.ndarray, conditions: dict[str, np.ndarray], nbins: int = 3
                    ) -> list[dict[str, float | str]]:
    """RMS of ``r`` by operating condition: for each named condition signal (velocity,
    acceleration, force...), the sign halves and ``nbins`` bins of its magnitude, plus the
    correlation of ``r`` with the signal and with its sign."""
    rows: list[dict[str, float | str]] = []
    for name, x in conditions.items():
        if x.size != r.size or not np.any(x):
            continue
        for label, mask in (("< 0", x < 0), ("> 0", x > 0)):
            if mask.any():
                rows.append({"condition": name, "bin": label,
                             "rms": float(np.sqrt(np.mean(r[mask] ** 2))),
                             "share": float(mask.mean())})
        mag = np.abs(x)
        edges = np.quantile(mag, np.linspace(0, 1, nbins + 1))
        for i in range(nbins):
            hi = edges[i + 1] if i < nbins - 1 else np.inf
            mask = (mag >= edges[i]) & (mag < hi)
            if mask.any():
                rows.append({"condition": name, "bin": f"|x| in [{edges[i]:.3g}, "
                             f"{edges[i + 1]:.3g}]", "rms": float(np.sqrt(np.mean(r[mask] ** 2))),
                             "share": float(mask.mean())})
        rows.append({"condition": name, "bin": "corr(r, x)", "rms": _corr(r, x), "share": 1.0})
        rows.append({"condition": name, "bin": "corr(r, sign x)", "rms": _corr(r, np.sign(x)),
                     "share": 1.0})
    return rows


def _corr(a: np.ndarray, b: np.ndarray) -> float:
    a = a - a.mean()
    b = b - b.mean()
    den = math.sqrt(float(np.dot(a, a)) * float(np.dot(b, b)))
    return float(np.dot(a, b) / den) if den > 0 else 0.0


def remaining_structure(res: dict[str, np.ndarray], diag, channels, top: int = 3
                        ) -> dict[str, object]:
    """Where a residual (noise units per channel) that is not noise sits: the channels with
    the largest RMS, the 0.25 s windows with the largest RMS (s), the frequency band where
    its spectrum rises most above the flat noise floor (Hz), its whiteness (n_eff/n) and its
    correlation with the states (commanded velocity and acceleration of the interface DOFs,
    the measured displacement and force)."""
    dt = diag.dt
    rows = slice(1, None)
    rms = {c: float(np.sqrt(np.mean(res[c][rows] ** 2))) for c in channels}
    worst = sorted(rms, key=lambda c: -rms[c])[:top]
    out: dict[str, object] = {"channels": {c: rms[c] for c in worst}}
    c0 = worst[0]
    r = np.nan_to_num(res[c0][rows])
    tw, wr = window_rms(r, dt, 0.25)
    idx = np.argsort(-wr)[:top]
    out["windows_s"] = [[float(tw[i] - 0.125 + dt), float(tw[i] + 0.125 + dt), float(wr[i])]
                        for i in sorted(idx)]
    f, p = residual_spectrum(r, dt)
    floor = float(np.median(p[1:])) if p.size > 2 else 0.0
    if floor > 0 and p.size > 4:
        excess = p / floor
        k = int(np.argmax(excess[1:])) + 1
        hi = k
        while hi + 1 < p.size and excess[hi + 1] > 3.0:
            hi += 1
        lo = k
        while lo - 1 > 0 and excess[lo - 1] > 3.0:
            lo -= 1
        out["band_hz"] = [float(f[lo]), float(f[hi]), float(excess[k])]
    out["whiteness"] = float(effective_samples(r) / max(r.size, 1))
    states: dict[str, np.ndarray] = {}
    for d in diag.scene.dofs:
        j = DOFS_INDEX[d]
        z = diag.replay.poses[:, j]
        v = np.gradient(z, dt)
        states[f"velocity.{d}"] = v
        states[f"acceleration.{d}"] = np.gradient(v, dt)
        if f"z_meas.{d}" in diag.measured:
            states[f"displacement.{d}"] = diag.measured[f"z_meas.{d}"]
        if f"f_meas.{d}" in diag.measured:
            states[f"force.{d}"] = diag.measured[f"f_meas.{d}"]
    corr = {name: _corr(r, x[rows]) for name, x in states.items() if np.any(x)}
    corr.update({f"sign velocity.{n[9:]}": _corr(r, np.sign(x[rows]))
                 for n, x in states.items() if n.startswith("velocity.") and np.any(x)})
    best = sorted(corr, key=lambda k: -abs(corr[k]))[:top]
    out["state_correlation"] = {k: corr[k] for k in best}
    return out


DOFS_INDEX = {d: i for i, d in enumerate(("x", "y", "z", "rx", "ry", "rz"))}
