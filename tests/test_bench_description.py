"""A scene describes any six-leg bench and any part (issue 35): [platform], [controller],
rigid payloads with a full inertial, the user's MJCF part, `rths3d bench init`.

Reference values come from other paths than the code under test: anchor patterns and leg
lengths written with their own trigonometry here, MJCF written here, m·g and c × m·g
computed here, a calibration fed with leg lengths computed here."""

from __future__ import annotations

import dataclasses
import json
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from rths3d.bench import Bench
from rths3d.bench.base import platform_config
from rths3d.errors import ConfigError
from rths3d.experiment import build_part_model
from rths3d.loop import run
from rths3d.platform.kinematics import inverse_kinematics
from rths3d.platform.model import ActuatorConfig, PlatformConfig, model_xml
from rths3d.scene import load_scene, scene_from_dict, scene_to_dict, scene_to_toml

sys.path.insert(0, str(Path(__file__).resolve().parent))
from independent import rotation_by_products  # noqa: E402

G = 9.81
SIX = ["x", "y", "z", "rx", "ry", "rz"]


def _six_dof_raw(experiment: dict, duration: float = 0.05, **tables) -> dict:
    I6 = np.eye(6)
    return {"name": "t", "dofs": SIX, "dt": 0.001, "duration": duration,
            "numerical": {"M": (I6 * 10).tolist(), "K": (I6 * 1e4).tolist()},
            "experiment": experiment, "transfer": {"kind": "stewart"},
            "safety": {"force": 500.0, "torque": 50.0}, **tables}


def _contact_raw(**over) -> dict:
    raw = scene_to_dict(load_scene("paper_contact"))
    raw = {**raw, "duration": 0.3,
           "excitation": {**raw["excitation"], "frequency": 5.0},
           "transfer": {**raw["transfer"], "kind": "ideal"}}
    raw.update(over)
    return raw


# ---------------------------------------------------------------------------- defaults
def test_empty_bench_tables_are_todays_bench():
    """Empty [platform] and [controller] tables (or ones that repeat the defaults) give
    today's platform configuration, the same MJCF text and the same record bit for bit,
    and a scene without them writes no such tables."""
    base = load_scene("paper_contact").with_transfer("stewart")
    raw = scene_to_dict(base)
    assert "platform" not in raw and "controller" not in raw
    t = base.transfer
    today = PlatformConfig(actuator=ActuatorConfig(kp=t.kp, kv=t.kv, timeconst=t.timeconst,
                                                   delay=t.delay, velocity_ff=t.velocity_ff),
                           dt=base.dt, substeps=t.substeps, integrator=t.integrator)
    same = scene_from_dict({**raw, "platform": {}, "controller": {
        "hold": "ramp", "sample": "end", "feedforward": "backward", "gravity": "nominal"}})
    assert platform_config(base) == today == platform_config(same)
    b0, b1 = Bench.from_scene(base), Bench.from_scene(same)
    assert model_xml(b0.platform, *b0.fragments) == model_xml(b1.platform, *b1.fragments)
    short = {"duration": 0.15}
    r0 = run(dataclasses.replace(base, **short), reference=False).record
    r1 = run(dataclasses.replace(same, **short), reference=False).record
    assert r0.columns.keys() == r1.columns.keys()
    for c in r0.columns:
        assert np.array_equal(r0.columns[c], r1.columns[c]), c


# ---------------------------------------------------------------------------- geometry
def _pattern(r: float, gap: float, centre: float, top: bool) -> np.ndarray:
    """Anchor pairs 120° apart centred on ``centre + k·120°`` (top: rolled by one leg so
    that every leg crosses to the neighbouring pair), written here from the docstring."""
    ang = [centre + k * 2 * math.pi / 3 + s * gap / 2 for k in range(3) for s in (-1, 1)]
    if top:
        ang = ang[-1:] + ang[:-1]
    return np.array([[r * math.cos(a), r * math.sin(a), 0.0] for a in ang])


OTHER = {"base_radius": 0.55, "top_radius": 0.32, "base_gap": 0.30, "top_gap": 0.20,
         "base_angle": 0.10, "home_height": 0.42}
"""A platform of other dimensions than the shipped one (m, rad)."""


