"""The payload's inertial parameters as a description candidate: classic payload identification
(:class:`~rths3d.diagnose.payload.PayloadIdentification`) from the measured plate pose and the
raw six-axis wrench, proposed as revisions of the ``[experiment]`` table of a rigid part: the
mass alone (k = 1), the centre of mass alone (k = 3), and mass, centre of mass and inertia
tensor together (k = 10; the inertia only where the motion excites it)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar

import numpy as np

from ...config import Scene
from ...effects import WRENCH
from ...experiment import part_class
from ...record import DOFS
from .base import Revision, current, register_description


def _sensor_pose(scene: Scene) -> tuple[float, ...]:
    pose = current(scene, "platform.fts_pose")
    if pose is not None and len(pose) == 6:
        return tuple(float(v) for v in pose)
    from ...bench import Bench

    h = Bench.from_scene(scene).platform.geometry.fts_height
    return (0.0, 0.0, float(h), 0.0, 0.0, 0.0)


@register_description
class PayloadParameters:
    """Mass, centre of mass and inertia of a rigid payload identified from wrench and pose."""

    name: ClassVar[str] = "payload"

    def revisions(self, scene: Scene, measured: Mapping[str, np.ndarray], dt: float
                  ) -> list[Revision]:
        from ...errors import ConfigError
        from ..payload import PayloadIdentification

        if not part_class(scene.experiment.kind).rigid_payload:
            return []
        src = "pose_meas" if all(f"pose_meas.{d}" in measured for d in DOFS) else None
        if src is None or not all(f"fts.{c}" in measured for c in WRENCH):
            return []
        q = np.column_stack([measured[f"{src}.{d}"] for d in DOFS])
        w = np.column_stack([measured[f"fts.{c}"] for c in WRENCH])
        try:
            est = PayloadIdentification(_sensor_pose(scene)).fit(q, w, dt)
        except ConfigError:
            return []
        if not (np.isfinite(est.mass_) and est.mass_ > 0):
            return []
        detail = tuple(est.lines())
        m = round(float(est.mass_), 4)
        com = [round(float(v), 5) for v in est.com_]
        sd_m = float(est.std_[0])
        sd_c = [float(s) / max(est.mass_, 1e-9) for s in est.std_[1:4]]
        out = [Revision(f"experiment.m={m:g}", {"experiment.m": m}, 1,
                        {"experiment.m": sd_m}, detail)]
        if "m*cz" not in est.unseen_:
            out.append(Revision("experiment.com=[" + ", ".join(f"{v:g}" for v in com) + "]",
                                {"experiment.com": com}, 3, {"experiment.com": sd_c}, detail))
            full = {"experiment.m": m, "experiment.com": com}
            k = 4
            Ic = est.inertia_
            lam = np.linalg.eigvalsh(0.5 * (Ic + Ic.T))
            # a physical tensor only (positive moments, the triangle inequality): a bench
            # whose controller holds its set-point biases the inertia (docs/diagnosis.md)
            physical = bool(lam[0] > 0 and lam[0] + lam[1] >= lam[2])
            if physical and not any(n.startswith("I") for n in est.unseen_):
                full["experiment.inertia"] = [round(float(v), 7) for v in (
                    Ic[0, 0], Ic[1, 1], Ic[2, 2], Ic[0, 1], Ic[0, 2], Ic[1, 2])]
                k = 10
            out.append(Revision("experiment.payload=identified", full, k,
                                {"experiment.m": sd_m}, detail))
        return out
