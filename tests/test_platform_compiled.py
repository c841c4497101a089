"""The compiled interface steps (MuJoCo's C API from numba, rths3d.platform.compiled) give the
records of the Python driver (PlatformBatch.advance one step at a time, the reference):
every channel equal to 1e-12 of its peak, with effects in every stage, safety stops,
a held set-point, start sampling and the central feed-forward, one test and a batch split
over threads."""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
import pytest

from rths3d.bench import Bench, BenchReplay
from rths3d.config import EffectConfig
from rths3d.platform.model import PlatformConfig
from rths3d.platform.ranges import track_batch
from rths3d.platform.sim import PlatformBatch
from rths3d.scene import load_scene

DT = 1.0e-3  # s


def _poses(n: int, scale: float = 1.0) -> np.ndarray:
    """A six-DOF multisine (m, rad) with a 0.1 s fade-in; ``scale`` enlarges it."""
    t = np.arange(n) * DT
    fade = np.minimum(1.0, t / 0.1)
    P = np.zeros((n, 6))
    for j, (a, fr) in enumerate(((0.001, 3.0), (0.0008, 5.0), (0.002, 7.0), (0.003, 4.0),
                                 (0.002, 6.0), (0.004, 2.0))):
        P[:, j] = scale * a * fade * np.sin(2 * np.pi * fr * t + j)
    return P


