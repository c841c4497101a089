"""The simulated platform: tracking, delays, FTS conventions, limits and blow-up detection."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rths3d.errors import ConfigError, SafetyStop
from rths3d.platform.kinematics import rotation_matrix
from rths3d.platform.model import ActuatorConfig, PlatformConfig, build_model, predicted_delay
from rths3d.platform.sim import PlatformBatch
from rths3d.platform.single import PlatformSim
from rths3d.platform.tracking import sine_trajectory, track, tracking_figures

MASS = 2.0  # kg, payload of the FTS tests
COM = 0.05  # m, payload centre of mass above the FTS site
PAYLOAD = (f'<body name="mass"><geom type="box" size="0.05 0.05 {COM}" pos="0 0 {COM}" '
           f'mass="{MASS}"/></body>')
# a stiff, light specimen: explicit in its spring, it blows up within a few 1 ms steps
STIFF = ('<body name="spec"><joint name="spec_z" type="slide" axis="0 0 1" stiffness="1e9"/>'
         '<geom type="sphere" size="0.02" mass="0.001" pos="0 0 0.02"/></body>')


@pytest.fixture(scope="module")
def heave_runs():
    """1 Hz, 5 mm heave with and without velocity feed-forward (ramped in over 0.5 s)."""
    out = {}
    for ff in (True, False):
        cfg = PlatformConfig(actuator=ActuatorConfig(velocity_ff=ff))
        rec = track(sine_trajectory("z", 0.005, 1.0, 2.5, ramp=0.5), cfg)
        out[ff] = (cfg, rec, tracking_figures(rec, "z", 1.0, cfg))
    return out


@pytest.fixture(scope="module")
def payload_sim():
    return PlatformSim(PlatformConfig(), payload_xml=PAYLOAD)


@pytest.mark.parametrize("ff", [True, False])
def test_heave_delay_matches_actuator_prediction(heave_runs, ff):
    """1 Hz 5 mm heave: achieved delay within 0.5 ms of the settings' prediction."""
    cfg, rec, fig = heave_runs[ff]
    assert rec.meta["status"] == "ok"
    assert fig.delay == pytest.approx(predicted_delay(cfg, 1.0), abs=0.5e-3)
    # and the two cases really differ by the servo lag kv/kp = 10 ms
    expected_lag = 0.0 if ff else cfg.actuator.kv / cfg.actuator.kp
    assert fig.delay - predicted_delay(PlatformConfig(actuator=ActuatorConfig(
        velocity_ff=True)), 1.0) == pytest.approx(expected_lag, abs=0.5e-3)
    assert fig.amplitude_ratio == pytest.approx(1.0, abs=0.01)


@pytest.mark.parametrize("ff", [True, False])
def test_heave_parasitic_motion_and_equality_gap(heave_runs, ff):
    """Heave moves the other five DOF < 1 µm / 1 µrad; the leg-plate gap stays < 5 µm."""
    _, rec, fig = heave_runs[ff]
    assert fig.parasitic_translation < 1e-6
    assert fig.parasitic_rotation < 1e-6
    assert fig.max_eq_gap < 5e-6
    assert np.max(np.abs(rec.columns["pose_meas.z"])) > 4.9e-3  # it did move


@pytest.mark.parametrize("dof,amp", [("x", 0.005), ("y", 0.005), ("rx", 0.01), ("ry", 0.01),
                                     ("rz", 0.01)])
def test_other_dofs_track(dof, amp):
    """Surge, sway, roll, pitch and yaw follow a 1 Hz sine with the predicted delay."""
    cfg = PlatformConfig()
    rec = track(sine_trajectory(dof, amp, 1.0, 2.0, ramp=0.5), cfg)
    fig = tracking_figures(rec, dof, 1.0, cfg)
    assert fig.delay == pytest.approx(predicted_delay(cfg), abs=0.5e-3)
    assert fig.amplitude_ratio == pytest.approx(1.0, abs=0.01)
    assert fig.nrms_error < 0.05
    # coupling into the other DOF stays small against the motion itself
    assert fig.parasitic_translation < 1e-3 * 0.005 / 0.01 * (amp if dof[0] == "r" else 0.01)
    assert fig.parasitic_rotation < 5e-3 * (amp / 0.005 * 0.01 if dof[0] != "r" else amp)


