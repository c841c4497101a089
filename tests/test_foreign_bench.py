"""The diagnosis on benches made by other code than the bench model (tests/foreign_bench.py: own
MJCF of platforms of other dimensions, own stepping loop with a zero-order-hold controller that
samples every channel at the start of the interval, 0.25 ms physics, documented zeroing and
noise), given only the record file and the scene a user would write from the bench's data:

- the generator itself agrees with the bench model where both follow today's conventions;
- payload identification recovers an off-axis payload measured on such a bench;
- Null: described correctly, only noise (validation ≤ 1.2 noise units, counted in the noise
  the bench added) — benches A, B, D (the servo's lag after the hold), E (a servo-valve) and
  F (D with a four times stiffer chain and a disc plate: every convention other than the
  project's);
- Described wrong (one error each: hold mode, sampling instant, payload mass, centre-of-mass
  height, one anchor; on bench D, whose servo lag sits after the hold: the lag's place not
  stated, the lag or the delay stated twice what the bench has; on E the valve's
  frequency): the error found first, validation ≤ 1.2 after it;
- a matrix of per-leg, geometry, FTS and payload effects (centre of mass and inertia
  included) on such a bench.

The benches a scene cannot fully describe (an unstated disc plate, structural damping in the
frame, with and without a baseline) and a contact gap of the user's MJCF part:
tests/test_foreign_unmodelled.py. The full matrix with its figures: ``python
examples/66_foreign_bench.py``.
"""

from __future__ import annotations

import math
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

pytestmark = pytest.mark.slow  # every case replays a whole foreign record (10–70 s each)

from foreign_bench import (  # noqa: E402
    DOFS,
    LAST_RUN,
    NOISE,
    WRENCH,
    ForeignBench,
    anchor_pairs,
    multisine,
    plate_inertial,
    write_record,
)

from rths3d.diagnose import Diagnosis  # noqa: E402
from rths3d.diagnose.payload import PayloadIdentification  # noqa: E402
from rths3d.record import Record  # noqa: E402

DT = 1e-3


# ---------------------------------------------------------------------------- the benches
def _anchors(base_r, top_r, base_gap, top_gap, angle0):
    """Base anchors on pairs centred at angle0 + k·120°, top anchors on pairs centred at
    angle0 + 60° + k·120°, leg i crossing to the neighbouring pair."""
    b = anchor_pairs(base_r, angle0, math.radians(base_gap), 0.0)
    t = anchor_pairs(top_r, angle0, math.radians(top_gap), math.pi / 3)
    return b, np.roll(t, 1, axis=0)


@dataclass
class Spec:
    """A foreign bench and what its user knows about it (the truth; the scene states it)."""

    name: str
    base: np.ndarray
    top: np.ndarray
    home_height: float
    masses: dict
    fts_height: float
    part: dict
    """The [experiment] table the user writes (rigid: m, com, inertia; mjcf: file, dofs)."""
    part_xml: str
    world_xml: str = ""
    files: dict = field(default_factory=dict)
    poses: dict = field(default_factory=dict)
    servo: dict = field(default_factory=lambda: {"kp": 2.0e5, "kv": 2.0e3})
    bench: dict = field(default_factory=dict)
    """How the foreign bench itself runs (its physics step …), beyond what the scene states."""
    platform: dict = field(default_factory=dict)
    """What else the scene's [platform] table states (a plate's inertia)."""


def _rigid_xml(m, com, inertia):
    xx, yy, zz, xy, xz, yz = inertia
    return (f'<body name="payload" pos="{com[0]} {com[1]} {com[2]}"><inertial pos="0 0 0" '
            f'mass="{m}" fullinertia="{xx} {yy} {zz} {xy} {xz} {yz}"/></body>')


def rigid_bench() -> Spec:
    """Bench A: a 0.9 m base, a 0.56 m plate, 0.40 m home height; a 4 kg block with its centre
    of mass off-axis and 45 mm above the sensor face."""
    b, t = _anchors(0.45, 0.28, 20.0, 12.0, 0.0)
    m, com = 4.0, [0.02, -0.01, 0.045]
    inertia = [0.0075, 0.0112, 0.0133, 0.0006, -0.0004, 0.0003]
    return Spec("rigid", b, t, 0.40, {"plate_mass": 14.0, "cylinder_mass": 2.4,
                                      "piston_mass": 1.1, "fts_mass": 0.35}, 0.035,
                {"kind": "rigid", "m": m, "com": com, "inertia": inertia},
                _rigid_xml(m, com, inertia))


