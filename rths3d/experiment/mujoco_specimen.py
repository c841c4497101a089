"""The MuJoCo specimen with a prescribed mount (ideal / LTI transfer), K tests batched.

The mount joints (one per interface DOF) carry a huge armature and are driven every physics
step by the generalised force that makes semi-implicit Euler land exactly on the mount's
set-point: a = ((q* − q)/h − q̇)/h, so the achieved interface motion is the piecewise-linear
path from z'_n to z'_{n+1}. The specimen feels the mount's motion through its joints and the
FTS site measures the wrench, exactly as on the platform. After the last physics step of an
interface step the forward dynamics are recomputed (``stage = acc``) so the reported wrench
belongs to the new state, not to the start of the last substep.

The measured restoring force F'_m (paper F_m) is the sensor wrench rotated to world axes,
minus its value at rest (the static preload).
"""

from __future__ import annotations

from collections.abc import Sequence

import mujoco
import mujoco.batch
import numpy as np

from ..config import ExperimentConfig
from .base import make_part
from .mjcf import MOUNT_ARMATURE, specimen_model_xml

_ORDER = ("x", "y", "z", "rz", "ry", "rx")


class MujocoSpecimen:
    """K MuJoCo specimens stepped together through ``mujoco.batch.Batch``.

    ``cfgs``: one :class:`ExperimentConfig` per test (or one for all).
    """

    tolerance = 1e-9
    """Reference convergence (m, rad): the contact solver's reproducibility."""

    def __init__(self, cfgs: ExperimentConfig | Sequence[ExperimentConfig], dofs: tuple[str, ...],
                 dt: float, K: int = 1, nthread: int = 0):
        if isinstance(cfgs, ExperimentConfig):
            cfgs = [cfgs] * K
        self.K = len(cfgs)
        self.dofs = tuple(dofs)
        self.n_if = len(dofs)
        self.dt = float(dt)
        self.substeps = cfgs[0].substeps
        h = self.dt / self.substeps
        self.h = h
        xmls = [specimen_model_xml(make_part(c), c.kind, self.dofs, h) for c in cfgs]
        self.models = [mujoco.MjModel.from_xml_string(x) for x in dict.fromkeys(xmls)]
        lookup = {x: self.models[i] for i, x in enumerate(dict.fromkeys(xmls))}
        self.model = self.models[0]
        nthread = nthread or (2 if self.K >= 8 else 1)
        # one test: a plain MjData (a batch's thread-pool dispatch costs more than the step)
        self.batch = _Single(self.model) if self.K == 1 else \
            mujoco.batch.Batch(self.model, self.K, nthread=nthread)
        if len(self.models) > 1:
            self.batch.set_models([lookup[x] for x in xmls])
        order = [d for d in _ORDER if d in self.dofs]
        # column of each interface DOF among the mount joints (qpos/qvel/qfrc indices)
        col = np.array([order.index(d) for d in self.dofs])
        self._qpos = self.batch.bind("qpos")
        self._qvel = self.batch.bind("qvel")
        self._qfrc = self.batch.bind("qfrc_applied")
        self._sens = self.batch.bind("sensordata")
        self._xmat = self.batch.bind("site_xmat")
        self._time = self.batch.bind("time") if self.K > 1 else None
        self._site = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, "fts")
        self._is_rot = np.array([d.startswith("r") for d in self.dofs])
        self._widx = np.array([("x", "y", "z", "rx", "ry", "rz").index(d) for d in self.dofs])
        self.f = np.zeros((self.K, self.n_if))
        self.wrench = np.zeros((self.K, 6))
        self._world = np.zeros((self.K, 6))
        # advance() works in these buffers; the mount columns are a slice (views, no copies)
        # whenever the interface DOFs come in the mount joints' order, as in every shipped scene
        n = self.n_if
        self._cols = slice(0, n) if np.array_equal(col, np.arange(n)) else col
        self._dz = np.zeros((self.K, n))
        self._tgt = np.zeros((self.K, n))
        self._acc = np.zeros((self.K, n))
        self.reset()

    def reset(self) -> None:
        """All tests at rest, preload measured."""
        self.batch.reset()
        self._qfrc[:] = 0.0
        self.batch.forward()
        self.preload = self._world_wrench().copy()
        self.f[:] = 0.0

    def _world_wrench(self) -> np.ndarray:
        """Sensor wrench in world axes (K, 6) in a reused buffer: [F (N), M (N·m)]."""
        R = self._xmat[:, self._site].reshape(self.K, 3, 3)
        s, w = self._sens, self._world
        np.einsum("kij,kj->ki", R, s[:, 0:3], out=w[:, 0:3])
        np.einsum("kij,kj->ki", R, s[:, 3:6], out=w[:, 3:6])
        return w

    def get_state(self) -> tuple[np.ndarray, ...]:
        """Copy of (qpos, qvel, time)."""
        t = self._time.copy() if self._time is not None else np.array([self.batch.d.time])
        return (self._qpos.copy(), self._qvel.copy(), t)

    def set_state(self, s: tuple[np.ndarray, ...]) -> None:
        """Restore a state from :meth:`get_state`."""
        self._qpos[:], self._qvel[:] = s[0], s[1]
        if self._time is not None:
            self._time[:] = s[2]
        else:
            self.batch.d.time = float(s[2][0])

    def compiled(self) -> None:
        """MuJoCo is stepped from Python: no compiled kernel (the loop's Python driver)."""
        return None

    def advance(self, z0: np.ndarray, z1: np.ndarray) -> np.ndarray:
        """Drive the mount from ``z0`` to ``z1`` (K, n_if) linearly over ΔT; return F'_m."""
        ns, h = self.substeps, self.h
        cols = self._cols
        dz, tgt, acc = self._dz, self._tgt, self._acc
        np.subtract(z1, z0, out=dz)
        for j in range(ns):
            # set-point on the straight path: z0 + (z1 − z0)·(j+1)/ns
            np.multiply(dz, (j + 1) / ns, out=tgt)
            tgt += z0
            # a = ((q* − q)/h − q̇)/h lands semi-implicit Euler on the set-point
            np.subtract(tgt, self._qpos[:, cols], out=acc)
            acc /= h
            acc -= self._qvel[:, cols]
            acc /= h
            acc *= MOUNT_ARMATURE
            self._qfrc[:, cols] = acc
            if j == ns - 1:
                self.batch.step(stage=mujoco.mjtStage.mjSTAGE_ACC)
            else:
                self.batch.step()
        np.subtract(self._world_wrench(), self.preload, out=self.wrench)
        np.take(self.wrench, self._widx, axis=1, out=self.f)
        return self.f


class _Single:
    """The part of the ``mujoco.batch.Batch`` interface used above, for one MjData."""

    def __init__(self, model: mujoco.MjModel):
        self.m = model
        self.d = mujoco.MjData(model)

    def bind(self, name: str) -> np.ndarray:
        return getattr(self.d, name)[None]

    def reset(self) -> None:
        mujoco.mj_resetData(self.m, self.d)
        mujoco.mj_forward(self.m, self.d)

    def forward(self) -> None:
        mujoco.mj_forward(self.m, self.d)

    def step(self, stage: int = 0) -> None:
        mujoco.mj_step(self.m, self.d)
        if stage == mujoco.mjtStage.mjSTAGE_ACC:
            mujoco.mj_forward(self.m, self.d)
