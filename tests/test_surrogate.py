"""The surrogate reference: a part identified from a test's own record, coupled exactly.

Ground truth never comes from the code under test: records are made by the closed vRTHS loop
(`rths3d.loop.run`, numpy specimen integrated with its own Euler substeps, the LTI transfer
system) and the true reference z^r by `rths3d.reference.reference_solution` (RK4 part,
interface iteration); part data for the model classes come from the specimen advanced
directly, driven by signals written here.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import numpy as np
import pytest
from cli_cases import run_in_process

from rths3d.experiment.specimen import Specimen1D
from rths3d.loop import run, scene_with
from rths3d.metrics import compute_measures, e_rel_ref, feature_row
from rths3d.record import Record
from rths3d.scene import load_scene
from rths3d.surrogate import (
    ARX,
    RunningRMS,
    SurrogateReference,
    SwitchedARX,
    running_rms,
    surrogate_reference,
)

REPO = Path(__file__).resolve().parents[1]


def _record(scene: str, **overrides) -> Record:
    s = scene_with(load_scene(REPO / "scenes" / f"{scene}.toml"),
                   {"duration": 4.0, **overrides})
    res = run(s)
    assert res.status == "ok", res.reason
    return res.record


@pytest.fixture(scope="module")
def linear_record() -> Record:
    # Table-2 system (d_EXP 5 N·s/m), 4 ms actuator delay
    return _record("paper_linear", **{"transfer.delay": 4e-3})


@pytest.fixture(scope="module")
def contact_record() -> Record:
    # three contact cycles (0.5 Hz): two would leave each held-out block a lone event
    return _record("paper_contact", **{"transfer.delay": 6e-3, "duration": 6.0})


def _drive(n: int, dt: float, seed: int = 0) -> np.ndarray:
    """A mount motion written here: two sines and a slow sweep (m)."""
    t = np.arange(n) * dt
    rng = np.random.default_rng(seed)
    ph = rng.uniform(0, 2 * np.pi, 3)
    return (0.004 * np.sin(2 * np.pi * 0.7 * t + ph[0]) + 0.002 * np.sin(2 * np.pi * 3.1 * t + ph[1])
            + 0.001 * np.sin(2 * np.pi * (0.2 + 0.5 * t / t[-1]) * t + ph[2]))


def _specimen_force(z: np.ndarray, dt: float, h0: float = np.inf) -> np.ndarray:
    """F'_m of the numpy specimen (0.4 kg on 8000 N/m, 3 N·s/m) driven along z."""
    sp = Specimen1D(1, 0.4, 8000.0, 3.0, h0, 1e5, 40.0, dt=dt, substeps=4)
    f = np.zeros(len(z))
    for i in range(1, len(z)):
        f[i] = sp.advance(np.array([[z[i - 1]]]), np.array([[z[i]]]))[0, 0]
    return f


def test_arx_is_exact_for_a_linear_part_driven_directly() -> None:
    """A linear mass–spring–damper driven through its mount is ARX(4, 2): the fitted model run
    freely reproduces the specimen's force to round-off, also on a drive it never saw."""
    dt = 1e-3
    z = _drive(4000, dt)
    f = _specimen_force(z, dt)
    m = ARX(4, 2).fit(z, f)
    assert m.residual_ < 1e-9
    z2 = _drive(3000, dt, seed=5)
    f2 = _specimen_force(z2, dt)
    sim = m.predict(z2, f2)
    assert np.max(np.abs(sim[:, 0] - f2[3:])) < 1e-6 * np.max(np.abs(f2))


def test_switched_arx_finds_the_contact_gap() -> None:
    """The search finds a contact's gap h0 (m) from z' and F'_m alone, and the switched model
    runs freely within 2 % of the specimen's force where the linear one cannot."""
    dt = 1e-3
    z = 2.5 * _drive(6000, dt, seed=2)
    h0 = 0.006
    f = _specimen_force(z, dt, h0)
    m = SwitchedARX(4, 2).fit(z, f)
    sw = m.switch_
    # w = a (z − (c/a) F) − h: the gap is h/a in metres
    assert sw.h / sw.a[0] == pytest.approx(h0, rel=0.05)
    assert m.simulation_error(z, f) < 0.02
    assert ARX(4, 2).fit(z, f).simulation_error(z, f) > 5 * m.simulation_error(z, f)


