"""compute_measures / feature_row on records (1 and 6 DOF), J1 through the metrics layer, CLI."""

from __future__ import annotations

import json
import math
import subprocess

import numpy as np
import pytest
from cli_cases import run_in_process

from rths3d.errors import ConfigError
from rths3d.metrics import FEATURE_SETS, compute_measures, e_rel_track, feature_row, fei
from rths3d.record import DOFS, Record

DT = 1e-3
SDOF_META = {"params": {"m_num": 9.62, "k_num": 1e4, "d_num": 100.0},
             "experiment": {"m_exp": 0.38, "k_exp": [[8650.0]]}}


def sdof_record(f=1.0, a=0.95, tau=0.012, n=4000, with_ref=True) -> Record:
    """One-DOF record: delayed, scaled sine, spring specimen, sinusoidal external force."""
    t = np.arange(n) * DT
    z = 0.005 * np.sin(2 * np.pi * f * t)
    zp = a * 0.005 * np.sin(2 * np.pi * f * (t - tau))
    cols = {"z_cmd": z, "z_meas": zp, "f_meas": 8650.0 * zp,
            "f_ext": 20.0 * np.sin(2 * np.pi * f * t + 0.3)}
    if with_ref:
        cols["z_ref"] = 1.02 * z
    return Record(t, cols, json.loads(json.dumps(SDOF_META)))


@pytest.fixture(scope="module")
def sdof() -> Record:
    return sdof_record()


@pytest.fixture(scope="module")
def six_dof() -> Record:
    """Six DOF, each a delayed sine of its own frequency, delay and force level."""
    t = np.arange(6000) * DT
    cols = {}
    for j, d in enumerate(DOFS):
        f, tau, a = 0.5 + 0.5 * j, 0.002 * (j + 1), 0.9 + 0.04 * j
        z = 0.004 * np.sin(2 * np.pi * f * t)
        zp = a * 0.004 * np.sin(2 * np.pi * f * (t - tau))
        cols[f"z_cmd.{d}"] = z
        cols[f"z_meas.{d}"] = zp
        cols[f"f_meas.{d}"] = (1e4 if j != 2 else 1e5) * zp  # z exchanges the most power
        cols[f"z_ref.{d}"] = z
    meta = {"experiment": {"m_exp": 0.5, "k_exp": np.diag([1e4, 1e4, 1e5, 1e4, 1e4, 1e4])
                           .tolist()},
            "numerical": {"M": np.eye(6).tolist(), "C": (np.eye(6) * 10).tolist(),
                          "K": (np.eye(6) * 4e4).tolist(), "gamma": np.eye(6).tolist()}}
    return Record(t, cols, meta)


def test_single_dof_flat_dict_has_issue_keys(sdof):
    """A 1-DOF record gives a flat dict with every measure name the issue lists."""
    m = compute_measures(sdof)
    keys = ["e_rel_track", "e_mte_track", "e_peak_track", "e_rel_track_f", "ti", "theta_pc",
            "paei_phase", "paei_amp", "fei_A", "fei_phi", "fei_d", "f_eq", "e_error",
            "e_input", "hsem_s", "hsem_i", "e_rel_ref", "e_mre_ref", "e_peak_ref",
            "e_rel_ref_f", "phi", "kappa", "zeta", "tau_ratio_num", "tau_ratio_dyn",
            "tau_ratio_max", "psi"]
    missing = [k for k in keys if k not in m]
    assert not missing
    assert m["fei_d"] == pytest.approx(0.012, rel=0.01)
    assert m["phi"] == pytest.approx(9.62 / 0.38)
    assert m["kappa"] == pytest.approx(1e4 / 8650.0)
    assert m["tau_ratio_num"] == pytest.approx(m["fei_d"] * math.sqrt(1e4 / 9.62))
    assert m["tau_ratio_max"] == pytest.approx(m["fei_d"] / m["tau_cr"])
    assert m["e_rel_ref"] > 0


@pytest.mark.parametrize("tau", [0.001, 0.007, 0.02])
def test_j1_within_one_sample(tau):
    """J1 (benchmark tracking delay) through compute_measures equals τ within one sample."""
    pytest.importorskip("rths3d.metrics.criteria")
    m = compute_measures(sdof_record(f=0.5, tau=tau))
    if "j1" not in m:
        pytest.skip("criteria module has no j_criteria")
    assert abs(m["j1"] - tau) <= DT
    assert "j4" in m and "j6" not in m  # J4/J5 need z^r (present); J6–J9 need floors