def contact_bench(gap_shift: float = 0.0) -> Spec:
    """Bench B (geometry of A): a 2 kg block carrying a 0.4 kg specimen on a spring
    (8650 N/m, 10 N·s/m) whose tip meets a world-fixed surface 1 mm above it. The
    fragment is written at its static equilibrium (the spring's ``springref`` holds the
    specimen's weight), as a user writes a part that starts at rest. ``gap_shift`` (m): the
    bench's surface that much further away than the part's file (the scene) says."""
    s = rigid_bench()
    h_site = s.home_height + s.fts_height
    part = ('<body name="block" pos="0 0 0.02"><inertial pos="0 0 0" mass="2.0" '
            'diaginertia="0.004 0.004 0.006"/>'
            '<body name="specimen" pos="0 0 0.04"><joint name="spring" type="slide" '
            f'axis="0 0 1" stiffness="8650" springref="{0.4 * 9.81 / 8650!r}" damping="10"/>'
            '<inertial pos="0 0 0" mass="0.4" diaginertia="1e-4 1e-4 1e-4"/>'
            '<geom name="tip" type="sphere" size="0.005" pos="0 0 0.01" mass="0" '
            'contype="4" conaffinity="4" condim="1" solref="0.004 1"/></body></body>')
    # the surface's lower face 1 mm above the tip's top, in the sensor frame at home
    z = 0.02 + 0.04 + 0.01 + 0.005 + 0.001 + 0.005

    def surface(zc: float) -> str:
        return (f'<body name="world_surface" pos="0 0 {zc}"><geom name="surface" type="box" '
                'size="0.05 0.05 0.005" contype="4" conaffinity="4" condim="1" '
                'solref="0.004 1"/></body>')

    return Spec("contact", s.base, s.top, s.home_height, s.masses, s.fts_height,
                {"kind": "mjcf", "file": "block_with_specimen.xml",
                 "dofs": list(DOFS)}, part, surface(h_site + z + gap_shift),
                files={"world": surface(z)},
                poses={"trans": 2.5e-3, "rot": 0.006})


def other_geometry_bench() -> Spec:
    """Bench C: another geometry (a 1.2 m base rotated by 15°, a 0.6 m plate, 0.50 m home
    height, irregular anchors a few mm off the pattern) with a 6 kg rigid payload."""
    b, t = _anchors(0.60, 0.30, 10.0, 25.0, math.radians(15.0))
    rng = np.random.default_rng(7)
    b = b + np.c_[rng.uniform(-3e-3, 3e-3, (6, 2)), np.zeros(6)]
    t = t + rng.uniform(-2e-3, 2e-3, (6, 3))
    m, com = 6.0, [-0.015, 0.025, 0.06]
    inertia = [0.02, 0.025, 0.018, -0.001, 0.0005, 0.0008]
    return Spec("geometry", b, t, 0.50, {"plate_mass": 18.0, "cylinder_mass": 3.0,
                                         "piston_mass": 1.5, "fts_mass": 0.4}, 0.04,
                {"kind": "rigid", "m": m, "com": com, "inertia": inertia},
                _rigid_xml(m, com, inertia), servo={"kp": 3.0e5, "kv": 2.5e3})


SERVO_LAG = 0.003
"""s: the first-order lag of bench D's servo, continuous after the hold."""


def servo_bench() -> Spec:
    """Bench D (bench A): its servo with a continuous first-order lag of 3 ms after the
    zero-order hold (a valve or amplifier), integrated at the bench's own physics step —
    another convention than the bench model's set-point filter before the hold."""
    s = rigid_bench()
    return Spec("servo", s.base, s.top, s.home_height, s.masses, s.fts_height, s.part,
                s.part_xml, servo={"kp": 2.0e5, "kv": 2.0e3, "timeconst": SERVO_LAG,
                                   "lag": "servo"})


VALVE = (55.0, 0.6)
"""Hz, 1: bench E's servo-valve, its natural frequency and damping ratio."""