def test_explicit_anchors_equal_the_same_platform_by_parameters():
    """Six base and six top anchors written in the test give the same platform as its
    parameters: the same leg lengths at any pose (and the ones computed here), and the same
    MuJoCo model (leg bodies, anchor sites, masses and inertias to 1e-9)."""
    b = _pattern(OTHER["base_radius"], OTHER["base_gap"], OTHER["base_angle"], False)
    p = _pattern(OTHER["top_radius"], OTHER["top_gap"], OTHER["base_angle"] + math.pi / 3,
                 True)
    exp = {"kind": "rigid", "m": 2.0}
    by_par = scene_from_dict(_six_dof_raw(exp, platform=OTHER))
    by_anc = scene_from_dict(_six_dof_raw(exp, platform={
        "base_anchors": b.tolist(), "top_anchors": p.tolist(),
        "home_height": OTHER["home_height"]}))
    g1, g2 = by_par.platform.geometry, by_anc.platform.geometry
    poses = np.array([[0, 0, 0, 0, 0, 0], [0.01, -0.02, 0.015, 0.03, -0.02, 0.05],
                      [-0.03, 0.01, -0.02, -0.04, 0.05, -0.02]])
    R = [rotation_by_products(*q[3:]) for q in poses]
    mine = np.array([[np.linalg.norm(q[:3] + [0, 0, OTHER["home_height"]] + Ri @ p[i] - b[i])
                      for i in range(6)] for q, Ri in zip(poses, R, strict=True)])
    L1 = inverse_kinematics(g1, poses)
    L2 = inverse_kinematics(g2, poses)
    np.testing.assert_allclose(L1, mine, atol=1e-12)
    np.testing.assert_allclose(L2, mine, atol=1e-12)
    m1, m2 = Bench.from_scene(by_par).model(), Bench.from_scene(by_anc).model()
    for i in range(6):
        for name, kind in ((f"leg{i}_cyl", "body"), (f"plate_anchor{i}", "site")):
            a, c = getattr(m1, kind)(name), getattr(m2, kind)(name)
            np.testing.assert_allclose(a.pos, c.pos, atol=1e-10)
        np.testing.assert_allclose(m1.body(f"leg{i}_cyl").pos, b[i], atol=1e-10)
        np.testing.assert_allclose(m1.site(f"plate_anchor{i}").pos, p[i], atol=1e-10)
    np.testing.assert_allclose(m1.body_mass, m2.body_mass, rtol=1e-9)
    np.testing.assert_allclose(m1.body_inertia, m2.body_inertia, rtol=1e-6)
    np.testing.assert_allclose(m1.body("plate").pos, [0, 0, OTHER["home_height"]])


