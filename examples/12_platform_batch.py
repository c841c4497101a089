"""Many platform tests at once: payload masses swept in one ``PlatformBatch``.

Eight platforms carry payloads from 0.5 to 4 kg (per-test body masses in one
``mujoco.batch.Batch``) and track the same heave; one of them is commanded beyond the leg
stroke and is stopped and flagged while the others go on. Prints the static FTS reading and
the peak interface force of each test.

Run: ``python examples/12_platform_batch.py``
"""

from __future__ import annotations

import argparse

import numpy as np

from rths3d.platform import PlatformBatch, PlatformConfig, sine_trajectory

PAYLOAD = ('<body name="payload"><geom type="box" size="0.08 0.08 0.04" pos="0 0 0.04" '
           'mass="1.0"/></body>')


def main() -> None:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    K = 8
    batch = PlatformBatch(PlatformConfig(), nsim=K, nthread=2, payload_xml=PAYLOAD)
    masses = np.linspace(0.5, 4.0, K)
    body = batch.batch.body("payload")
    body.mass = masses[:, None]  # per-test payload mass (kg)
    # the inertia scales with the mass (compiled for 1 kg), else the dynamics stay those of 1 kg
    body.inertia = batch.model.body("payload").inertia[None, :] * masses[:, None]
    batch.reset(set_const=True)  # derived constants, static equilibrium and FTS preload
    print("static FTS fz (N):", np.round(batch.wrench[:, 2], 4))
    print("expected m·g (N): ", np.round(masses * 9.81, 4))
    poses = sine_trajectory("z", 0.005, 4.0, 1.0, ramp=0.25)
    peak = np.zeros(K)
    for k, q in enumerate(poses):
        cmd = np.tile(q, (K, 1))
        cmd[K - 1, 2] += 0.06 * (k / 800) ** 2  # the last test drifts out of the stroke
        batch.step(cmd)
        peak = np.maximum(peak, np.abs(batch.interface_wrench[:, 2]))
    for k in range(K):
        state = batch.reasons[k] if batch.stopped[k] else "ok"
        print(f"test {k}: m = {masses[k]:.2f} kg, peak |f_meas,z| = {peak[k]:7.3f} N "
              f"(m·a = {masses[k] * 0.005 * (2 * np.pi * 4) ** 2:6.3f} N): {state}")


if __name__ == "__main__":
    import sys

    from rths3d.errors import RthsError

    try:
        main()
    except RthsError as exc:  # a user mistake (flag, file, output folder): no traceback
        print(f"error: {exc}", file=sys.stderr)
        raise SystemExit(2) from None
