"""rths3d.kernels.layout: one compiled specialisation per structure of a range kernel's arguments,
whatever the layout and write flags of its array views, with the same results."""

import numba
import numpy as np
import pytest
from numba import types

from rths3d.effects.blocks import GainBlock
from rths3d.kernels import AnyLayout, kernel_type, padded_kernels, run_chain
from rths3d.platform.compiled import flat


@numba.njit
def _weighted(group, out, k):
    a, w = group
    s = 0.0
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            s += a[i, j] * w[j]
    out[k, 0] = s
    return s


def test_views_of_every_layout_share_one_specialisation_and_agree():
    rng = np.random.default_rng(3)
    base = rng.normal(size=(5, 8))
    w = rng.normal(size=8)
    out = np.zeros((4, 3))
    call = AnyLayout(_weighted)
    views = [base, base[:, :4], base[::2], np.broadcast_to(base[0], (5, 8)), base[:1, 2:6]]
    for k, a in enumerate(views[:4]):
        ww = w[: a.shape[1]]
        got = call((a, ww), out[:, 1:], k)  # a strided output view is written in place
        # the answer by hand, through another path
        want = float(sum(a[i, j] * ww[j] for i in range(a.shape[0]) for j in range(a.shape[1])))
        assert got == pytest.approx(want, rel=1e-12)
        assert out[k, 1] == pytest.approx(want, rel=1e-12)
    call((views[4], w[:4]), out, 0)
    assert len(_weighted.overloads) == 1


def test_groups_of_compiled_functions_keep_their_contiguous_arrays():
    g = GainBlock(1, 2, gain=2.0)
    fns, ps, ss = padded_kernels((type(g).kernel,), (g.params,), (g.state,))
    chain = (fns, ps, ss, np.zeros(2))
    t = kernel_type(numba.typeof((chain, np.zeros((3, 3)))))
    assert t.types[0] == numba.typeof(chain)  # as it is: its arrays go to compiled kernels
    assert t.types[1] == types.float64[:, :]  # elsewhere: any layout


def test_chains_pad_to_few_lengths_with_bit_exact_pass_through():
    blocks = [GainBlock(1, 3, gain=1.5), GainBlock(1, 3, gain=-0.25)]
    fns, ps, ss = padded_kernels(tuple(type(b).kernel for b in blocks),
                                 tuple(b.params for b in blocks), tuple(b.state for b in blocks))
    assert len(fns) == 4
    assert [len(padded_kernels(fns[:1] * n, ps[:1] * n, ss[:1] * n)[0]) for n in
            (1, 2, 3, 5, 9)] == [1, 4, 4, 8, 16]
    u = np.array([0.1, -2.0, 3.0])
    y = np.zeros(3)
    run_chain(fns, ps, ss, u, y, np.zeros(3))
    np.testing.assert_array_equal(y, u * 1.5 * -0.25)


def test_flat_views_contiguous_rows_and_refuses_strided_ones():
    @numba.njit
    def double_rows(a):
        r = flat(a)
        for i in range(r.shape[0]):
            r[i] *= 2.0

    a = np.arange(6.0).reshape(2, 3)
    double_rows(a)
    np.testing.assert_array_equal(a, np.arange(6.0).reshape(2, 3) * 2)
    with pytest.raises(ValueError, match="strided"):
        double_rows(np.zeros((2, 6))[:, :3])


def test_ready_compiles_a_kernel_once_when_threads_race_for_it():
    """Threads that build blocks at once (the diagnosis' replays) all get the one compiled
    kernel; none meets the closed dispatcher (compile() after disable_compile() raises)."""
    import threading

    from rths3d.kernels import BLOCK_SIG, block_kernel, ready

    def _scale(p, s, u, y, w):
        for r in range(u.shape[0]):
            y[r] = p[r, 0] * u[r]

    kernel = block_kernel(_scale)
    start = threading.Barrier(6)
    errors: list[BaseException] = []

    def build():
        start.wait()
        try:
            ready(kernel)
        except BaseException as e:  # noqa: BLE001 - the race's failure is what is counted
            errors.append(e)

    threads = [threading.Thread(target=build) for _ in range(6)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert errors == []
    assert kernel.signatures == [BLOCK_SIG.args]
    y = np.zeros(2)
    kernel(np.array([[2.0], [3.0]]), np.zeros((2, 0)), np.array([1.0, -1.0]), y, np.zeros(2))
    np.testing.assert_array_equal(y, [2.0, -3.0])
