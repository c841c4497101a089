"""The maRTHS partitioned frame through the MuJoCo Stewart platform: the scene.

The numerical substructure is the benchmark's (:func:`rths3d.community.marths.model.
partition`: the 29-DOF reference minus the code's ideal physical model), reduced exactly to
its DOFs with mass plus the interface rotation θ = −U21 (the other rotations are massless:
static condensation, which is exact for a Rayleigh-damped structure from rest — the ideal
physical model's own damping on θ29 aside), with ``J_THETA`` added on θ because a scene's
mass matrix must be positive definite. The interface DOFs are x = U27 (the platform's x)
and θ = −U21 (the platform's ry); the experimental part is
:class:`rths3d.experiment.marths_frame.MarthsFramePart`; the ground motion is the record's
CSV of the benchmark folder, scaled by the intensity, loading the three floor sways through
M_N (as the benchmark does).

``python -m rths3d.community.marths.stewart [--data DIR] [--out FILE]`` writes the scene
(``scenes/marths_stewart.toml``).
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .data import data_dir
from .engine import structure
from .model import EQ_THETA, EQ_X

__all__ = ["J_THETA", "StewartPartition", "stewart_partition", "stewart_scene"]

J_THETA = 1.0e-3
"""Rotational inertia (kg·m²) added on the numerical θ21 (massless in the benchmark; the
frame's own 0.89 kg·m² is on the experimental part)."""


@dataclass(frozen=True, eq=False)
class StewartPartition:
    """Reduced numerical substructure: M, C, K (n × n, SI), the ground influence vector
    ``l`` (n,), Γ (n × 2 over x, ry), ``keep`` (the 29-DOF indices kept) and the reduction
    ``T`` (29 × n: U = T u)."""

    M: np.ndarray
    C: np.ndarray
    K: np.ndarray
    l: np.ndarray  # noqa: E741 (the benchmark's name)
    gamma: np.ndarray
    keep: np.ndarray
    T: np.ndarray


def stewart_partition(data_path: str | None = None) -> StewartPartition:
    """The benchmark's numerical substructure reduced to its mass DOFs plus θ21."""
    p = structure(data_path)
    ix, ith = EQ_X - 1, EQ_THETA - 1
    mass = np.diag(p.MN) > 0
    mass[ith] = True
    keep = np.flatnonzero(mass)
    drop = np.flatnonzero(~mass)
    T = np.zeros((p.KN.shape[0], keep.size))
    T[keep, np.arange(keep.size)] = 1.0
    T[np.ix_(drop, np.arange(keep.size))] = -np.linalg.solve(p.KN[np.ix_(drop, drop)],
                                                             p.KN[np.ix_(drop, keep)])
    sym = lambda a: 0.5 * (a + a.T)  # noqa: E731
    M = sym(T.T @ p.MN @ T)
    j = int(np.flatnonzero(keep == ith)[0])
    M[j, j] += J_THETA
    G = np.zeros((keep.size, 2))
    G[int(np.flatnonzero(keep == ix)[0]), 0] = 1.0
    G[j, 1] = -1.0
    return StewartPartition(M, sym(T.T @ p.CN @ T), sym(T.T @ p.KN @ T), p.l[keep], G,
                            keep, T)


def _mat(a: np.ndarray) -> str:
    return "[" + ", ".join("[" + ", ".join(f"{v:.17g}" for v in row) + "]" for row in a) + "]"


def stewart_scene(data_path: str | None = None, record: str = "ElCentro",
                  intensity: float = 0.02, duration: float = 6.0) -> str:
    """The scene's TOML text: ``duration`` s of the record (s, m/s²) from the sample before
    its first non-zero one (t = 0 there), written into it."""
    sp = stewart_partition(data_path)
    vec = ", ".join(f"{v:.17g}" for v in sp.l)
    rec = np.loadtxt(data_dir(data_path) / "data" / f"ground_motion_{record}.csv",
                     delimiter=",", skiprows=1)
    t0 = rec[np.flatnonzero(rec[:, 1])[0], 0] - (rec[1, 0] - rec[0, 0])
    rec = rec[(rec[:, 0] >= t0) & (rec[:, 0] <= t0 + duration + 1e-9)]
    times = ", ".join(f"{v - t0:.6g}" for v in rec[:, 0])
    values = ", ".join(f"{v:.9g}" for v in rec[:, 1])
    return f"""\
# maRTHS (Condori Uribe et al. 2023) through the MuJoCo Stewart platform: the benchmark's
# partitioned one-bay frame, written by `python -m rths3d.community.marths.stewart` from
# rths3d.community.marths (docs/marths.md, "Through the Stewart platform"):
# - [numerical] M, C, K: the benchmark's numerical substructure (29-DOF SAP2000 reference
#   minus the code's ideal physical model, Rayleigh 5 %; model.partition) reduced to the
#   DOFs with mass plus the interface rotation (29-DOF indices
#   {sp.keep.tolist()}), the massless rotations condensed
#   statically; {J_THETA:g} kg·m² added on θ21 (massless there).
# - gamma: x = U27 -> platform x, θ = -U21 -> platform ry.
# - [excitation]: the benchmark's {record} ground acceleration (m/s²,
#   data/ground_motion_{record}.csv, {duration:g} s from its onset at {t0:g} s) × {intensity:g}
#   on the floor sways
#   (direction = the benchmark's influence vector l), loaded through M_N as the benchmark does.
# - [experiment] marths_frame: the benchmark's 5-DOF specimen condensed to (x, θ), base fixed
#   to the world (rths3d/experiment/marths_frame.py).
# - [transfer], [safety]: the project's Stewart platform, its defaults; the force limits sized
#   for the frame's 2.3e6 N/m.
name = "marths_stewart"
dofs = ["x", "ry"]
dt = 0.001
duration = {duration:g}

[numerical]
M = {_mat(sp.M)}
C = {_mat(sp.C)}
K = {_mat(sp.K)}
gamma = {_mat(sp.gamma)}

[excitation]
kind = "ground"
signal = "array"
times = [{times}]
values = [{values}]
scale = {intensity:g}
direction = [{vec}]

[experiment]
kind = "marths_frame"
substeps = 4

[transfer]
kind = "stewart"
delay = 0.0
substeps = 1

[safety]
stroke = 0.04
rotation = 0.2
force = 20000.0
torque = 5000.0
"""


def main(argv: Sequence[str] | None = None) -> None:
    import argparse

    ap = argparse.ArgumentParser(description="write the maRTHS Stewart-platform scene")
    ap.add_argument("--data", default=None, help="maRTHS benchmark folder holding data/")
    ap.add_argument("--out", default=os.path.join("scenes", "marths_stewart.toml"))
    args = ap.parse_args(argv)
    with open(args.out, "w", encoding="utf-8") as f:
        f.write(stewart_scene(args.data))


if __name__ == "__main__":
    main()
