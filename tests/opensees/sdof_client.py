"""An OpenSees SDOF with a genericClient element: the numerical side of a hybrid test against
a SimApp server (run in its own process: OpenSees keeps the GIL in its blocking calls).

Node 1 fixed, node 2 free (1 DOF) with mass m (kg), a linear spring k (N/m, a zeroLength
element), mass-proportional damping a0·m (N·s/m) and a force F0·sin(2π f t) (N); the
genericClient joins nodes 1 and 2 (element DOFs u1, u2) and takes the lab's force.
Newmark (γ = 1/2, β = 1/4), the Linear algorithm (one trial per step). Writes the node's
displacement after every step to OUT (.npy).

Usage: python sdof_client.py PORT OUT STEPS [m k a0 F0 f dt [data_size]]
"""

import sys

import numpy as np
import openseespy.opensees as ops

port, out, steps = int(sys.argv[1]), sys.argv[2], int(sys.argv[3])
m, k, a0, F0, f, dt = (float(x) for x in (sys.argv[4:10] or
                                          (10.0, 4.0e4, 2.0, 50.0, 2.0, 1e-3)))
extra = ["-dataSize", int(sys.argv[10])] if len(sys.argv) > 10 else []

ops.wipe()
ops.model("basic", "-ndm", 1, "-ndf", 1)
ops.node(1, 0.0)
ops.node(2, 0.0)
ops.fix(1, 1)
ops.mass(2, m)
ops.uniaxialMaterial("Elastic", 1, k)
ops.element("zeroLength", 1, 1, 2, "-mat", 1, "-dir", 1)
ops.element("genericClient", 2, "-node", 1, 2, "-dof", 1, "-dof", 1, "-server", port,
            "127.0.0.1", *extra)
ops.rayleigh(a0, 0.0, 0.0, 0.0)
ops.timeSeries("Trig", 1, 0.0, 1.0e6, 1.0 / f, "-factor", F0)
ops.pattern("Plain", 1, 1)
ops.load(2, 1.0)
ops.constraints("Plain")
ops.numberer("Plain")
ops.system("FullGeneral")
ops.test("NormDispIncr", 1e-12, 10)
ops.algorithm("Linear")
ops.integrator("Newmark", 0.5, 0.25)
ops.analysis("Transient")
u = np.zeros(steps + 1)
for n in range(steps):
    if ops.analyze(1, dt) != 0:
        print(f"analyze failed at step {n}", file=sys.stderr)
        np.save(out, u[: n + 1])
        sys.exit(3)
    u[n + 1] = ops.nodeDisp(2, 1)
np.save(out, u)
ops.wipe()
