"""A new transfer system and a new experimental part, defined here and registered, run a batch
of eight tests with the reference through the loop and the metrics; nothing else is edited.

The part is a massless spring on the FTS (F_m = k_p z'); the transfer system is a first-order
actuator lag (time constant ``transfer.timeconst``) through a block of its own. The coupled
system is then M ẍ + C ẋ + (K + k_p) x = p, whose response scipy computes independently; the
reference z^r must match it, and without lag the hybrid test must stay close to it.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pytest
import scipy.signal

import rths3d
from rths3d.config import ExperimentConfig
from rths3d.experiment import PARTS, ExperimentalPart, register_part
from rths3d.kernels import Block, Chain, block_kernel
from rths3d.scene import scene_from_dict
from rths3d.transfer import TRANSFERS, ChainTransfer, register_transfer


@block_kernel
def _spring_kernel(p, s, z0, z1, f):
    for r in range(z1.shape[0]):
        f[r] = p[r, 0] * z1[r]


class SpringModel:
    """K massless springs: F = k z at the end of the step (no state)."""

    n_if = 1
    tolerance = 1e-11

    def __init__(self, k: np.ndarray):
        self.K = len(k)
        self.params = np.ascontiguousarray(np.asarray(k, float)[:, None])
        self.state = np.zeros((self.K, 0))
        self.f = np.zeros((self.K, 1))

    def reset(self) -> None:
        self.f[:] = 0.0

    def advance(self, z0: np.ndarray, z1: np.ndarray) -> np.ndarray:
        _spring_kernel(self.params, self.state, np.ascontiguousarray(z0[:, 0]),
                       np.ascontiguousarray(z1[:, 0]), self.f[:, 0])
        return self.f

    def get_state(self) -> np.ndarray:
        return self.state.copy()

    def set_state(self, s: np.ndarray) -> None:
        pass

    def compiled(self):
        return _spring_kernel, self.params, self.state


class SpringPart(ExperimentalPart):
    """A massless spring of stiffness ``experiment.k`` (N/m) on the FTS."""

    kind = "test_spring"

    def payload_xml(self) -> str:
        return ""  # no MuJoCo body: a numpy-only part

    def interface_matrices(self):
        return [[self.cfg.k]], [[1e-9]]

    @classmethod
    def numpy_model(cls, cfgs: Sequence[ExperimentConfig], dt: float, *, substeps: int,
                    method: str) -> SpringModel:
        return SpringModel(np.array([c.k for c in cfgs]))


@block_kernel
def _lag_kernel(p, s, u, y, w):
    # backward-Euler lag: y_{n+1} = y_n + a (u − y_n), a = ΔT / (τ + ΔT)
    for r in range(u.shape[0]):
        s[r, 0] += p[r, 0] * (u[r] - s[r, 0])
        y[r] = s[r, 0]


class BackwardLag(Block):
    """First-order lag per row (τ = 0: y = u)."""

    kernel = _lag_kernel

    def __init__(self, K: int, n: int, tau: Sequence[float], dt: float):
        a = np.array([dt / (t + dt) for t in tau])
        super().__init__(K, n, np.repeat(a, n)[:, None], np.zeros((K * n, 1)))


class LagTransfer(ChainTransfer):
    """An actuator with a first-order lag of ``transfer.timeconst`` (s), per test."""

    kind = "test_lag"

    @classmethod
    def actuator_chain(cls, scenes, n):
        tau = [s.transfer.timeconst for s in scenes]
        return Chain(len(scenes), n, [BackwardLag(len(scenes), n, tau, scenes[0].dt)]), \
            [{"lag": x} for x in tau]


@pytest.fixture
def registered():
    register_part(SpringPart)
    register_transfer(LagTransfer)
    yield
    PARTS.pop(SpringPart.kind)
    TRANSFERS.pop(LagTransfer.kind)


def _scene():
    return scene_from_dict({
        "name": "spring", "dofs": ["z"], "dt": 1e-3, "duration": 2.0,
        "numerical": {"m": 10.0, "c": 40.0, "k": 2.0e4},
        "excitation": {"kind": "force", "signal": "sine", "amplitude": 50.0, "frequency": 3.0},
        "experiment": {"kind": "test_spring", "k": 5.0e3},
        "transfer": {"kind": "test_lag"},
        "safety": {"force": 1e4},
    })


def test_new_transfer_and_part_run_a_batch_with_reference_and_metrics(registered):
    """Eight tests of a test-defined transfer system and part run in one compiled batch; the
    reference equals scipy's solution of the coupled linear system, no lag tracks it, and
    the metrics see the error grow with the lag."""
    sc = _scene()
    sets = [{"numerical.k": 2.0e4 + 2.0e3 * (i // 4), "transfer.timeconst": 0.002 * (i % 4)}
            for i in range(8)]
    results = rths3d.run_batch(sc, sets)
    assert len(results) == 8 and all(r.status == "ok" for r in results)
    t = results[0].record.t
    p = 50.0 * np.sin(2 * np.pi * 3.0 * t)
    errs = []
    for ps, res in zip(sets, results, strict=True):
        rec = res.record
        assert rec.meta["loop"] == "compiled"
        k_num = ps["numerical.k"]
        sys = scipy.signal.lti([[0, 1], [-(k_num + 5e3) / 10.0, -4.0]], [[0], [0.1]],
                               [[1, 0]], [[0]])
        _, z_exact, _ = scipy.signal.lsim(sys, p, t, interp=True)
        zr = rec.columns["z_ref.z"]
        # the reference holds F'_m linear over a step: second order in ΔT, (ω ΔT)²/12 ≈ 2e-4
        assert np.max(np.abs(zr - z_exact)) < 5e-4 * np.max(np.abs(z_exact))
        m = rths3d.compute_measures(rec)
        assert np.isfinite(m["e_rel_ref"]) and np.isfinite(m["e_rel_track"])
        errs.append(m["e_rel_ref"])
        assert rec.meta["transfer_meta"]["lag"] == ps["transfer.timeconst"]
        if ps["transfer.timeconst"] == 0.0:
            # no lag: only the partitioned exchange's first-order error is left
            assert m["e_rel_ref"] < 0.05
    # within each stiffness, a longer lag gives a larger reference error
    for first in (0, 4):
        assert all(np.diff(errs[first:first + 4]) > 0), errs