def valve_bench() -> Spec:
    """Bench E (bench A): its servo acts through a servo-valve of 55 Hz and damping 0.6
    after the zero-order hold, advanced exactly over each of the bench's physics steps
    (tests/foreign_bench.py) — not the bench model's spool integrated by MuJoCo."""
    s = rigid_bench()
    return Spec("valve", s.base, s.top, s.home_height, s.masses, s.fts_height, s.part,
                s.part_xml, servo={"kp": 2.0e5, "kv": 2.0e3, "valve_hz": VALVE[0],
                                   "valve_damping": VALVE[1]})


STIFF_CLOSURE = (0.0005, 1.0)
"""solref (s, 1) of bench F's tip-to-plate connections: four times stiffer than the bench
model's 2 ms (MuJoCo's floor at F's 0.25 ms physics step)."""


def physics_bench() -> Spec:
    """Bench F (bench D's servo, its lag continuous after the hold): a chain that closes four
    times more stiffly than the model's, a uniform disc plate of radius 0.30 m (its inertia
    m·R²/4, m·R²/4, m·R²/2 about its centre, stated in the scene as its data sheet gives it),
    its own statics — conventions other than the project's in all of them."""
    s = servo_bench()
    m, r = s.masses["plate_mass"] + s.masses["fts_mass"], 0.30
    disc = (m * r * r / 4, m * r * r / 4, m * r * r / 2)
    return Spec("physics", s.base, s.top, s.home_height, s.masses, s.fts_height, s.part,
                s.part_xml, servo=s.servo,
                bench={"closure": STIFF_CLOSURE, "plate_ipos": (0.0, 0.0, 0.0),
                       "plate_iquat": (1.0, 0.0, 0.0, 0.0), "plate_inertia": disc},
                platform={"plate_inertia": list(disc), "plate_com": [0.0, 0.0, 0.0]})


BENCHES = {"rigid": rigid_bench, "contact": contact_bench, "geometry": other_geometry_bench,
           "servo": servo_bench, "valve": valve_bench, "physics": physics_bench}


# ---------------------------------------------------------------------------- the scene
def _toml(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, list | tuple | np.ndarray):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    return repr(float(v)) if isinstance(v, float | np.floating) else str(v)


def description(spec: Spec) -> dict:
    """The scene a user writes from the bench's data sheet (right in every part)."""
    return {
        "name": f"foreign_{spec.name}", "dofs": list(DOFS), "dt": DT, "duration": 10.0,
        "numerical": {"M": np.diag([12.0] * 3 + [0.3] * 3).tolist(),
                      "C": np.diag([50.0] * 3 + [1.0] * 3).tolist(),
                      "K": np.diag([2.0e4] * 3 + [600.0] * 3).tolist()},
        "platform": {"base_anchors": spec.base.tolist(), "top_anchors": spec.top.tolist(),
                     "home_height": spec.home_height, **spec.masses,
                     "fts_height": spec.fts_height,
                     "fts_pose": [0.0, 0.0, spec.fts_height, 0.0, 0.0, 0.0],
                     **spec.platform},
        "controller": {"timeconst": 0.0, "delay": 0.001, **spec.servo, "hold": "zoh",
                       "sample": "start", "feedforward": "backward", "gravity": "measured"},
        "transfer": {"kind": "stewart"},
        "experiment": dict(spec.part),
    }


def write_scene(folder: Path, spec: Spec, desc: dict) -> Path:
    """The description as a TOML file (and the part's MJCF file beside it)."""
    lines = []
    for key in ("name", "dofs", "dt", "duration"):
        lines.append(f"{key} = {_toml(desc[key])}")
    for sec in ("numerical", "platform", "controller", "transfer", "experiment"):
        lines += ["", f"[{sec}]"] + [f"{k} = {_toml(v)}" for k, v in desc[sec].items()]
    if spec.part.get("kind") == "mjcf":
        (folder / spec.part["file"]).write_text(
            f"<mujoco><worldbody>{spec.part_xml}{spec.files.get('world', '')}"
            "</worldbody></mujoco>")
    path = folder / f"{desc['name']}.toml"
    path.write_text("\n".join(lines) + "\n")
    return path


def _model_of(scene_path: Path):
    """The description's compiled bench model (for the plate's inertial only)."""
    from rths3d.bench import Bench
    from rths3d.scene import load_scene

    return Bench.from_scene(load_scene(scene_path)).nominal_model()