def test_known_answer_part_in_the_model_class(linear_record) -> None:
    """Closed-loop record of a linear part (exactly in the ARX class): ê_rel,ref within 2 % of
    e_rel,ref from the reference solution, and ẑ^r within 1 % of z^r at every sample."""
    e_true = compute_measures(linear_record)["e_rel_ref"]
    est = SurrogateReference().fit(linear_record)
    assert e_true > 5e-3  # a real error to recover
    assert est.estimates_["e_rel_ref"] == pytest.approx(e_true, rel=0.02)
    zr = linear_record.signal("z_ref")
    assert np.max(np.abs(est.z_ref_ - zr)) < 0.01 * np.max(np.abs(zr))
    assert est.estimates_["e_rel_ref_std"] < 0.02 * e_true


def test_ideal_transfer_record_gives_about_zero() -> None:
    """With the ideal transfer system the only error is the loop's partitioned exchange:
    ê_rel,ref ≈ e_rel,ref ≈ 0 (both below 1e-3, and within 10 % of each other)."""
    rec = _record("paper_linear", **{"transfer.kind": "ideal"})
    e_true = compute_measures(rec)["e_rel_ref"]
    e_hat = SurrogateReference().fit(rec).estimates_["e_rel_ref"]
    assert e_true < 1e-3 and e_hat < 1e-3
    assert e_hat == pytest.approx(e_true, rel=0.1)


def test_contact_record_every_step(contact_record) -> None:
    """Contact part (two regimes) through the closed loop: ê_rel,ref within 5 %, and the
    running RMS of ê (0.25 s) follows the true running RMS of z' − z^r (ρ ≥ 0.95)."""
    rec, e = surrogate_reference(contact_record)
    e_true = compute_measures(contact_record)["e_rel_ref"]
    assert e["model"].startswith("switched")
    assert e["e_rel_ref"] == pytest.approx(e_true, rel=0.05)
    zp, zr = contact_record.signal("z_meas"), contact_record.signal("z_ref")
    true_rms = running_rms(zp - zr, rec.dt)[:, 0]
    rho = np.corrcoef(true_rms, rec.columns["e_hat_rms.z"])[0, 1]
    assert rho >= 0.95
    lo, hi = rec.columns["e_hat_rms_lo.z"], rec.columns["e_hat_rms_hi.z"]
    assert np.all(lo <= rec.columns["e_hat_rms.z"] + 1e-15)
    assert np.all(hi >= rec.columns["e_hat_rms.z"] - 1e-15)
    # ê over the whole record is e_rel,ref's numerator: RMS(ê)/RMS(ẑ^r)
    eh = rec.columns["e_hat.z"]
    assert np.sqrt(np.mean(eh**2)) / np.sqrt(np.mean(rec.columns["z_ref_hat.z"] ** 2)) \
        == pytest.approx(e["e_rel_ref"], rel=1e-9)
    assert e_rel_ref(rec.columns["z_ref_hat.z"], zp[:, 0]) == pytest.approx(e["e_rel_ref"])


def test_per_step_columns_survive_save_and_load(contact_record, tmp_path) -> None:
    rec, e = surrogate_reference(contact_record)
    path = rec.save(tmp_path / "est.parquet")
    back = Record.load(path)
    for col in ("z_ref_hat.z", "e_hat.z", "e_hat_rms.z"):
        np.testing.assert_array_equal(back.columns[col], rec.columns[col])
    assert back.meta["surrogate"]["e_rel_ref"] == pytest.approx(e["e_rel_ref"])
    assert back.meta["surrogate"]["window"] == 0.25


def test_running_rms_online_equals_offline_and_knows_a_sine() -> None:
    """RunningRMS.update, one sample at a time, equals running_rms of the whole signal; over
    whole periods of a sine of amplitude A the running RMS is A/√2."""
    dt = 1e-3
    t = np.arange(3000) * dt
    e = np.column_stack([0.003 * np.sin(2 * np.pi * 8.0 * t), 1e-4 * np.cos(2 * np.pi * 4 * t)])
    mon = RunningRMS(2, 250)
    online = np.array([mon.update(x).copy() for x in e])
    np.testing.assert_allclose(online, running_rms(e, dt), rtol=1e-10, atol=1e-18)
    # 0.25 s = two whole periods of 8 Hz and one of 4 Hz
    np.testing.assert_allclose(online[1000:, 0], 0.003 / np.sqrt(2), rtol=1e-9)
    np.testing.assert_allclose(online[1000:, 1], 1e-4 / np.sqrt(2), rtol=1e-9)
    with pytest.raises(ValueError):
        mon.value[0] = 1.0  # a read-only view


