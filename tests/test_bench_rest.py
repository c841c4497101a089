"""A bench starts at rest where its controller holds it: the closed chain assembled at the
pose a set-point bias (anchor and encoder errors the controller does not know) holds, and the
gravity compensation of the bench's own holding forces (``controller.gravity = "measured"``).

Checked against what the starting code did not compute: the forward kinematics of
:mod:`rths3d.platform.kinematics` (Newton on the geometry object, not on MuJoCo's bodies),
the calibration model's encoder lengths, and the statically determinate leg forces of a
six-leg platform (a leg's extension at rest is its set-point minus its force over its own
gain).
"""

from __future__ import annotations

import mujoco
import numpy as np
import pytest

from rths3d.bench import Bench, BenchReplay
from rths3d.bench.base import platform_batch
from rths3d.platform.backend import assemble
from rths3d.platform.calibrate.kinematic import CalibratedGeometry
from rths3d.platform.kinematics import forward_kinematics
from rths3d.platform.model import PlatformConfig, build_spec
from rths3d.record import DOFS
from rths3d.scene import load_scene


def test_assemble_closes_the_chain_at_the_forward_kinematics_pose():
    """Legs extended by given slides (m): every leg tip on its plate anchor to 1e-12 m, and
    the plate at the pose the geometry's own forward kinematics gives for those lengths."""
    cfg = PlatformConfig()
    model = build_spec(cfg).compile()
    data = mujoco.MjData(model)
    slides = np.array([1e-3, -2e-3, 0.0, 5e-4, 0.0, 3e-3])
    assemble(model, data, slides)
    for i in range(6):
        tip = data.site_xpos[model.site(f"leg{i}_tip").id]
        anc = data.site_xpos[model.site(f"plate_anchor{i}").id]
        assert np.linalg.norm(tip - anc) < 1e-12
        assert data.qpos[model.jnt_qposadr[model.joint(f"leg{i}_slide").id]] == \
            pytest.approx(slides[i], abs=1e-12)
    g = cfg.geometry
    pose = forward_kinematics(g, g.home_leg_lengths() + slides)
    qa = model.jnt_qposadr[model.joint("plate_free").id]
    assert np.allclose(data.qpos[qa:qa + 3], pose[:3] + [0, 0, g.home_height], atol=1e-10)
    R = np.zeros(9)
    mujoco.mju_quat2Mat(R, data.qpos[qa + 3:qa + 7])
    rx, ry, rz = pose[3:]
    # x-y-z (extrinsic) Euler angles of the kinematics, written out here
    Rx = np.array([[1, 0, 0], [0, np.cos(rx), -np.sin(rx)], [0, np.sin(rx), np.cos(rx)]])
    Ry = np.array([[np.cos(ry), 0, np.sin(ry)], [0, 1, 0], [-np.sin(ry), 0, np.cos(ry)]])
    Rz = np.array([[np.cos(rz), -np.sin(rz), 0], [np.sin(rz), np.cos(rz), 0], [0, 0, 1]])
    assert np.allclose(R.reshape(3, 3), Rz @ Ry @ Rx, atol=1e-10)


def test_a_bench_with_anchor_and_encoder_errors_starts_and_stays_at_rest():
    """Anchor and encoder errors the controller does not know: at rest the encoders read the
    commanded home lengths through the calibration model of the true geometry (the plate is
    where the biased set-points hold it, 0.1–1 mm off home), and a held command leaves the
    plate there (it drifted by 35 µm over the first 0.1 s when the bench started at home)."""
    sc = load_scene("bench6", ["duration=0.4", "effect.base_anchor.leg2.x=1.5e-3",
                               "effect.top_anchor.leg4.z=-1e-3", "effect.leg_offset.leg3=5e-4"])
    out = BenchReplay(sc, np.zeros((301, 6))).run([list(sc.effects)])[0]
    pose = np.column_stack([out[f"pose_meas.{d}"] for d in DOFS])
    enc = np.column_stack([out[f"leg_len.{i}"] for i in range(6)])
    bench = Bench.from_scene(sc)
    nominal = bench.platform.geometry.home_leg_lengths()
    true = bench.true_geometry()
    assert isinstance(true, CalibratedGeometry)
    assert np.max(np.abs(pose[0, :3])) > 1e-4  # the bias moved the plate off home
    # the encoders at rest read the commanded home lengths (gravity compensated: µm level)
    assert np.max(np.abs(enc[0] - nominal)) < 5e-6
    assert np.max(np.abs(true.encoder_lengths(pose[0]) - enc[0])) < 5e-6
    # held: it stays there to a tenth of the pose noise σ (1 µm, 5 µrad): what still moves
    # is the µm-level sag the nominal gravity compensation leaves (translation m, rotation rad)
    assert np.max(np.abs(pose[1:, :3] - pose[0, :3])) < 1e-7
    assert np.max(np.abs(pose[1:, 3:] - pose[0, 3:])) < 5e-7


@pytest.mark.parametrize("gravity", ["nominal", "measured"])
def test_gravity_from_the_bench_s_own_holding_forces(gravity):
    """A leg whose servo gain is 15 % below the controller's (servo_gain.leg1 = −0.15): with
    the nominal model's gravity compensation the leg sags at rest by f₁ (1/k_p − 1/k_p,true)
    — the six legs of the platform carry the load statically determinately, so f₁ is the
    nominal model's — and with ``gravity = "measured"`` (the bench's own holding forces over
    its own gains) it sits at its home length."""
    sc = load_scene("bench6", ["duration=0.3", "effect.servo_gain.leg1=-0.15",
                               f"controller.gravity='{gravity}'"])
    out = BenchReplay(sc, np.zeros((101, 6))).run([list(sc.effects)])[0]
    bench = Bench.from_scene(sc)
    home = bench.platform.geometry.home_leg_lengths()
    kp = sc.transfer.kp
    f1 = platform_batch([Bench.from_scene(load_scene("bench6"))]).statics[0].leg_forces[1]
    sag = f1 / kp - f1 / (0.85 * kp)  # m, negative: the leg is shorter
    ext = out["leg_len.1"] - home[1]
    if gravity == "nominal":
        assert abs(sag) > 2e-6
        assert ext[-1] == pytest.approx(sag, rel=0.02)
    else:
        assert abs(ext[-1]) < 0.01 * abs(sag)
    assert np.max(np.abs(ext[1:] - ext[-1])) < 0.01 * abs(sag)  # at rest from the start