def make_record(folder: Path, spec: Spec, *, duration: float = 2.5, seed: int = 0,
                noise_seed: int | None = None, **truth) -> Path:
    """Run the foreign bench (its truth: the spec, changed by ``truth``) and write the
    record file; the plate's inertial is the right description's model's."""
    right = write_scene(folder, spec, description(spec))
    fb = ForeignBench(base=spec.base, top=spec.top, home_height=spec.home_height,
                      **plate_inertial(_model_of(right)),
                      cylinder_mass=spec.masses["cylinder_mass"],
                      piston_mass=spec.masses["piston_mass"],
                      fts_pose=(0.0, 0.0, spec.fts_height, 0.0, 0.0, 0.0),
                      kp=spec.servo["kp"], kv=spec.servo["kv"], delay_samples=1,
                      servo_lag=(spec.servo.get("timeconst", 0.0)
                                 if spec.servo.get("lag") == "servo" else 0.0),
                      valve_hz=spec.servo.get("valve_hz", 0.0),
                      valve_damping=spec.servo.get("valve_damping", 0.7),
                      part_xml=spec.part_xml, world_xml=spec.world_xml)
    fb = fb.with_(**{**spec.bench, **truth})
    poses = multisine(duration, DT, seed=seed, **spec.poses)
    noise = seed + 100 if noise_seed is None else noise_seed
    ch = fb.run(poses, seed=noise)
    return write_record(folder / f"{spec.name}_{seed}_{noise}.csv", ch, DT)


def true_sigma(channel: str) -> float:
    """The noise σ the foreign bench added to a channel (SI units)."""
    kind, _, axis = channel.partition(".")
    if kind in ("pose_meas", "z_meas"):
        return NOISE["pose"][0 if axis in ("x", "y", "z") else 1]
    if kind == "leg_len":
        return NOISE["leg_len"]
    if kind == "leg_force":
        return NOISE["leg_force"]
    if kind == "f_meas":
        return NOISE["force" if axis in ("x", "y", "z") else "torque"]
    return NOISE["force" if axis in ("fx", "fy", "fz") else "torque"]


def validation_error(diag: Diagnosis) -> float:
    """RMS residual of the accepted model on the validation blocks, pooled over channels, in
    units of the noise the bench added (1 = only noise)."""
    out = diag.predict()
    v = [np.mean(((diag.measured[c] - out[c]) / true_sigma(c))[diag.val] ** 2)
         for c in diag.channels]
    return float(math.sqrt(np.mean(v)))


# ---------------------------------------------------------------------------- tests
def test_generator_agrees_with_the_bench_model_on_todays_conventions(tmp_path):
    """The foreign bench with today's conventions (ramp, end-of-step sampling, no delay) and
    today's geometry, replayed by the shipped bench6 scene's model (a 1.5 kg payload 20 mm
    above the sensor): every channel within 1.2 noise units of the noise it added — the
    generator and the model agree where they should."""
    import dataclasses

    from rths3d.platform.geometry import StewartGeometry
    from rths3d.platform.model import PlatformConfig, build_model
    from rths3d.scene import load_scene

    g = StewartGeometry()
    fb = ForeignBench(base=g.base_anchors(), top=g.top_anchors(), home_height=g.home_height,
                      **plate_inertial(build_model(PlatformConfig(geometry=g))),
                      part_xml='<body pos="0 0 0.02"><inertial pos="0 0 0" mass="1.5" '
                               'diaginertia="0.002 0.002 0.002"/></body>',
                      hold="ramp", sample="end")
    ch = fb.run(multisine(1.5, DT, seed=3), seed=1)
    rec = Record.load(write_record(tmp_path / "today.csv", ch, DT))
    scene = dataclasses.replace(load_scene("bench6"), duration=1.5)
    diag = Diagnosis(rec, scene, candidates=[], descriptions=())
    out = diag.predict()
    for c in diag.channels:
        rms = float(np.sqrt(np.mean(((diag.measured[c] - out[c]) / true_sigma(c))[1:] ** 2)))
        assert rms <= 1.2, (c, rms)


@pytest.mark.parametrize("hold,sample", [pytest.param("ramp", "end", marks=pytest.mark.slow),
                                         ("zoh", "start")])
