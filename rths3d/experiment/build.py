"""The one place that turns K experimental parts into the model the loop steps."""

from __future__ import annotations

from collections.abc import Sequence

from ..config import ExperimentConfig
from ..errors import ConfigError
from .base import PartModel, part_class, uses_numpy
from .mujoco_specimen import MujocoSpecimen

__all__ = ["build_part_model"]


def build_part_model(cfgs: Sequence[ExperimentConfig], dofs: Sequence[str], dt: float, *,
                     model: str = "auto", method: str = "euler", substeps: int | None = None,
                     nthread: int = 0) -> PartModel:
    """The model of K parts (one :class:`~rths3d.config.ExperimentConfig` per test, one kind)
    that the transfer systems and the reference step.

    ``model``: ``numpy`` (the part's numpy/numba model), ``mujoco`` (MuJoCo behind a
    prescribed mount) or ``auto`` (numpy where the part has one). ``method`` and
    ``substeps`` (default: the part's ``substeps``) set the numpy model's integration
    (``euler`` as MuJoCo, ``rk4`` for the reference).
    """
    cfgs = list(cfgs)
    kinds = {c.kind for c in cfgs}
    if len(kinds) != 1:
        raise ConfigError("experiment.kind", sorted(kinds), "tests stepped together need one "
                          "kind of part")
    if uses_numpy(cfgs[0], model):
        out = part_class(cfgs[0].kind).numpy_model(cfgs, dt, substeps=substeps or
                                                   cfgs[0].substeps, method=method)
        if out is not None:
            return out
    return MujocoSpecimen(cfgs, tuple(dofs), dt, nthread=nthread)