def test_record_columns_and_leg_commands():
    """The tracking record holds the schema columns; leg commands are the IK of the poses."""
    from rths3d.platform.kinematics import inverse_kinematics

    cfg = PlatformConfig()
    poses = sine_trajectory("z", 0.002, 2.0, 0.3, ramp=0.1)
    rec = track(poses, cfg)
    for c in ("pose_cmd.z", "pose_meas.rx", "z_cmd.z", "z_meas.z", "f_meas.z", "leg_cmd.0",
              "leg_len.5", "leg_force.3", "fts.fz", "fts.tz", "eq_gap"):
        assert c in rec.columns
    L = np.column_stack([rec.columns[f"leg_cmd.{i}"] for i in range(6)])
    assert np.allclose(L, inverse_kinematics(cfg.geometry, poses), atol=1e-15)
    assert rec.t[0] == pytest.approx(cfg.dt) and rec.dt == pytest.approx(cfg.dt)


def test_gravity_compensation_removes_sag():
    """Gravity compensation holds home to < 5 µm; without it the legs sag by f/kp."""
    on = PlatformSim(PlatformConfig(), payload_xml=PAYLOAD, settle=0.3)
    off = PlatformSim(PlatformConfig(actuator=ActuatorConfig(gravity_comp=False)),
                      payload_xml=PAYLOAD, settle=0.3)
    assert abs(on.pose[2]) < 5e-6
    sag = np.array(off.leg_lengths) - off.config.geometry.home_leg_lengths()
    # static leg force / kp is the sag of an uncompensated position servo
    assert np.allclose(sag, -off.static.leg_forces / off.config.actuator.kp, rtol=0.05)
    assert np.all(sag < -1e-4)


def test_static_leg_forces_balance_weight():
    """With (nearly) massless legs each leg carries M·g / (6·u_z) by symmetry (statics)."""
    from rths3d.platform.geometry import StewartGeometry

    geom = StewartGeometry(cylinder_mass=1e-6, piston_mass=1e-6)
    # massless pistons: only an integrator implicit in the servo damping steps them
    sim = PlatformSim(PlatformConfig(geometry=geom, integrator="implicitfast"),
                      payload_xml=PAYLOAD)
    uz = geom.home_leg_vectors()[:, 2] / geom.home_leg_lengths()
    M = geom.plate_mass + geom.fts_mass + MASS
    assert np.allclose(sim.static.leg_forces, M * 9.81 / (6 * uz), rtol=1e-5)
    assert sim.static.payload_mass == pytest.approx(MASS)
    assert np.allclose(sim.static.preload, [0, 0, MASS * 9.81, 0, 0, 0], atol=1e-9)


