"""Synthetic measurements: the bench model with hidden effects plus sensor noise.

The same effect components the diagnosis fits generate the "measurements" for tests and
examples; the record carries only what a real bench would record (commands and measured
channels) and the nominal bench parameters in ``meta['bench']`` — never the effects.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from ..record import Record
from .bench import BenchConfig

DEFAULT_TONES: tuple[tuple[float, float], ...] = (
    (0.4, 3.0e-3), (1.1, 1.0e-3), (2.7, 4.0e-4), (6.3, 1.5e-4), (11.0, 8.0e-5),
    (17.0, 4.0e-5), (31.0, 2.0e-5),
)
"""(frequency Hz, amplitude m) of the default multisine excitation."""


def multisine(duration: float, dt: float = 1e-3, tones=DEFAULT_TONES, seed: int = 0,
              taper: float = 0.25) -> tuple[np.ndarray, np.ndarray]:
    """Commanded displacement ``z_cmd`` (m): a sum of sines with seeded random phases, faded
    in and out over ``taper`` s so that the test starts and ends at rest. Returns (t, z_cmd)."""
    rng = np.random.default_rng(seed)
    n = int(round(duration / dt)) + 1
    t = dt * np.arange(n)
    z = np.zeros(n)
    for f, a in tones:
        z += a * np.sin(2 * math.pi * f * t + rng.uniform(0, 2 * math.pi))
    w = np.ones(n)
    m = max(2, int(round(taper / dt)))
    ramp = 0.5 - 0.5 * np.cos(np.linspace(0.0, math.pi, m))
    w[:m] = ramp
    w[-m:] = ramp[::-1]
    return t, z * w


def synthetic_measurement(effects: Mapping[str, float] | None = None, *, duration: float = 3.0,
                          dt: float = 1e-3, noise: float = 1.0, seed: int = 0,
                          bench: BenchConfig | None = None, excitation_seed: int | None = None,
                          model: str = "bench") -> Record:
    """A record as a bench would produce it, with ``effects`` hidden in the physics and
    sensors and white sensor noise (``noise`` × the nominal σ of each channel). ``model``:
    ``"bench"`` (1-D heave bench) or ``"stewart"`` (six-leg platform)."""
    from .stewart import make_model

    model = make_model(bench, dt, model)
    t, z_cmd = multisine(duration, dt, seed=seed if excitation_seed is None else excitation_seed)
    eff = dict(effects or {})
    if noise:
        eff["sensor_noise"] = float(noise)
    out = model.replay(z_cmd, eff, rng=np.random.default_rng(seed + 1000))
    cols = {"z_cmd.z": z_cmd}
    for name, values in out.items():
        if name != "contact":
            cols[name] = values
    return Record(t, cols, {"scene": "bench", "bench": model.as_meta(), "dt": dt,
                            "status": "ok", "reason": ""})
