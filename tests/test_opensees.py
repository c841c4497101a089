"""OpenSees models as numerical substructures (``[numerical] kind = "opensees"``).

Independent answers: rths3d's own Newmark recurrence of the same M, C, K (and a Newmark
loop written out here from its formulas), the model's matrices written by hand from its
parameters, and the whole coupled system (frame + part) as one OpenSees model.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import rths3d
from rths3d.errors import ConfigError
from rths3d.numerical import LinearSubstructure, discretise
from rths3d.reference import reference_solution
from rths3d.scene import load_scene, scene_from_dict, scene_to_dict

sys.path.insert(0, str(Path(__file__).parent))
from processes import alive_in_session  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
LINEAR = ROOT / "scenes" / "opensees_linear.toml"
FRAME = ROOT / "scenes" / "opensees_frame_stewart.toml"


# ---------------------------------------------------------------- rths3d's own Newmark
def _newmark_by_hand(M, C, K, p, dt):
    """Newmark's average acceleration written out (Chopra, Table 5.4.2), load at t_{n+1}."""
    g, b = 0.5, 0.25
    n_steps = p.shape[0] - 1
    x = np.zeros((n_steps + 1, M.shape[0]))
    v = np.zeros_like(x)
    a = np.zeros_like(x)
    a[0] = np.linalg.solve(M, p[0])
    Kh = K + g / (b * dt) * C + M / (b * dt**2)
    A = M / (b * dt) + g / b * C
    B = M / (2 * b) + dt * (g / (2 * b) - 1) * C
    for i in range(n_steps):
        dp = p[i + 1] - p[i] + A @ v[i] + B @ a[i]
        du = np.linalg.solve(Kh, dp)
        dv = g / (b * dt) * du - g / b * v[i] + dt * (1 - g / (2 * b)) * a[i]
        x[i + 1] = x[i] + du
        v[i + 1] = v[i] + dv
        a[i + 1] = np.linalg.solve(M, p[i + 1] - C @ v[i + 1] - K @ x[i + 1])
    return x, v


def test_newmark_recurrence_equals_the_written_out_method():
    M = np.diag([2.0, 1.5])
    K = np.array([[3e3, -1e3], [-1e3, 1e3]])
    C = 0.01 * K + 0.2 * M
    dt = 1e-3
    t = np.arange(2001) * dt
    p = np.stack([np.sin(7 * t), 0.5 * np.cos(3 * t) - 0.5], axis=1)
    x_hand, v_hand = _newmark_by_hand(M, C, K, p, dt)
    sub = LinearSubstructure(M, C, K, np.eye(2), p, dt, method="newmark")
    xs = [sub.x[0].copy()]
    for n in range(2000):
        sub.step(n, np.zeros((1, 2)), np.zeros((1, 2)))
        xs.append(sub.x[0].copy())
    assert np.max(np.abs(np.array(xs) - x_hand)) < 1e-12 * np.max(np.abs(x_hand)) + 1e-15
    # and it converges to the exact discretisation at second order in ΔT
    d = discretise(M, C, K, dt, "newmark")
    assert d.Ad.shape == (6, 6)


