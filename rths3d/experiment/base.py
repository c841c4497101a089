"""The experimental-part component: one class per kind of part, registered by name.

An experimental part is the physical specimen mounted on the force-torque sensor (FTS). Its
class owns everything the rest of rths3d needs to know about it:

- ``dofs``: the interface DOFs it is tested through (the scene must name exactly these);
- :meth:`~ExperimentalPart.payload_xml` / :meth:`~ExperimentalPart.world_xml`: its MJCF
  fragments (the bodies on the FTS site, the world-fixed parts such as a contact surface),
  used by the Stewart platform and by the prescribed-mount MuJoCo model alike;
- :meth:`~ExperimentalPart.interface_matrices` and :meth:`~ExperimentalPart.damping_matrix`:
  k_EXP, m_EXP, c_EXP for the τ-ratios, the strain energy and the delay margin;
- :meth:`~ExperimentalPart.numpy_model`: a fast numpy/numba model of K such parts for the
  1-D loop and the reference, or None (then MuJoCo runs it behind a prescribed mount);
- :meth:`~ExperimentalPart.batch_key`: what must match for parts stepped together.

:func:`rths3d.experiment.build_part_model` is the one place that turns K parts into a model
that the loop, the transfer systems and the reference step (``advance(z_from, z_to) -> F``).
A new kind of part is one subclass in one file, decorated with :func:`register_part`.
"""

from __future__ import annotations

from collections.abc import Hashable, Mapping, Sequence
from typing import Any, ClassVar, Protocol

import numpy as np

from ..config import ExperimentConfig
from ..errors import ConfigError

__all__ = ["ExperimentalPart", "PartModel", "has_numpy_model", "make_part", "part_class",
           "part_kinds", "register_part", "uses_numpy"]


class PartModel(Protocol):
    """A model of K parts stepped at the interface rate (numpy, numba or MuJoCo).

    ``advance(z_from, z_to)`` moves the mount linearly from ``z_from`` to ``z_to`` ((K, n_if)
    m / rad) over one step ΔT and returns the restoring force F_m (K, n_if) (N, N·m) at its
    end; ``get_state``/``set_state`` save and restore its state (the reference iterates);
    ``compiled()`` gives (kernel, params, state) for the compiled loop, or None.
    """

    K: int
    n_if: int
    tolerance: float
    """The interface displacement (m, rad) below which the model's own arithmetic does not
    reproduce itself: the reference's default convergence tolerance."""

    def reset(self) -> None: ...

    def advance(self, z_from: np.ndarray, z_to: np.ndarray) -> np.ndarray: ...

    def get_state(self) -> Any: ...

    def set_state(self, state: Any) -> None: ...

    def compiled(self) -> tuple[Any, np.ndarray, np.ndarray] | None: ...


