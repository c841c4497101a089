"""The paper's linear numerical substructure (Fig. 5, Table 2) as an OpenSees model.

One node (2) of mass m = 20 kg on a zeroLength spring k = 1e4 N/m with a viscous damper
c = 100 N·s/m to the fixed node 1, one DOF (1-D model): the interface DOF z is node 2, DOF 1.
rths3d calls ``build(ops)`` with ``openseespy.opensees`` and adds the analysis, the
excitation and the interface force itself.
"""

M = 20.0      # kg
K = 1.0e4     # N/m
C = 100.0     # N·s/m


def build(ops) -> None:
    ops.model("basic", "-ndm", 1, "-ndf", 1)
    ops.node(1, 0.0)
    ops.node(2, 0.0)
    ops.fix(1, 1)
    ops.mass(2, M)
    ops.uniaxialMaterial("Elastic", 1, K)
    ops.uniaxialMaterial("Viscous", 2, C, 1.0)
    ops.uniaxialMaterial("Parallel", 3, 1, 2)
    ops.element("zeroLength", 1, 1, 2, "-mat", 3, "-dir", 1)