# ---------------------------------------------------------------- linear equivalence
def test_paper_linear_system_in_opensees_equals_rths3d_newmark_over_the_whole_test():
    """The paper's linear test (10 s, LTI transfer): the OpenSees model stepped in the loop
    and rths3d's own Newmark of the same m, c, k agree to 1e-9 m at every sample, test and
    reference alike."""
    os_scene = load_scene(LINEAR)
    twin = load_scene(ROOT / "scenes" / "paper_linear.toml", ["numerical.integrator=newmark"])
    a = rths3d.run(os_scene, transfer="lti")
    b = rths3d.run(twin, transfer="lti", numerical=None)
    assert a.status == b.status == "ok"
    assert len(a.record.t) == len(b.record.t) == 10001
    for col in ("z_cmd.z", "z_meas.z", "f_meas.z", "x_num.0"):
        assert np.max(np.abs(a.record.columns[col] - b.record.columns[col])) < 1e-9, col
    assert np.max(np.abs(b.record.columns["z_cmd.z"])) > 1e-3  # a response, not zeros
    # the reference: OpenSees' implicit step against rths3d's Newmark in the same iteration
    ref_b = reference_solution([twin], numerical=lambda s: LinearSubstructure.from_scenes(
        s, method="newmark"))
    assert np.max(np.abs(a.record.columns["z_ref.z"] - ref_b["z_ref"][0, :, 0])) < 1e-9
    # an elastic model may also be rolled back for every interface pass: then it is exact
    short = ["duration=2.0"]
    it = reference_solution([load_scene(LINEAR, short + ["numerical.reference=iterate"])])
    ref_c = reference_solution([load_scene(ROOT / "scenes" / "paper_linear.toml", short)],
                               numerical=lambda s: LinearSubstructure.from_scenes(
                                   s, method="newmark"))
    assert np.max(np.abs(it["z_ref"] - ref_c["z_ref"])) < 1e-14
    # the record says what ran, and the τ-ratios' ω_0,NUM is √(k/m)
    meta = a.record.meta
    assert meta["numerical"]["kind"] == "opensees"
    assert meta["omega_num_max"] == pytest.approx(np.sqrt(1e4 / 20.0), rel=1e-12)


def test_opensees_batch_runs_each_test_in_its_own_domain():
    """K = 3 tests of an OpenSees scene (one per group) equal their Newmark twins."""
    sets = [{"experiment.k": k, "duration": 1.0} for k in (5e3, 8650.0, 1.5e4)]
    res = rths3d.run_batch(load_scene(LINEAR), sets, transfer="ideal")
    twin = load_scene(ROOT / "scenes" / "paper_linear.toml", ["numerical.integrator=newmark"])
    ref = rths3d.run_batch(twin, sets, transfer="ideal", reference=False)
    for r, q in zip(res, ref, strict=True):
        assert r.status == "ok"
        assert np.max(np.abs(r.record.columns["z_cmd.z"] - q.record.columns["z_cmd.z"])) < 1e-9
        assert np.all(np.isfinite(r.record.columns["z_ref.z"]))
    # different parts, different responses
    assert abs(res[0].record.columns["f_meas.z"][-1] - res[2].record.columns["f_meas.z"][-1]) > 0


# ---------------------------------------------------------------- the nonlinear frame
def test_frame_matrices_are_the_models_own():
    """The linearised M, C, K the record's τ-ratios come from equal the frame's matrices
    written from its parameters (and C = a0 M + a1 K: -doRayleigh is set)."""
    sys.path.insert(0, str(ROOT / "scenes" / "opensees"))
    import steel02_frame as frame

    sub = rths3d.numerical.OpenSeesSubstructure(load_scene(FRAME, ["duration=0.1"]))
    M, C, K, G = sub.linearised()
    (m1, m2), (k1, k2) = frame.MASSES, frame.STIFFNESS
    Mh = np.diag([m1, m2])
    Kh = np.array([[k1 + k2, -k2], [-k2, k2]])
    a0, a1 = frame.rayleigh_factors()
    order = [sub.eqs[0] == 1, sub.eqs[0] == 0]  # the roof's equation
    assert G[sub.eqs[0], 0] == 1.0 and order[0]
    assert np.allclose(M, Mh, rtol=1e-12)
    assert np.allclose(K, Kh, rtol=1e-12)
    assert np.allclose(C, a0 * Mh + a1 * Kh, rtol=1e-10)
    sub.close()