def test_calibrated_geometry_file_round_trips(tmp_path):
    """`rths3d platform calibrate` on leg lengths computed here from a perturbed platform
    writes a file; a scene naming it (path relative to the scene) has the true anchors and
    encoder offsets, its MuJoCo legs sit on them, and the scene's record form reads back to
    the same geometry."""
    from typer.testing import CliRunner

    from rths3d.cli import app

    rng = np.random.default_rng(3)
    b = _pattern(0.40, math.radians(15), 0.0, False) + rng.normal(0, 1e-3, (6, 3))
    p = _pattern(0.25, math.radians(15), math.pi / 3, True) + rng.normal(0, 1e-3, (6, 3))
    off = rng.normal(0, 2e-3, 6)
    q = np.c_[rng.uniform(-0.02, 0.02, (60, 3)), rng.uniform(-0.06, 0.06, (60, 3))]
    L = np.array([[np.linalg.norm(qk[:3] + [0, 0, 0.35] + rotation_by_products(*qk[3:]) @ p[i] - b[i])
                   + off[i] for i in range(6)] for qk in q])
    cols = [f"pose_meas.{d}" for d in SIX] + [f"leg_len.{i}" for i in range(6)]
    np.savetxt(tmp_path / "poses.csv", np.c_[q, L], delimiter=",", header=",".join(cols),
               comments="")
    (tmp_path / "cal").mkdir()
    res = CliRunner().invoke(app, ["platform", "calibrate", str(tmp_path / "poses.csv"),
                                   "--out", str(tmp_path / "cal" / "geometry.json")])
    assert res.exit_code == 0, res.output
    data = json.loads((tmp_path / "cal" / "geometry.json").read_text())
    text = scene_to_toml(scene_from_dict(_six_dof_raw({"kind": "rigid", "m": 1.0})))
    (tmp_path / "s.toml").write_text(text + '\n[platform]\ngeometry_file = '
                                     '"cal/geometry.json"\nplate_mass = 10.0\n')
    sc = load_scene(tmp_path / "s.toml")
    g = sc.platform.geometry
    # the file's geometry, number for number; the calibration itself recovers the truth
    # to 0.14 mm from these 60 poses (its fit stops at 0.08 µm RMS, condition number 7932)
    np.testing.assert_array_equal(g.base_anchors(), np.array(data["base_anchor_xyz"]))
    np.testing.assert_array_equal(g.top_anchors(), np.array(data["top_anchor_xyz"]))
    np.testing.assert_array_equal(g.leg_offsets(), np.array(data["leg_offset"]))
    np.testing.assert_allclose(g.base_anchors(), b, atol=5e-4)
    np.testing.assert_allclose(g.top_anchors(), p, atol=5e-4)
    np.testing.assert_allclose(g.leg_offsets(), off, atol=5e-4)
    assert g.plate_mass == 10.0
    m = Bench.from_scene(sc).model()
    for i in range(6):
        np.testing.assert_allclose(m.body(f"leg{i}_cyl").pos, g.base_anchors()[i], atol=1e-9)
        np.testing.assert_allclose(m.site(f"plate_anchor{i}").pos, g.top_anchors()[i],
                                   atol=1e-9)
    back = scene_from_dict(scene_to_dict(sc))
    assert back.platform.geometry == g


# ---------------------------------------------------------------------------- parts
def test_rigid_payload_off_axis_static_wrench():
    """A 4 kg payload with its centre of mass off-axis and 45 mm above the sensor and a full
    inertia tensor: at rest the FTS reads m·g up and the torque c × m·g (computed here)."""
    m, c = 4.0, np.array([0.02, -0.01, 0.045])
    sc = scene_from_dict(_six_dof_raw({"kind": "rigid", "m": m, "com": c.tolist(),
                                       "inertia": [0.02, 0.025, 0.03, 0.001, -0.002, 0.0015]}))
    rec = run(sc, reference=False).record
    got = np.array([rec.columns[f"fts.{k}"][-1] for k in ("fx", "fy", "fz", "tx", "ty", "tz")])
    want = np.r_[0.0, 0.0, m * G, np.cross(c, [0.0, 0.0, m * G])]
    np.testing.assert_allclose(got[:3], want[:3], atol=1e-3)      # N
    np.testing.assert_allclose(got[3:], want[3:], atol=1e-4)      # N·m
    assert abs(got[2] / (m * G) - 1) < 1e-5


def test_fts_pose_moves_and_tilts_the_sensor():
    """An FTS mounted 50 mm off-axis, 40 mm above the plate and tilted by 0.1 rad about y:
    the site sits there in the model, and at rest the sensor reads the payload's weight in
    its tilted frame, m·g·(−sin 0.1, 0, cos 0.1) (computed here)."""
    m, ry = 2.0, 0.1
    sc = scene_from_dict(_six_dof_raw({"kind": "rigid", "m": m, "com": [0.0, 0.0, 0.03]},
                                      platform={"fts_pose": [0.05, 0.0, 0.04, 0.0, ry, 0.0]}))
    model = Bench.from_scene(sc).model()
    np.testing.assert_allclose(model.site("fts").pos, [0.05, 0.0, 0.04], atol=1e-12)
    rec = run(sc, reference=False).record
    f = np.array([rec.columns[f"fts.{k}"][-1] for k in ("fx", "fy", "fz")])
    np.testing.assert_allclose(f, m * G * np.array([-math.sin(ry), 0.0, math.cos(ry)]),
                               atol=2e-3)


BLOCK = 0.5
"""Mass of the test's block (kg)."""


