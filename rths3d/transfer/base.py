"""The transfer-system component: what the loop drives, one class per kind, registered.

A transfer system moves the experimental part to the numerical substructure's command and
measures its restoring force, for K tests at once. The loop never asks which kind it holds:
everything it needs is in :class:`TransferSystem` —

- ``step(z, zdot)``: command z (K, n_if) for the end of the step (and its rate); afterwards
  ``z_meas`` (achieved z') and ``f_meas`` (measured F'_m) hold the step's result;
- ``stopped``/``reasons``: tests the bench itself halted (e.g. a leg limit of the platform);
- ``metas``: each test's transfer metadata for its record (``transfer_meta``);
- ``signals``: the extra record signals it adds (e.g. the platform's commanded and measured
  pose), as :class:`RecordSignal`; ``part_model``: which model of the part it moves
  (``numpy`` or ``mujoco``), so that the reference z^r uses the same;
- ``compiled()``: its per-step kernels for the compiled loop (:mod:`rths3d.stepping`), or
  None when part of it runs in Python (MuJoCo); the loop then steps it from Python, and the
  record's ``loop`` metadata says which path ran;
- the classmethods ``build(scenes, …)`` and ``batch_key(settings)``: how to make one for K
  tests and which settings must be equal for tests stepped together; ``threads_over_tests(
  scene, specimen)``: whether a big batch may be stepped as slices of tests on threads
  (each test's rows independent of the others', no thread pool of its own). The rule is written once
  here and used by the loop (:func:`batch_key` of a scene) and by the sweeps (of a test's
  parameters), so both group tests alike.

A new kind is one class in one file decorated with :func:`register_transfer`.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, ClassVar, NamedTuple, Protocol

import numpy as np

from ..config import Scene
from ..errors import ConfigError

__all__ = ["TRANSFERS", "CompiledTransfer", "RecordSignal", "TransferSystem", "batch_key",
           "build_transfer", "effect_labels", "effect_on", "register_transfer", "sensor_key",
           "setting", "transfer_class", "transfer_kinds"]


@dataclass(frozen=True)
class RecordSignal:
    """An extra record signal of a transfer system: columns ``<name>.<label>``.

    ``source`` is a live (K, w) array the loop copies after every step; ``convert`` turns a
    block of those copies (rows, K, w) into the record's values (rows, K, len(labels)) when
    the record is written (default: the copies themselves, w = len(labels)).
    """

    name: str
    labels: tuple[str, ...]
    source: np.ndarray
    convert: Callable[[np.ndarray], np.ndarray] | None = None
    initial: np.ndarray | None = None
    """The (w,) value of every row before the first step, or (K, w) one per test (default
    zeros)."""

    @property
    def columns(self) -> list[str]:
        return [f"{self.name}.{lab}" for lab in self.labels]


class CompiledTransfer(NamedTuple):
    """A transfer system's per-step kernels and their arrays, for the compiled loop.

    Stages, each over R = K·n_if rows: the compensator (``comp``: (kernel,), params, state),
    the actuator chain (``act``: kernels, params, states; an empty chain is one pass-through
    block), the part model (``part``: (kernel,), params, state; z_from → z_to gives F) and
    the sensor chain (``sens``). Kernels come in tuples, so numba types them as first-class
    functions of their signature and caches the loop once for any component.
    ``act_noise``/``sens_noise`` draw the chains' noise (or None).
    """

    comp: tuple[Any, np.ndarray, np.ndarray]
    act: tuple[tuple, tuple, tuple]
    part: tuple[Any, np.ndarray, np.ndarray]
    sens: tuple[tuple, tuple, tuple]
    act_noise: Any
    sens_noise: Any


class TransferSystem(Protocol):
    """What the loop drives (see the module docstring). Arrays are over K tests."""

    kind: ClassVar[str]
    K: int
    n_if: int
    z_meas: np.ndarray
    f_meas: np.ndarray
    stopped: np.ndarray
    reasons: list[str]
    metas: list[dict[str, Any]]
    signals: tuple[RecordSignal, ...]
    part_model: str
    """The part's model, ``numpy`` or ``mujoco``: the reference z^r uses the same."""
    replays_bench: ClassVar[bool]
    """Its physics is the Stewart bench model (:class:`rths3d.bench.Bench`) that the
    diagnosis replays; a record made through another system is replayed through that bench
    with the same servo settings. Absent: False."""

    @classmethod
    def build(cls, scenes: Sequence[Scene], *, nthread: int = 0,
              specimen: str = "auto") -> TransferSystem: ...

    @classmethod
    def batch_key(cls, settings: Mapping[str, Any]) -> Hashable: ...

    @classmethod
    def threads_over_tests(cls, scene: Scene, specimen: str) -> bool:
        """Whether :func:`~rths3d.loop.run_batch` may step a big batch of this kind as
        slices of tests on threads, each slice built and stepped on its own: the tests'
        rows are independent (seeded per test) and the system keeps no thread pool of its
        own (the platform's MuJoCo batch has one)."""
        ...

    def reset(self) -> None: ...

    def step(self, z: np.ndarray, zdot: np.ndarray) -> None: ...

    def compiled(self) -> CompiledTransfer | None: ...

    def closed_range(self, group: Any) -> Callable[[int, int], int] | None:
        """A system without a 1-D kernel (:meth:`compiled` None) that steps the whole loop
        in compiled ranges itself: ``run(n0, n1)`` for a loop group, returning the steps
        done; None: the loop steps it from Python."""
        ...


