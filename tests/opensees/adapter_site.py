"""An OpenSees model as a remote site: an `adapter` element (stiffness KB, N/m) imposes the
client's displacement on node 1, which carries the linear part — a spring k (N/m) and a
damper d (N·s/m) to node 2 of mass m (kg). Newmark (γ = 1/2, β = 1/4), Newton. The adapter
answers getForce with node 1's displacement and the force holding it: the part's restoring
force. The analysis runs until the client sends DIE (the adapter then ends the process).

Usage: python adapter_site.py PORT STEPS [m k d dt KB]
"""

import sys

import openseespy.opensees as ops

port, steps = int(sys.argv[1]), int(sys.argv[2])
m, k, d, dt, kb = (float(x) for x in (sys.argv[3:8] or (0.38, 8650.0, 5.0, 1e-3, 1e12)))

ops.wipe()
ops.model("basic", "-ndm", 1, "-ndf", 1)
ops.node(1, 0.0)
ops.node(2, 0.0)
ops.mass(2, m)
ops.uniaxialMaterial("Elastic", 1, k)
ops.uniaxialMaterial("Viscous", 2, d, 1.0)
ops.element("zeroLength", 1, 1, 2, "-mat", 1, 2, "-dir", 1, 1)
print("adapter listening", flush=True)
ops.element("adapter", 2, "-node", 1, "-dof", 1, "-stif", kb, port)
ops.constraints("Plain")
ops.numberer("Plain")
ops.system("FullGeneral")
ops.test("NormDispIncr", 1e-14, 20)
ops.algorithm("Newton")
ops.integrator("Newmark", 0.5, 0.25)
ops.analysis("Transient")
for n in range(steps + 2):
    if ops.analyze(1, dt) != 0:
        print(f"analyze failed at step {n}", file=sys.stderr)
        sys.exit(3)
