"""The controller's conventions (ActuatorConfig ``hold``, ``sample``, ``feedforward``) in the
platform's stepping, against stepping loops, set-point formulas and hold/lag figures written
here (not through the platform's own kernels)."""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np
import pytest

from rths3d.bench import Bench, BenchReplay
from rths3d.errors import ConfigError
from rths3d.platform.model import ActuatorConfig, PlatformConfig, build_model
from rths3d.platform.sim import PlatformBatch
from rths3d.scene import load_scene

DT = 1.0e-3  # s, the interface step of every test here


def _config(**act) -> PlatformConfig:
    return PlatformConfig(actuator=ActuatorConfig(**act))


def _ik(cfg: PlatformConfig, poses: np.ndarray) -> np.ndarray:
    """Leg lengths (N, 6), m, of poses (N, 6) (x y z rx ry rz relative to home; R = Rz Ry Rx)
    from the geometry's anchors, written here with scipy-free numpy."""
    g = cfg.geometry
    b, p = g.base_anchors(), g.top_anchors()
    out = np.empty((len(poses), 6))
    for n, (x, y, z, rx, ry, rz) in enumerate(poses):
        cx, sx, cy, sy, cz, sz = (math.cos(rx), math.sin(rx), math.cos(ry), math.sin(ry),
                                  math.cos(rz), math.sin(rz))
        Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
        Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
        Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
        t = np.array([x, y, z + g.home_height])
        out[n] = np.linalg.norm(t + p @ (Rz @ Ry @ Rx).T - b, axis=1)
    return out


def _sine(n: int, f: float, amp: np.ndarray) -> np.ndarray:
    """Poses (n, 6) of a sine of frequency f (Hz) per DOF amplitude amp (m, rad), the pose
    of row r commanded for t = r·ΔT."""
    t = np.arange(n) * DT
    return np.sin(2 * np.pi * f * t)[:, None] * np.asarray(amp)[None, :]


def _phase_delay(x: np.ndarray, f: float) -> tuple[float, float]:
    """Amplitude and delay (s) of the frequency-f component of x (rows at r·ΔT), by least
    squares on sin, cos and an offset."""
    t = np.arange(len(x)) * DT
    A = np.c_[np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t), np.ones_like(t)]
    (s, c, _), *_ = np.linalg.lstsq(A, x, rcond=None)
    return math.hypot(s, c), -math.atan2(c, s) / (2 * np.pi * f)


def _stepped(cfgs: list[PlatformConfig], poses: np.ndarray, replay: bool = False,
             settle: float = 0.05) -> tuple[PlatformBatch, dict[str, np.ndarray]]:
    """Step a batch (one test per config) through the poses; the measured channels per row
    (row 0: before the first step) and the servo set-points after each step."""
    sim = PlatformBatch(cfgs[0], nsim=len(cfgs), configs=cfgs, replay=replay, settle=settle)
    N, K = len(poses), len(cfgs)
    rec = {k: np.zeros((N, K, w)) for k, w in (("q", 7), ("lq", 6), ("lf", 6), ("fts", 6),
                                                  ("z", 6), ("f", 6), ("act", 6))}
    idx = np.arange(6, dtype=np.int64)
    z, f = np.zeros((K, 6)), np.zeros((K, 6))
    sim.read(idx, z, f)
    act = sim.model.actuator_actadr[sim.ids.act]

    def keep(r: int) -> None:
        rec["q"][r], rec["lq"][r], rec["lf"][r] = sim.plate_qpos, sim.meas_legs_q, \
            sim.meas_legs_f
        rec["fts"][r], rec["z"][r], rec["f"][r] = sim.fts_reading, z, f
        rec["act"][r] = sim.batch.bind("act")[:, act]

    keep(0)
    for r in range(1, N):
        sim.poses_next[:] = poses[min(r + 1, N - 1)]
        sim.step_interface(np.broadcast_to(poses[r], (K, 6)).copy(), idx, z, f)
        keep(r)
    assert not sim.stopped.any(), sim.reasons
    return sim, rec