class ExperimentalPart:
    """Base class of an experimental part (see the module docstring).

    Subclasses set :attr:`kind` and :attr:`dofs` and implement the MJCF fragments and the
    interface matrices; :meth:`numpy_model` is optional.
    """

    kind: ClassVar[str] = ""
    dofs: ClassVar[tuple[str, ...]] = ("z",)
    has_contact: ClassVar[bool] = False
    """It meets a world-fixed surface across a gap (the gap is a property of the bench)."""
    has_spring: ClassVar[bool] = False
    """It has an interface stiffness and damping of its own (a specimen, not only a mass)."""
    rigid_payload: ClassVar[bool] = False
    """It is one rigid body on the sensor: its mass, centre of mass and inertia are what the
    bench's statics identify."""

    def __init__(self, cfg: ExperimentConfig):
        self.cfg = cfg

    # ------------------------------------------------------------------ MJCF
    def payload_xml(self) -> str:
        """Bodies of the part in the FTS site frame (attach at the site)."""
        raise NotImplementedError

    def world_xml(self, site_pos: tuple[float, float, float]) -> str:
        """World-fixed parts (e.g. a contact surface) for an FTS site at ``site_pos`` (m)."""
        return ""

    def extra_xml(self) -> str:
        """Top-level MJCF sections the part's bodies need (``<default>``, ``<asset>``,
        ``<contact>``, ``<equality>``), appended to the model; "" for none."""
        return ""

    @classmethod
    def interface_dofs(cls, cfg: ExperimentConfig) -> tuple[str, ...]:
        """The interface DOFs a part of ``cfg`` is tested through (the class's
        :attr:`dofs`, unless the configuration names them)."""
        return cls.dofs

    @classmethod
    def validate(cls, cfg: ExperimentConfig) -> None:
        """Raise :class:`ConfigError` (field, value, limit) for a configuration this part
        cannot be built from; the scene parser calls it after the generic checks."""

    # ------------------------------------------------------------------ matrices
    def interface_matrices(self) -> tuple[list[list[float]], list[list[float]]]:
        """Interface stiffness k_EXP (N/m, N·m/rad) and mass m_EXP (kg, kg·m²) matrices of the
        part as built (contact open), over :attr:`dofs`."""
        raise NotImplementedError

    def damping_matrix(self) -> list[list[float]]:
        """Interface damping c_EXP (N·s/m, N·m·s/rad) over :attr:`dofs`."""
        return [[self.cfg.d]]

    def meta(self) -> dict[str, Any]:
        """Record metadata ``experiment`` of the part (SI)."""
        k_exp, m_exp = self.interface_matrices()
        c = self.cfg
        out = {"kind": c.kind, "m_exp": c.m, "k_exp": k_exp, "m_exp_matrix": m_exp,
               "d_exp": c.d, "c_exp": self.damping_matrix(), "h0": None,
               "k_contact": c.k_contact, "d_contact": c.d_contact}
        if not has_numpy_model(c.kind):
            out["model"] = NO_TWIN
        return out

    # ------------------------------------------------------------------ models
    @classmethod
    def numpy_model(cls, cfgs: Sequence[ExperimentConfig], dt: float, *, substeps: int,
                    method: str) -> PartModel | None:
        """A numpy/numba model of K parts (one config each), or None (MuJoCo only)."""
        return None

    @classmethod
    def batch_key(cls, settings: Mapping[str, Any]) -> Hashable:
        """What must be equal for parts stepped together, from the flat scene settings
        (``experiment.*``): by default the kind and its physics substeps (every parameter may
        differ test by test: per-row arrays, or per-test MuJoCo models of one structure)."""
        return (settings.get("experiment.kind"), str(settings.get("experiment.substeps", 4)))


NO_TWIN = ("MuJoCo only, no numpy twin (on the platform, or behind a prescribed mount for "
           "the 1-D transfer systems and the reference)")
"""What a record's ``meta.experiment.model`` says of a part without a numpy model."""

PARTS: dict[str, type[ExperimentalPart]] = {}
"""Registered experimental parts by kind."""


def register_part(cls: type[ExperimentalPart]) -> type[ExperimentalPart]:
    """Class decorator: register ``cls`` under ``cls.kind``."""
    if not cls.kind:
        raise ValueError(f"{cls.__name__}: kind is empty")
    PARTS[cls.kind] = cls
    return cls


def part_kinds() -> tuple[str, ...]:
    """The registered kinds of experimental part."""
    return tuple(PARTS)


def part_class(kind: str) -> type[ExperimentalPart]:
    """The part class of ``kind``, or a ConfigError naming the registered kinds."""
    try:
        return PARTS[kind]
    except KeyError:
        raise ConfigError("experiment.kind", kind,
                          f"must be one of {', '.join(PARTS)}") from None


def make_part(cfg: ExperimentConfig) -> ExperimentalPart:
    """The part of a configuration."""
    return part_class(cfg.kind)(cfg)


def has_numpy_model(kind: str) -> bool:
    """Whether the part ``kind`` has a numpy/numba model."""
    cls = part_class(kind)
    return cls.numpy_model.__func__ is not ExperimentalPart.numpy_model.__func__  # type: ignore


def uses_numpy(cfg: ExperimentConfig, model: str = "auto") -> bool:
    """Whether ``model`` (``numpy``, ``mujoco`` or ``auto``: numpy where the part has one)
    selects the numpy model of the part."""
    if model == "mujoco":
        return False
    has = has_numpy_model(cfg.kind)
    if model == "numpy" and not has:
        raise ConfigError("specimen", "numpy", f"the {cfg.kind} part has no numpy model; "
                          "use 'mujoco' or 'auto'")
    return has