def _mjcf_part(tmp_path, k=8650.0, m=0.38, h0=0.005, block=BLOCK, k_c=1.0e5, d_c=40.0):
    """A block carrying a spring-mounted contact specimen against a world-fixed surface,
    written here (the surface h0 above the tip at static equilibrium)."""
    sref = m * G / k
    tip_top = 0.02 + 0.01 + 0.01          # specimen at 20 mm, body half 10 mm, tip ⌀ 10 mm
    attrs = (f'contype="4" conaffinity="4" condim="1" solref="{-k_c / m:.9g} {-d_c / m:.9g}" '
             f'solimp="0.01 0.01 0.001 0.5 2" margin="0"')
    blk = (f'<geom name="block" type="box" size="0.05 0.05 0.005" pos="0 0 -0.005" '
           f'mass="{block}" contype="0" conaffinity="0"/>' if block else "")
    xml = f"""<mujoco>
  <default><default class="soft"><geom rgba="0.2 0.5 0.9 1"/></default></default>
  <worldbody>
    <body name="carrier">
      {blk}
      <body name="specimen" pos="0 0 0.02">
        <joint name="heave" type="slide" axis="0 0 1" stiffness="{k}" springref="{sref:.12g}"/>
        <geom name="mass" class="soft" type="cylinder" size="0.03 0.01" mass="{m}"
              contype="0" conaffinity="0"/>
        <geom name="tip" type="sphere" size="0.005" pos="0 0 0.015" mass="0" {attrs}/>
      </body>
    </body>
    <body name="world_surface" pos="0 0 {tip_top + h0 + 0.005}">
      <geom name="surface" type="box" size="0.04 0.04 0.005" {attrs}/>
    </body>
  </worldbody>
</mujoco>"""
    f = tmp_path / "part.xml"
    f.write_text(xml)
    return f


def test_mjcf_part_is_the_shipped_contact_part_when_it_writes_the_same(tmp_path):
    """The contact part written by the user as MJCF (no block) runs in the loop and its
    reference exactly like the shipped contact part on MuJoCo: same z, force and reference
    (ideal transfer, 5 Hz raised cosine into contact)."""
    f = _mjcf_part(tmp_path, block=0.0)
    text = scene_to_toml(scene_from_dict(_contact_raw(
        experiment={"kind": "mjcf", "file": str(f), "dofs": ["z"], "substeps": 4})))
    assert text.count(str(f)) == 1
    (tmp_path / "s.toml").write_text(text.replace(str(f), "part.xml"))  # beside the scene
    mine = load_scene(tmp_path / "s.toml")
    ship = scene_from_dict(_contact_raw())
    a = run(mine).record
    b = run(ship, specimen="mujoco").record
    assert a.meta["experiment"]["kind"] == "mjcf"
    assert "no numpy twin" in a.meta["experiment"]["model"]
    fz = b.columns["f_meas"] if "f_meas" in b.columns else b.columns["f_meas.z"]
    # contact: a free spring-mass following the mount would pass < m·(2π·5 Hz)²·10 mm ≈ 4 N
    assert np.max(fz) > 20.0
    for c in b.columns:
        if c.startswith(("z_meas", "f_meas", "z_ref", "z_cmd")):
            scale = max(float(np.max(np.abs(b.columns[c]))), 1e-12)
            assert np.max(np.abs(a.columns[c] - b.columns[c])) <= 1e-9 * scale, c


def test_mjcf_block_with_specimen_runs_on_the_platform(tmp_path):
    """A block carrying a contact specimen (written here) on the platform: at rest the FTS
    reads the weight of block and specimen, (m_block + m)·g; the part's interface mass is
    their sum; the test runs to its end on the Stewart platform."""
    _mjcf_part(tmp_path)
    raw = _contact_raw(experiment={"kind": "mjcf", "file": str(tmp_path / "part.xml"),
                                   "substeps": 4})
    raw["transfer"] = {**raw["transfer"], "kind": "stewart"}
    raw["duration"] = 0.1
    sc = scene_from_dict(raw)
    assert sc.experiment.dofs == ("z",)
    rec = run(sc, reference=False).record
    assert rec.meta["status"] == "ok"
    # 5e-3: the undamped specimen still rings (24 Hz) from the platform's settling
    assert abs(rec.columns["fts.fz"][1] / ((BLOCK + 0.38) * G) - 1) < 5e-3
    assert rec.meta["experiment"]["m_exp"] == pytest.approx(BLOCK + 0.38, rel=1e-12)


