"""The surrogate estimate on contact systems it never saw, and an uncertainty that covers the
truth.

Ground truth never comes from the code under test: the records are made by the closed vRTHS
loop (`rths3d.loop.run_batch`, the numpy contact specimen with its own substeps, the 1-D LTI
transfer system with delays of 1–12 ms) and the true e_rel,ref by the reference solution in
each record (RK4 part, interface iteration). The tests' parameters are drawn here (a seed
per family), like the sweep families `contact` and `contact_force` of
`scenes/sweeps/families_xl.toml`, and a 2-DOF chain written here (a contact part at its upper
mass, a ground acceleration of twelve sines under an envelope). A small sample of each keeps
the suite short; `examples/47_surrogate_contact.py` scores whole families (docs/surrogate.md).

For every family: ρ (eq. 15) between the estimate and the truth ≥ 0.9 over the stable tests,
no NaN, the truth inside the reported band or the test flagged in ≥ 90 % of the tests, and
no test whose truth exceeds three times its estimate without a flag.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rths3d.loop import run_batch
from rths3d.metrics import compute_measures
from rths3d.metrics.fidelity import surrogate_measures
from rths3d.record import Record
from rths3d.scene import load_scene
from rths3d.surrogate import surrogate_reference

REPO = Path(__file__).resolve().parents[1]
DELAYS = (1e-3, 2e-3, 4e-3, 8e-3, 12e-3)  # s


def _lu(r: np.random.Generator, a: float, b: float) -> float:
    return float(np.exp(r.uniform(np.log(a), np.log(b))))


def _transfer(r: np.random.Generator) -> dict:
    return {"transfer.delay": float(r.choice(DELAYS)),
            "transfer.compensation": str(r.choice(["none", "velocity"])),
            "transfer.velocity_ff": bool(r.choice([True, False])),
            "transfer.timeconst": float(r.choice([0.0, 3e-3, 6e-3])),
            "transfer.comp_time": 4e-3}


def _part(r: np.random.Generator) -> dict:
    # kg, N/m, m: the paper_contact specimen over the sweeps' ranges
    return {"experiment.m": r.uniform(0.2, 0.6), "experiment.k": _lu(r, 4e3, 2e4),
            "experiment.h0": r.uniform(0.002, 0.01)}


def _contact(r):   # support motion (the paper's raised cosine) under the numerical mass
    return {"numerical.m": _lu(r, 4, 25), "numerical.k": _lu(r, 250, 2e6),
            "numerical.c": _lu(r, 40, 500), "excitation.frequency": r.uniform(0.25, 1.0),
            "excitation.overtravel": r.uniform(0.003, 0.009), **_part(r), **_transfer(r)}


def _contact_force(r):   # a sine force on the numerical mass
    return {"excitation.kind": "force", "excitation.signal": "sine",
            "numerical.m": _lu(r, 4, 25), "numerical.k": _lu(r, 2e3, 5e4),
            "numerical.c": _lu(r, 40, 300), "excitation.amplitude": r.uniform(10, 80),
            "excitation.frequency": r.uniform(0.3, 2.0), **_part(r), **_transfer(r)}


def ground_motion(r: np.random.Generator, duration: float, dt: float = 0.005
                  ) -> tuple[list[float], list[float]]:
    """A ground acceleration (normalised to peak 1; the scene's scale gives m/s²): twelve
    sines of 0.5–6 Hz, ramped in over 1 s and out over the last second."""
    t = np.arange(0.0, duration + dt, dt)
    f = np.exp(r.uniform(np.log(0.5), np.log(6.0), 12))
    a = r.uniform(0.5, 1.0, 12) / np.sqrt(f)
    ph = r.uniform(0, 2 * np.pi, 12)
    u = (a[:, None] * np.sin(2 * np.pi * f[:, None] * t + ph[:, None])).sum(0)
    u *= np.minimum(1.0, t / 1.0) * np.minimum(1.0, (duration - t) / 1.0 + 0.2)
    return t.tolist(), (u / np.max(np.abs(u))).tolist()


def chain(r: np.random.Generator, duration: float) -> dict:
    """A 2-DOF chain (ground – k1 – m1 – k2 – m2) with the contact part at m2 (Γ = [0, 1]ᵀ)
    under a ground acceleration of peak 0.5–6 m/s²."""
    m1, m2 = _lu(r, 5, 30), _lu(r, 2, 15)            # kg
    k1, k2 = _lu(r, 2e3, 1e5), _lu(r, 2e3, 5e4)      # N/m
    c1, c2 = _lu(r, 20, 300), _lu(r, 10, 200)        # N·s/m
    tt, vv = ground_motion(r, duration)
    return {"numerical.M": [[m1, 0.0], [0.0, m2]],
            "numerical.C": [[c1 + c2, -c2], [-c2, c2]],
            "numerical.K": [[k1 + k2, -k2], [-k2, k2]], "numerical.gamma": [[0.0], [1.0]],
            "excitation.kind": "ground", "excitation.signal": "array",
            "excitation.times": tt, "excitation.values": vv,
            "excitation.scale": _lu(r, 0.5, 6.0), **_part(r), **_transfer(r)}


def family_records(name: str, n: int, seed: int, duration: float = 8.0) -> list[Record]:
    """The stable tests (status ok) of ``n`` drawn from family ``name``, with z^r."""
    r = np.random.default_rng(seed)
    draw = {"contact": _contact, "contact_force": _contact_force}.get(name)
    params = [chain(r, duration) if draw is None else draw(r) for _ in range(n)]
    scene = load_scene(REPO / "scenes" / "paper_contact.toml", [f"duration={duration}"])
    return [res.record for res in run_batch(scene, params) if res.status == "ok"]


def scores(truth: list[float], est: list[dict]) -> dict[str, float]:
    """The Must-show figures of the surrogate estimates ``est`` (of
    :func:`~rths3d.metrics.fidelity.surrogate_measures`) against the true e_rel,ref."""
    truth = np.asarray(truth, dtype=float)
    e = np.array([x["e_rel_ref_hat"] for x in est])
    lo = np.array([x["e_rel_ref_hat_lo"] for x in est])
    hi = np.array([x["e_rel_ref_hat_hi"] for x in est])
    flag = np.array([x["surrogate_flag"] for x in est]) > 0
    inside = (truth >= lo) & (truth <= hi)
    return {"n": len(truth), "nan": int(np.sum(~np.isfinite(e) & ~flag)),
            "rho": float(np.corrcoef(e, truth)[0, 1]),
            "rho_log10": float(np.corrcoef(np.log10(e), np.log10(truth))[0, 1]),
            "covered": float(np.mean(inside | flag)), "flagged": float(np.mean(flag)),
            "under3": int(np.sum((truth > 3 * e) & ~flag)),
            "spread": float(truth.max() / truth.min())}


@pytest.mark.slow  # a family of tests identified one by one
@pytest.mark.parametrize("family, n, seed", [("contact", 10, 3), ("contact_force", 10, 5),
                                             ("chain", 14, 7)])
def test_never_seen_contact_family(family: str, n: int, seed: int) -> None:
    recs = family_records(family, n, seed)
    s = scores([compute_measures(r)["e_rel_ref"] for r in recs], surrogate_measures(recs))
    assert s["n"] >= 6, s                 # enough stable tests to rank
    assert s["spread"] > 3.0, s          # errors that differ, so that ρ means something
    assert s["nan"] == 0, s
    assert s["rho"] >= 0.9, s
    assert s["covered"] >= 0.9, s
    assert s["under3"] == 0, s


def test_a_force_the_part_does_not_explain_is_flagged_with_its_reason() -> None:
    """F'_m replaced by a signal unrelated to z' (noise written here): no part model explains
    it, the estimate is flagged unreliable and says why — it is not silently trusted."""
    rec = family_records("contact", 1, 3, duration=4.0)[0]
    rng = np.random.default_rng(1)
    cols = dict(rec.columns)
    cols["f_meas.z"] = 50.0 * rng.standard_normal(rec.n)   # N
    bad = Record(rec.t, cols, rec.meta)
    _, e = surrogate_reference(bad, columns=False)
    assert e["status"] in ("unreliable", "failed")
    assert not e["reliable"]
    assert "F'_m" in e["reason"] or "diverged" in e["reason"]
    flat = surrogate_measures(bad)
    assert flat["surrogate_flag"] == 1.0
    assert flat["surrogate_reason"].startswith(e["status"])


def test_band_contains_the_estimate_and_a_faithful_fit_is_reliable() -> None:
    """A contact test the classes describe: reliable, and lo ≤ ê ≤ hi with a band no wider
    than the members' range and the widening (5 % plus the held-out error) allow."""
    rec = family_records("contact", 1, 3, duration=6.0)[0]
    _, e = surrogate_reference(rec, columns=False)
    assert e["status"] == "ok" and e["reliable"] and e["reason"] == ""
    assert e["e_rel_ref_lo"] <= e["e_rel_ref"] <= e["e_rel_ref_hi"]
    u = 0.05 + e["validation"]
    m = np.array(e["e_rel_ref_members"])
    assert e["e_rel_ref_hi"] == pytest.approx(m.max() * (1 + u))
    assert e["e_rel_ref_lo"] == pytest.approx(m.min() / (1 + u))