def _equal(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for c in a:
        peak = max(float(np.nanmax(np.abs(b[c]))) if np.isfinite(b[c]).any() else 0.0, 1e-300)
        assert np.array_equal(np.isnan(a[c]), np.isnan(b[c])), c
        d = np.nan_to_num(a[c] - b[c])
        assert float(np.max(np.abs(d))) <= 1e-12 * peak, (c, float(np.max(np.abs(d))))


def _replays(sc, poses, sets, **kw):
    py = BenchReplay(sc, poses, compiled=False, **kw).run(sets)
    cc = BenchReplay(sc, poses, compiled=True, **kw).run(sets)
    return py, cc


def test_replay_batch_with_effects_and_stops_equals_the_python_driver():
    """Four variants of a six-DOF bench (leg delay and friction, FTS gain and cross-talk, a
    leg offset, and one whose friction makes MuJoCo diverge: a safety stop) on a large
    multisine that overruns a leg's speed limit in some, over 2 threads: every channel of
    the compiled replay equals the Python driver's, stops included."""
    sc = load_scene("bench6", ["duration=0.3", "sensor.kind=first_order",
                               "sensor.time_constant=0.002"])
    sets = [[EffectConfig("delay", 0.002, 1), EffectConfig("viscous_friction", 400.0, 3)],
            [EffectConfig("fts_gain", 0.05, axis="fz"), EffectConfig("fts_crosstalk", 0.02,
                                                                     axis="fx.tz")],
            [EffectConfig("leg_offset", 0.001, 2)],
            [EffectConfig("viscous_friction", 9.0e4, -1)]]
    py, cc = _replays(sc, _poses(300, 3.0), sets, nthread=2)
    assert [o["_stopped"] for o in py] == [o["_stopped"] for o in cc]
    assert any(o["_stopped"] == 1 for o in py), "the overloaded variant should stop"
    assert any(o["_stopped"] == 0 for o in py)
    for a, b in zip(cc, py, strict=True):
        _equal(a, b)


@pytest.mark.parametrize("act", [{"hold": "zoh"}, {"sample": "start", "feedforward": "central"}])
def test_replay_of_one_test_with_other_conventions_equals_the_python_driver(act):
    """One test (a plain MjData stepped in place) with a held set-point, or sampled at the
    start with the central feed-forward: the compiled replay equals the Python driver's."""
    sc = load_scene("bench6", ["duration=0.25"])
    b = Bench.from_scene(sc)
    b = dataclasses.replace(b, platform=dataclasses.replace(
        b.platform, actuator=dataclasses.replace(b.platform.actuator, **act)))
    sets = [[EffectConfig("actuator_lag", 0.002, 4)]]
    py, cc = _replays(sc, _poses(250), sets, base=b)
    _equal(cc[0], py[0])


def test_command_limit_stop_in_a_compiled_range_matches_the_python_driver():
    """A pose beyond the stroke in the middle of a range: the compiled range hands that step
    to the Python driver, which stops that test (and only it) at the same row with the same
    reason; the other test's record is unaffected."""
    cfg = PlatformConfig()
    P = np.zeros((200, 2, 6))
    P[:, :, 2] = 0.002 * np.sin(2 * np.pi * 5 * np.arange(200) * DT)[:, None]
    P[120:, 1, 2] = cfg.stroke  # test 1 is commanded out of its stroke at row 120
    out = {}
    for comp in (False, True):
        sim = PlatformBatch(cfg, nsim=2)
        rec = track_batch(sim, P, np.arange(6), compiled=comp)
        out[comp] = (rec, list(sim.reasons), sim.k)
    (a, ra, ka), (b, rb, kb) = out[True], out[False]
    assert ra == rb and ra[0] == "" and "commanded stroke" in ra[1]
    assert list(a.stop) == list(b.stop) == [200, 120]
    assert ka == kb
    for name in ("q", "legs_q", "legs_f", "fts", "z", "f"):
        x, y = getattr(a, name), getattr(b, name)
        assert np.max(np.abs(x - y)) <= 1e-12 * max(np.max(np.abs(y)), 1e-300), name


def test_compiled_range_steps_the_same_mujoco_state_as_mj_step():
    """The state the compiled range leaves in the batch's rows is MuJoCo's own: stepping a
    fresh MjData from the saved start state with the same controls by mujoco.mj_step reaches
    the same qpos (bit for bit), so the C API is called on the right model and data."""
    cfg = PlatformConfig()
    sim = PlatformBatch(cfg, nsim=2)
    inner = sim.batch.batch
    start = inner.state.copy()
    P = _poses(3)
    track_batch(sim, P, np.arange(6), compiled=True)
    # replay the same three steps by hand on test 0 from its start row
    m = sim.model
    d = mujoco.MjData(m)
    sig = mujoco.mjtState.mjSTATE_INTEGRATION
    sim2 = PlatformBatch(cfg, nsim=2)
    mujoco.mj_setState(m, d, start[0], sig)
    for r in range(1, 3):
        sim2.poses[:] = P[r]
        sim2.advance()
        d.ctrl[:] = sim2._ctrl[0]
        # the servo set-point at the start of the step is the previous end of the ramp
        mujoco.mj_step(m, d)
        d.act[:] = sim2._act[0]
        mujoco.mj_forward(m, d)
    got = inner.state[0].copy()
    want = np.zeros_like(got)
    mujoco.mj_getState(m, d, want, sig)
    assert np.array_equal(got[1:], want[1:])


def test_compiled_range_of_a_batch_with_start_sampling_and_holds_equals_the_python_driver():
    """A batch (not a replay) of three controllers — ramp/end, zoh/start with a miscalibrated
    FTS, ramp/start without feed-forward — tracked with every channel sampled as each bench
    samples it: the compiled range equals the Python driver row for row."""
    from rths3d.platform.model import ActuatorConfig

    cfgs = [PlatformConfig(),
            PlatformConfig(actuator=ActuatorConfig(hold="zoh", sample="start")),
            PlatformConfig(actuator=ActuatorConfig(sample="start", feedforward="none"))]
    C = np.tile(np.eye(6), (3, 1, 1))
    C[1, 2, 0] = 0.03  # fz picks up 3 % of fx
    P = _poses(220, 2.0)
    recs = []
    for comp in (False, True):
        sim = PlatformBatch(cfgs[0], nsim=3, configs=cfgs, fts_matrix=C)
        recs.append(track_batch(sim, P, np.array([0, 2, 4]), compiled=comp))
    a, b = recs
    assert list(a.stop) == list(b.stop) == [220] * 3
    for name in ("q", "legs_q", "legs_f", "fts", "z", "f"):
        x, y = getattr(b, name), getattr(a, name)
        assert np.max(np.abs(x - y)) <= 1e-12 * max(np.max(np.abs(y)), 1e-300), name
    # the start-sampled tests' row 1 is the state before the first step acts (the rest)
    assert np.array_equal(a.q[1, 1:], a.q[0, 1:])
    assert not np.array_equal(a.q[1, 0], a.q[0, 0])
