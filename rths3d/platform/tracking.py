"""Pose tracking: command a 6-DOF trajectory sampled at the interface rate, record the result.

:func:`track` drives a :class:`~rths3d.platform.single.PlatformSim` through a trajectory of
poses (N, 6) and returns a :class:`~rths3d.record.Record` with the columns of the record
schema: ``pose_cmd.<dof>``, ``pose_meas.<dof>``, ``z_cmd.<dof>`` / ``z_meas.<dof>`` (the same
poses, as interface signals), ``f_meas.<dof>`` (restoring wrench, world axes, preload
removed), ``leg_cmd.<i>``, ``leg_len.<i>``, ``leg_force.<i>``, ``fts.<fx..tz>`` (raw sensor)
and ``eq_gap`` (largest leg-tip-to-plate-anchor distance, m). Sample k is taken at
``t_k = (k + 1)·ΔT``, the time the command of step k is meant for.

If the platform stops (:class:`~rths3d.errors.SafetyStop`), the samples up to the stop are
returned with ``meta["status"] = "stopped"`` and the reason in ``meta["reason"]``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import ConfigError, SafetyStop
from ..record import DOFS, WRENCH_COMPONENTS, Record
from .model import PlatformConfig, predicted_delay
from .single import PlatformSim

__all__ = [
    "TrackingFigures",
    "sine_delay",
    "sine_trajectory",
    "track",
    "tracking_figures",
]


def sine_trajectory(dof: str, amplitude: float, frequency: float, duration: float,
                    dt: float = 1e-3, ramp: float = 0.0) -> np.ndarray:
    """Poses (N, 6) of a sine ``A·sin(2π f t)`` in one DOF, sampled at ``t_k = (k+1)·dt``.

    ``amplitude`` in m (x, y, z) or rad (rx, ry, rz); ``frequency`` in Hz; ``ramp`` (s): a
    raised-cosine fade-in of the amplitude that avoids a velocity step at t = 0.
    """
    if dof not in DOFS:
        raise ConfigError("dof", dof, f"one of {', '.join(DOFS)}")
    for name, v in (("amplitude", amplitude), ("frequency", frequency),
                    ("duration", duration), ("dt", dt)):
        if not (math.isfinite(v) and v > 0):
            raise ConfigError(name, v, "must be a finite number > 0")
    n = int(round(duration / dt))
    t = (np.arange(n) + 1) * dt
    env = np.ones(n)
    if ramp > 0:
        r = t < ramp
        env[r] = 0.5 - 0.5 * np.cos(np.pi * t[r] / ramp)
    poses = np.zeros((n, 6))
    poses[:, DOFS.index(dof)] = amplitude * env * np.sin(2 * np.pi * frequency * t)
    return poses


def track(poses: np.ndarray, config: PlatformConfig | None = None, *,
          sim: PlatformSim | None = None, payload_xml: str | None = None,
          world_xml: str | None = None, progress: bool = False) -> Record:
    """Command ``poses`` (N, 6; m, rad, relative to home), one per ΔT; return the record.

    Uses ``sim`` if given (reset first), else builds a :class:`PlatformSim` from ``config``
    and the fragments. Never raises on a safety stop: the partial record carries
    ``meta["status"] == "stopped"`` and ``meta["reason"]``.
    """
    poses = np.asarray(poses, dtype=float)
    if poses.ndim != 2 or poses.shape[1] != 6 or poses.shape[0] < 1:
        raise ConfigError("poses", f"array of shape {poses.shape}", "need (N, 6) poses")
    if not np.all(np.isfinite(poses)):
        raise ConfigError("poses", "NaN/inf", "all poses must be finite")
    if sim is None:
        sim = PlatformSim(config, payload_xml, world_xml)
    else:
        sim.reset()
    config = sim.config
    n = poses.shape[0]
    buf = np.zeros((n, 6 * 7 + 1))
    status, reason = "ok", ""
    x = sim.data.site_xpos
    tips = sim.ids.tip_site
    anchors = sim.ids.anchor_site
    it = range(n)
    if progress:
        from tqdm import tqdm

        it = tqdm(it, desc="tracking", unit="step", mininterval=0.5)
    k = 0
    step = sim.step
    rows = poses.tolist()
    try:
        for k in it:
            step(*rows[k])
            row = buf[k]
            row[0:6] = sim.pose
            row[6:12] = sim.leg_commands
            row[12:18] = sim.leg_lengths
            row[18:24] = sim.leg_forces
            row[24:30] = sim.wrench
            row[30:36] = sim.interface_wrench
            row[36] = np.max(np.linalg.norm(x[tips] - x[anchors], axis=1))
        k = n
    except SafetyStop as stop:
        status, reason = "stopped", stop.reason
    buf = buf[:k]
    t = (np.arange(k) + 1) * config.dt
    cols: dict[str, np.ndarray] = {}
    for j, d in enumerate(DOFS):
        cols[f"pose_cmd.{d}"] = poses[:k, j]
        cols[f"pose_meas.{d}"] = buf[:, j]
        cols[f"z_cmd.{d}"] = poses[:k, j]
        cols[f"z_meas.{d}"] = buf[:, j]
        cols[f"f_meas.{d}"] = buf[:, 30 + j]
    for i in range(6):
        cols[f"leg_cmd.{i}"] = buf[:, 6 + i]
        cols[f"leg_len.{i}"] = buf[:, 12 + i]
        cols[f"leg_force.{i}"] = buf[:, 18 + i]
    for j, c in enumerate(WRENCH_COMPONENTS):
        cols[f"fts.{c}"] = buf[:, 24 + j]
    cols["eq_gap"] = buf[:, 36]
    a = config.actuator
    meta = {
        "transfer": "stewart",
        "dt": config.dt,
        "status": status,
        "reason": reason,
        "platform": {
            "substeps": config.substeps, "kp": a.kp, "kv": a.kv, "timeconst": a.timeconst,
            "delay": a.delay, "velocity_ff": a.velocity_ff, "gravity_comp": a.gravity_comp,
            "payload_mass": sim.static.payload_mass if sim.static else 0.0,
            "predicted_delay_1hz": predicted_delay(
                config, 1.0, sim.static.payload_mass if sim.static else 0.0),
        },
    }
    return Record(t, cols, meta)


def sine_delay(t: np.ndarray, cmd: np.ndarray, meas: np.ndarray,
               frequency: float) -> tuple[float, float]:
    """Delay (s) and amplitude ratio of ``meas`` behind ``cmd`` by least-squares sine fits.

    Both signals are fitted with ``a·sin(ωt) + b·cos(ωt) + c`` at the known frequency (Hz);
    the delay is the phase difference divided by ω (positive: ``meas`` lags). Unbiased where
    cross-correlation is not (it favours zero lag).
    """
    w = 2 * np.pi * frequency
    X = np.column_stack([np.sin(w * t), np.cos(w * t), np.ones_like(t)])

    def phase_amp(y: np.ndarray) -> tuple[float, float]:
        a, b, _ = np.linalg.lstsq(X, y, rcond=None)[0]
        return math.atan2(b, a), math.hypot(a, b)

    pc, ac = phase_amp(np.asarray(cmd, float))
    pm, am = phase_amp(np.asarray(meas, float))
    dphi = (pc - pm + np.pi) % (2 * np.pi) - np.pi
    return dphi / w, am / ac


@dataclass(frozen=True)
class TrackingFigures:
    """Figures of a one-DOF sine tracking run.

    Attributes
    ----------
    dof:
        The commanded DOF.
    delay, predicted_delay:
        Achieved delay from sine fits and the delay the actuator settings predict (s).
    amplitude_ratio:
        Achieved over commanded amplitude (1).
    nrms_error:
        RMS of ``pose_meas − pose_cmd`` in the DOF over the RMS of the command (1),
        the relative RMS tracking error e_rel,track of the paper, eq. (1).
    parasitic_translation, parasitic_rotation:
        Largest |pose_meas| in the other translational (m) and rotational (rad) DOFs.
    max_eq_gap:
        Largest leg-tip-to-plate-anchor gap of the equality constraints (m).
    """

    dof: str
    delay: float
    predicted_delay: float
    amplitude_ratio: float
    nrms_error: float
    parasitic_translation: float
    parasitic_rotation: float
    max_eq_gap: float

    def as_dict(self) -> dict:
        """Plain dict (for JSON)."""
        return dict(self.__dict__)


def tracking_figures(record: Record, dof: str, frequency: float,
                     config: PlatformConfig | None = None, skip: float = 1.0) -> TrackingFigures:
    """Figures of a sine tracking record, ignoring the first ``skip`` seconds (transient)."""
    t = record.t
    sel = t >= t[0] + skip
    if sel.sum() < 8:
        raise ConfigError("skip", skip, f"leaves fewer than 8 samples of {record.n}")
    cmd = record.columns[f"pose_cmd.{dof}"][sel]
    meas = record.columns[f"pose_meas.{dof}"][sel]
    delay, ratio = sine_delay(t[sel], cmd, meas, frequency)
    nrms = float(np.sqrt(np.mean((meas - cmd) ** 2)) / np.sqrt(np.mean(cmd ** 2)))
    others = [d for d in DOFS if d != dof]
    tr = [np.max(np.abs(record.columns[f"pose_meas.{d}"][sel])) for d in others
          if d in ("x", "y", "z")]
    rot = [np.max(np.abs(record.columns[f"pose_meas.{d}"][sel])) for d in others
           if d in ("rx", "ry", "rz")]
    payload = float(record.meta.get("platform", {}).get("payload_mass", 0.0))
    pd = predicted_delay(config, frequency, payload) if config is not None else float("nan")
    gap = float(np.max(record.columns["eq_gap"])) if "eq_gap" in record.columns else float("nan")
    return TrackingFigures(dof=dof, delay=float(delay), predicted_delay=float(pd),
                           amplitude_ratio=float(ratio), nrms_error=nrms,
                           parasitic_translation=float(max(tr)),
                           parasitic_rotation=float(max(rot)), max_eq_gap=gap)