def test_ideal_record_all_tracking_zero():
    """z' = z in a record: all tracking errors < 1e-9 and E_error = 0."""
    t = np.arange(3000) * DT
    z = 0.01 * np.sin(2 * np.pi * 1.3 * t) + 0.002 * np.sin(2 * np.pi * 7 * t)
    rec = Record(t, {"z_cmd": z, "z_meas": z, "f_meas": 100 * z, "z_ref": z})
    m = compute_measures(rec)
    for k in ("e_rel_track", "e_mte_track", "e_peak_track", "e_rel_track_f", "fei_d",
              "e_error", "e_rel_ref", "e_mre_ref", "e_peak_ref", "e_rel_ref_f"):
        assert abs(m[k]) < 1e-9, k


def test_multi_dof_same_code_path(six_dof):
    """Each DOF of a 6-DOF record gets exactly what its 1-D signals give; aggregate documented."""
    m = compute_measures(six_dof)
    assert set(m) == {"dofs", "aggregate"}
    assert list(m["dofs"]) == list(DOFS)
    for j, d in enumerate(DOFS):
        z = six_dof.columns[f"z_cmd.{d}"]
        zp = six_dof.columns[f"z_meas.{d}"]
        assert m["dofs"][d]["e_rel_track"] == pytest.approx(e_rel_track(z, zp), rel=1e-12)
        assert m["dofs"][d]["fei_d"] == pytest.approx(fei(z, zp, DT).d, rel=1e-12)
        assert m["dofs"][d]["fei_d"] == pytest.approx(0.002 * (j + 1), rel=0.01)
    agg = m["aggregate"]
    assert agg["dominant_dof"] == "z"
    assert agg["fei_d"] == m["dofs"]["z"]["fei_d"]
    assert agg["e_error"] == pytest.approx(sum(m["dofs"][d]["e_error"] for d in DOFS))
    assert agg["hsem_s"] == pytest.approx(agg["e_error"] / agg["e_strain"])
    assert agg["omega_num"] == pytest.approx(200.0)
    for d in DOFS:
        assert m["dofs"][d]["e_rel_ref"] > 0


def test_feature_rows_table3(sdof, six_dof):
    """Feature sets have 15, 12 and 7 named entries; set 2 drops κ, τ_ratio,DYN, τ_ratio,max."""
    assert [len(FEATURE_SETS[i]) for i in (1, 2, 3)] == [15, 12, 7]
    assert set(FEATURE_SETS[1]) - set(FEATURE_SETS[2]) == {"kappa", "tau_ratio_dyn",
                                                          "tau_ratio_max"}
    row = feature_row(sdof, set=1)
    assert list(row) == list(FEATURE_SETS[1])
    assert all(math.isfinite(v) for v in row.values())
    m = compute_measures(sdof)
    assert row["e_rel_track"] == m["e_rel_track"] and row["hsem_s"] == m["hsem_s"]
    assert list(feature_row(six_dof, set=3)) == list(FEATURE_SETS[3])
    bare = Record(sdof.t, {k: v for k, v in sdof.columns.items()
                           if k in ("z_cmd.z", "z_meas.z")})
    assert math.isnan(feature_row(bare, set=2)["e_error"])  # no force: NaN, not guessed


def test_eei_from_record_states():
    """A record with numerical states x_num.0 and p_num.0 gets EEI ≈ HSEM^S (exact signals)."""
    n, f, tau, a = 3001, 1.0, 0.01, 0.97
    m_, c_, k_, ke = 9.62, 100.0, 1e4, 8650.0
    t = np.arange(n) * DT
    w = 2 * np.pi * f
    x = 0.005 * np.sin(w * t)
    zp = a * 0.005 * np.sin(w * (t - tau))
    fm = ke * zp
    p = -m_ * w * w * x + c_ * 0.005 * w * np.cos(w * t) + k_ * x + fm
    rec = Record(t, {"z_cmd": x, "z_meas": zp, "f_meas": fm, "x_num.0": x, "p_num.0": p},
                 {"numerical": {"M": [[m_]], "C": [[c_]], "K": [[k_]], "gamma": [[1.0]]},
                  "experiment": {"m_exp": 0.38, "k_exp": ke}})
    m = compute_measures(rec)
    assert m["eei"] == pytest.approx(m["hsem_s"], rel=0.01)


def run_cli(*args: str) -> subprocess.CompletedProcess:
    return run_in_process("metrics", *args)  # as python -m rths3d runs it, in this process


