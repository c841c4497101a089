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


def build_numerical(scenes, method: str | None = None) -> LinearSubstructure:
    """The :class:`LinearSubstructure` of K scenes, their loads included (see
    :meth:`LinearSubstructure.from_scenes`)."""
    return LinearSubstructure.from_scenes(scenes, method)


__all__ = [
    "CubicSpringSubstructure",
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
