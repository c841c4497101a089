"""Kinematic calibration (42 parameters, identifiability) and FTS / payload calibration.

The measurements come from MuJoCo, not from the calibration's own model: the platform MJCF
is edited in the test (base anchors = the leg cylinders' joint positions, top anchors = the
plate's anchor sites, leg offsets = the piston tip sites moved along the piston, the FTS
site moved and turned for a mounting error), driven to poses by this file's own set-point
ramp, and read as a bench reads it: plate pose from the free joint (converted to angles with
scipy), encoder lengths from the slide joints, the raw FTS sensor. Noise, gains and
cross-talk are applied here, with the numbers written below.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from rths3d.cli import main
from rths3d.errors import ConfigError
from rths3d.platform import DEFAULT_GEOMETRY as G
from rths3d.platform import ActuatorConfig, PlatformConfig, build_spec, check_workspace
from rths3d.platform.calibrate.fts import FTSCalibration, PayloadEstimator, load_wrench
from rths3d.platform.calibrate.kinematic import (
    CalibratedGeometry,
    KinematicCalibration,
    geometry_from_parameters,
    identifiability,
    identification_jacobian,
    leg_residuals,
    load_geometry,
    parameter_names,
    parameter_vector,
)
from rths3d.platform.calibrate.poses import select_poses

POSE_NOISE = (5e-6, 20e-6)  # pose measurement: 5 µm per translation, 20 µrad per angle
ENCODER_NOISE = 1e-6  # leg encoders, m
F_NOISE, T_NOISE = 0.05, 0.003  # FTS noise, N and N·m
RIG = PlatformConfig(actuator=ActuatorConfig(delay=0.0, timeconst=0.0))


# ----------------------------------------------------------------------------- MuJoCo rig
def _random_poses(rng, n, span=(0.03, 0.03, 0.03, 0.12, 0.12, 0.15)):
    """n poses uniform in a box, kept when the nominal platform reaches them with 5 mm of
    stroke to spare."""
    lo, hi = G.leg_length_limits()
    out = []
    while len(out) < n:
        q = rng.uniform(-1, 1, 6) * np.array(span)
        try:
            L = check_workspace(G, q)
        except Exception:
            continue
        if np.all(L > lo + 0.005) and np.all(L < hi - 0.005):
            out.append(q)
    return np.array(out)


def _pose_of(qpos7):
    """Pose relative to home from the plate free joint (position, quaternion w x y z)."""
    from scipy.spatial.transform import Rotation

    w, x, y, z = qpos7[3:]
    rz, ry, rx = Rotation.from_quat([x, y, z, w]).as_euler("ZYX")
    return np.array([qpos7[0], qpos7[1], qpos7[2] - G.home_height, rx, ry, rz])


def _drive(model, targets, loads=None, body=None, ramp=0.2, hold=0.15):
    """Drive the compiled platform to each target pose (raised-cosine ramp of the leg
    set-points from the nominal IK, then a hold) and read it at rest.

    ``loads`` (n, 6): external force/couple on ``body`` (world axes), ramped with the pose.
    Returns plate poses (n, 6), encoder lengths (n, 6) and raw FTS wrenches (n, 6).
    """
    import mujoco

    data = mujoco.MjData(model)
    dt = model.opt.timestep
    home = G.home_leg_lengths()
    slide = [model.jnt_qposadr[model.joint(f"leg{i}_slide").id] for i in range(6)]
    act = [model.actuator(f"leg{i}").id for i in range(6)]
    aadr = model.actuator_actadr[act]
    free = model.jnt_qposadr[model.joint("plate_free").id]
    fa = model.sensor_adr[model.sensor("fts_force").id]
    ta = model.sensor_adr[model.sensor("fts_torque").id]
    bid = model.body(body).id if body else None
    for _ in range(int(0.2 / dt)):  # let the edited chain close and settle at home
        mujoco.mj_step(model, data)
    from rths3d.platform import inverse_kinematics

    prev_s, prev_w = np.zeros(6), np.zeros(6)
    poses, lengths, wrench = [], [], []
    nr, nh = int(ramp / dt), int(hold / dt)
    for k, q in enumerate(targets):
        s = inverse_kinematics(G, q) - home
        w = np.zeros(6) if loads is None else np.asarray(loads[k], float)
        for j in range(nr + nh):
            a = 0.5 - 0.5 * math.cos(math.pi * min(1.0, (j + 1) / nr))
            # the servo's set-point is its activation (the control is its rate)
            data.act[aadr] = prev_s + a * (s - prev_s)
            if bid is not None:
                data.xfrc_applied[bid] = prev_w + a * (w - prev_w)
            mujoco.mj_step(model, data)
        prev_s, prev_w = s, w
        poses.append(_pose_of(data.qpos[free:free + 7]))
        lengths.append(home + data.qpos[slide])
        wrench.append(np.r_[data.sensordata[fa:fa + 3], data.sensordata[ta:ta + 3]])
    return np.array(poses), np.array(lengths), np.array(wrench)


@pytest.fixture(scope="module")
def bench():
    """A platform with anchor errors σ = 1 mm and leg offsets σ = 0.5 mm, measured at 50
    calibration and 50 validation poses (true and noisy readings)."""
    rng = np.random.default_rng(29)
    db = rng.normal(0.0, 1e-3, (6, 3))
    dp = rng.normal(0.0, 1e-3, (6, 3))
    dtip = rng.normal(0.0, 0.5e-3, 6)
    spec = build_spec(RIG)
    for i in range(6):
        spec.body(f"leg{i}_cyl").pos = spec.body(f"leg{i}_cyl").pos + db[i]
        spec.site(f"plate_anchor{i}").pos = spec.site(f"plate_anchor{i}").pos + dp[i]
        # the tip sits δ further along the piston: the geometric length is δ longer than
        # the encoder (home length + slide) reads, i.e. leg_offset = −δ
        spec.site(f"leg{i}_tip").pos = spec.site(f"leg{i}_tip").pos + [0.0, 0.0, dtip[i]]
    model = spec.compile()
    targets = _random_poses(rng, 100)
    q, L, _ = _drive(model, targets)
    noise = np.r_[[POSE_NOISE[0]] * 3, [POSE_NOISE[1]] * 3]
    q_meas = q + rng.normal(0.0, 1.0, q.shape) * noise
    L_meas = L + rng.normal(0.0, ENCODER_NOISE, L.shape)
    truth = np.concatenate([(G.base_anchors() + db).reshape(-1),
                            (G.top_anchors() + dp).reshape(-1), -dtip])
    return {"q": q, "L": L, "q_meas": q_meas, "L_meas": L_meas, "truth": truth,
            "cal": slice(0, 50), "val": slice(50, 100)}


# ----------------------------------------------------------------------------- geometry
def test_jacobian_matches_central_differences():
    """The analytic identification Jacobian equals central differences of the encoder
    lengths at a perturbed geometry and tilted poses (to 1e-8)."""
    rng = np.random.default_rng(1)
    th = parameter_vector(G) + rng.normal(0, 1e-3, 42)
    q = _random_poses(rng, 4)
    J = identification_jacobian(geometry_from_parameters(G, th), q)
    eps = 1e-6
    num = np.empty_like(J)
    for j in range(42):
        d = np.zeros(42)
        d[j] = eps
        num[:, j] = (geometry_from_parameters(G, th + d).encoder_lengths(q)
                     - geometry_from_parameters(G, th - d).encoder_lengths(q)).ravel() / (2 * eps)
    assert J.shape == (24, 42)
    g = geometry_from_parameters(G, th)
    L = g.encoder_lengths(q) + rng.normal(0, 1e-5, (4, 6))
    assert np.allclose(leg_residuals(g, q, L), g.encoder_lengths(q) - L, rtol=0, atol=1e-15)
    assert np.abs(J - num).max() < 1e-8
    assert parameter_names()[8] == "base_anchor[2].z" and parameter_names()[40] == "leg_offset[4]"


def test_calibrated_geometry_round_trip_and_drives_the_simulator(tmp_path):
    """A CalibratedGeometry survives JSON exactly, defaults to the nominal anchors, and the
    platform built from it (top anchors off the plate plane) reaches commanded poses through
    its own IK in PlatformSim and PlatformBatch (no gravity: 1e-9 m / rad)."""
    from rths3d.platform import PlatformBatch, PlatformSim, ScalarIK, inverse_kinematics

    assert np.array_equal(CalibratedGeometry().base_anchors(), G.base_anchors())
    assert np.array_equal(CalibratedGeometry().top_anchors(), G.top_anchors())
    rng = np.random.default_rng(2)
    th = parameter_vector(G) + np.r_[rng.normal(0, 1e-3, 36), rng.normal(0, 5e-4, 6)]
    g = geometry_from_parameters(G, th)
    path = tmp_path / "g.json"
    path.write_text(json.dumps(g.to_dict()))
    g2 = load_geometry(path)
    assert g2 == g and hash(g2) == hash(g)
    assert np.array_equal(parameter_vector(g2), th)
    q = np.array([0.01, -0.02, 0.015, 0.05, -0.04, 0.06])
    assert np.allclose(ScalarIK(g).ik(*q), inverse_kinematics(g, q), atol=1e-15)
    assert np.allclose(g.pose_from_encoders(g.encoder_lengths(q)), q, atol=1e-12)
    cfg = PlatformConfig(geometry=g, actuator=ActuatorConfig(delay=0.0, timeconst=0.0),
                         gravity=0.0)
    sim, batch = PlatformSim(cfg), PlatformBatch(cfg, nsim=1)
    for k in range(700):
        a = 0.5 - 0.5 * math.cos(math.pi * min(1.0, k / 500))
        sim.step(*(a * q))
        batch.step((a * q)[None])
    assert np.abs(np.array(sim.pose) - q).max() < 1e-9
    assert np.abs(batch.pose[0] - q).max() < 1e-9
    with pytest.raises(ConfigError, match="leg_offset"):
        CalibratedGeometry.from_dict({**g.to_dict(), "leg_offset": [0.0] * 5})


# ----------------------------------------------------------------------------- calibration
def test_calibration_predicts_unseen_poses_to_noise_level(bench):
    """Anchor errors σ = 1 mm, leg offsets σ = 0.5 mm, 50 poses measured with 5 µm /
    20 µrad: the calibrated geometry's forward kinematics from the 50 other poses' encoder
    readings lands within 3× the pose noise (RMS) of MuJoCo's poses; the nominal geometry
    misses by far more."""
    b = bench
    cal = KinematicCalibration().fit(b["q_meas"][b["cal"]], b["L_meas"][b["cal"]])
    assert cal.success_
    qv, Lv = b["q"][b["val"]], b["L_meas"][b["val"]]
    fk_cal = cal.predict_pose(Lv)
    fk_nom = CalibratedGeometry().pose_from_encoders(Lv)

    def rms(e):
        return (float(np.sqrt(np.mean(e[:, :3] ** 2))), float(np.sqrt(np.mean(e[:, 3:] ** 2))))

    t_cal, r_cal = rms(fk_cal - qv)
    t_nom, r_nom = rms(fk_nom - qv)
    # the IK side: encoder lengths predicted at the measured (noisy) validation poses
    ik_cal = float(np.sqrt(np.mean((cal.predict(b["q_meas"][b["val"]]) - Lv) ** 2)))
    ik_nom = float(np.sqrt(np.mean((CalibratedGeometry().encoder_lengths(
        b["q_meas"][b["val"]]) - Lv) ** 2)))
    print(f"\nFK pose error RMS: calibrated {t_cal * 1e6:.2f} µm / {r_cal * 1e6:.2f} µrad, "
          f"nominal {t_nom * 1e6:.1f} µm / {r_nom * 1e6:.1f} µrad; IK leg-length RMS: "
          f"calibrated {ik_cal * 1e6:.2f} µm, nominal {ik_nom * 1e6:.1f} µm; fit RMS "
          f"{cal.rms_ * 1e6:.2f} µm (nominal {cal.nominal_rms_ * 1e6:.1f} µm); condition "
          f"{cal.report_.condition_number:.4g}; parameter error max "
          f"{np.abs(cal.params_ - b['truth']).max() * 1e3:.3f} mm")
    assert t_cal < 3 * POSE_NOISE[0] and r_cal < 3 * POSE_NOISE[1]
    assert t_nom > 30 * POSE_NOISE[0] and r_nom > 30 * POSE_NOISE[1]
    assert ik_nom > 20 * ik_cal
    # the fitted parameters agree with the MJCF edits within 4 standard deviations
    z = (cal.params_ - b["truth"]) / cal.std_
    assert np.all(np.isfinite(cal.std_)) and np.abs(z).max() < 4.0
    assert float(np.sqrt(np.mean(z ** 2))) < 2.0
    # no exactly unobservable parameter from this pose set; every rigid motion of the frames
    # pinned (the translations only to ~1 mm: a leg offset trades against its base anchor
    # moving along the leg, which leg directions within ±0.15 rad barely tell apart)
    assert cal.report_.unobservable == () and cal.report_.rank == 42
    assert all(math.isfinite(g["std"]) for g in cal.report_.gauge)
    assert max(cal.std_[36:]) > 3 * max(cal.std_[18:36])  # offsets the weakest, as known


def test_pose_sets_that_cannot_identify_name_the_parameters(bench):
    """Heave-only poses cannot see any anchor (only base-to-top differences, and not their
    azimuth); poses without tilt cannot separate base from top anchor heights. The report
    names exactly those parameters and the rigid motions left free; the rich set names none."""
    heave = np.zeros((50, 6))
    heave[:, 2] = np.linspace(-0.03, 0.03, 50)
    rep = identifiability(G, heave, sigma=7e-6)
    assert rep.rank == 18  # per leg: radial distance, height difference, offset
    assert "base_anchor[2].z" in rep.unobservable and "top_anchor[5].x" in rep.unobservable
    assert len(rep.unobservable) == 36 and not any("leg_offset" in n for n in rep.unobservable)
    assert "leg_offset[4]" in rep.unidentifiable  # seen, but only through curvature
    assert rep.condition_number > 1e12
    assert any("cannot see 36 parameter(s)" in line for line in rep.lines())

    flat = bench["q_meas"][:50].copy()
    flat[:, 3:5] = 0.0  # yaw only
    rep = identifiability(G, flat, sigma=7e-6)
    expect = {f"{w}_anchor[{i}].z" for w in ("base", "top") for i in range(6)}
    assert set(rep.unobservable) == expect and rep.rank == 36
    free = {g["name"] for g in rep.gauge if not g["seen"]}
    assert {"base frame translation z", "plate frame translation z"} <= free

    rep = identifiability(G, bench["q_meas"][:50], sigma=7e-6)
    assert rep.unobservable == () and rep.condition_number < 1e5


def test_select_poses_beats_random_choice():
    """D-optimal selection of 30 of 600 workspace poses gives a smaller condition number and
    smaller worst parameter deviation than 30 random ones."""
    rng = np.random.default_rng(5)
    cand = _random_poses(rng, 600, span=(0.05, 0.05, 0.04, 0.25, 0.25, 0.3))
    idx = select_poses(G, cand, 30)
    assert len(set(idx.tolist())) == 30
    best = identifiability(G, cand[idx])
    rand = identifiability(G, cand[:30])
    assert best.condition_number < rand.condition_number
    assert max(best.parameter_std) < max(rand.parameter_std)


# ----------------------------------------------------------------------------- FTS
def _fts_spec(payload_mass, com, site_shift=(0, 0, 0), site_rotvec=(0, 0, 0)):
    """Platform with a payload (mass, CoM in the sensor frame) and the FTS site moved and
    turned in the MJCF (a mounting error)."""
    from scipy.spatial.transform import Rotation

    xml = (f'<body name="payload"><inertial pos="{com[0]} {com[1]} {com[2]}" '
           f'mass="{payload_mass}" diaginertia="0.05 0.05 0.05"/>'
           '<geom type="box" size="0.05 0.05 0.02" mass="0" contype="0" conaffinity="0"/>'
           '</body>')
    spec = build_spec(RIG, payload_xml=xml)
    site = spec.site("fts")
    site.pos = site.pos + np.asarray(site_shift, float)
    x, y, z, w = Rotation.from_rotvec(site_rotvec).as_quat()
    site.quat = [w, x, y, z]
    return spec.compile()


def test_fts_matrix_and_mounting_recovered_from_known_loads():
    """A sensor with gains, symmetric cross-talk, offset, noise (applied here) and a mounting
    error made in the MJCF (site moved by d, turned by R_m) reads two known payloads at six
    orientations under seven known load cases (applied forces/couples): the fitted 6×6
    matrix matches the truth within 1 % of full scale (torques over 0.1 m), the mounting
    offset within 0.2 mm and the mounting rotation within 1 mrad."""
    from scipy.spatial.transform import Rotation

    from rths3d.platform.kinematics import skew

    rng = np.random.default_rng(7)
    d = np.array([0.002, -0.0015, 0.003])
    rv = np.array([0.01, -0.006, 0.02])
    Rm = Rotation.from_rotvec(rv).as_matrix()
    GF = np.eye(3) + np.array([[0.02, 0.012, -0.015], [0.012, -0.03, 0.02],
                               [-0.015, 0.02, 0.01]])
    GT = np.eye(3) + np.array([[-0.02, 0.015, 0.01], [0.015, 0.03, -0.01],
                               [0.01, -0.01, -0.012]])
    o = np.array([1.5, -2.0, 3.0, 0.1, -0.05, 0.08])
    orients = np.array([[0, 0, 0, 0, 0, 0], [0, 0, 0, 0.12, 0, 0], [0, 0, 0, -0.12, 0, 0],
                        [0, 0, 0, 0, 0.12, 0], [0, 0, 0, 0, -0.12, 0],
                        [0, 0, 0, 0.08, -0.08, 0.2]])
    cases = np.array([[0, 0, 0, 0, 0, 0], [60, 0, 0, 0, 0, 0], [0, 60, 0, 0, 0, 0],
                      [0, 0, -80, 0, 0, 0], [0, 0, 0, 8, 0, 0], [0, 0, 0, 0, 8, 0],
                      [0, 0, 0, 0, 0, 8]], float)
    W, raw = [], []
    for mass, com in ((8.0, (0.03, -0.02, 0.06)), (15.0, (-0.04, 0.05, 0.10))):
        model = _fts_spec(mass, com, d, rv)
        targets = np.repeat(orients, len(cases), axis=0)
        loads = np.tile(cases, (len(orients), 1))
        q, _, w = _drive(model, targets, loads=loads, body="payload")
        q_meas = q + rng.normal(0, 1, q.shape) * np.r_[[POSE_NOISE[0]] * 3,
                                                     [POSE_NOISE[1]] * 3]
        W.append(load_wrench(q_meas, mass, com, force=loads[:, :3], torque=loads[:, 3:]))
        raw.append(w)
    W, raw = np.concatenate(W), np.concatenate(raw)
    G6 = np.zeros((6, 6))
    G6[:3, :3], G6[3:, 3:] = GF, GT
    mount = np.zeros((6, 6))
    mount[:3, :3] = mount[3:, 3:] = Rm.T
    mount[3:, :3] = -Rm.T @ skew(d)
    M_true = G6 @ mount
    readings = raw @ G6.T + o + rng.normal(0, 1, raw.shape) * np.r_[
        [F_NOISE] * 3, [T_NOISE] * 3]
    fts = FTSCalibration().fit(W, readings)
    D = np.diag([1, 1, 1, 0.1, 0.1, 0.1])
    err = np.abs(np.linalg.inv(D) @ (fts.matrix_ - M_true) @ D)
    print(f"\nFTS: matrix error max {err.max() * 100:.3f} % of full scale, gains "
          f"{np.abs(fts.gains_ / np.diag(M_true) - 1).max() * 100:.3f} %, offset error "
          f"{np.abs(fts.offset_ - o).max():.4f}, mounting offset error "
          f"{np.abs(fts.mounting_offset_ - d).max() * 1e3:.4f} mm, rotation error "
          f"{np.abs(fts.mounting_rotation_ - rv).max() * 1e3:.4f} mrad, condition "
          f"{fts.condition_:.3g}")
    assert err.max() < 0.01
    assert np.abs(fts.gains_ / np.diag(M_true) - 1).max() < 0.01
    assert np.abs(fts.mounting_offset_ - d).max() < 2e-4
    assert np.abs(fts.mounting_rotation_ - rv).max() < 1e-3
    assert np.abs(fts.offset_ - o)[:3].max() < 0.1 and np.abs(fts.offset_ - o)[3:].max() < 0.01
    # corrected readings give the known loads back (nominal sensor frame)
    corr = fts.correct(readings) - W
    assert np.abs(corr[:, :3]).max() < 5 * F_NOISE and np.abs(corr[:, 3:]).max() < 5 * T_NOISE


def test_payload_mass_and_com_from_tared_and_untared_wrench():
    """A 5 kg payload with its centre of mass at (25, −15, 70) mm, read at ten orientations
    with noise: mass within 1 % and CoM within 1 mm, whether the sensor was zeroed unloaded
    (reading carries the weight) or tared at rest with the payload on."""
    rng = np.random.default_rng(11)
    mass, com = 5.0, np.array([0.025, -0.015, 0.07])
    model = _fts_spec(mass, com)
    orients = np.zeros((10, 6))
    orients[1:, 3:5] = rng.uniform(-0.12, 0.12, (9, 2))
    orients[1:, 5] = rng.uniform(-0.2, 0.2, 9)
    q, _, w = _drive(model, orients)
    q_meas = q + rng.normal(0, 1, q.shape) * np.r_[[POSE_NOISE[0]] * 3, [POSE_NOISE[1]] * 3]
    noise = np.r_[[F_NOISE] * 3, [T_NOISE] * 3]
    untared = w + rng.normal(0, 1, w.shape) * noise
    tare = w[0] + rng.normal(0, 1, 6) * noise
    tared = w - tare + rng.normal(0, 1, w.shape) * noise
    for mode, data in (("zero", untared), ("fit", tared)):
        p = PayloadEstimator(offset=mode).fit(data, q_meas)
        print(f"\npayload ({mode}): mass {p.mass_:.4f} kg (±{p.mass_std_:.4f}), CoM "
              f"{np.round(p.com_ * 1e3, 3)} mm (±{np.round(p.com_std_ * 1e3, 3)})")
        assert abs(p.mass_ / mass - 1) < 0.01
        assert np.abs(p.com_ - com).max() < 1e-3
        assert np.all(p.residual_rms_[:3] < 2 * F_NOISE) and np.all(p.residual_rms_[3:] < 2 * T_NOISE)
        assert np.abs(p.predict(q_meas) - data)[:, :3].max() < 5 * F_NOISE
    with pytest.raises(ConfigError, match="orientations"):
        PayloadEstimator(offset="fit").fit(tared[:1].repeat(3, 0), np.zeros((3, 3)))


# ----------------------------------------------------------------------------- CLI
def _run(argv, capsys):
    with pytest.raises(SystemExit) as info:
        main(argv)
    out = capsys.readouterr()
    return info.value.code, out.out, out.err


def _table(bench, path):
    import pandas as pd

    cols = {f"pose_meas.{d}": bench["q_meas"][:50, j]
            for j, d in enumerate(("x", "y", "z", "rx", "ry", "rz"))}
    cols.update({f"leg_len.{i}": bench["L_meas"][:50, i] for i in range(6)})
    frame = pd.DataFrame(cols)
    if path.suffix == ".csv":
        frame.to_csv(path, index=False, float_format="%.17g")
    else:
        frame.to_parquet(path)
    return frame


def test_cli_calibrate_writes_geometry_and_reports(bench, tmp_path, capsys):
    """`platform calibrate POSES.csv --out g.json --json` fits, writes a loadable geometry
    and prints RMS before/after and the identifiability report; the text output names the
    parameters and the condition number."""
    src = tmp_path / "poses.csv"
    _table(bench, src)
    out = tmp_path / "g.json"
    code, stdout, err = _run(["platform", "calibrate", str(src), "--out", str(out),
                              "--json"], capsys)
    assert code == 0, err
    fig = json.loads(stdout.strip().splitlines()[-1])
    assert fig["rms_calibrated_m"] < 10e-6 < 100e-6 < fig["rms_nominal_m"]
    assert fig["identifiability"]["rank"] == 42 and fig["identifiability"]["unobservable"] == []
    g = load_geometry(out)
    cal = KinematicCalibration().fit(bench["q_meas"][:50], bench["L_meas"][:50])
    assert np.allclose(parameter_vector(g), cal.params_, atol=1e-12)
    pq = tmp_path / "poses.parquet"
    _table(bench, pq)
    code, stdout, _ = _run(["platform", "calibrate", str(pq)], capsys)
    assert code == 0
    assert "base_anchor[2].z" in stdout and "condition number" in stdout
    assert "leg_offset[4]" in stdout and "RMS leg-length residual" in stdout


@pytest.mark.parametrize("case, needle", [
    ("missing", "column 'leg_len.3' missing"),
    ("nan", "column 'pose_meas.ry' row 4"),
    ("short", "need at least 7 poses"),
    ("suffix", "must be a .csv or .parquet file"),
    ("out", "--out"),
    ("mm", "check units (m, rad)"),
])
def test_cli_calibrate_bad_input_one_line_exit_2(bench, tmp_path, capsys, case, needle):
    """Bad input exits 2 with one line naming the field or path; the output path is checked
    before any work."""
    src = tmp_path / "poses.csv"
    frame = _table(bench, src)
    argv = ["platform", "calibrate", str(src)]
    if case == "missing":
        frame.drop(columns="leg_len.3").to_csv(src, index=False)
    elif case == "nan":
        frame.loc[4, "pose_meas.ry"] = float("nan")
        frame.to_csv(src, index=False)
    elif case == "short":
        frame.iloc[:5].to_csv(src, index=False)
    elif case == "suffix":
        argv[-1] = str(tmp_path / "poses.txt")
    elif case == "mm":  # leg lengths written in mm
        frame[[f"leg_len.{i}" for i in range(6)]] *= 1e3
        frame.to_csv(src, index=False)
    elif case == "out":
        (tmp_path / "file").write_text("x")
        argv += ["--out", str(tmp_path / "file" / "g.json")]
    code, _, err = _run(argv, capsys)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1, err
    assert needle in lines[0] and "Traceback" not in err


def test_example_rejects_too_few_poses_in_one_line(tmp_path):
    """examples/13: `--poses 3` is one `error:` line naming the flag, exit 2, nothing run."""
    import subprocess
    import sys
    from pathlib import Path

    script = Path(__file__).resolve().parents[1] / "examples" / "13_kinematic_calibration.py"
    out = subprocess.run([sys.executable, str(script), "--poses", "3", "--out",
                          str(tmp_path / "o")], capture_output=True, text=True, timeout=120)
    err = out.stderr.strip().splitlines()
    assert out.returncode == 2 and len(err) == 1 and err[0].startswith("error: --poses: 3")
    assert not (tmp_path / "o").exists()