def test_cli_json_bare_csv_and_plots(tmp_path, sdof):
    """`rths3d metrics file.csv --json --plot DIR` on bare names: issue keys, three PNGs."""
    path = sdof.save(tmp_path / "rec.csv", bare=True)
    res = run_cli(str(path), "--json", "--plot", str(tmp_path / "plots"))
    assert res.returncode == 0, res.stderr
    data = json.loads(res.stdout)
    for k in ("e_rel_track", "e_mte_track", "e_peak_track", "e_rel_track_f", "ti",
              "theta_pc", "paei_phase", "paei_amp", "fei_A", "fei_phi", "fei_d", "f_eq",
              "e_error", "e_input", "hsem_s", "hsem_i", "e_rel_ref", "e_mre_ref",
              "e_peak_ref", "e_rel_ref_f"):
        assert isinstance(data[k], float), k
    assert data["fei_d"] == pytest.approx(0.012, rel=0.01)
    for name in ("ssp.png", "fei.png", "time.png"):
        png = tmp_path / "plots" / name
        assert png.stat().st_size > 10_000
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_cli_table_multi_dof_parquet(tmp_path, six_dof):
    """The readable table lists every DOF and the aggregate; JSON has dofs/aggregate."""
    path = six_dof.save(tmp_path / "six.parquet")
    res = run_cli(str(path), "--json")
    assert res.returncode == 0, res.stderr
    data = json.loads(res.stdout)
    assert set(data) == {"dofs", "aggregate"} and data["aggregate"]["dominant_dof"] == "z"
    res = run_cli(str(path))
    assert res.returncode == 0 and "e_rel_track" in res.stdout and "aggregate" in res.stdout


def test_cli_bad_record_one_line_exit_2(tmp_path):
    """A record with a NaN: one-line error naming the column, exit code 2, no traceback."""
    path = tmp_path / "bad.csv"
    path.write_text("t,z_cmd,z_meas\n" + "".join(
        f"{i * DT},{math.sin(i * 0.1)},{'nan' if i == 5 else math.sin(i * 0.1)}\n"
        for i in range(20)))
    res = run_cli(str(path))
    assert res.returncode == 2
    assert "z_meas" in res.stderr and "Traceback" not in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1


def test_dominant_dof_ignores_static_offset():
    """A DOF held at a static offset exchanges no interface power: the moving DOF dominates."""
    t = np.arange(4000) * DT
    x = 0.01 * np.sin(2 * np.pi * t)
    xp = 0.0095 * np.sin(2 * np.pi * (t - 0.01))
    zm = 0.02 + 2e-6 * np.random.default_rng(1).standard_normal(t.size)
    cols = {"z_cmd.x": x, "z_meas.x": xp, "f_meas.x": 8650.0 * xp,
            "z_cmd.z": np.full(t.size, 0.02), "z_meas.z": zm, "f_meas.z": 8650.0 * zm}
    agg = compute_measures(Record(t, cols, {}))["aggregate"]
    assert agg["dominant_dof"] == "x"
    assert agg["fei_d"] == pytest.approx(0.01, rel=1e-6)


_BAD_SYSTEM = [
    ({"experiment": {"m_exp": 0.0}}, "m_exp"),
    ({"experiment": {"k_exp": 0.0}}, "k_exp"),
    ({"experiment": {"k_exp": -8650.0}}, "k_exp"),
    ({"experiment": {"k_exp": "8650 N/m"}}, "k_exp"),
    ({"params": {"m_num": 0.0}}, "m_num"),
    ({"params": {"d_num": -100.0}}, "d_num"),
    ({"numerical": {"M": [[9.62, 0], [0, 1.0]], "C": [[100, 0], [0, 1]],
                    "K": [[2e4, -1e4], [-1e4, 1e4]], "gamma": [1, 0, 0]}}, "numerical.gamma"),
    ({"numerical": {"M": [[9.62, 0], [0, 0.0]], "C": [[100, 0], [0, 1]],
                    "K": [[2e4, -1e4], [-1e4, 1e4]], "gamma": [1, 0]}}, "M"),
]


@pytest.mark.parametrize("change,field", _BAD_SYSTEM)
def test_bad_system_parameters_raise_config_error(change, field):
    """Zero/negative/text experimental or numerical parameters raise ConfigError naming the
    field (no inf from a division, no reshape or LinAlgError traceback)."""
    meta = json.loads(json.dumps(SDOF_META))
    for group, values in change.items():
        meta.setdefault(group, {}).update(values)
    rec = sdof_record()
    rec = Record(rec.t, dict(rec.columns), meta)
    with pytest.raises(ConfigError, match=f"^{field}:"):
        compute_measures(rec)


def test_cli_bad_parameter_one_line_exit_2(tmp_path, sdof):
    """A phase margin given in degrees: one-line error saying rad, exit 2, no traceback."""
    meta = dict(sdof.meta, phase_margin=30.0, crossover=10.0)
    path = Record(sdof.t, dict(sdof.columns), meta).save(tmp_path / "deg.parquet")
    res = run_cli(str(path))
    assert res.returncode == 2 and "Traceback" not in res.stderr
    assert "rad, not degrees" in res.stderr and len(res.stderr.strip().splitlines()) == 1
