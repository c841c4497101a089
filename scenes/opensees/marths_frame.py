"""The maRTHS benchmark's numerical substructure as an OpenSees model, built from the
benchmark's own data (Condori Uribe et al. 2023; FermandoisLab/maRTHS-bmk-RoDeAC).

The 29-DOF reference frame is a SAP2000 export of K and M (``data/reference_K.csv``,
``data/reference_M.csv``; equation order 1…29). OpenSees has no element that takes a full
matrix, so the frame is written as springs: one node per equation (``-ndm 1 -ndf 1``; node
tag = SAP2000 equation number, DOF 1), a fixed ground node 100, and for every non-zero
off-diagonal K_ij a ``zeroLength`` spring of stiffness −K_ij between nodes i and j, plus a
spring of the row sum Σ_j K_ij from node i to the ground. The assembled stiffness is K
(to rounding). The masses are the diagonal of M (rotations massless).

Damping as the benchmark states it (``build_reference.m``): Rayleigh 5 % at 13.493 and
165.125 rad/s (SAP2000 modes 1 and 3) on the reference, ``rayleigh(α, β, 0, 0)`` with the
springs' ``-doRayleigh 1``.

The numerical substructure is the reference minus the "ideal" 3-DOF physical model of
``build_physical_ideal.m`` at equations [27, 29, 21] (``data/partitioning.json``: KP, MP,
CP): three more springs of stiffness −KP (no Rayleigh) whose material viscosity carries
−CP, the floor-1 mass reduced by MP₁₁, and the α·MP₁₁ the Rayleigh mass term loses with it
given back as a dashpot at equation 27 — so C_N = α M_ref + β K_ref − CP, as the benchmark's
code forms it.

Interface: equations 27 (floor-1 sway x), 21 (rotation of joint 7, θ = −U21) and 29
(rotation of joint 6): nodes 27, 21 and 29, DOF 1. The ground acceleration loads the floor
sways 13, 26, 27 through their masses (the benchmark's influence vector).
"""

import json
import os
from pathlib import Path

import numpy as np

GROUND = 100                       # fixed ground node
EQUATIONS = 29
INTERFACE = (27, 29, 21)           # the ideal physical model's DOF order (x, θ29, θ21)
OMEGA = (13.493, 165.125)          # rad/s, Rayleigh anchors (SAP2000 modes 1 and 3)
ZETA = 0.05


def data_folder() -> Path:
    """The benchmark folder: $RTHS3D_MARTHS_DIR, else ../shared/external/marths-benchmark
    beside the repository."""
    env = os.environ.get("RTHS3D_MARTHS_DIR")
    if env:
        return Path(env)
    return Path(__file__).resolve().parents[3] / "shared" / "external" / "marths-benchmark"


def rayleigh_factors() -> tuple[float, float]:
    """(α in 1/s, β in s): ½ [[1/ω_i, ω_i], [1/ω_j, ω_j]] [α, β] = [ζ, ζ]."""
    wi, wj = OMEGA
    return tuple(np.linalg.solve(0.5 * np.array([[1 / wi, wi], [1 / wj, wj]]), [ZETA, ZETA]))


def _springs(ops, tag: int, mat: int, nodes, K, C, rayleigh: bool) -> tuple[int, int]:
    """Springs (and dashpots) assembling the symmetric K and C over ``nodes``; returns the
    next free element and material tags."""
    n = len(nodes)
    flag = ("-doRayleigh", 1 if rayleigh else 0)
    for i in range(n):
        for j in range(i, n):
            if i == j:
                k, c = float(np.sum(K[i])), float(np.sum(C[i]))
                a, b = GROUND, nodes[i]
            else:
                k, c = -float(K[i, j]), -float(C[i, j])
                a, b = nodes[i], nodes[j]
            if k == 0.0 and c == 0.0:
                continue
            ops.uniaxialMaterial("Elastic", mat, k, c)
            ops.element("zeroLength", tag, a, b, "-mat", mat, "-dir", 1, *flag)
            tag += 1
            mat += 1
    return tag, mat


def build(ops) -> None:
    d = data_folder() / "data"
    K = np.loadtxt(d / "reference_K.csv", delimiter=",")
    M = np.loadtxt(d / "reference_M.csv", delimiter=",")
    ideal = json.loads((d / "partitioning.json").read_text())["physical_ideal_3dof"]
    KP, MP, CP = (np.array(ideal[key], float) for key in ("KP", "MP_full", "CP"))
    alpha, beta = rayleigh_factors()

    ops.model("basic", "-ndm", 1, "-ndf", 1)
    ops.node(GROUND, 0.0)
    ops.fix(GROUND, 1)
    for e in range(1, EQUATIONS + 1):
        ops.node(e, 0.0)
        m = float(M[e - 1, e - 1]) - (MP[0, 0] if e == INTERFACE[0] else 0.0)
        if m > 0.0:
            ops.mass(e, m)
    # the reference frame: K as springs, Rayleigh on them
    tag, mat = _springs(ops, 1, 1, list(range(1, EQUATIONS + 1)), K,
                        np.zeros_like(K), rayleigh=True)
    # minus the ideal physical model; the Rayleigh mass term of the MP₁₁ removed kept
    D = -CP.copy()
    D[0, 0] += alpha * MP[0, 0]
    _springs(ops, tag, mat, list(INTERFACE), -KP, D, rayleigh=False)
    ops.rayleigh(alpha, beta, 0.0, 0.0)