def _coupled_in_opensees(duration: float, dt: float, amp: float, f: float, part) -> np.ndarray:
    """Frame + part (a mass on a spring and damper at the roof) as ONE OpenSees model under
    the same ground motion: the roof's displacement, relative to the ground. The ground
    acceleration loads the frame's floors (−m ü_g) and not the part: in the hybrid test the
    part is moved through the relative displacement of the roof."""
    import openseespy.opensees as ops
    import steel02_frame as frame

    ops.wipe()
    frame.build(ops)
    ops.node(4, 0.0)
    ops.mass(4, part.m)
    ops.uniaxialMaterial("Elastic", 90, part.k)
    ops.uniaxialMaterial("Viscous", 91, part.d, 1.0)
    ops.uniaxialMaterial("Parallel", 92, 90, 91)
    ops.element("zeroLength", 90, 3, 4, "-mat", 92, "-dir", 1)
    t = np.arange(int(round(duration / dt)) + 1) * dt
    ops.timeSeries("Path", 1, "-dt", dt, "-values", *(amp * np.sin(2 * np.pi * f * t)).tolist())
    ops.pattern("Plain", 1, 1)
    for node, m in zip((2, 3), frame.MASSES, strict=True):
        ops.load(node, -m)
    ops.constraints("Transformation")
    ops.numberer("RCM")
    ops.system("BandGen")
    ops.test("NormDispIncr", 1e-12, 50)
    ops.algorithm("Newton")
    ops.integrator("Newmark", 0.5, 0.25)
    ops.analysis("Transient")
    out = [0.0]
    for _ in range(len(t) - 1):
        assert ops.analyze(1, dt) == 0
        out.append(ops.nodeDisp(3, 1))
    ops.wipe()
    return np.array(out)


def test_yielding_frame_reference_equals_the_monolithic_model():
    """The frame yields (storey drift 3.5× its yield drift); the reference (one committed
    OpenSees step per interface step, the part iterated against it) equals the frame and
    the part solved as one OpenSees model to 0.2 % of the peak; the test's own record
    carries the frame's hysteresis loop and the interface loop."""
    sys.path.insert(0, str(ROOT / "scenes" / "opensees"))
    import steel02_frame as frame

    scene = load_scene(FRAME, ["duration=2.0"])
    res = rths3d.run(scene, transfer="ideal")
    c = res.record.columns
    exc = scene.excitation
    mono = _coupled_in_opensees(2.0, scene.dt, exc.amplitude, exc.frequency, scene.experiment)
    peak = np.max(np.abs(mono))
    assert np.max(np.abs(c["z_ref.z"] - mono)) < 2e-3 * peak
    # the test (force held over a step) stays close to it too
    assert np.max(np.abs(c["z_cmd.z"] - mono)) < 2e-2 * peak
    drift, shear = c["ele_deformation.1"], c["ele_force.1"]
    assert np.max(np.abs(drift)) > 3 * frame.YIELD_DRIFT
    # yielded: the storey's shear stays far below the elastic k·drift
    k1 = frame.STIFFNESS[0]
    assert np.max(np.abs(shear)) < 0.5 * k1 * np.max(np.abs(drift))
    # a hysteresis loop encloses area (energy dissipated, J): ∮ V dδ > 0
    assert np.sum(0.5 * (shear[1:] + shear[:-1]) * np.diff(drift)) > 1.0
    m = rths3d.compute_measures(res.record)
    assert 0 < m["e_rel_ref"] < 0.05


def test_frame_on_the_stewart_platform_records_loops_and_metrics():
    res = rths3d.run(load_scene(FRAME, ["duration=1.0"]), transfer="stewart")
    assert res.status == "ok"
    c = res.record.columns
    for col in ("f_meas.z", "z_meas.z", "ele_force.1", "ele_deformation.2", "pose_cmd.z"):
        assert np.all(np.isfinite(c[col])), col
    m = rths3d.compute_measures(res.record)
    assert np.isfinite(m["e_rel_track"]) and m["e_rel_track"] > 0
    assert np.isfinite(m["fei_d"])


# ---------------------------------------------------------------- errors, safe stops
def _cli(args: list[str], cwd: Path) -> tuple[subprocess.CompletedProcess, list]:
    proc = subprocess.Popen([sys.executable, "-m", "rths3d", *args], cwd=cwd,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True, env={**os.environ, "COLUMNS": "200"})
    out, err = proc.communicate(timeout=300)
    left = alive_in_session(proc.pid)
    return subprocess.CompletedProcess(proc.args, proc.returncode, out, err), left


def _scene_copy(tmp_path: Path, model_text: str) -> Path:
    (tmp_path / "opensees").mkdir()
    (tmp_path / "opensees" / "paper_linear.py").write_text(model_text)
    scene = tmp_path / "s.toml"
    scene.write_text(LINEAR.read_text().replace("duration = 10.0", "duration = 0.5"))
    return scene