def test_running_rms_update_allocates_no_arrays(peak_bytes) -> None:
    """Per sample nothing the size of the window (2 kB here) or of a sample's array: the
    update works in its preallocated buffers (the bound covers the call machinery)."""
    mon = RunningRMS(1, 250)
    x = np.array([1e-4])
    mon.update(x)
    assert peak_bytes(lambda: mon.update(x), n=200) < 1024


def test_metrics_reports_the_estimate(contact_record) -> None:
    """compute_measures(surrogate=True) adds the estimate; a feature row may ask for it."""
    m = compute_measures(contact_record, surrogate=True)
    assert m["e_rel_ref_hat"] == pytest.approx(m["e_rel_ref"], rel=0.05)
    assert m["surrogate_validation"] < 0.1 and m["surrogate_members"] >= 2
    row = feature_row(contact_record, ["e_rel_track", "e_rel_ref_hat", "e_rel_ref_hat_std"])
    assert list(row) == ["e_rel_track", "e_rel_ref_hat", "e_rel_ref_hat_std"]
    assert row["e_rel_ref_hat"] == pytest.approx(m["e_rel_ref_hat"])
    # without the numerical substructure the estimate is left out, never guessed
    bare = Record(contact_record.t, dict(contact_record.columns), {})
    assert "e_rel_ref_hat" not in compute_measures(bare, surrogate=True)


def _cli(*args: str) -> subprocess.CompletedProcess:
    return run_in_process(*args)  # as python -m rths3d runs it, in this process


def test_cli_metrics_estimate_and_plot(contact_record, tmp_path) -> None:
    path = contact_record.save(tmp_path / "rec.parquet")
    p = _cli("metrics", str(path), "--json", "--plot", str(tmp_path / "plots"),
             "--save-estimate", str(tmp_path / "est.parquet"))
    assert p.returncode == 0, p.stderr
    res = json.loads(p.stdout)
    assert res["e_rel_ref_hat"] == pytest.approx(res["e_rel_ref"], rel=0.05)
    assert (tmp_path / "plots" / "fidelity.png").stat().st_size > 10_000
    assert "e_hat_rms.z" in Record.load(tmp_path / "est.parquet").columns
    # a record without the numerical model: one error line naming the option, exit 2
    bare = Record(contact_record.t, {k: v for k, v in contact_record.columns.items()
                                     if not k.startswith("p_num")}, {})
    bp = bare.save(tmp_path / "bare.parquet")
    q = _cli("metrics", str(bp), "--save-estimate", str(tmp_path / "x.parquet"))
    assert q.returncode == 2 and "--save-estimate" in q.stderr
    assert "Traceback" not in q.stderr


def test_online_reference_equals_the_exact_coupling(contact_record, peak_bytes) -> None:
    """OnlineReference and the estimator's batch coupling, one closed-form step per sample,
    reach the same ẑ^r as the interface iteration of couple_exact (to its tolerance), and
    the online running RMS equals the offline one; a step allocates no arrays."""
    from rths3d.numerical import LinearSubstructure
    from rths3d.reference import couple_exact
    from rths3d.surrogate import LagPart, OnlineReference, identify
    from rths3d.surrogate.estimator import couple_members, numerical_of

    z, f = contact_record.signal("z_meas"), contact_record.signal("f_meas")
    model = identify(z, f).model
    M, C, K, G, p = numerical_of(contact_record)
    # the reference solution's interface iteration, with the identified part
    batch = couple_exact(LinearSubstructure(M, C, K, G, p, contact_record.dt, "exact"),
                         LagPart([model]), contact_record.n - 1, tol=1e-12)["z_ref"][0]
    # the estimator's closed-form coupling reaches the same fixed point
    np.testing.assert_allclose(couple_members([contact_record], [[model]])[0][0], batch,
                               rtol=0, atol=1e-7 * np.max(np.abs(batch)))
    on = OnlineReference(LinearSubstructure(M, C, K, G, p, contact_record.dt, "exact"),
                         [model], 250)
    zo, rms = np.zeros_like(z), np.zeros_like(z)
    for n in range(contact_record.n - 1):
        rms[n + 1] = on.update(n, z[n + 1][None])[0]
        zo[n + 1] = on.z_ref[0]
    assert np.max(np.abs(zo - batch)) < 1e-7 * np.max(np.abs(batch))
    # the online window starts at sample 1 (sample 0 is the rest state, ê = 0)
    np.testing.assert_allclose(rms[1:], running_rms(z[1:] - zo[1:], contact_record.dt),
                               rtol=1e-9, atol=1e-15)
    # the monitor's block update: the same running RMS, its peak and first crossing
    blk = OnlineReference(LinearSubstructure(M, C, K, G, p, contact_record.dt, "exact"),
                          [model], 250)
    peak, lim = np.zeros((1, 1)), np.full((1, 1), 0.5 * rms.max())
    first, fdof, fval = np.full(1, -1), np.zeros(1, dtype=np.int64), np.zeros(1)
    n_half = contact_record.n // 2
    for a, b in ((0, n_half), (n_half, contact_record.n - 1)):
        blk.update_block(a, b, np.ascontiguousarray(z[a + 1:b + 1, None, :]), 1, peak, lim,
                         first, fdof, fval)
    np.testing.assert_allclose(blk.value[0], rms[-1], rtol=1e-12)
    assert peak[0, 0] == pytest.approx(rms.max(), rel=1e-12)
    assert first[0] == int(np.argmax(rms[:, 0] > lim[0, 0]))
    zn = z[5][None].copy()
    assert peak_bytes(lambda: on.update(5, zn), n=200) < 4096  # the call machinery only