def test_payload_identified_on_a_foreign_bench(hold, sample):
    """Payload identification from the record of bench A (noise on every channel): mass
    within 0.5 %, centre of mass within 1 mm, every parameter seen; with a ramped set-point
    the inertia about the COM within 10 % of its largest entry too. (A held set-point jumps
    at every sample: the wrench sampled at one instant of the interval is not the
    interval-average acceleration the differentiated pose gives, and the inertia comes out
    biased — measured 70 % low; the diagnosis' payload revisions of mass and centre of mass
    alone do not use it.)"""
    spec = rigid_bench()
    fb = ForeignBench(base=spec.base, top=spec.top, home_height=spec.home_height,
                      part_xml=spec.part_xml, fts_pose=(0, 0, spec.fts_height, 0, 0, 0),
                      delay_samples=1, hold=hold, sample=sample)
    ch = fb.run(multisine(3.0, DT, seed=5), seed=2)
    q = np.column_stack([ch[f"pose_meas.{d}"] for d in DOFS])
    w = np.column_stack([ch[f"fts.{c}"] for c in WRENCH])
    est = PayloadIdentification((0, 0, spec.fts_height, 0, 0, 0)).fit(q, w, DT)
    part = spec.part
    assert est.unseen_ == ()
    assert abs(est.mass_ - part["m"]) < 0.005 * part["m"]
    assert np.max(np.abs(est.com_ - part["com"])) < 1e-3
    if hold == "ramp":
        xx, yy, zz, xy, xz, yz = part["inertia"]
        truth = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
        assert np.max(np.abs(est.inertia_ - truth)) < 0.1 * np.max(np.abs(truth))


def _diagnose(folder: Path, spec: Spec, desc: dict, rec_path: Path, rounds: int = 3):
    from rths3d.scene import load_scene

    scene = load_scene(write_scene(folder, spec, desc))
    rec = Record.load(rec_path)
    diag = Diagnosis(rec, scene)
    res = diag.auto(max_rounds=rounds)
    return diag, res


@pytest.mark.parametrize("name", [
    "rigid", "servo", "valve", "physics", pytest.param("contact", marks=pytest.mark.slow),
    pytest.param("geometry", marks=[pytest.mark.slow, pytest.mark.skipif(
        not os.environ.get("RTHS3D_FULL_MATRIX"),
        reason="bench C's null runs with RTHS3D_FULL_MATRIX=1 (its geometry is checked in "
               "the suite by bench A's anchor case and the explicit-anchors test)")])])
def test_null_described_right_is_only_noise(tmp_path, name):
    """Null: the bench described right (geometry, masses, servo, conventions, part; bench D
    with its lag's place stated, ``lag = "servo"``): only noise — nothing proposed, no
    statement revised, validation error ≤ 1.2 units of the noise the bench added."""
    spec = BENCHES[name]()
    rec = make_record(tmp_path, spec, seed=11)
    if name == "contact":  # the specimen meets its surface during the test
        assert LAST_RUN["contact_fraction"] > 0.02
    diag, res = _diagnose(tmp_path, spec, description(spec), rec, rounds=1)
    assert res[0].proposal is None, res[0].proposal
    assert diag.revisions == []
    assert validation_error(diag) <= 1.2


def _wrong(spec: Spec, error: str) -> tuple[dict, tuple[str, ...]]:
    """The description with one error, and the candidates that count as finding it."""
    d = description(spec)
    d = {k: (dict(v) if isinstance(v, dict) else v) for k, v in d.items()}
    if error == "hold":
        d["controller"]["hold"] = "ramp"
        return d, ("scene:controller.hold=zoh",)
    if error == "sample":
        d["controller"]["sample"] = "end"
        return d, ("scene:controller.sample=start",)
    if error == "mass":
        d["experiment"]["m"] = round(d["experiment"]["m"] * 1.15, 4)
        return d, ("scene:experiment.m=", "scene:experiment.payload=")
    if error == "com_height":
        com = list(d["experiment"]["com"])
        com[2] -= 0.02
        d["experiment"]["com"] = com
        return d, ("scene:experiment.com=", "scene:experiment.payload=")
    if error == "anchor":
        # the user's data sheet has base anchor 2 off by 1.5 mm in x: the controller works
        # with it (the truth's controller uses the same wrong anchor), the mechanism does not
        base = np.array(d["platform"]["base_anchors"])
        base[2, 0] += 1.5e-3
        d["platform"]["base_anchors"] = base.tolist()
        return d, ("kinematic_calibration", "base_anchor.leg2")
    if error == "lag_place":  # a user who does not know where the lag sits: not stated
        del d["controller"]["lag"]
        return d, ("scene:controller.lag=servo",)
    if error == "timeconst":  # stated twice what the bench has
        d["controller"][error] = 2 * d["controller"][error]
        return d, (f"scene:transfer.{error}=",)
    if error == "valve_hz":  # the valve's frequency stated 1.6 times what the bench has
        d["controller"][error] = round(1.6 * d["controller"][error], 3)
        return d, (f"scene:transfer.{error}=",)
    if error == "delay":
        # stated 1.5 times what the bench has (stated twice, one sample too many, it is
        # exactly confounded with sampling at the end: docs/diagnosis.md)
        d["controller"][error] = 1.5 * d["controller"][error]
        return d, (f"scene:transfer.{error}=",)
    raise ValueError(error)


