"""Numerical substructures: linear multi-DOF ``M ẍ + C ẋ + K x = p(t) − Γ F'_m``.

Integrators (batched over K tests), excitations (force, support motion, ground
acceleration) and eigen-analysis for the τ-ratios (paper eqs. 12–13). A single-DOF
substructure is the 1×1 case of the same code. Nonlinear substructures plug in through the
:class:`NumericalSubstructure` protocol.
"""

from .excitation import excitation_signal, load_history
from .linear import (
    Discretisation,
    LinearSubstructure,
    NumericalFactory,
    NumericalSubstructure,
    discretise,
)
from .modal import (
    coupled_fastest_eigenfrequency,
    fastest_eigenfrequency,
    interface_delay_margin,
    part_impedance,
)
from .nonlinear import CubicSpringSubstructure
from .opensees import OpenSeesSubstructure

_KINDS: dict[str, type] = {}


def register_numerical(kind: str, cls: type) -> None:
    """Join a numerical substructure to scenes' ``[numerical] kind``: ``cls.from_scenes``
    builds it, ``cls.config(section, dofs, source)`` validates its table into a
    :class:`~rths3d.config.NumericalConfig`, ``cls.section(config)`` writes it back and
    ``cls.max_batch`` (0: any) bounds the tests of one group."""
    _KINDS[kind] = cls


def numerical_class(kind: str) -> type:
    """The registered class of ``numerical.kind`` (a ConfigError naming the kinds)."""
    if kind not in _KINDS:
        from ..errors import ConfigError

        raise ConfigError("numerical.kind", kind, f"must be one of {', '.join(_KINDS)}")
    return _KINDS[kind]


def numerical_factory(scene) -> NumericalFactory:
    """The factory of the scene's numerical substructure (its ``numerical.kind``)."""
    return numerical_class(scene.numerical.kind).from_scenes


def max_batch(scene) -> int:
    """The most tests of this scene's kind one group may step together (0: any)."""
    return int(getattr(numerical_class(scene.numerical.kind), "max_batch", 0))


register_numerical("linear", LinearSubstructure)
register_numerical("opensees", OpenSeesSubstructure)


def build_numerical(scenes, method: str | None = None) -> LinearSubstructure:
    """The :class:`LinearSubstructure` of K scenes, their loads included (see
    :meth:`LinearSubstructure.from_scenes`)."""
    return LinearSubstructure.from_scenes(scenes, method)


__all__ = [
    "CubicSpringSubstructure",
    "OpenSeesSubstructure",
    "max_batch",
    "numerical_class",
    "numerical_factory",
    "register_numerical",
    "Discretisation",
    "build_numerical",
    "LinearSubstructure",
    "NumericalFactory",
    "NumericalSubstructure",
    "coupled_fastest_eigenfrequency",
    "discretise",
    "excitation_signal",
    "fastest_eigenfrequency",
    "interface_delay_margin",
    "load_history",
    "part_impedance",
]