SWEEP = """
[sweep]
name = "est"
duration = 3.0
seed = 3
batch_size = 8

[[family]]
name = "linear"
scene = "{scenes}/paper_linear.toml"
transfer = "lti"
[family.grid]
"numerical.k" = [5.0e3, 2.0e4]
"transfer.delay" = [1e-3, 4e-3]
"""


def test_every_sweep_row_carries_the_estimate(tmp_path) -> None:
    """A sweep's table has the surrogate inputs as features beside Table 3 (and the other
    estimates as measures), within 2 % of e_rel,ref for a linear part; a physics-informed
    feature list reads them."""
    from rths3d.dataset import load_spec, run_sweep, training_data
    from rths3d.dataset.table import parse_features
    from rths3d.metrics.features import SET_1, SURROGATE

    spec = tmp_path / "est.toml"
    spec.write_text(SWEEP.format(scenes=REPO / "scenes"))
    table = run_sweep(load_spec(spec), tmp_path / "out", workers=1, progress=False)
    ok = table[table["status"] == "ok"]
    assert len(ok) == 4
    np.testing.assert_allclose(ok["feature.e_rel_ref_hat"], ok["target.e_rel_ref"], rtol=0.02)
    for col in ("feature.e_rel_ref_hat_std", "feature.surrogate_validation",
                "measure.e_mre_ref_hat", "measure.surrogate_members",
                "measure.e_rel_ref_hat_lo", "measure.e_rel_ref_hat_hi"):
        assert np.isfinite(ok[col]).all(), col
    # the band holds the estimate and, for a part in the class, the truth; none is flagged
    assert (ok["measure.e_rel_ref_hat_lo"] <= ok["feature.e_rel_ref_hat"]).all()
    assert (ok["measure.e_rel_ref_hat_hi"] >= ok["feature.e_rel_ref_hat"]).all()
    assert ((ok["measure.e_rel_ref_hat_lo"] <= ok["target.e_rel_ref"])
            & (ok["target.e_rel_ref"] <= ok["measure.e_rel_ref_hat_hi"])).all()
    assert (ok["measure.surrogate_flag"] == 0).all()
    assert (ok["measure.surrogate_reason"] == "ok").all()
    names = parse_features("1,surrogate")
    assert names == tuple(SET_1) + tuple(SURROGATE)
    X, y, _ = training_data(table, names)
    assert list(X.columns) == list(names) and len(y) == 4


def test_the_lowest_orders_a_config_allows_validate_too() -> None:
    """ARX(1, 0), the lowest orders SurrogateConfig accepts, on a static spring F = k z
    written here: it validates (held-out error at the noise level) and finds k."""
    from rths3d.surrogate import ARX

    rng = np.random.default_rng(0)
    z = rng.normal(0.0, 1e-3, (2000, 1))
    f = 8650.0 * z + rng.normal(0.0, 1e-3, (2000, 1))
    m = ARX(1, 0).fit(z, f)
    assert m.validate(z, f) < 1e-3
    np.testing.assert_allclose(m.predict(z, f), 8650.0 * z[1:], rtol=0, atol=1e-2)