def test_mjcf_part_follows_a_spring_mass_below_contact(tmp_path):
    """Behind a prescribed mount, the MJCF part's force equals the shipped numpy spring-mass
    (k, m) until the tip reaches the surface, and departs from it in contact."""
    _mjcf_part(tmp_path, block=0.0)
    dt, n = 1e-3, 200
    t = np.arange(n + 1) * dt
    z = 0.004 * (1 - np.cos(2 * np.pi * 5 * t))[:, None]      # peak 8 mm, gap 5 mm
    cfg = scene_from_dict(_contact_raw(experiment={
        "kind": "mjcf", "file": str(tmp_path / "part.xml"), "dofs": ["z"]})).experiment
    lin = dataclasses.replace(load_scene("paper_linear").experiment, m=0.38, k=8650.0, d=0.0)
    pm = build_part_model([cfg], ("z",), dt)
    nm = build_part_model([lin], ("z",), dt, model="numpy")
    f1 = np.array([pm.advance(z[i:i + 1], z[i + 1:i + 2])[0, 0] for i in range(n)])
    f2 = np.array([nm.advance(z[i:i + 1], z[i + 1:i + 2])[0, 0] for i in range(n)])
    gap = np.flatnonzero(z[1:, 0] > 0.004)[0]                 # well before the tip touches
    assert np.max(np.abs(f1 - f2)[:gap]) < 1e-6 * np.max(np.abs(f2[:gap]))
    assert np.max(np.abs(f1 - f2)) > 10.0                      # N, in contact


# ---------------------------------------------------------------------------- bench init
def test_bench_init_scene_loads_and_runs(tmp_path):
    """`rths3d bench init` with a geometry of other dimensions, a zero-order-hold controller
    sampling at the start and a rigid payload writes a scene that loads with exactly those
    values and runs."""
    from typer.testing import CliRunner

    from rths3d.cli import app

    out = tmp_path / "my.toml"
    res = CliRunner().invoke(app, [
        "bench", "init", str(out), "--base-radius", "0.5", "--top-radius", "0.3",
        "--home-height", "0.45", "--kp", "3e5", "--hold", "zoh", "--sample", "start",
        "--mass", "4", "--com", "0.02,-0.01,0.045", "--inertia", "0.02,0.025,0.03,0,0,0"])
    assert res.exit_code == 0, res.output
    sc = load_scene(out, ["duration=0.05"])
    g = sc.platform.geometry
    assert (g.base_radius, g.top_radius, g.home_height) == (0.5, 0.3, 0.45)
    assert sc.transfer.kp == 3e5 and sc.controller.hold == "zoh"
    assert sc.controller.sample == "start" and sc.experiment.com == (0.02, -0.01, 0.045)
    cfg = platform_config(sc)
    assert cfg.actuator.hold == "zoh" and cfg.actuator.sample == "start"
    rec = run(sc, reference=False).record
    assert rec.meta["status"] == "ok"
    assert abs(rec.columns["fts.fz"][1] / (4 * G) - 1) < 1e-3     # the sine has begun


# ---------------------------------------------------------------------------- bad input
BAD = [
    ({"platform": {"base_anchors": [[0, 0, 0]] * 5, "top_anchors": [[0, 0, 0]] * 6}},
     "platform.base_anchors"),
    ({"platform": {"base_anchors": [[0.4, 0, 0]] * 6}}, "platform.top_anchors"),
    ({"platform": {"stroke": -0.1}}, "platform.stroke"),
    ({"platform": {"geometry_file": "nowhere.json"}}, "platform.geometry_file"),
    ({"platform": {"base_radius": 0.5, "geometry_file": "x.json"}}, "platform.base_radius"),
    ({"platform": {"fts_pose": [0, 0, -0.01, 0, 0, 0]}}, "platform.fts_pose[2]"),
    ({"platform": {"wheels": 4}}, "platform.wheels"),
    ({"controller": {"hold": "foh"}}, "controller.hold"),
    ({"controller": {"kp": -2e5}}, "controller.kp"),
    ({"controller": {"delay": 0.9}}, "controller.delay"),
    ({"controller": {"kp": 3e5}, "transfer": {"kind": "stewart", "kp": 2e5}}, "controller.kp"),
    ({"controller": {"feedforward": "central"},
      "transfer": {"kind": "stewart", "velocity_ff": False}}, "controller.feedforward"),
]


