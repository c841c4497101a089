"""The maRTHS numerical substructure from an OpenSees model, stepped in the benchmark loop.

:class:`OpenSeesFrame` replaces the benchmark's own Newmark step of K_N, C_N, M_N
(:func:`.model.newmark_step`) in :func:`.engine.run_marths` (``numerical=``): a model file
with ``build(ops)`` (``scenes/opensees/marths_frame.py`` builds the 29-DOF frame from the
benchmark's K and M) whose SAP2000 equation e is node ``nodes[e]`` (default: node e), DOF 1.
Each sample k: the loads of the benchmark's R̄ — −F at the interface equations 27, 21, 29
(the specimen's force F27 and moments, signed as the benchmark's F vector) and
−m_e ẍ_g(t_k) at the floor sways 13, 26, 27 with the model's own nodal masses — imposed
through one ``Constant`` pattern per loaded equation scaled by a ``parameter``
(``updateParameter``, no domain change), then one ``analyze(1, dt)`` with OpenSees'
``Newmark 0.5 0.25`` from rest (no initial-acceleration solve, as the benchmark): the load
of sample k acts at the end of the step, whose displacement is U(t_k).

One OpenSees domain per process: one trial (plant) per run.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ...errors import ConfigError
from ...numerical.opensees import load_build, opensees_module
from .model import EQ_GROUND, EQ_R2, EQ_R3, EQ_THETA, EQ_THETA2, EQ_X, EQ_X2, EQ_X3

__all__ = ["OUTPUTS", "OpenSeesFrame"]

OUTPUTS = (EQ_X, EQ_THETA, EQ_X2, EQ_R2, EQ_X3, EQ_R3)
"""Equations read back each step (the benchmark's logged numerical signals)."""
LOADED = (EQ_X, EQ_THETA, EQ_THETA2) + tuple(e for e in EQ_GROUND if e != EQ_X)
"""Equations loaded each step: the interface (force) and the other floor sways (ground)."""
_TAG = 980000


class OpenSeesFrame:
    """An OpenSees model as the maRTHS numerical substructure (see the module docstring).

    ``model``: the model file; ``dt``: the benchmark's sample time (s); ``nodes``: SAP2000
    equation → node tag of every equation the benchmark loads or reads (default: the same
    number); ``algorithm``: ``Linear`` (the frame is linear) or ``Newton``."""

    def __init__(self, model: str | Path, dt: float,
                 nodes: Mapping[int, int] | None = None, algorithm: str = "Linear"):
        path = Path(model).resolve()
        if not path.is_file():
            raise ConfigError("opensees model", str(model), "file not found")
        if not dt > 0.0:
            raise ConfigError("dt", dt, "must be > 0 s")
        if algorithm not in ("Linear", "Newton"):
            raise ConfigError("algorithm", algorithm, "must be Linear or Newton")
        self.model, self.dt, self.algorithm = str(path), float(dt), algorithm
        self.nodes = {e: int((nodes or {}).get(e, e)) for e in set(OUTPUTS) | set(LOADED)}
        self.u = np.zeros(len(OUTPUTS))
        """U at :data:`OUTPUTS` after the last step (m, rad)."""
        self.reason = ""
        fd, self._log = tempfile.mkstemp(prefix="rths3d-marths-opensees-", suffix=".log")
        os.close(fd)
        self.ops = opensees_module()
        self._build()

    def _build(self) -> None:
        ops = self.ops
        build = load_build(self.model, "opensees model")
        ops.wipe()
        ops.logFile(self._log, "-noEcho")
        try:
            build(ops)
        except Exception as exc:  # the user's model
            raise ConfigError("opensees model", self.model,
                              f"build(ops) failed: {type(exc).__name__}: {exc}") from None
        have = set(ops.getNodeTags())
        for e, node in sorted(self.nodes.items()):
            if node not in have:
                raise ConfigError("opensees model", self.model,
                                  f"has no node {node} for equation {e}")
        self.mass = {e: float(ops.nodeMass(self.nodes[e], 1)) for e in EQ_GROUND}
        """The model's mass at each floor sway (kg): the ground load's."""
        for i, e in enumerate(LOADED):
            tag = _TAG + i
            ops.timeSeries("Constant", tag)
            ops.pattern("Plain", tag, tag)
            ops.load(self.nodes[e], 1.0)
            ops.parameter(tag, "loadPattern", tag, "loadAtNode", self.nodes[e], 1)
        ops.constraints("Transformation")
        ops.numberer("RCM")
        ops.system("BandGen")
        ops.test("NormDispIncr", 1e-12, 10)
        ops.algorithm(self.algorithm)
        ops.integrator("Newmark", 0.5, 0.25)
        ops.analysis("Transient")
        self._update, self._analyze, self._disp = ops.updateParameter, ops.analyze, ops.nodeDisp
        self._out = tuple(self.nodes[e] for e in OUTPUTS)
        self._m = tuple(self.mass.get(e, 0.0) for e in LOADED)
        self.u[:] = 0.0

    def reset(self) -> None:
        """At rest at t = 0 (the model rebuilt when it has been stepped)."""
        if self.ops.getTime() != 0.0:
            self._build()
        self.u[:] = 0.0
        self.reason = ""

    def step(self, ag: float, force: np.ndarray) -> bool:
        """Sample k: ground acceleration ``ag`` (m/s²) and the benchmark's F at equations
        27, 21, 29 (N, N·m); U at :data:`OUTPUTS` into :attr:`u`. False (and
        :attr:`reason`) when OpenSees does not converge."""
        upd = self._update
        f = (float(force[0]), float(force[1]), float(force[2]), 0.0, 0.0)
        for i, m in enumerate(self._m):
            upd(_TAG + i, -f[i] - m * ag)
        if self._analyze(1, self.dt) != 0:
            self.reason = (f"the OpenSees model did not converge at t = "
                           f"{self.ops.getTime():.4f} s")  # the committed time: the failed sample's
            return False
        disp, u = self._disp, self.u
        for i, node in enumerate(self._out):
            u[i] = disp(node, 1)
        return True

    def close(self) -> None:
        """Wipe the domain and remove the OpenSees log."""
        self.ops.wipe()
        Path(self._log).unlink(missing_ok=True)

    def __enter__(self) -> OpenSeesFrame:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()