def test_zoh_equals_a_held_setpoint_loop_written_here():
    """A zero-order-hold bench (no lag, delay, feed-forward or gravity compensation) steps
    exactly like a plain MuJoCo loop that sets the servo's set-point to L(pose) − L_home at
    the start of each step and holds it (ctrl 0), every channel read after mj_forward."""
    cfg = _config(hold="zoh", timeconst=0.0, delay=0.0, velocity_ff=False,
                  gravity_comp=False)
    poses = _sine(200, 5.0, [0.0005, -0.0003, 0.001, 0.002, 0.0, 0.001])
    _, rec = _stepped([cfg], poses)
    m = build_model(cfg)
    d = mujoco.MjData(m)
    mujoco.mj_resetData(m, d)
    # the bench starts at rest where its servos hold the weight (here uncompensated: sagged);
    # that configuration, from a batch that does not settle, is this loop's start
    d.qpos[:] = PlatformBatch(cfg, nsim=1, settle=0.0).batch.bind("qpos")[0]
    mujoco.mj_step(m, d, 50)  # the batch's 0.05 s settle at 1 ms
    home = cfg.geometry.home_leg_lengths()
    L = _ik(cfg, poses)
    aa = m.actuator_actadr[[m.actuator(f"leg{i}").id for i in range(6)]]
    qa = m.jnt_qposadr[m.joint("plate_free").id]
    q = np.zeros((len(poses), 7))
    mujoco.mj_forward(m, d)
    q[0] = d.qpos[qa:qa + 7]
    for r in range(1, len(poses)):
        d.act[aa] = L[r] - home
        d.ctrl[:] = 0.0
        mujoco.mj_step(m, d)
        mujoco.mj_forward(m, d)
        q[r] = d.qpos[qa:qa + 7]
    peak = np.max(np.abs(q[:, :3] - q[0, :3]))
    assert np.max(np.abs(rec["q"][:, 0, :3] - q[:, :3])) <= 1e-12 * max(peak, 1e-3)
    assert np.max(np.abs(rec["q"][:, 0, 3:] - q[:, 3:])) <= 1e-12
    # the held set-point is the commanded extension, not a ramp towards it
    np.testing.assert_allclose(rec["act"][1:, 0], L[1:] - home, rtol=0, atol=1e-15)


@pytest.mark.parametrize("f", [5.0, 20.0])
def test_zoh_leads_the_ramp_by_half_a_step(f):
    """Holding c_{k+1} over [t_k, t_{k+1}) instead of ramping c_k → c_{k+1} is the ramp
    advanced by ΔT/2 (the ZOH's rectangle is centred half a step before the sample, the ramp's
    triangle on it): at every frequency the plate's response leads by 0.5 ms (to 2 %), with
    the amplitude 1/sinc(ωΔT/2) larger (to 0.05 %)."""
    cfgs = [_config(), _config(hold="zoh")]
    n = int(round(0.25 / DT)) + int(round(8 / f / DT))
    _, rec = _stepped(cfgs, _sine(n, f, [0, 0, 0.0005, 0, 0, 0]))
    z = rec["q"][int(round(0.25 / DT)):, :, 2]
    (a0, d0), (a1, d1) = _phase_delay(z[:, 0], f), _phase_delay(z[:, 1], f)
    assert d0 - d1 == pytest.approx(DT / 2, rel=0.02)
    x = math.pi * f * DT
    assert a1 / a0 == pytest.approx(x / math.sin(x), rel=5e-4)


def test_start_sampling_is_the_end_record_one_row_earlier():
    """Open loop, a bench sampling at the start of each step records, in row r, what the
    end-sampling bench recorded in row r − 1: plate pose, leg extensions and forces, the raw
    FTS, the interface displacement and wrench (row 0, the rest, the same)."""
    cfgs = [_config(), _config(sample="start")]
    poses = _sine(300, 7.0, [0.001, 0.0005, 0.002, 0.003, -0.002, 0.004])
    _, rec = _stepped(cfgs, poses)
    for key, arr in rec.items():
        if key == "act":
            continue
        end, start = arr[:, 0], arr[:, 1]
        peak = max(float(np.max(np.abs(end))), 1e-300)
        assert np.max(np.abs(start[1:] - end[:-1])) <= 1e-12 * peak, key
        assert np.max(np.abs(start[0] - end[0])) <= 1e-12 * peak, key
    # and it is a real shift: the step moved the plate by more than rounding
    assert np.max(np.abs(rec["q"][1:, 0, 2] - rec["q"][1:, 1, 2])) > 1e-6


@pytest.mark.parametrize("form", ["backward", "central", "none"])
def test_feedforward_setpoints_follow_their_difference_form(form):
    """Servo set-points after each step (ramp hold: exactly c_{k+1}) equal
    L_{k+1} − L_home + (kv/kp)·D with D = (L_{k+1} − L_k)/ΔT, (L_{k+2} − L_k)/(2ΔT) or 0,
    from the inverse kinematics written here (no lag, delay or gravity compensation)."""
    cfg = _config(timeconst=0.0, delay=0.0, gravity_comp=False, feedforward=form)
    poses = _sine(120, 9.0, [0.001, -0.0005, 0.002, 0.001, 0.002, -0.003])
    _, rec = _stepped([cfg], poses, replay=True)
    a = cfg.actuator
    L = _ik(cfg, poses)
    home = cfg.geometry.home_leg_lengths()
    N = len(poses)
    want = L - home
    for r in range(1, N):
        nxt = L[min(r + 1, N - 1)]
        D = {"backward": (L[r] - L[r - 1]) / DT, "central": (nxt - L[r - 1]) / (2 * DT),
             "none": 0.0}[form]
        want[r] = want[r] + a.kv / a.kp * D
    np.testing.assert_allclose(rec["act"][1:, 0], want[1:], rtol=0, atol=1e-12)