@pytest.mark.parametrize("tables,field", BAD)
def test_bad_bench_tables_name_the_field(tables, field):
    """Each mistake is a ConfigError naming the field (one line, with value and limit)."""
    raw = _six_dof_raw({"kind": "rigid", "m": 1.0})
    raw.update(tables)
    with pytest.raises(ConfigError) as e:
        scene_from_dict(raw)
    assert e.value.field == field
    assert "\n" not in str(e.value) and e.value.limit


@pytest.mark.parametrize("inertia,word", [
    ([0.01, 0.01, -0.01, 0, 0, 0], "positive definite"),
    ([0.01, 0.01, 0.05, 0, 0, 0], "triangle inequality"),
    ([0.01, 0.01], "6 numbers")])
def test_bad_inertia_is_refused(inertia, word):
    """An inertia tensor that no body has (not positive definite, principal moments
    violating I_a + I_b >= I_c, wrong length) names experiment.inertia."""
    with pytest.raises(ConfigError) as e:
        scene_from_dict(_six_dof_raw({"kind": "rigid", "m": 1.0, "inertia": inertia}))
    assert e.value.field == "experiment.inertia" and word in str(e.value)


def test_cli_bad_input_exits_2_with_one_line(tmp_path, capsys):
    """`rths3d run` on a scene with a bad [controller] value and `rths3d bench init` with a
    bad flag: exit code 2, one line naming the field, no traceback."""
    from rths3d.cli import main

    text = scene_to_toml(scene_from_dict(_six_dof_raw({"kind": "rigid", "m": 1.0})))
    (tmp_path / "s.toml").write_text(text + '\n[controller]\nsample = "middle"\n')
    for argv, field in ((["run", str(tmp_path / "s.toml")], "controller.sample"),
                        (["bench", "init", str(tmp_path / "b.toml"), "--hold", "foh"],
                         "controller.hold"),
                        (["bench", "init", str(tmp_path / "c.toml"), "--com", "1,2"],
                         "--com")):
        with pytest.raises(SystemExit) as e:
            main(argv)
        err = capsys.readouterr().err.strip()
        assert e.value.code == 2, err
        assert err.count("\n") == 0 and field in err and "Traceback" not in err


def test_diagnose_header_names_what_came_from_the_scene():
    """`rths3d diagnose` first names which parts of the bench came from the scene (here
    the stroke, a zero-order hold, an off-axis payload) and which are defaults (geometry,
    the other conventions), and says when no scene was there and which default it uses."""
    from rths3d.cli.diagnose import _bench_origin

    sc = scene_from_dict(_six_dof_raw({"kind": "rigid", "m": 4.0, "com": [0.02, 0, 0.04]},
                                      platform={"stroke": 0.08},
                                      controller={"hold": "zoh"}))
    lines = _bench_origin(sc, "my.toml", {})
    assert lines[0] == "bench from the scene my.toml"
    assert "geometry: today's default" in lines[1] and "stroke from the scene" in lines[1]
    assert "hold = zoh" in lines[2] and "hold from the scene's [controller]" in lines[2]
    assert "sample = end" in lines[2] and "part: rigid" in lines[3]
    lines = _bench_origin(load_scene("paper_contact"), None, {"scene": "x"})
    assert "no scene" in lines[0] and "'paper_contact'" in lines[0]
    assert "today's default" in lines[1] and "conventions today's default" in lines[2]


@pytest.mark.parametrize("xml,word", [
    ("<mujoco><worldbody><body name='a'>", "not valid XML"),
    ("<mujoco><worldbody><body name='world_floor'/></worldbody></mujoco>", "no body to mount"),
    ("<mujoco><worldbody><body name='a'><geom size='0.1'/></body></worldbody>"
     "<actuator/></mujoco>", "<actuator> is not allowed"),
    ("<mujoco><worldbody><body name='a'><geom type='box' size='0.1'/></body></worldbody>"
     "</mujoco>", "MuJoCo rejects the part"),
])
def test_bad_mjcf_part_names_the_file(tmp_path, xml, word):
    """A part file MuJoCo or the convention cannot take is one error naming
    experiment.file and what is wrong."""
    f = tmp_path / "p.xml"
    f.write_text(xml)
    with pytest.raises(ConfigError) as e:
        scene_from_dict(_contact_raw(experiment={"kind": "mjcf", "file": str(f)}))
    assert e.value.field == "experiment.file" and word in str(e.value)
    assert "\n" not in str(e.value)


