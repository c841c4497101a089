"""Learning curves of the fidelity ANN on synthetic data with a known noise floor."""

from __future__ import annotations

import numpy as np
import pytest

from rths3d.ann import LearningPoint, learning_curve
from rths3d.ann.plots import save_learning_curve
from rths3d.errors import ConfigError

NOISE = 0.03  # decades: the irreducible log10 scatter of the synthetic targets


def power_law_data(n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """e = 10^(x0 + 0.5 sin 3x1) · 10^N(0, NOISE), x uniform in [-1, 1] (x2 pure noise)."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1.0, 1.0, (n, 3))
    log_e = x[:, 0] + 0.5 * np.sin(3.0 * x[:, 1]) + rng.normal(0.0, NOISE, n)
    return x, 10.0 ** (log_e - 2.0)


@pytest.fixture(scope="module")
def curve() -> list[LearningPoint]:
    x, y = power_law_data(1400)
    return learning_curve(x, y, [40, 200, 1000], n_test=400, n_trainings=2,
                          topologies=[(8,)], seed=0)


def test_residual_falls_to_the_noise_floor(curve) -> None:
    """More training tests lower the test residual, down to the data's own log scatter."""
    res = [p.log_residual_test for p in curve]
    assert res[-1] < res[0]
    assert 0.8 * NOISE < res[-1] < 1.5 * NOISE
    assert curve[-1].r_test_ensemble > curve[0].r_test_ensemble


def test_sizes_split_into_training_and_validation(curve) -> None:
    """Each size is training + 15 % validation samples, with the chosen topology reported."""
    assert [p.n_train + p.n_val for p in curve] == [40, 200, 1000]
    assert [p.n_val for p in curve] == [6, 30, 150]
    assert all(p.topology == "8+lin" and p.seconds > 0 for p in curve)


def test_learning_curve_plot_written(curve, tmp_path) -> None:
    """The learning-curve figure is a PNG file."""
    path = save_learning_curve(tmp_path / "lc.png", {"synthetic": curve}, title="test")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_bad_sizes_name_the_field() -> None:
    """Sizes beyond the samples left after the test set, or decreasing, are user errors."""
    x, y = power_law_data(100)
    with pytest.raises(ConfigError, match="sizes"):
        learning_curve(x, y, [50, 90], n_test=20)
    with pytest.raises(ConfigError, match="sizes"):
        learning_curve(x, y, [60, 30], n_test=20)
    with pytest.raises(ConfigError, match="n_test"):
        learning_curve(x, y, [30], n_test=100)