def test_model_with_a_syntax_error_is_one_line_exit_2(tmp_path):
    scene = _scene_copy(tmp_path, "def build(ops)\n    pass\n")
    res, left = _cli(["run", str(scene), "--json"], tmp_path)
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "numerical.model" in lines[0] and "syntax error at line 1" \
        in lines[0], res.stderr
    assert not left


def test_missing_interface_node_is_one_line_exit_2(tmp_path):
    scene = _scene_copy(tmp_path, (ROOT / "scenes/opensees/paper_linear.py").read_text())
    res, left = _cli(["run", str(scene), "--json", "--set", "numerical.interface=[[7, 1]]"],
                     tmp_path)
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and "numerical.interface[0]" in lines[0] and "node 7" in lines[0]
    assert not left


def test_non_convergence_mid_test_stops_safely_with_the_partial_record(tmp_path):
    """Newton allowed two iterations: the frame's first yielding step does not converge.
    The test stops there, keeps its record up to the last converged sample (written with
    --out), says what and when, and leaves nothing running."""
    out = tmp_path / "rec.parquet"
    res, left = _cli(["run", str(FRAME), "--transfer", "ideal", "--json", "--out", str(out),
                      "--set", "numerical.max_iter=2", "--set", "duration=1.0"], tmp_path)
    assert res.returncode == 0, res.stderr
    import json

    summary = json.loads(res.stdout.strip().splitlines()[-1])
    assert summary["status"] == "stopped"
    assert "did not converge at t = " in summary["reason"]
    rec = rths3d.Record.load(out)
    t_fail = float(summary["reason"].split("t = ")[1].split(" s")[0])
    assert 0.01 < rec.t[-1] < t_fail <= rec.t[-1] + 2e-3
    assert np.all(np.isfinite(rec.columns["z_cmd.z"]))
    assert not left


def test_scene_keys_are_checked():
    raw = scene_to_dict(load_scene(LINEAR))
    back = scene_from_dict(raw, source=str(LINEAR))
    assert back.numerical == load_scene(LINEAR).numerical
    bad = [("interface", [[2, 1], [2, 2]], "numerical.interface"),
           ("interface", [[0, 1]], "numerical.interface[0]"),
           ("integrator", "Euler", "numerical.integrator"),
           ("algorithm", "Magic", "numerical.algorithm"),
           ("model", "nowhere.py", "numerical.model"),
           ("reference", "guess", "numerical.reference"),
           ("stiffness", 3.0, "numerical.stiffness")]
    for key, value, field in bad:
        r = dict(raw)
        r["numerical"] = {**raw["numerical"], key: value}
        with pytest.raises(ConfigError) as info:
            scene_from_dict(r, source=str(LINEAR))
        assert info.value.field == field, (key, info.value)
    r = dict(raw)
    r["numerical"] = {**raw["numerical"], "kind": "abaqus"}
    with pytest.raises(ConfigError, match="numerical.kind"):
        scene_from_dict(r, source=str(LINEAR))
    # a linear scene refuses the OpenSees keys
    lin = scene_to_dict(load_scene(ROOT / "scenes" / "paper_linear.toml"))
    lin["numerical"]["interface"] = [[2, 1]]
    with pytest.raises(ConfigError, match="numerical.interface"):
        scene_from_dict(lin)


def test_numerical_scalars_are_not_an_opensees_models_parameters():
    """m, c, k of a one-DOF OpenSees scene are its model file's: an override of them is
    refused (one ConfigError naming the field), and the viewer offers no slider for them."""
    from rths3d.scene import scene_with
    from rths3d.viz.live import LiveRun

    sc = load_scene(LINEAR)
    assert not sc.numerical.has_matrices
    assert load_scene(ROOT / "scenes" / "paper_linear.toml").numerical.has_matrices
    with pytest.raises(ConfigError) as info:
        scene_with(sc, {"numerical.k": 5e3})
    assert info.value.field == "numerical.k"
    params = LiveRun(sc, transfer="ideal").key_params()
    assert params and not any(name.startswith("numerical.") for name in params)


