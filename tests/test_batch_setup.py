"""The per-test set-up of a batch done once for the batch: the delay margins of one-DOF tests
computed for all tests together agree with the scalar function test by test, and the
metadata of a batch equals the metadata built test by test."""

from __future__ import annotations

import math

import numpy as np
import pytest

from rths3d.loop import run_batch
from rths3d.metadata import record_meta
from rths3d.numerical import LinearSubstructure, interface_delay_margin
from rths3d.numerical.modal import interface_delay_margins_1dof
from rths3d.scene import load_scene


def test_delay_margins_of_many_tests_equal_the_scalar_function() -> None:
    """Numerical mass, damping and stiffness over four decades, parts stiff and soft, damped
    and not: τ_cr, ω_c and PM of the batch equal :func:`interface_delay_margin`'s (1e-9
    relative), including the tests that no delay destabilises (τ_cr = inf)."""
    rng = np.random.default_rng(3)
    T = 60
    m = 10 ** rng.uniform(-0.5, 1.5, T)
    c = 10 ** rng.uniform(0, 3, T)
    k = 10 ** rng.uniform(2, 6, T)
    me = 10 ** rng.uniform(-1, 1, T)
    ce = np.where(rng.random(T) < 0.3, 0.0, 10 ** rng.uniform(0, 2, T))
    ke = 10 ** rng.uniform(3, 6, T)
    ke[:5] = 1.0  # a soft part under a heavy numerical mass: |μ| < 1 everywhere
    m[:5] = 1e3
    tau, wc, pm = interface_delay_margins_1dof(m, c, k, 1.0, me, ce, ke)
    finite = 0
    for i in range(T):
        want = interface_delay_margin([[m[i]]], [[c[i]]], [[k[i]]], [[1.0]], [[me[i]]],
                                      [[ce[i]]], [[ke[i]]])
        if math.isinf(want[0]):
            assert math.isinf(tau[i]) and math.isnan(wc[i]), i
            continue
        finite += 1
        np.testing.assert_allclose([tau[i], wc[i], pm[i]], want, rtol=1e-9, err_msg=str(i))
    assert 10 <= finite <= T - 5


def test_batch_metadata_equals_the_metadata_of_each_test() -> None:
    """A batch of the paper's contact test with its numerical stiffness varied: every
    record's metadata equals :func:`record_meta` of its test alone (the margins to 1e-9)."""
    sc = load_scene("paper_contact", ["duration=0.2"])
    sets = [{"numerical.k": v} for v in (250.0, 5e3, 2e5, 2e6)] + [{"experiment.m": 0.5}]
    res = run_batch(sc, sets, "lti", reference=False)
    from rths3d.scene import scene_with

    for r, ps in zip(res, sets, strict=True):
        s = scene_with(sc.with_transfer("lti"), ps)
        num = LinearSubstructure.from_scenes([s])
        want = record_meta(s, num, 0, r.record.meta["transfer_meta"])
        got = r.record.meta
        for key, v in want.items():
            if key in ("delay_margin", "crossover", "phase_margin"):
                assert got[key] == pytest.approx(v, rel=1e-9), key
            elif key not in ("status", "reason"):
                assert got[key] == v, key
        assert ("delay_margin" in got) == ("delay_margin" in want)


def test_a_big_batch_stepped_as_slices_on_threads_gives_the_records_of_one_group() -> None:
    """130 tests of the 1-D path (≥ 2 × SLICE_MIN: two slices, each built and stepped on its
    own thread) against the same tests as one group on one thread: every record equal bit
    for bit — with seeded sensor noise, a delay varied per test and tests the safety limits
    stop (an FTS range below the test's force) at different rows."""
    from rths3d.loop import SLICE_MIN

    sc = load_scene("paper_contact", ["duration=0.5", "transfer.kind='lti'",
                                      "sensor.noise_std=0.02", "effect.sensor_noise=1.0"])
    n = 2 * SLICE_MIN + 2
    sets = [{"numerical.k": 1e3 + 50.0 * i, "transfer.delay": 1e-3 * (i % 3),
             "sensor.seed": i} for i in range(n)]
    for i, limit in ((5, 0.05), (70, 0.1), (129, 0.2)):  # N: the force limit stops them
        sets[i] = {**sets[i], "safety.force": limit}
    one = run_batch(sc, sets, reference=False, nthread=1, max_k=n)
    two = run_batch(sc, sets, reference=False, nthread=2, max_k=n)
    stopped = [i for i, r in enumerate(one) if r.status == "stopped"]
    assert stopped == [5, 70, 129], stopped
    assert len({len(one[i].record.t) for i in stopped}) == 3  # at three different rows
    noisy = one[0].record.columns["f_meas.z"]
    assert np.std(np.diff(noisy[:50])) > 0  # the noise is in the record
    for i, (a, b) in enumerate(zip(one, two, strict=True)):
        assert (a.status, a.reason) == (b.status, b.reason), i
        assert a.record.columns.keys() == b.record.columns.keys()
        np.testing.assert_array_equal(a.record.t, b.record.t, err_msg=str(i))
        for c, v in a.record.columns.items():
            np.testing.assert_array_equal(v, b.record.columns[c], err_msg=f"{i} {c}")
    # the two slices ran the same compiled path as one group
    assert {r.record.meta["loop"] for r in one + two} == {"compiled"}