WRONG = [("rigid", e) for e in ("hold", "sample", "mass", "com_height", "anchor")] + \
    [("contact", e) for e in ("hold", "sample", "anchor")] + \
    [("geometry", e) for e in ("hold", "sample", "mass", "com_height", "anchor")] + \
    [("servo", e) for e in ("lag_place", "timeconst", "delay")] + [("valve", "valve_hz")]


def described_wrong_case(folder: Path, name: str, error: str, seed: int = 21) -> dict:
    """One described-wrong case: the found-first label, the validation error after the
    diagnosis' rounds (noise units of the bench), the description's revised parts."""
    spec = BENCHES[name]()
    desc, found = _wrong(spec, error)
    truth = {}
    if error == "anchor":
        truth = {"ctrl_base": np.array(desc["platform"]["base_anchors"])}
    rec = make_record(folder, spec, seed=seed, **truth)
    diag, res = _diagnose(folder, spec, desc, rec)
    first = res[0].proposal.effect if res[0].proposal is not None else None
    return {"bench": name, "error": error, "first": first,
            "found": first is not None and first.startswith(found),
            "error_val": validation_error(diag), "revisions": diag.revisions,
            "other_revisions": [r["label"] for r in diag.revisions
                                if not ("scene:" + r["label"]).startswith(found)]}


FULL = pytest.mark.skipif(
    not os.environ.get("RTHS3D_FULL_MATRIX"),
    reason="the rest of the foreign-bench figures (1–2 min each): RTHS3D_FULL_MATRIX=1 runs them "
           "here, examples/66_foreign_bench.py prints them all; the suite keeps the cases "
           "measured on 2026-11-27")
MEASURED_WRONG = {("rigid", "hold"), ("rigid", "anchor"), ("servo", "lag_place"),
                  ("valve", "valve_hz")}
"""Described-wrong cases the suite runs (the whole set passes with RTHS3D_FULL_MATRIX=1,
measured 2026-11-27; docs/diagnosis.md)."""
MEASURED_MATRIX = {"coulomb_friction.leg2"}
"""Matrix cases the suite runs (fts_mount.x was measured and passes too; docs/diagnosis.md)."""


@pytest.mark.parametrize("name,error", [
    ("rigid", "hold"), ("servo", "lag_place"),
    *[pytest.param(n, e, marks=[pytest.mark.slow,
                                *([] if (n, e) in MEASURED_WRONG else [FULL])])
      for n, e in WRONG if (n, e) not in (("rigid", "hold"), ("servo", "lag_place"))]])
def test_described_wrong_is_found_and_fixed(tmp_path, name, error):
    """Described wrong (one error): the error is found first and the validation error falls
    to ≤ 1.2 units of the bench's noise; a description error is reported as the revised
    part of the description."""
    out = described_wrong_case(tmp_path, name, error)
    assert out["found"], out
    assert out["error_val"] <= 1.2, out
    if out["first"].startswith("scene:"):
        key = out["first"].removeprefix("scene:").split("=")[0]
        assert any(key in r["label"] for r in out["revisions"]), out
        if name in ("servo", "valve"):  # no other statement is revised on the way to noise
            assert [r["label"].split("=")[0] for r in out["revisions"]] == [key], out