def test_fts_static_payload_reads_mg(payload_sim):
    """A static payload of mass m reads +m·g along the sensor z axis; f_meas is zero."""
    sim = payload_sim
    sim.reset()
    for _ in range(200):
        sim.step(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    fx, fy, fz, tx, ty, tz = sim.wrench
    assert fz == pytest.approx(MASS * 9.81, rel=1e-6)
    assert max(abs(fx), abs(fy), abs(tx), abs(ty), abs(tz)) < 1e-6
    assert np.max(np.abs(sim.interface_wrench)) < 1e-4


def test_fts_tilted_plate_reads_rotated_weight(payload_sim):
    """Tilted by (rx, ry), the sensor reads Rᵀ(0,0,mg) and the torque of the offset mass."""
    sim = payload_sim
    sim.reset()
    target = np.array([0.0, 0.0, 0.0, 0.04, -0.03, 0.0])
    n_ramp, n_hold = 1000, 800
    for k in range(n_ramp + n_hold):
        s = min(1.0, (k + 1) / n_ramp)
        q = target * (0.5 - 0.5 * math.cos(math.pi * s))
        sim.step(*map(float, q))
    pose = np.array(sim.pose)
    assert np.allclose(pose, target, atol=1e-4)  # gravity compensation is exact at home only
    R = rotation_matrix(*pose[3:])
    W = np.array([0.0, 0.0, MASS * 9.81])
    f_site = R.T @ W
    t_site = np.cross([0.0, 0.0, COM], f_site)
    w = np.array(sim.wrench)
    assert np.allclose(w[:3], f_site, atol=2e-3 * MASS * 9.81)
    assert np.allclose(w[3:], t_site, atol=2e-3 * MASS * 9.81 * COM)
    assert abs(f_site[0]) > 0.5  # the tilt is visible in the reading
    # interface wrench: world axes, the weight itself removed, the torque change remains
    iw = np.array(sim.interface_wrench)
    assert np.allclose(iw[:3], 0.0, atol=2e-3 * MASS * 9.81)
    assert np.allclose(iw[3:], np.cross(R @ [0, 0, COM], W), atol=2e-3 * MASS * 9.81 * COM)


def test_interface_force_sign_restoring():
    """A spring pressed by the rising plate gives f_meas,z = +k·Δz (restoring force)."""
    k = 2.0e4  # N/m
    # a free mass on a slide spring under a world-fixed stop: the plate pushes it up
    payload = (f'<body name="spec"><joint name="spec_z" type="slide" axis="0 0 1" '
               f'stiffness="{k}" damping="200"/><geom type="sphere" size="0.02" mass="0.5" '
               f'pos="0 0 0.02"/></body>')
    sim = PlatformSim(PlatformConfig(), payload_xml=payload, settle=0.5)
    # hold the specimen mass against the world so that the spring is compressed by z
    eq = sim.model.jnt_qposadr[sim.model.joint("spec_z").id]
    q_eq = -0.5 * 9.81 / k  # static equilibrium of the specimen spring under its weight
    assert sim.data.qpos[eq] == pytest.approx(q_eq, rel=1e-3)
    n = 1500
    for j in range(n):
        s = min(1.0, (j + 1) / 1000)
        z = 0.002 * (0.5 - 0.5 * math.cos(math.pi * s))
        sim.data.qpos[eq] = q_eq - z  # specimen mass held fixed in the world
        sim.data.qvel[sim.model.jnt_dofadr[sim.model.joint("spec_z").id]] = 0.0
        sim.step(0.0, 0.0, z, 0.0, 0.0, 0.0)
    # hold the mass where it is meant to be at the sampling instant too (the step let it
    # move for 1 ms), then sample the channels of that state again
    sim.data.qpos[eq] = q_eq - z
    sim.data.qvel[sim.model.jnt_dofadr[sim.model.joint("spec_z").id]] = 0.0
    import mujoco

    mujoco.mj_forward(sim.model, sim.data)
    sim._b.read_fts()  # the sensor's reading of that state
    fz = sim.interface_wrench[2]
    z = sim.pose[2]
    assert z == pytest.approx(0.002, abs=5e-5)  # servo compliance under the 40 N load
    assert fz == pytest.approx(k * 0.002, rel=0.02)
    assert fz > 0


def test_unreachable_pose_stops_before_step():
    """A pose beyond the stroke stops before stepping, naming leg, quantity, value and limit."""
    sim = PlatformSim(PlatformConfig())
    with pytest.raises(SafetyStop) as info:
        sim.step(0.0, 0.0, 0.0003, 0.0, 0.0, 0.0)
        for k in range(2, 400):
            sim.step(0.0, 0.0, 0.0003 * k, 0.0, 0.0, 0.0)
    e = info.value
    assert e.quantity == "leg 0 commanded stroke"
    assert e.value > e.limit == pytest.approx(0.05)
    assert "leg 0 commanded stroke" in str(e) and "0.05" in str(e)
    # the plate never went beyond the stroke
    assert max(abs(v) for v in np.array(sim.leg_lengths) - sim.config.geometry.home_leg_lengths()) \
        <= 0.05


def test_velocity_limit_stops_at_the_step():
    """A command step faster than the leg speed limit stops with 'leg i commanded velocity'."""
    sim = PlatformSim(PlatformConfig())
    sim.step(0.0, 0.0, 0.0001, 0.0, 0.0, 0.0)
    with pytest.raises(SafetyStop, match=r"leg \d commanded velocity = .* m/s exceeds the limit "
                                         r"0\.3 m/s") as info:
        sim.step(0.0, 0.0, 0.002, 0.0, 0.0, 0.0)
    assert info.value.t == pytest.approx(0.002)  # the time the refused command was meant for


def test_force_limit_stops_with_measured_force():
    """A leg force above the limit stops the test naming 'leg i force', value and limit."""
    cfg = PlatformConfig(actuator=ActuatorConfig(force_limit=60.0))
    sim = PlatformSim(cfg, payload_xml=PAYLOAD)
    assert np.all(np.abs(sim.static.leg_forces) < 60.0)
    with pytest.raises(SafetyStop, match=r"leg \d force = .* N exceeds the limit 60 N") as info:
        for k in range(2000):  # a fast upward sine needs more than the static force
            sim.step(0.0, 0.0, 0.004 * math.sin(2 * math.pi * 8 * (k + 1) * 1e-3), 0, 0, 0)
    assert abs(info.value.value) > 60.0


def test_blow_up_detected_not_silently_reset():
    """An unstable specimen (1e9 N/m on 1 g at 1 ms) is caught as divergence, never a silent
    reset (the legs stay within their real stroke, so the blow-up itself stops the test)."""
    sim = PlatformSim(PlatformConfig(), payload_xml=STIFF, settle=0.0)
    with pytest.raises(SafetyStop, match="divergence") as info:
        for k in range(1000):
            sim.step(0.0, 0.0, 1e-5 * k, 0.0, 0.0, 0.0)
    assert info.value.t > 0.0
    assert "bad acceleration" in str(info.value)


def test_track_keeps_partial_record_on_stop():
    """track() returns the samples up to a stop with status 'stopped' and the reason."""
    poses = np.zeros((2000, 6))
    poses[:, 2] = np.linspace(0, 0.2, 2000)  # 0.1 m/s; leaves the stroke near z = 60 mm
    rec = track(poses, PlatformConfig())
    assert rec.meta["status"] == "stopped"
    assert "commanded stroke" in rec.meta["reason"]
    assert 100 <= rec.n < 2000
    assert rec.columns["pose_meas.z"][-1] > 0.04


def test_bad_config_and_fragment_are_named():
    """Bad actuator values and invalid MJCF fragments raise ConfigError naming the field."""
    with pytest.raises(ConfigError, match="actuator.kp"):
        ActuatorConfig(kp=-1.0)
    with pytest.raises(ConfigError, match="platform.substeps"):
        PlatformConfig(substeps=0)
    with pytest.raises(ConfigError, match="payload_xml"):
        build_model(PlatformConfig(), payload_xml="<body><geom type='nonsense'/></body>")


def test_model_names_and_substeps():
    """Stable names exist; substeps divide the interface step."""
    m = build_model(PlatformConfig(substeps=4))
    assert m.opt.timestep == pytest.approx(0.25e-3)
    for name in ("plate", "fts_body"):
        m.body(name)
    m.site("fts")
    m.sensor("fts_force")
    m.sensor("fts_torque")
    for i in range(6):
        m.joint(f"leg{i}_slide")
        m.actuator(f"leg{i}")
    assert m.neq == 6


def test_batch_matches_single_and_freezes_stopped_test():
    """PlatformBatch reproduces PlatformSim; a test at its limit is frozen, others go on."""
    cfg = PlatformConfig()
    poses = sine_trajectory("z", 0.004, 2.0, 0.4, ramp=0.1)
    single = track(poses, cfg)
    batch = PlatformBatch(cfg, nsim=3, nthread=1)
    out = np.zeros((poses.shape[0], 3, 6))
    f = np.zeros((poses.shape[0], 3, 6))
    for k, q in enumerate(poses):
        cmd = np.tile(q, (3, 1))
        cmd[1, 2] = q[2] + 0.3 * min(1.0, k / 300)  # test 1 leaves the stroke
        batch.step(cmd)
        out[k] = batch.pose
        f[k] = batch.interface_wrench
    z = single.columns["pose_meas.z"]
    assert np.allclose(out[:, 0, 2], z, atol=1e-12)
    assert np.allclose(out[:, 2, 2], z, atol=1e-12)
    assert np.allclose(f[:, 0, 2], single.columns["f_meas.z"], atol=1e-9)
    assert list(batch.stopped) == [False, True, False]
    assert "leg" in batch.reasons[1] and "test 1" in batch.reasons[1]
    assert batch.reasons[0] == "" and np.isnan(batch.stop_time[0])
    assert 0.0 < batch.stop_time[1] < 0.4


def test_batch_divergence_flags_only_the_unstable_test():
    """A batch test with an unstable specimen is flagged 'divergence'; a stable one runs on."""
    batch = PlatformBatch(PlatformConfig(), nsim=2, nthread=1, payload_xml=STIFF, settle=0.0)
    batch.batch.joint("spec_z").stiffness = np.array([[1e3], [1e9]])  # test 0: stable
    batch.reset()
    for k in range(600):
        q = np.zeros((2, 6))
        q[:, 2] = 1e-5 * k
        batch.step(q)
    assert list(batch.stopped) == [False, True]
    assert "divergence" in batch.reasons[1] and "bad acceleration" in batch.reasons[1]
    assert 0.0 < batch.stop_time[1] < 0.1
    assert batch.pose[0, 2] == pytest.approx(1e-5 * 599, abs=3e-4)  # the ramp, a few ms late
    assert abs(batch.pose[0, 2]) > 1e-3


def test_payload_inertia_force_is_mass_times_acceleration(payload_sim):
    """At 4 Hz the interface force of a rigid payload is m·a, opposite to the displacement."""
    from rths3d.platform.tracking import sine_delay

    f_hz = 4.0
    rec = track(sine_trajectory("z", 0.002, f_hz, 1.5, ramp=0.25), sim=payload_sim)
    sel = rec.t > 0.75
    t = rec.t[sel]
    z = rec.columns["pose_meas.z"][sel]
    fz = rec.columns["f_meas.z"][sel]
    w = 2 * np.pi * f_hz
    X = np.column_stack([np.sin(w * t), np.cos(w * t), np.ones_like(t)])
    amp_z = np.hypot(*np.linalg.lstsq(X, z, rcond=None)[0][:2])
    amp_f = np.hypot(*np.linalg.lstsq(X, fz, rcond=None)[0][:2])
    assert amp_f == pytest.approx(MASS * w ** 2 * amp_z, rel=0.01)
    # f = m·a = −m ω² z: in anti-phase with the displacement, sampled at the same instant
    # (every channel is read at the end of the step from one state: no lag)
    lag, _ = sine_delay(t, -z, fz, f_hz)
    assert lag == pytest.approx(0.0, abs=0.05e-3)


@pytest.mark.parametrize("substeps", [2, 4])
def test_substeps_keep_predicted_delay_and_tighter_gap(substeps):
    """With 2 or 4 physics substeps the delay still matches the prediction; the gap shrinks."""
    cfg = PlatformConfig(substeps=substeps)
    rec = track(sine_trajectory("z", 0.005, 1.0, 2.0, ramp=0.5), cfg)
    fig = tracking_figures(rec, "z", 1.0, cfg)
    assert cfg.timestep == pytest.approx(1e-3 / substeps)
    assert fig.delay == pytest.approx(predicted_delay(cfg, 1.0), abs=0.5e-3)
    assert fig.max_eq_gap < 2.5e-6


def test_world_contact_force_reaches_interface_wrench():
    """A world surface (world_xml) stopping the specimen: f_meas,z = spring force, > 0."""
    from rths3d.platform.geometry import DEFAULT_GEOMETRY as G

    k, m, gap = 2.0e4, 0.5, 0.002
    q_eq = -m * 9.81 / k
    payload = (f'<body name="spec"><joint name="spec_z" type="slide" axis="0 0 1" '
               f'stiffness="{k}" damping="200"/><geom type="sphere" size="0.02" '
               f'mass="{m}" pos="0 0 0.02"/></body>')
    top = G.home_height + G.fts_height + 0.04 + q_eq  # sphere top at rest, world z (m)
    world = (f'<geom name="stop" type="box" size="0.1 0.1 0.01" pos="0 0 {top + gap + 0.01}" '
             f'solref="0.002 1"/>')
    sim = PlatformSim(PlatformConfig(), payload_xml=payload, world_xml=world, settle=0.3)
    assert sim.interface_wrench[2] == pytest.approx(0.0, abs=1e-3)  # no contact yet
    adr = sim.model.jnt_qposadr[sim.model.joint("spec_z").id]
    for j in range(1500):
        s = min(1.0, (j + 1) / 1000)
        sim.step(0.0, 0.0, 0.005 * (0.5 - 0.5 * math.cos(math.pi * s)), 0.0, 0.0, 0.0)
    compression = q_eq - float(sim.data.qpos[adr])
    assert compression > 0.002  # the surface holds the mass while the plate rises 5 mm
    assert sim.interface_wrench[2] == pytest.approx(k * compression, rel=0.02)
    assert sim.model.geom("stop").contype == 1  # world geoms keep MuJoCo's defaults


def test_batch_translation_path_matches_full_path():
    """The translation-only IK and the translational interface force equal the full 6-DOF path
    (same leg commands, same plate motion, same F'_m rows)."""
    cfg = PlatformConfig()
    poses = sine_trajectory("z", 0.004, 2.0, 0.2, ramp=0.05)
    poses[:, 0] = 0.3 * poses[:, 2]  # surge with heave, no rotation
    full = PlatformBatch(cfg, nsim=2, nthread=1, payload_xml=PAYLOAD)
    fast = PlatformBatch(cfg, nsim=2, nthread=1, payload_xml=PAYLOAD)
    rows = np.array([0, 2])
    for q in poses:
        cmd = np.tile(q, (2, 1))
        full.step(cmd)
        fast.step(cmd, translation_only=True)
        np.testing.assert_allclose(fast.plate_qpos, full.plate_qpos, atol=1e-12)
        np.testing.assert_allclose(fast.interface_force(rows),
                                   full.interface_wrench[:, rows], atol=1e-9)
    assert np.abs(full.pose[:, 2]).max() > 1e-3  # it moved


def test_plate_pose_of_qpos_rows_matches_scalar_conversion():
    """plate_pose over (…, 7) rows gives the scalar pose conversion of PlatformSim."""
    from rths3d.platform.kernels import _quat_to_euler, plate_pose

    rng = np.random.default_rng(3)
    q = rng.normal(size=(4, 5, 7))
    q[..., 3:] /= np.linalg.norm(q[..., 3:], axis=-1, keepdims=True)
    out = plate_pose(q, 0.5)
    for i in range(4):
        for j in range(5):
            w, x, y, z = q[i, j, 3:]
            exp = (q[i, j, 0], q[i, j, 1], q[i, j, 2] - 0.5, *_quat_to_euler(w, x, y, z))
            np.testing.assert_allclose(out[i, j], exp, atol=1e-12)


def test_batch_variants_per_test_servo_settings():
    """Per-test servo settings in one batch: each test tracks like its own single platform."""
    fast = PlatformConfig(actuator=ActuatorConfig(kp=3e5, velocity_ff=True))
    slow = PlatformConfig(actuator=ActuatorConfig(kp=1e5, velocity_ff=False, timeconst=0.006))
    poses = sine_trajectory("z", 0.004, 2.0, 0.3, ramp=0.1)
    batch = PlatformBatch(nsim=2, nthread=1, variants=[(fast, None, None), (slow, None, None)])
    z = np.zeros((poses.shape[0], 2))
    for k, q in enumerate(poses):
        batch.step(np.tile(q, (2, 1)), translation_only=True)
        z[k] = batch.pose[:, 2]
    for j, cfg in enumerate((fast, slow)):
        single = track(poses, cfg)
        np.testing.assert_allclose(z[:, j], single.columns["pose_meas.z"], atol=1e-12)
    assert np.abs(z[:, 0] - z[:, 1]).max() > 1e-5
    # the set-point delay is a per-test block: tests with different delays batch together
    late = PlatformConfig(actuator=ActuatorConfig(delay=0.0035))
    batch = PlatformBatch(nsim=2, nthread=1, variants=[(fast, None, None), (late, None, None)])
    for k, q in enumerate(poses):
        batch.step(np.tile(q, (2, 1)))
        z[k] = batch.pose[:, 2]
    np.testing.assert_allclose(z[:, 1], track(poses, late).columns["pose_meas.z"], atol=1e-12)


def test_variants_of_another_structure_raise_config_error():
    """Variants whose payloads differ in structure raise a one-line ConfigError, not
    mujoco.FatalError."""
    other = '<body name="p"><geom type="sphere" size=".05" mass="1"/></body>'
    with pytest.raises(ConfigError, match="variants: .*one model structure"):
        PlatformBatch(nsim=2, nthread=1, variants=[(PlatformConfig(), None, None),
                                                   (PlatformConfig(), other, None)])


def test_variants_reset_set_const_recomputes_each_model():
    """reset(set_const=True) on a variant batch recomputes each test's model constants: a
    payload made heavier on one variant model gets its own FTS preload."""
    pay = '<body name="payload"><geom type="box" size=".05 .05 .05" mass="5"/></body>'
    variants = [(PlatformConfig(), pay, None),
                (PlatformConfig(actuator=ActuatorConfig(kp=3e5)), pay, None)]
    batch = PlatformBatch(nsim=2, nthread=1, variants=variants)
    heavy = batch.batch.models[1]
    b = heavy.body("payload").id
    heavy.body_mass[b] = 20.0
    heavy.body_inertia[b] *= 4.0
    batch.reset(set_const=True)
    assert batch.wrench[:, 2] == pytest.approx([5 * 9.81, 20 * 9.81], rel=1e-3)
    assert np.abs(batch.interface_wrench[:, 2]).max() < 0.05  # the preload follows the mass


def test_measured_limits_report_the_same_reason_in_single_and_batch():
    """A leg over stroke while another is over speed stops with the same reason in
    PlatformSim and PlatformBatch (leg by leg, then stroke, speed, force)."""
    sim = PlatformSim(settle=0.0)
    q, v, f = [0.0, 0.0, 0.06, 0.0, 0.0, 0.0], [0.5, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0] * 6
    with pytest.raises(SafetyStop) as info:
        sim._check_measured(q, v, f)
    batch = PlatformBatch(nsim=1, nthread=1, settle=0.0)
    batch.measured_limits(np.array([q]), np.array([v]), np.array([f]))
    assert info.value.reason == batch.reasons[0]
    assert info.value.quantity == "leg 0 velocity"


def test_stroke_override_beyond_the_legs_is_rejected():
    """An actuator stroke override whose half exceeds the home leg length is a ConfigError."""
    with pytest.raises(ConfigError, match="actuator.stroke: 5.0 .*home leg length 0.4512 m"):
        PlatformConfig(actuator=ActuatorConfig(stroke=5.0))
    assert PlatformConfig(actuator=ActuatorConfig(stroke=0.9)).stroke == 0.9


def test_stopped_sim_stays_stopped_until_reset():
    """After a SafetyStop every step raises it again without moving, until reset()."""
    sim = PlatformSim(PlatformConfig())
    sim.step(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    with pytest.raises(SafetyStop) as first:
        sim.step(0.0, 0.0, 0.06, 0.0, 0.0, 0.0)
    assert sim.stopped_by is first.value
    t, time = sim.t, float(sim.data.time)
    for _ in range(2):
        with pytest.raises(SafetyStop) as again:
            sim.step(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        assert again.value.reason == first.value.reason
    assert (sim.t, float(sim.data.time)) == (t, time)  # not stepped
    sim.reset()
    assert sim.stopped_by is None
    sim.step(0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    assert sim.t == pytest.approx(sim.config.dt)


def test_settle_zero_reads_the_compensated_state():
    """With settle=0, leg forces and the interface wrench describe the gravity-compensated
    state (static forces, preload removed), in PlatformSim and PlatformBatch."""
    pay = '<body name="payload"><geom type="box" size=".05 .05 .05" mass="5"/></body>'
    sim = PlatformSim(payload_xml=pay, settle=0.0)
    assert np.allclose(sim.leg_forces, sim.static.leg_forces, rtol=1e-6)
    assert abs(sim.interface_wrench[2]) < 1.0  # was −51.7 N: forces of ctrl = 0
    batch = PlatformBatch(nsim=2, nthread=1, payload_xml=pay, settle=0.0)
    np.testing.assert_allclose(batch.leg_forces, np.tile(sim.leg_forces, (2, 1)), atol=1e-9)
    np.testing.assert_allclose(batch.interface_wrench, np.tile(sim.interface_wrench, (2, 1)),
                               atol=1e-9)


def test_nan_command_is_a_safety_stop() -> None:
    """A NaN pose command stops the platform with a SafetyStop naming the leg, not a crash."""
    sim = PlatformSim(PlatformConfig())
    with pytest.raises(SafetyStop, match="leg 0 commanded stroke"):
        sim.step(0.0, 0.0, float("nan"), 0.0, 0.0, 0.0)
