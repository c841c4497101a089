"""Open-loop replay of measured pose commands through K variants of one bench.

:class:`BenchReplay` drives :func:`~rths3d.bench.platform_batch` — the code the vRTHS loop
steps — with the commanded poses of a record (``pose_cmd.<dof>``, or ``z_cmd.<dof>`` of the
interface DOFs when the record has no pose command), one :class:`~rths3d.bench.Bench` per
variant (the same bench with other effects), and returns every channel a bench records, in
the record's convention (:mod:`rths3d.platform.sim`, docs/records.md):

``z_meas.<dof>`` (interface DOFs, from the measured rest pose), ``f_meas.<dof>`` (interface
wrench tared at rest, through the scene's force-sensor chain without its noise),
``pose_meas.<dof>`` (absolute plate pose relative to the nominal home), ``leg_len.<i>``
(encoders), ``leg_force.<i>`` (tared at rest) and ``fts.<fx…tz>`` (raw, zeroed unloaded).
Row 0 is the state before the first step, like a record's.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np

from ..config import EffectConfig, Scene
from ..effects import WRENCH, get_effect
from ..errors import ConfigError, RecordError
from ..platform.ranges import track_batch
from ..platform.sim import plate_pose
from ..record import DOFS, Record
from .base import Bench, platform_batch

__all__ = ["BenchReplay", "ReplayInput", "replay_channels"]

LEGS = tuple(str(i) for i in range(6))


def replay_channels(dofs: Sequence[str]) -> tuple[str, ...]:
    """Every channel a replay produces for a test through ``dofs``."""
    return (*(f"z_meas.{d}" for d in dofs), *(f"f_meas.{d}" for d in dofs),
            *(f"pose_meas.{d}" for d in DOFS), *(f"leg_len.{i}" for i in LEGS),
            *(f"leg_force.{i}" for i in LEGS), *(f"fts.{c}" for c in WRENCH))


@dataclass(frozen=True)
class ReplayInput:
    """The commanded poses (N, 6) (m, rad, relative to home) of a record, one per row
    (row n + 1: the pose commanded at step n), and where they came from."""

    poses: np.ndarray
    source: str

    @classmethod
    def from_record(cls, rec: Record, dofs: Sequence[str]) -> ReplayInput:
        """``pose_cmd.<dof>`` of all six DOFs if present (what the platform was commanded,
        after any compensation), else ``z_cmd.<dof>`` of the interface DOFs (others 0)."""
        cols = rec.columns
        poses = np.zeros((rec.n, 6))
        if all(f"pose_cmd.{d}" in cols for d in DOFS):
            for j, d in enumerate(DOFS):
                poses[:, j] = cols[f"pose_cmd.{d}"]
            return cls(poses, "pose_cmd")
        have = [d for d in DOFS if f"z_cmd.{d}" in cols]
        if not have:
            raise RecordError("the record has no pose command: need pose_cmd.<dof> (all six) "
                              "or z_cmd.<dof> (m, rad) to replay")
        missing = [d for d in dofs if d not in have]
        if missing:
            raise RecordError(f"the record lacks z_cmd.{missing[0]} of the interface DOFs "
                              f"{list(dofs)}")
        for d in have:
            poses[:, DOFS.index(d)] = cols[f"z_cmd.{d}"]
        return cls(poses, "z_cmd")


class BenchReplay:
    """Replay commanded poses through variants of the bench of ``scene``.

    Parameters
    ----------
    scene:
        The test's scene (its bench: leg servos, part, sensor chain; its effects are the
        baseline the variants replace).
    poses:
        :class:`ReplayInput` or an (N, 6) array of commanded poses.
    substeps:
        Physics substeps of the replay (default 1: RK4 at ΔT agrees with finer steps to
        well below sensor noise, :mod:`rths3d.platform.sim`).
    nthread:
        Threads of the batched MuJoCo stepping.
    compiled:
        Step in compiled ranges (:mod:`rths3d.platform.compiled`); False: the Python driver,
        one step at a time (the reference; both give the same channels).
    base:
        The bench to replay when it is given as a :class:`Bench` (its platform with the
        controller's conventions, part and effects) rather than by ``scene``, which then
        supplies the interface DOFs and the force-sensor chain.
    """

    def __init__(self, scene: Scene, poses: ReplayInput | np.ndarray, *, substeps: int = 1,
                 nthread: int = 2, base: Bench | None = None, compiled: bool = True):
        self.scene = scene
        self.base = base
        self.compiled = compiled
        p = poses.poses if isinstance(poses, ReplayInput) else np.asarray(poses, dtype=float)
        if p.ndim != 2 or p.shape[1] != 6 or p.shape[0] < 2:
            raise ConfigError("poses", f"array of shape {p.shape}", "need (N, 6), N >= 2")
        self.poses = np.ascontiguousarray(p)
        self.substeps = int(substeps)
        self.nthread = int(nthread)
        self.dofs = tuple(scene.dofs)
        self.channels = replay_channels(self.dofs)
        self.nsim = 0
        """Simulations run so far (benchmarks, tests)."""

    def bench(self, effects: Sequence[EffectConfig]) -> Bench:
        """The replay's bench with ``effects``."""
        if self.base is not None:
            return dataclasses.replace(self.base, effects=tuple(effects), platform=(
                dataclasses.replace(self.base.platform, substeps=self.substeps)))
        return Bench.from_scene(self.scene, substeps=self.substeps, effects=tuple(effects))

    def _sensor(self, effect_sets: Sequence[Sequence[EffectConfig]]):
        from ..transfer.sensor import sensor_chain

        quiet = dataclasses.replace(self.scene.sensor, noise_std=0.0)
        scenes = [dataclasses.replace(self.scene, sensor=quiet, effects=tuple(
            e for e in E if not get_effect(e.name).floor)) for E in effect_sets]
        return sensor_chain(scenes, len(self.dofs))

    def run(self, effect_sets: Sequence[Sequence[EffectConfig]],
            models: Sequence | None = None) -> list[dict[str, np.ndarray]]:
        """Replay with each effect set (batched by structure); every channel per set (rows
        as the record's). A variant the platform stopped (a limit, divergence) has NaN from
        the step it stopped and ``_stopped`` = 1."""
        if not effect_sets:
            return []
        groups: dict[tuple, list[int]] = {}
        benches = [self.bench(E) for E in effect_sets]
        for i, b in enumerate(benches):
            # one batch per model structure: the set-point, sensor and FTS blocks of the
            # benches are united (each bench's own at their off values pass exactly)
            key = any(eff.structural for eff, _ in b.active())
            groups.setdefault((key,), []).append(i)
        out: list[dict[str, np.ndarray] | None] = [None] * len(benches)
        jobs = []
        threaded = self.compiled and self.nthread > 1
        if threaded and models is None:
            models = [b.model() for b in benches]  # compiled here, not in the threads
        for idx in groups.values():
            if threaded and len(idx) > 1:
                # threads over tests: the compiled ranges release the GIL, so each thread
                # steps its own share of the tests (each test's arithmetic is its own)
                parts = np.array_split(np.asarray(idx), min(self.nthread, len(idx)))
                jobs.extend(list(p) for p in parts)
            else:
                jobs.append(list(idx))

        def job(idx: list[int]) -> None:
            res = self._run([benches[i] for i in idx], [effect_sets[i] for i in idx],
                            None if models is None else [models[i] for i in idx],
                            1 if len(jobs) > 1 else self.nthread)
            for i, r in zip(idx, res, strict=True):
                out[i] = r

        if len(jobs) > 1 and self.compiled and self.nthread > 1:
            with ThreadPoolExecutor(self.nthread) as pool:
                list(pool.map(job, jobs))
        else:
            for j in jobs:
                job(j)
        return out  # type: ignore[return-value]

    def _run(self, benches: list[Bench], effect_sets: list, models,
             nthread: int) -> list[dict]:
        K = len(benches)
        N = self.poses.shape[0]
        sim = platform_batch(benches, nthread=nthread, models=models, replay=True)
        self.nsim += K
        sensor = self._sensor(effect_sets)
        sensor.reset()
        idx = np.array([DOFS.index(d) for d in self.dofs], dtype=np.int64)
        # a ramped set-point is a state (the servo's activation), so step r + 1's evaluation
        # at its start is step r's end-of-step sample (lazy: one evaluation per step less);
        # a held set-point jumps at the start of the step: then every step samples its end
        rec = track_batch(sim, self.poses, idx, lazy=not sim.any_zoh,
                          compiled=self.compiled)
        q, lq, lf, ft, zz, ff, stop = rec.q, rec.legs_q, rec.legs_f, rec.fts, rec.z, rec.f, \
            rec.stop
        # a bench that samples at the start of the step records every channel one row
        # earlier: row r holds the state at the end of step r − 1 (row 0, the rest, stays)
        shift = np.flatnonzero(sim.sample_start)
        for arr in (q, lq, lf, ft, zz, ff):
            arr[1:, shift] = arr[:-1, shift]
        stop[shift] = np.minimum(stop[shift] + 1, N)
        if not sensor.empty:
            for r in range(1, N):
                ff[r] = sensor(ff[r])
        pose = plate_pose(q, sim.home_height)
        enc = sim.encoder_lengths(lq)
        out = []
        for k in range(K):
            d: dict[str, np.ndarray] = {}
            for j, dof in enumerate(self.dofs):
                d[f"z_meas.{dof}"] = zz[:, k, j]
                d[f"f_meas.{dof}"] = ff[:, k, j]
            for j, dof in enumerate(DOFS):
                d[f"pose_meas.{dof}"] = pose[:, k, j]
            for i in range(6):
                d[f"leg_len.{i}"] = enc[:, k, i]
                d[f"leg_force.{i}"] = lf[:, k, i] - sim.rest_leg_forces[k, i]
            for j, c in enumerate(WRENCH):
                d[f"fts.{c}"] = ft[:, k, j]
            if stop[k] < N:
                for v in d.values():
                    v[stop[k]:] = np.nan
            d["_stopped"] = np.array(float(stop[k] < N))
            out.append(d)
        return out