# the matrix: (effect label expected, truth change of the foreign bench, accepted labels)
MATRIX = {
    "coulomb_friction.leg2": ({"friction": (0, 0, 40.0, 0, 0, 0)}, ()),
    "viscous_friction.leg4": ({"damping": (0, 0, 0, 0, 600.0, 0)}, ()),
    "servo_gain.leg1": ({"kp_scale": (1, 0.85, 1, 1, 1, 1)}, ()),
    "delay.leg5": ({"leg_delay": (0, 0, 0, 0, 0, 2)}, ()),
    "actuator_lag.leg0": ({"leg_lag": (0.004, 0, 0, 0, 0, 0)}, ()),
    "leg_offset.leg3": ({"encoder_offsets": (0, 0, 0, 5e-4, 0, 0)}, ("kinematic_calibration",)),
    "kinematic_calibration": ({"base_shift": (2, 0, 1.5e-3)}, ("base_anchor.leg2.x",)),
    "fts_calibration": ({"fts_gain": (2, 1.03)}, ("fts_gain.fz",)),
    "fts_offset.tx": ({"fts_offset": (0, 0, 0, 0.05, 0, 0)}, ("fts_calibration",)),
    "fts_mount.x": ({"site_offset": (0.005, 0.0, 0.0)}, ()),
    "fixture_mass": ({"fixture_mass": 0.3}, ("scene:experiment.m=",
                                             "scene:experiment.payload=")),
}
_A = rigid_bench().part
MATRIX.update({
    # the payload's centre of mass 5 mm off what the scene states (bench A's part)
    "payload_com.x": ({"part_xml": _rigid_xml(_A["m"], [_A["com"][0] + 0.005, *_A["com"][1:]],
                                              _A["inertia"])},
                      ("scene:experiment.com=", "scene:experiment.payload=")),
    # its moments of inertia about x and y 60 % above the stated ones
    "payload_inertia": ({"part_xml": _rigid_xml(_A["m"], _A["com"], [
        1.6 * _A["inertia"][0], 1.6 * _A["inertia"][1], *_A["inertia"][2:]])},
                        ("scene:experiment.payload=",)),
})


def _truth(spec: Spec, change: dict) -> dict:
    out = dict(change)
    if "base_shift" in out:
        i, ax, v = out.pop("base_shift")
        base = np.array(spec.base, dtype=float)
        base[i, ax] += v
        out["base"] = base
        out["ctrl_base"] = np.array(spec.base, dtype=float)
    if "fts_gain" in out:
        j, g = out.pop("fts_gain")
        C = np.eye(6)
        C[j, j] = g
        out["fts_matrix"] = C
    return out


def matrix_case(folder: Path, label: str, seed: int = 31, bench: str = "rigid") -> dict:
    """One matrix case on bench A (or another of :data:`BENCHES` with a rigid payload: D,
    whose servo lag sits after the hold): the right effect first, the right leg, the
    validation error after adding it, the description's revised parts."""
    spec = BENCHES[bench]()
    change, also = MATRIX[label]
    rec = make_record(folder, spec, seed=seed, **_truth(spec, change))
    diag, res = _diagnose(folder, spec, description(spec), rec)
    first = res[0].proposal.effect if res[0].proposal is not None else None
    ok = first is not None and (first == label or first.startswith(also or ("\0",)))
    leg = ("leg" in label.split(".")[1]) if "." in label else False
    right_leg = None
    if leg and first is not None:
        right_leg = label.split(".")[1] in first.split(".")
    return {"effect": label, "first": first, "found": ok, "right_leg": right_leg,
            "error_val": validation_error(diag), "revisions": diag.revisions,
            "other_revisions": [r["label"] for r in diag.revisions
                                if not ("scene:" + r["label"]).startswith(also or ("\0",))]}


# the matrix's measured misses (the whole matrix on the idle machine, 2026-11-27)
MATRIX_MISSES: dict[str, str] = {}
"""The matrix's measured misses (none since 2026-11-27: the bench starting at rest, gravity
compensation from the bench's holding forces, the anchors screened after a leg's offset)."""


def _miss(label: str) -> list:
    if label not in MATRIX_MISSES:
        return []
    return [pytest.mark.xfail(reason=f"measured on bench A (2026-11-27): {MATRIX_MISSES[label]}",
                              strict=True)]


