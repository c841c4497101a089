"""A two-storey shear frame with yielding storeys (OpenSees ``Steel02``), for a hybrid test.

Floors: nodes 2 and 3 (one horizontal DOF each, 1-D model) of 40 kg and 30 kg over the
fixed base node 1. Each storey is a ``zeroLength`` element of a Giuffrè–Menegotto–Pinto
steel material: initial stiffness 4e4 N/m (storey 1) and 3e4 N/m (storey 2), yield at a
drift of 4 mm (160 N and 120 N), 2 % strain hardening. Rayleigh damping of 2 % in both
elastic modes on the initial stiffness (``-doRayleigh 1``: zeroLength elements take no
Rayleigh damping without it). The roof (node 3, DOF 1) is the interface; elements 1 and 2
are the storeys whose shear and drift the record keeps (``numerical.elements``).
"""

import math

import numpy as np

MASSES = (40.0, 30.0)          # kg, floors 1 and 2
STIFFNESS = (4.0e4, 3.0e4)     # N/m, storeys 1 and 2 (initial)
YIELD_DRIFT = 0.004            # m
HARDENING = 0.02               # post-yield / initial stiffness
ZETA = 0.02                    # damping ratio in both elastic modes


def rayleigh_factors() -> tuple[float, float]:
    """(a0, a1) of C = a0 M + a1 K_init giving ZETA in both elastic modes."""
    m1, m2 = MASSES
    k1, k2 = STIFFNESS
    M = np.diag([m1, m2])
    K = np.array([[k1 + k2, -k2], [-k2, k2]])
    w = np.sqrt(np.sort(np.linalg.eigvals(np.linalg.solve(M, K)).real))
    a1 = 2 * ZETA / (w[0] + w[1])
    return a1 * w[0] * w[1], a1


def build(ops) -> None:
    ops.model("basic", "-ndm", 1, "-ndf", 1)
    for tag in (1, 2, 3):
        ops.node(tag, 0.0)
    ops.fix(1, 1)
    for tag, m in zip((2, 3), MASSES, strict=True):
        ops.mass(tag, m)
    for i, k in enumerate(STIFFNESS, start=1):
        fy = k * YIELD_DRIFT
        ops.uniaxialMaterial("Steel02", i, fy, k, HARDENING, 18.0, 0.925, 0.15)
        ops.element("zeroLength", i, i, i + 1, "-mat", i, "-dir", 1, "-doRayleigh", 1)
    a0, a1 = rayleigh_factors()
    ops.rayleigh(a0, 0.0, a1, 0.0)
    assert math.isfinite(a0 + a1)