def test_bench_init_from_files_names_them_beside_the_scene(tmp_path):
    """`rths3d bench init --geometry-file … --part-file …` writes the two paths relative to
    the scene's folder, and the scene loads them from wherever it is run."""
    import os

    from typer.testing import CliRunner

    from rths3d.cli import app
    from rths3d.platform.calibrate.kinematic import CalibratedGeometry

    (tmp_path / "cal").mkdir()
    (tmp_path / "scenes").mkdir()
    geom = CalibratedGeometry.from_nominal(leg_offsets=np.full(6, 1e-3))
    (tmp_path / "cal" / "g.json").write_text(json.dumps(geom.to_dict()))
    part = _mjcf_part(tmp_path)
    out = tmp_path / "scenes" / "b.toml"
    res = CliRunner().invoke(app, [
        "bench", "init", str(out), "--geometry-file", str(tmp_path / "cal" / "g.json"),
        "--stroke", "0.12", "--part-file", str(part), "--dofs", "z", "--gravity", "none"])
    assert res.exit_code == 0, res.output
    text = out.read_text()
    assert 'geometry_file = "../cal/g.json"' in text and 'file = "../part.xml"' in text
    cwd = os.getcwd()
    try:
        os.chdir(tmp_path / "cal")
        sc = load_scene(out)
    finally:
        os.chdir(cwd)
    assert sc.platform.geometry.leg_offsets() == pytest.approx(np.full(6, 1e-3))
    assert sc.platform.geometry.stroke == 0.12 and sc.dofs == ("z",)
    assert sc.experiment.file == str(part.resolve()) and sc.controller.gravity == "none"
    assert platform_config(sc).actuator.gravity_comp is False


def test_contact_gap_moves_the_surface_of_the_users_mjcf_part(tmp_path):
    """The contact gap acts on a part the user wrote as MJCF through the file's world-fixed
    bodies: with the surface 1 mm closer on the Stewart platform, the record equals the
    shipped contact part's with the same effect (to 1e-9 of the peaks) and differs from the
    part without it; it is a candidate for a file with a surface, not for one without."""
    from rths3d.diagnose.engine import default_candidates

    f = _mjcf_part(tmp_path, block=0.0)
    stewart = {"kind": "stewart"}
    raw = _contact_raw(experiment={"kind": "mjcf", "file": str(f), "dofs": ["z"],
                                   "substeps": 4})
    raw["transfer"] = {**raw["transfer"], **stewart}
    ship = _contact_raw()
    ship["transfer"] = {**ship["transfer"], **stewart}
    gap = [{"name": "contact_gap", "value": -1e-3}]
    mine = run(scene_from_dict({**raw, "effect": gap}), reference=False).record
    theirs = run(scene_from_dict({**ship, "effect": gap}), reference=False).record
    plain = run(scene_from_dict(raw), reference=False).record
    for c in ("z_meas.z", "f_meas.z"):
        x, y = np.asarray(mine.columns[c]), np.asarray(theirs.columns[c])
        assert np.max(np.abs(x - y)) <= 1e-9 * np.max(np.abs(y)), c
    assert np.max(np.abs(mine.columns["f_meas.z"] - plain.columns["f_meas.z"])) > 5.0  # N
    assert "contact_gap" in default_candidates(scene_from_dict(raw))
    bare = tmp_path / "bare.xml"
    bare.write_text('<mujoco><worldbody><body name="block"><geom type="box" '
                    'size="0.03 0.03 0.01" mass="1"/></body></worldbody></mujoco>')
    rigid = _contact_raw(experiment={"kind": "mjcf", "file": str(bare), "dofs": ["z"]})
    assert "contact_gap" not in default_candidates(scene_from_dict(rigid))