@pytest.mark.parametrize("label", [
    "coulomb_friction.leg2",
    *[pytest.param(k, marks=[pytest.mark.slow, *_miss(k),
                             *([] if k in MEASURED_MATRIX else [FULL])])
      for k in MATRIX if k != "coulomb_friction.leg2"]])
def test_matrix_effect_on_a_foreign_bench(tmp_path, label):
    """An effect of today's matrix hidden in foreign bench A: it ranks first (on the right
    leg) and the validation error falls to ≤ 1.2 units of the bench's noise."""
    out = matrix_case(tmp_path, label)
    assert out["found"], out
    assert out["right_leg"] in (None, True), out
    assert out["error_val"] <= 1.2, out


@pytest.mark.slow
@pytest.mark.parametrize("label", ["servo_gain.leg1"])
def test_matrix_effect_on_the_servo_lag_bench(tmp_path, label):
    """A leg's gain 15 % low on bench D (its servo's lag after the hold, stated): found first
    on the right leg, ≤ 1.2 after it, no statement revised — the gain effect acts on the
    lagged set-point as the bench's servo does (measured 2026-11-29: 0.998; 1.84 while the
    effect left the lag's share of the force at the stated gain)."""
    out = matrix_case(tmp_path, label, bench="servo")
    assert out["found"] and out["right_leg"], out
    assert out["error_val"] <= 1.2, out
    assert out["other_revisions"] == [], out


FRAME_DAMPING = 15.0
"""N·m·s/rad: viscous damping in every universal joint's hinges of bench A — structural
damping of the frame, which no effect of the library has (its null: 10.9 noise units)."""


def _disc_plate(folder: Path, spec: Spec) -> dict:
    """The truth of a uniform disc plate of radius 0.30 m (what a scene that leaves
    ``plate_inertia`` out cannot state), at the plate's centre."""
    m, r = plate_inertial(_model_of(write_scene(folder, spec, description(spec))))[
        "plate_mass"], 0.30
    return {"plate_ipos": (0.0, 0.0, 0.0), "plate_iquat": (1.0, 0.0, 0.0, 0.0),
            "plate_inertia": (m * r * r / 4, m * r * r / 4, m * r * r / 2)}


def baseline_case(folder: Path, spec: Spec, common: dict, label: str | None) -> dict:
    """A healthy record and a changed one (``label``'s truth) of a bench that differs from
    its scene by ``common`` in both, the same commands, other noise, diagnosed against the
    healthy one: the first proposal, whether it is right (none for a null; on the right
    leg), the validation error after the rounds over √2 (the noise of two records'
    difference), the statements revised, and the changed record's error without the
    baseline."""
    from rths3d.scene import load_scene

    change, also = MATRIX[label] if label else ({}, ())
    healthy = make_record(folder, spec, seed=31, noise_seed=131, **common)
    changed = make_record(folder, spec, seed=31, noise_seed=231,
                          **{**common, **_truth(spec, change)})
    scene = load_scene(write_scene(folder, spec, description(spec)))
    plain = validation_error(Diagnosis(Record.load(changed), scene))
    diag = Diagnosis(Record.load(changed), scene, baseline=Record.load(healthy))
    res = diag.auto(max_rounds=3)
    first = res[0].proposal.effect if res[0].proposal is not None else None
    if label is None:
        found = first is None and diag.accepted == {}
    else:
        found = first is not None and (first == label or first.startswith(also or ("\0",)))
    leg = label is not None and "." in label and "leg" in label.split(".")[1]
    return {"effect": label, "first": first, "found": found,
            "right_leg": (label.split(".")[1] in first.split(".")) if leg and first else
            None, "error_val": validation_error(diag) / math.sqrt(2),
            "error_without_baseline": plain, "revisions": diag.revisions,
            "other_revisions": [r["label"] for r in diag.revisions]}


def _baseline_case(folder: Path, spec: Spec, common: dict, label: str | None,
                   to_noise: bool = True) -> None:
    """:func:`baseline_case`, asserted: a null proposes nothing, an effect ranks first (on
    its leg), no statement is revised and, with ``to_noise`` (and for a null), only the
    noise of the two records' difference (√2 σ) remains."""
    out = baseline_case(folder, spec, common, label)
    assert out["found"], out
    assert out["right_leg"] in (None, True), out
    assert out["revisions"] == [], out
    if to_noise or label is None:
        assert out["error_val"] <= 1.2, out