TRANSFERS: dict[str, type] = {}
"""Registered transfer systems by kind."""


def register_transfer(cls: type) -> type:
    """Class decorator: register ``cls`` under ``cls.kind``."""
    if not getattr(cls, "kind", ""):
        raise ValueError(f"{cls.__name__}: kind is empty")
    TRANSFERS[cls.kind] = cls
    return cls


def transfer_kinds() -> tuple[str, ...]:
    """The registered kinds of transfer system."""
    return tuple(TRANSFERS)


def transfer_class(kind: str) -> Any:
    """The transfer system of ``kind``, or a ConfigError naming the registered kinds."""
    try:
        return TRANSFERS[kind]
    except KeyError:
        raise ConfigError("transfer.kind", kind,
                          f"must be one of {', '.join(TRANSFERS)}") from None


def setting(settings: Mapping[str, Any], key: str, default: float) -> float:
    """The number ``settings[key]`` (default when absent), or a ConfigError naming the key."""
    v = settings.get(key, default)
    if isinstance(v, bool) or not isinstance(v, int | float):
        raise ConfigError(key, v, "must be a number")
    return float(v)


def effect_labels(settings: Mapping[str, Any]) -> list[tuple[str, str, float]]:
    """The bench effects of flat settings (``effect.<label>`` keys): (name, label, value)."""
    return [(k[len("effect."):].split(".")[0], k[len("effect."):], float(v))
            for k, v in settings.items() if k.startswith("effect.")]


def effect_on(settings: Mapping[str, Any], name: str) -> bool:
    """Whether the effect ``name`` acts (anywhere, at a value other than its off value)."""
    from ..effects import get_effect

    return any(n == name and not get_effect(n).is_off(v)
               for n, _, v in effect_labels(settings))


def sensor_key(settings: Mapping[str, Any]) -> tuple:
    """The force sensor's structure (which of its effects act); their values and the noise
    seed are per test."""
    s = settings
    return (s.get("sensor.kind", "ideal") == "first_order", effect_on(s, "fts_lowpass"),
            setting(s, "sensor.gain", 1.0) != 1.0, setting(s, "sensor.offset", 0.0) != 0.0,
            setting(s, "sensor.noise_std", 0.0) > 0.0 or effect_on(s, "sensor_noise"),
            setting(s, "sensor.delay", 0.0) > 0.0)


def batch_key(settings: Mapping[str, Any] | Scene) -> tuple:
    """Tests with equal keys can be stepped together: the time grid, the interface, the
    numerical integrator and Γ, and what the transfer system's own rule
    (``batch_key(settings)`` of its class) says. ``settings``: a scene, or the flat dotted
    settings of one (:meth:`~rths3d.config.Scene.params`, or a sweep's base scene with a
    test's parameters over it)."""
    s = settings.params() if isinstance(settings, Scene) else settings
    kind = s.get("transfer.kind", "ideal")
    gamma = s.get("numerical.gamma", ())
    return (kind, setting(s, "dt", 1e-3), setting(s, "duration", 10.0),
            s.get("numerical.integrator", "exact"), s.get("numerical.kind", "linear"),
            np.asarray(gamma, dtype=float).tobytes() if len(gamma) else b"",
            transfer_class(kind).batch_key(s))


def build_transfer(scene: Scene, K: int, experiments: Sequence[Any] | None = None,
                   nthread: int = 0, specimen: str = "auto", *,
                   scenes: Sequence[Scene] | None = None) -> TransferSystem:
    """The transfer system of ``scene`` (its kind) for K tests.

    ``scenes``: one per test when their settings differ (within one :func:`batch_key`);
    default: K copies of ``scene``. ``experiments``: per-test parts (replacing each scene's).
    ``specimen``: the part model, ``numpy``, ``mujoco`` or ``auto`` (numpy where the part
    has one; ignored by the Stewart platform, which carries the part in MuJoCo).
    """
    per_test = list(scenes) if scenes is not None and K > 1 else [scene] * K
    if len(per_test) != K:
        raise ValueError(f"scenes: {len(per_test)} given for K = {K} tests")
    if experiments is not None:
        per_test = [replace(s, experiment=e) for s, e in zip(per_test, experiments, strict=True)]
    return transfer_class(scene.transfer.kind).build(per_test, nthread=nthread,
                                                     specimen=specimen)