def test_stewart_frame_record_gives_the_metrics_on_the_command_line(tmp_path):
    """The yielding frame on the Stewart platform from ``rths3d run --out``: the record
    keeps the interface loop (f_meas.z over z_meas.z) and the storeys' hysteresis (storey 1
    yields: drift past its 4 mm, ∮F dδ > 1 J dissipated; measured 13 mm, 3.6 J over 1 s);
    ``rths3d metrics`` on the file gives the run's e_rel,track and a finite FEI; no process
    is left behind."""
    import json

    out = tmp_path / "frame.parquet"
    res, left = _cli(["run", str(FRAME), "--json", "--out", str(out), "--set",
                      "duration=1.0"], tmp_path)
    assert res.returncode == 0, res.stderr
    assert not left
    run = json.loads(res.stdout.strip().splitlines()[-1])
    assert run["status"] == "ok" and run["transfer"] == "stewart"
    rec = rths3d.Record.load(out)
    c = rec.columns
    assert np.ptp(c["f_meas.z"]) > 1.0 and np.ptp(c["z_meas.z"]) > 1e-3  # N, m
    drift, shear = c["ele_deformation.1"], c["ele_force.1"]
    assert np.max(np.abs(drift)) > 0.004
    assert np.trapezoid(shear, drift) > 1.0  # J
    met, left = _cli(["metrics", str(out), "--json"], tmp_path)
    assert met.returncode == 0, met.stderr
    assert not left
    m = json.loads(met.stdout.strip().splitlines()[-1])
    assert m["e_rel_track"] == pytest.approx(run["e_rel_track"], rel=1e-9)
    assert 0 < m["e_rel_track"] < 0.05
    assert np.isfinite(m["fei_d"]) and np.isfinite(m["fei_A"])


def test_sweep_workers_each_own_their_opensees_domain(tmp_path):
    """A sweep of the OpenSees scene over the part's stiffness, two worker processes: the
    table equals the one-process sweep's exactly, every test ran, and the tests differ."""
    import pandas as pd

    from rths3d.dataset import load_spec, run_sweep

    spec = tmp_path / "os.toml"
    spec.write_text(f"""
[sweep]
name = "os"
duration = 0.5
seed = 3
batch_size = 2

[[family]]
name = "frame"
scene = "{LINEAR}"
transfer = "ideal"
[family.grid]
"experiment.k" = [5.0e3, 8650.0, 1.2e4, 1.5e4]
""")
    one = run_sweep(load_spec(spec), tmp_path / "one", workers=1, progress=False)
    two = run_sweep(load_spec(spec), tmp_path / "two", workers=2, progress=False)
    key = "test_id"
    pd.testing.assert_frame_equal(two.sort_values(key).reset_index(drop=True),
                                  one.sort_values(key).reset_index(drop=True))
    assert len(one) == 4 and (one["status"] == "ok").all()
    ref = one["target.e_rel_ref"]
    assert np.isfinite(ref).all() and ref.nunique() == 4
    assert one["measure.omega_dyn"].nunique() == 4  # rad/s: the part's stiffness in the τ-ratio


def test_tau_ratio_frequency_equals_opensees_eigen():
    """The record's ω_0,NUM (the τ-ratios' fastest numerical eigenfrequency, from the
    model's matrices) equals OpenSees' own ``eigen`` of the yielding frame at rest, in the
    record's metadata and in its measures."""
    import openseespy.opensees as ops

    sys.path.insert(0, str(ROOT / "scenes" / "opensees"))
    import steel02_frame as frame

    res = rths3d.run(load_scene(FRAME, ["duration=0.2"]), transfer="ideal", reference=False)
    assert res.status == "ok"
    ops.wipe()
    frame.build(ops)
    lam = ops.eigen("-fullGenLapack", 2)
    ops.wipe()
    w_max = float(np.sqrt(max(lam)))
    assert w_max > 2 * np.pi  # rad/s: a stiff frame, not zero
    assert res.record.meta["omega_num_max"] == pytest.approx(w_max, rel=1e-9)
    m = rths3d.compute_measures(res.record)
    assert m["omega_num"] == pytest.approx(w_max, rel=1e-9)
