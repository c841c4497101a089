"""Benchmark: an OpenSees model's interface step against rths3d's internal linear step.

Prints ONE JSON line. For shear frames of 10 and 200 storeys (``zeroLength`` elastic storeys,
Rayleigh damping, ground motion, the roof the interface): ``os_lin<n>_us`` µs per interface
step of :class:`~rths3d.numerical.OpenSeesSubstructure` (``updateParameter``, ``analyze(1,
ΔT)``, the interface's displacement and velocity read back) with ``Linear -factorOnce``,
``os_lin<n>_linear_us`` with ``Linear`` (factorised every step), ``internal<n>_us`` the
internal :class:`~rths3d.numerical.LinearSubstructure` of the same M, C, K (``exact``, its
compiled step) and ``ratio_lin<n>`` their ratio. ``os_steel02_<n>_us``: the same frames with
yielding ``Steel02`` storeys (``Newton``), ``ratio_steel02_<n>`` against the internal step of
their initial stiffness. Every figure is the median over repetitions of 2000 steps (``--quick``:
one repetition of 1000). ``stewart_frame_rtf``: the real-time factor of the closed loop of
``scenes/opensees_frame_stewart.toml`` (the yielding two-storey frame on the Stewart platform,
4 s, no reference): ≥ 1 is faster than real time. ``marths_internal_s`` /
``marths_opensees_s``: one maRTHS run (RoDeAC, nominal plant, sensor noise, El Centro × 0.4,
the whole 41.2 s record; ``--quick``: its first 10 s) with the benchmark's internal frame and
with the 29-DOF frame as an OpenSees model (``scenes/opensees/marths_frame.py``),
``marths_opensees_rtf`` the record's duration over the OpenSees run's time and
``marths_j_rel_max`` the largest relative difference of their 24 J-values.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import tempfile
import time
from pathlib import Path

MODEL = '''
N = {n}
YIELD = {yield_drift}


def build(ops):
    ops.model("basic", "-ndm", 1, "-ndf", 1)
    for i in range(N + 1):
        ops.node(i + 1, 0.0)
    ops.fix(1, 1)
    for i in range(N):
        ops.mass(i + 2, 1000.0)
        k = 2.0e7 * (1.0 - 0.5 * i / N)
        if YIELD > 0:
            ops.uniaxialMaterial("Steel02", i + 1, k * YIELD, k, 0.02, 18.0, 0.925, 0.15)
        else:
            ops.uniaxialMaterial("Elastic", i + 1, k)
        ops.element("zeroLength", i + 1, i + 1, i + 2, "-mat", i + 1, "-dir", 1,
                    "-doRayleigh", 1)
    ops.rayleigh(0.2, 0.0, 1.0e-4, 0.0)
'''


def _scene(root: Path, n: int, yield_drift: float, algorithm: str, steps: int):
    from rths3d.scene import scene_from_dict

    model = root / f"frame{n}_{yield_drift:g}.py"
    model.write_text(MODEL.format(n=n, yield_drift=yield_drift))
    raw = {"name": f"frame{n}", "dofs": ["z"], "dt": 1e-3, "duration": steps * 1e-3,
           "numerical": {"kind": "opensees", "model": str(model), "interface": [[n + 1, 1]],
                         "algorithm": algorithm, "tol": 1e-10},
           "excitation": {"kind": "ground", "signal": "sine", "amplitude": 3.0,
                          "frequency": 1.0},
           "experiment": {"kind": "linear", "m": 0.5, "k": 8650.0, "d": 5.0},
           "transfer": {"kind": "ideal"}, "safety": {"stroke": 0.05, "force": 1e9}}
    return scene_from_dict(raw, source=str(root / "bench.toml"))


def _per_step_us(sub, steps: int) -> float:
    import numpy as np

    f = np.zeros((1, 1))
    t0 = time.perf_counter()
    for n in range(steps):
        f[0, 0] = 10.0 * np.sin(0.01 * n)
        sub.step(n, f)
    return (time.perf_counter() - t0) / steps * 1e6


def _marths(root: Path, t_end: float | None) -> dict:
    """The maRTHS run with the internal frame and with the OpenSees frame (see above)."""
    from rths3d.community.marths import MarthsConfig, run_marths
    from rths3d.community.marths.opensees_frame import OpenSeesFrame

    cfg = MarthsConfig(t_end=t_end)
    run_marths(MarthsConfig(t_end=0.01))  # compiled once
    t0 = time.perf_counter()
    inner = run_marths(cfg)[0]
    t1 = time.perf_counter()
    with OpenSeesFrame(root / "scenes" / "opensees" / "marths_frame.py", cfg.dt) as frame:
        t2 = time.perf_counter()
        ext = run_marths(cfg, numerical=frame)[0]
        t3 = time.perf_counter()
    rel = max(abs(a - b) / abs(b) for key, ref in inner.j.items()
              for a, b in zip(ext.j[key], ref, strict=True) if b != 0.0)
    return {"marths_internal_s": round(t1 - t0, 2), "marths_opensees_s": round(t3 - t2, 2),
            "marths_opensees_rtf": round(float(inner.t[-1]) / (t3 - t2), 2),
            "marths_j_rel_max": float(f"{rel:.2g}")}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="one repetition of 1000 steps")
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    root_dir = Path(__file__).resolve().parents[1]
    sys.path.insert(0, str(root_dir))
    import numpy as np

    import rths3d
    from rths3d.numerical import LinearSubstructure, OpenSeesSubstructure

    reps = 1 if args.quick else args.repeat
    steps = 1000 if args.quick else 2000
    out: dict = {}
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        for n in (10, 200):
            for key, yd, algo in ((f"os_lin{n}", 0.0, "LinearFactorOnce"),
                                  (f"os_lin{n}_linear", 0.0, "Linear"),
                                  (f"os_steel02_{n}", 0.004, "Newton")):
                scene = _scene(root, n, yd, algo, steps)
                times = []
                for _ in range(reps):
                    sub = OpenSeesSubstructure(scene)
                    times.append(_per_step_us(sub, steps))
                    if key == f"os_lin{n}":
                        M, C, K, G = sub.linearised()
                    sub.close()
                out[f"{key}_us"] = round(statistics.median(times), 2)
            p = np.zeros((steps + 1, M.shape[0]))
            times = []
            for _ in range(reps):
                lin = LinearSubstructure(M, C, K, G, p, 1e-3)
                lin.step(0, np.zeros((1, 1)))  # compiled once
                lin.reset()
                times.append(_per_step_us(lin, steps))
            out[f"internal{n}_us"] = round(statistics.median(times), 3)
            for key in (f"os_lin{n}", f"os_steel02_{n}"):
                ratio = out[f"{key}_us"] / out[f"internal{n}_us"]
                out[f"ratio_{key.removeprefix('os_')}"] = round(ratio, 1)
        scene = rths3d.load_scene(root_dir / "scenes" / "opensees_frame_stewart.toml")
        rtfs = [rths3d.run(scene, reference=False).rtf for _ in range(reps)]
        out["stewart_frame_rtf"] = round(statistics.median(rtfs), 2)
    out.update(_marths(root_dir, 10.0 if args.quick else None))
    print(json.dumps(out))


if __name__ == "__main__":
    main()
