"""Configuration of a benchmark run and where the benchmark's data live.

The benchmark's structure, plant and controller are built from their published parameters
(:mod:`.structure`, :mod:`.plant`); only the ground-motion records are read from the
benchmark's data folder (``data/ground_motion_<name>.csv``, time in s and unscaled
acceleration in m/s²). That folder is found, in order, from the ``data_dir`` argument, the
environment variable ``RTHS3D_BENCHMARK_DIR``, or ``../shared/external/rths-benchmark``
beside the repository; a ``data_dir`` given without ``data/`` in it is an error.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import ConfigError
from ..lti import DifferenceEquation, GroundMotion, load_ground_motion
from .plant import PlantParams

__all__ = ["EXCITATIONS", "BenchmarkConfig", "ControllerParams", "data_dir",
           "load_excitation"]

EXCITATIONS = ("ElCentro", "Kobe", "Morgan")
"""Ground-motion records of the benchmark (E_sw = 1, 2, 3)."""

ENV_VAR = "RTHS3D_BENCHMARK_DIR"


def benchmark_folder(path: str | Path | None, env_var: str, name: str, marker: str,
                     field: str, holds: str, what: str = "") -> Path:
    """A community benchmark's folder: ``path`` if given, else ``$env_var``, else
    ``shared/external/<name>`` beside the repository; it must hold ``marker`` (a path
    inside it, named ``what`` in messages). ConfigError naming the places tried (only ``path``
    when it is given)."""
    what = what or marker
    if path:
        if not (Path(path) / marker).exists():
            raise ConfigError(field, str(path), f"no {what} in it; the benchmark folder "
                              f"holds {holds}")
        return Path(path)
    tried = []
    env = os.environ.get(env_var)
    if env:
        if (Path(env) / marker).exists():
            return Path(env)
        tried.append(env)
    p = Path(__file__).resolve().parents[2] / ".." / "shared" / "external" / name
    if (p / marker).exists():
        return p.resolve()
    tried.append(str(p))
    raise ConfigError(field, None, f"no {what} found (tried {', '.join(tried)}); set "
                      f"{env_var}")


def canonical_name(name: str, choices: tuple[str, ...], field: str) -> str:
    """The entry of ``choices`` that ``name`` spells (case and separators ignored)."""
    key = str(name).replace("-", "").replace("_", "").replace(" ", "").lower()
    for c in choices:
        if c.lower() == key:
            return c
    raise ConfigError(field, name, f"must be one of {', '.join(choices)}")


def data_dir(path: str | Path | None = None) -> Path:
    """The benchmark data folder (holding ``data/``); ConfigError naming the places tried
    (only ``path`` when it is given)."""
    return benchmark_folder(path, ENV_VAR, "rths-benchmark", "data", "data",
                            "data/ground_motion_<name>.csv", "data/ folder")


def excitation_name(name: str) -> str:
    """Canonical record name for ``name`` (case and separators ignored)."""
    return canonical_name(name, EXCITATIONS, "excitation")


def load_excitation(name: str, intensity: float = 0.4, path: str | Path | None = None
                    ) -> GroundMotion:
    """Ground motion ``name`` scaled by ``intensity`` (the Simulink gain eq_intensity)."""
    e = excitation_name(name)
    return load_ground_motion(data_dir(path) / "data" / f"ground_motion_{e}.csv",
                              scale=intensity, name=e)


@dataclass(frozen=True)
class ControllerParams:
    """The tracking controller.

    By default the benchmark's sample controller: PI ``K_p + K_i/s`` (kp, ki in 1/s) on the
    tracking error and the phase lead ``(n₁ s + n₀)/(s + d₀)`` on the numerical displacement,
    both by Tustin at dt. ``tracking`` / ``lead`` replace them by any discrete controller of
    order ≤ 1 (e.g. from :func:`rths3d.lti.controller_from_dict`); ``phase_lead=False``
    removes the lead (unit gain).
    """

    kp: float = 2.0
    ki: float = 95.0  # 1/s
    lead_num: tuple[float, float] = (50.83163360273612, 8570.397339444286)
    lead_den: tuple[float, float] = (1.0, 8570.397339444286)
    phase_lead: bool = True
    tracking: DifferenceEquation | None = None
    lead: DifferenceEquation | None = None


@dataclass(frozen=True)
class BenchmarkConfig:
    """One benchmark run (defaults: the published setting, case 1).

    Attributes
    ----------
    case: partitioning case 1–4.
    excitation: ``ElCentro | Kobe | Morgan``; intensity: scale of the record (0.4).
    dt: sample period of controller, converters and RK4 (s), 1/4096.
    plant: :class:`PlantParams` (nominal by default).
    controller: :class:`ControllerParams`.
    noise: sensor noise on/off; noise_generator ``simulink`` (Random Number block emulation,
      the published realisation for seed 0) or ``numpy``; noise_seed; noise_cov_d (m²·s) and
      noise_cov_f (N²·s) the band-limited white-noise powers; noise_shared: one normalised
      sequence for both channels (as both Simulink blocks share a seed).
    force_delay: the one-sample unit delay on the measured force (True in the benchmark).
    quantize: A/D and D/A quantisation (interval q, m) and saturation (±sat, in m).
    derivative: CSI/force derivative blocks ``simulink`` (backward differences) or ``exact``
      (CSI from the state velocity; force derivatives stay backward differences).
    ground_interp: ground acceleration at RK4 stages: ``linear`` (From File block with
      interpolation, the benchmark), ``hold`` (ẍ_g(t_k) held over each RK4 step) or
      ``record_hold`` (the record itself held between its samples, no interpolation).
    reference: discretisation of the reference response, ``foh`` (lsim) or ``zoh``.
    force_limit: |F_act| limit in N (8900); the run stops when reached.
    convention: J1–J9 convention of :mod:`rths3d.metrics.criteria`.
    """

    case: int = 1
    excitation: str = "ElCentro"
    intensity: float = 0.4
    dt: float = 1.0 / 4096.0
    plant: PlantParams = field(default_factory=PlantParams)
    controller: ControllerParams = field(default_factory=ControllerParams)
    noise: bool = True
    noise_generator: str = "simulink"
    noise_seed: int = 0
    noise_cov_d: float = 6.25e-14
    noise_cov_f: float = 1.16e-3
    noise_shared: bool = True
    force_delay: bool = True
    quantize: bool = True
    q: float = 2.0**-18
    sat: float = 3.8
    derivative: str = "simulink"
    ground_interp: str = "linear"
    reference: str = "foh"
    force_limit: float = 8900.0
    convention: str = "code"
    t_end: float | None = None

    def __post_init__(self) -> None:
        if self.case not in (1, 2, 3, 4):
            raise ConfigError("case", self.case, "must be 1, 2, 3 or 4")
        object.__setattr__(self, "excitation", excitation_name(self.excitation))
        checks = [
            ("intensity", self.intensity, math.isfinite(self.intensity) and self.intensity > 0,
             "must be finite and > 0"),
            ("dt", self.dt, self.dt > 0.0 and self.dt <= 0.01, "must be in (0, 0.01] s"),
            ("q", self.q, self.q >= 0.0, "must be ≥ 0 m"),
            ("sat", self.sat, self.sat > 0.0, "must be > 0 m"),
            ("noise_cov_d", self.noise_cov_d, self.noise_cov_d >= 0.0, "must be ≥ 0"),
            ("noise_cov_f", self.noise_cov_f, self.noise_cov_f >= 0.0, "must be ≥ 0"),
            ("force_limit", self.force_limit, self.force_limit > 0.0, "must be > 0 N"),
            ("noise_generator", self.noise_generator,
             self.noise_generator in ("simulink", "numpy"), "must be 'simulink' or 'numpy'"),
            ("derivative", self.derivative, self.derivative in ("simulink", "exact"),
             "must be 'simulink' or 'exact'"),
            ("ground_interp", self.ground_interp,
             self.ground_interp in ("linear", "hold", "record_hold"),
             "must be 'linear', 'hold' or 'record_hold'"),
            ("reference", self.reference, self.reference in ("foh", "zoh"),
             "must be 'foh' or 'zoh'"),
            ("convention", self.convention, self.convention in ("code", "paper"),
             "must be 'code' or 'paper'"),
        ]
        if self.t_end is not None:
            checks.append(("t_end", self.t_end, self.t_end > 0.0, "must be > 0 s"))
        for name, value, ok, limit in checks:
            if not ok:
                raise ConfigError(name, value, limit)