def test_no_feedforward_lags_by_kv_over_kp():
    """Without feed-forward the servo's damping on the absolute leg velocity lags the plate by
    kv/kp (10 ms here) at low frequency against the backward-difference feed-forward (2 Hz:
    to 3 %)."""
    f = 2.0
    cfgs = [_config(), _config(feedforward="none")]
    n = int(round(0.25 / DT)) + int(round(3 / f / DT))
    _, rec = _stepped(cfgs, _sine(n, f, [0, 0, 0.001, 0, 0, 0]))
    z = rec["q"][int(round(0.25 / DT)):, :, 2]
    d_back, d_none = _phase_delay(z[:, 0], f)[1], _phase_delay(z[:, 1], f)[1]
    a = cfgs[0].actuator
    assert d_none - d_back == pytest.approx(a.kv / a.kp, rel=0.03)


def test_central_feedforward_is_refused_in_a_closed_loop():
    """A closed loop does not know its next set-point: one ConfigError naming the field."""
    with pytest.raises(ConfigError) as exc:
        PlatformBatch(_config(feedforward="central"))
    assert exc.value.field == "controller.feedforward"
    assert "\n" not in str(exc.value) and "central" in str(exc.value)


@pytest.fixture(scope="module")
def replays():
    """A heave scene's bench replayed with each sampling instant and hold."""
    sc = load_scene("bench6", ["duration=0.3"])
    poses = _sine(300, 6.0, [0.0005, 0.0, 0.002, 0.0, 0.003, 0.0])
    out = {}
    for name, act in (("end", {}), ("start", {"sample": "start"}), ("zoh", {"hold": "zoh"}),
                      ("central", {"feedforward": "central"})):
        b = Bench.from_scene(sc)
        b = dataclasses.replace(b, platform=dataclasses.replace(
            b.platform, actuator=dataclasses.replace(b.platform.actuator, **act)))
        out[name] = (b, BenchReplay(sc, poses, base=b).run([list(sc.effects)])[0])
    return sc, poses, out


def test_replay_of_a_start_sampling_bench_shifts_every_channel(replays):
    """The replay of a start-sampling bench is the end-sampling one shifted by one row, in
    every channel (interface, pose, legs, FTS)."""
    sc, _, out = replays
    end, start = out["end"][1], out["start"][1]
    for c, v in end.items():
        if c.startswith("_"):
            continue
        peak = max(float(np.max(np.abs(v))), 1e-300)
        assert np.max(np.abs(start[c][1:] - v[:-1])) <= 1e-12 * peak, c


def test_replay_of_a_zoh_bench_equals_its_stepped_record(replays):
    """The replay of a zero-order-hold bench (each step sampled at its end) equals the same
    bench stepped one step at a time with a sample after each (plate pose, legs, FTS)."""
    sc, poses, out = replays
    b, got = out["zoh"]
    from rths3d.bench import platform_batch

    sim = platform_batch([b])
    N = len(poses)
    q = np.zeros((N, 7))
    lf = np.zeros((N, 6))
    ft = np.zeros((N, 6))
    q[0], lf[0], ft[0] = sim.plate_qpos[0], sim.meas_legs_f[0], sim.fts_reading[0]
    for r in range(1, N):
        sim.step(poses[r][None])
        q[r], lf[r], ft[r] = sim.plate_qpos[0], sim.meas_legs_f[0], sim.fts_reading[0]
    assert np.max(np.abs(got["pose_meas.z"] - (q[:, 2] - b.platform.geometry.home_height))) \
        <= 1e-12 * np.max(np.abs(got["pose_meas.z"]))
    for i in range(6):
        want = lf[:, i] - sim.rest_leg_forces[0, i]
        assert np.max(np.abs(got[f"leg_force.{i}"] - want)) <= 1e-12 * np.max(np.abs(want))
    for j, c in enumerate(("fx", "fy", "fz", "tx", "ty", "tz")):
        peak = max(float(np.max(np.abs(ft[:, j]))), 1e-300)
        assert np.max(np.abs(got[f"fts.{c}"] - ft[:, j])) <= 1e-12 * peak, c


def test_replay_central_feedforward_differs_from_backward_by_a_lead(replays):
    """The central difference's feed-forward is half a step ahead of the backward one: the
    replayed leg forces differ (the form is honoured), by less than the servo's own lag term
    (kv·ΔL/ΔT, the whole feed-forward)."""
    _, poses, out = replays
    a, c = out["end"][1], out["central"][1]
    diff = max(float(np.max(np.abs(a[f"leg_force.{i}"] - c[f"leg_force.{i}"])))
               for i in range(6))
    assert diff > 1e-3  # N
    assert np.max(np.abs(a["pose_meas.z"] - c["pose_meas.z"])) < 0.05 * np.max(
        np.abs(a["pose_meas.z"]))
