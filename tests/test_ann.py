"""Tests of the fidelity ANN (rths3d.ann) on synthetic data with known structure."""

from __future__ import annotations

import warnings

import numpy as np
import pytest
import torch
from torch.func import jacrev

from rths3d.ann import (
    AdamConfig,
    ExtrapolationWarning,
    FidelityANN,
    LMConfig,
    MinMax,
    NonFiniteInputWarning,
    Topology,
    mse,
    pearson_rho,
    rank,
    sensitivity_mean,
    sensitivity_permutation,
    split_indices,
    time_to_val_mse,
    train_adam,
    train_lm,
)
from rths3d.ann.network import forward, init_weights, jacobian
from rths3d.errors import ConfigError


def smooth_data(n: int = 300, d: int = 4, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """y = sin(2 x0) + 0.5 x1² (x2.. pure noise features), x uniform in [-1, 1]."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1.0, 1.0, (n, d))
    return x, np.sin(2.0 * x[:, 0]) + 0.5 * x[:, 1] ** 2


@pytest.fixture(scope="module")
def fitted() -> tuple[FidelityANN, np.ndarray, np.ndarray]:
    x, y = smooth_data(300, 4)
    model = FidelityANN(topologies=((5,), (8,)), n_trainings=5, seed=0)
    model.fit(x, y, feature_names=["relevant", "quadratic", "noise1", "noise2"])
    return model, x, y


def test_analytic_jacobian_matches_autograd() -> None:
    """The analytic LM Jacobian equals torch autograd's for a 2-hidden-layer satlins net."""
    topo = Topology(3, (4, 3))
    w = init_weights(topo, np.random.default_rng(0)) * 1.5
    x = torch.as_tensor(np.random.default_rng(1).uniform(-1, 1, (40, 3)), dtype=torch.float64)
    a, j = jacobian(topo, w, x)
    j_ref = jacrev(lambda v: forward(topo, v, x))(w)
    assert torch.allclose(a, forward(topo, w, x), atol=1e-14)
    assert torch.allclose(j, j_ref, atol=1e-12)
    assert j.shape == (40, topo.n_weights)


def test_hidden_activation_is_symmetric_saturating_linear() -> None:
    """Hidden units are satlins: output linear inside [-1, 1] and clipped at ±1 outside."""
    topo = Topology(1, (1,))
    # weights: hidden W=1, b=0; output W=1, b=0 → a = clip(x, -1, 1)
    w = torch.tensor([1.0, 0.0, 1.0, 0.0], dtype=torch.float64)
    x = torch.tensor([[-3.0], [-0.5], [0.25], [2.0]], dtype=torch.float64)
    assert forward(topo, w, x).tolist() == [-1.0, -0.5, 0.25, 1.0]


def test_minmax_maps_to_unit_box_and_back() -> None:
    """mapminmax: columns span exactly [-1, 1], inverse restores data, constant column → 0."""
    x = np.array([[0.0, 5.0, 3.0], [10.0, 7.0, 3.0], [5.0, 6.0, 3.0]])
    s = MinMax.fit(x)
    z = s.transform(x)
    assert np.allclose(z[:, 0], [-1, 1, 0]) and np.allclose(z[:, 1], [-1, 1, 0])
    assert np.all(z[:, 2] == 0.0)
    assert np.allclose(s.inverse(z)[:, :2], x[:, :2])
    assert s.outside(np.array([[11.0, 6.0, 3.0]])).tolist() == [[True, False, False]]


def test_split_is_70_15_15_disjoint_and_deterministic() -> None:
    """The split covers every sample once, has 70/15/15 sizes and repeats for a seed."""
    s = split_indices(280, seed=3)
    assert (len(s["train"]), len(s["val"]), len(s["test"])) == (196, 42, 42)
    allidx = np.concatenate(list(s.values()))
    assert np.array_equal(np.sort(allidx), np.arange(280))
    s2 = split_indices(280, seed=3)
    assert all(np.array_equal(s[k], s2[k]) for k in s)
    assert not np.array_equal(split_indices(280, seed=4)["test"], s["test"])


def test_pearson_rho_known_values() -> None:
    """ρ (eq. 15) is 1 for an increasing affine map, −1 for a decreasing one, as numpy's."""
    a = np.random.default_rng(0).normal(size=50)
    t = a + np.random.default_rng(1).normal(size=50)
    assert pearson_rho(a, 2 * a + 1) == pytest.approx(1.0)
    assert pearson_rho(a, -a) == pytest.approx(-1.0)
    assert pearson_rho(a, t) == pytest.approx(np.corrcoef(a, t)[0, 1], rel=1e-12)
    assert mse(np.array([1.0, 2.0]), np.array([0.0, 0.0])) == pytest.approx(2.5)


def test_lm_fits_smooth_function() -> None:
    """LM fits y = sin(2x0) + x1²/2 to MSE < 1e-3 (normalised) in under 200 epochs."""
    x, y = smooth_data(300, 2)
    xn, tn = MinMax.fit(x).transform(x), MinMax.fit(y[:, None]).transform(y[:, None])[:, 0]
    s = split_indices(300)
    r = train_lm(Topology(2, (8,)), xn[s["train"]], tn[s["train"]], xn[s["val"]],
                 tn[s["val"]], seed=1)
    assert r.val_mse < 1e-3 and r.train_mse < 1e-3
    assert r.epochs < 200
    a = r.predict(xn[s["test"]])
    assert pearson_rho(a, tn[s["test"]]) > 0.99


def test_lm_early_stopping_stops_and_returns_best_validation_weights() -> None:
    """On pure-noise targets the validation error rises: training stops after 6 fails and
    returns the weights of the best validation epoch."""
    rng = np.random.default_rng(5)
    x = rng.uniform(-1, 1, (120, 3))
    t = rng.uniform(-1, 1, 120)
    s = split_indices(120, seed=1)
    r = train_lm(Topology(3, (20,)), x[s["train"]], t[s["train"]], x[s["val"]],
                 t[s["val"]], seed=0)
    assert r.stop == "validation stop"
    assert r.epochs == r.best_epoch + 6
    vals = [h[3] for h in r.history]
    assert r.val_mse == pytest.approx(min(vals), rel=1e-12)
    assert np.mean((r.predict(x[s["val"]]) - t[s["val"]]) ** 2) == pytest.approx(r.val_mse)


def test_adam_baseline_learns_and_stops_at_target() -> None:
    """The Adam baseline lowers the validation MSE and stops once it reaches the target."""
    x, y = smooth_data(200, 2, seed=2)
    xn, tn = MinMax.fit(x).transform(x), MinMax.fit(y[:, None]).transform(y[:, None])[:, 0]
    s = split_indices(200)
    r0 = r = train_adam(Topology(2, (8,)), xn[s["train"]], tn[s["train"]], xn[s["val"]],
                        tn[s["val"]], seed=1, config=AdamConfig(target_val_mse=0.01))
    assert r.stop == "target reached" and r.val_mse <= 0.01
    assert r0.history[0][3] > 0.01
    assert time_to_val_mse(r, 0.01) <= r.seconds
    assert time_to_val_mse(r, -1.0) == float("inf")


def test_estimator_scores_and_topology_search(fitted) -> None:
    """The ensemble reaches ρ > 0.99 on train/val/test; the chosen topology has the
    smallest mean validation MSE of the search."""
    model, x, y = fitted
    sc = model.scores(x, y)
    assert sc["r_train"] > 0.99 and sc["r_val"] > 0.99 and sc["r_test"] > 0.99
    assert len(sc["members_r_test"]) == 5
    best = min(model.search, key=lambda s: s.mean_val_mse)
    assert model.topology.hidden == best.hidden
    assert sc["topology"] == list(best.hidden)


def test_topology_search_rejects_too_small_net() -> None:
    """A one-neuron net cannot fit a sine over two half-periods: the search picks more."""
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, (200, 1))
    y = np.sin(3.0 * x[:, 0])
    m = FidelityANN(topologies=((1,), (6,)), n_trainings=3, seed=1).fit(x, y)
    scores = {s.hidden: s.mean_val_mse for s in m.search}
    assert scores[(6,)] < 0.1 * scores[(1,)]
    assert m.topology.hidden == (6,)


def test_ensemble_gives_spread(fitted) -> None:
    """predict(return_std=True) returns the members' median and a non-negative spread."""
    model, x, _ = fitted
    members = model.predict_members(x[:10])
    pred, std = model.predict(x[:10], return_std=True)
    assert members.shape == (5, 10)
    assert np.allclose(pred, np.median(members, axis=0))
    assert np.allclose(std, members.std(axis=0))
    assert np.all(std >= 0) and np.any(std > 0)


def test_save_load_round_trip_predicts_identically(fitted, tmp_path) -> None:
    """A saved and reloaded model predicts bit-identically and keeps names, ranges, split."""
    model, x, _ = fitted
    path = model.save(tmp_path / "model.json")
    back = FidelityANN.load(path)
    assert np.array_equal(back.predict(x), model.predict(x))
    assert back.feature_names == model.feature_names
    assert all(np.array_equal(back.indices[k], model.indices[k]) for k in model.indices)
    assert np.array_equal(back.x_scale.lo, model.x_scale.lo)


def test_predicting_outside_training_range_warns(fitted) -> None:
    """Inputs outside the training ranges raise an ExtrapolationWarning naming the feature;
    inputs inside do not."""
    model, x, _ = fitted
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        model.predict(x[:5])
    bad = x[:3].copy()
    bad[0, 2] = 5.0
    with pytest.warns(ExtrapolationWarning, match="noise1"):
        model.predict(bad)


def test_sensitivity_ranks_relevant_above_noise(fitted) -> None:
    """Both sensitivity methods rank the two relevant features above the pure-noise ones."""
    model, x, y = fitted
    for imp in (sensitivity_mean(model, x, y), sensitivity_permutation(model, x, y)):
        assert set(rank(imp)[:2]) == {"relevant", "quadratic"}
        assert imp["relevant"] > 10 * max(abs(imp["noise1"]), abs(imp["noise2"]))


def test_dataframe_input_uses_column_names(fitted) -> None:
    """A DataFrame is matched by column name (any order); a missing column is a ConfigError."""
    import pandas as pd

    model, x, _ = fitted
    df = pd.DataFrame(x, columns=model.feature_names)[["noise2", "relevant", "noise1",
                                                       "quadratic"]]
    assert np.allclose(model.predict(df), model.predict(x), rtol=1e-12, atol=1e-15)
    with pytest.raises(ConfigError, match="quadratic"):
        model.predict(df.drop(columns="quadratic"))


def test_bad_input_raises_config_error() -> None:
    """Mismatched targets, NaN targets and empty hidden layers are ConfigErrors naming the field."""
    x, y = smooth_data(30, 2)
    with pytest.raises(ConfigError, match="^y"):
        FidelityANN(n_trainings=1).fit(x, y[:-1])
    with pytest.raises(ConfigError, match="y"):
        FidelityANN(n_trainings=1).fit(x, np.where(np.arange(30) == 3, np.nan, y))
    with pytest.raises(ConfigError, match="topology.hidden"):
        Topology(2, ())
    with pytest.raises(ConfigError, match="model"):
        FidelityANN().predict(x)


def test_regression_plots_written(fitted, tmp_path) -> None:
    """save_figures writes a non-trivial PNG with a regression and a prediction plot."""
    from rths3d.ann.plots import save_figures

    model, x, y = fitted
    te = model.indices["test"]
    mean, std = model.predict(x[te], return_std=True)
    p = save_figures(tmp_path / "fig.png", {"test": (y[te], mean)}, spread={"test": std})
    assert p.stat().st_size > 10_000


def test_prediction_plot_sorts_large_sets_by_target() -> None:
    """Up to sort_above samples keep their order; a larger set is drawn sorted by target, each
    prediction still beside its own target, on a log axis when all values are positive."""
    from rths3d.ann.plots import prediction_axes
    from rths3d.figures import new_figure

    rng = np.random.default_rng(0)
    t = 10.0 ** rng.uniform(-3, 0, 500)
    a = t * 10.0 ** rng.normal(0.0, 0.05, 500)
    small, large = new_figure().subplots(1, 2)
    prediction_axes(small, t[:50], a[:50])
    prediction_axes(large, t, a)
    assert np.array_equal(small.lines[0].get_ydata(), t[:50])
    assert small.get_yscale() == "linear"
    order = np.argsort(t)
    target_line = next(ln for ln in large.lines if ln.get_label() == "target")
    output_line = next(ln for ln in large.lines if ln.get_label() == "net output")
    assert np.array_equal(target_line.get_ydata(), t[order])
    assert np.array_equal(output_line.get_ydata(), a[order])
    assert large.get_yscale() == "log"


def test_log_transform_is_default_and_fits_power_laws_over_decades() -> None:
    """The default transform is 'log' (stored in the model); on a power law spanning three
    decades it beats the paper's linear map, and signed columns (a lead: fei_d < 0) stay finite."""
    rng = np.random.default_rng(3)
    x = 10.0 ** rng.uniform(-3.0, 0.0, (300, 3))
    x[:, 2] = rng.uniform(-0.002, 0.013, 300)  # a signed, delay-like column
    y = 0.5 * x[:, 0] ** 1.5 * x[:, 1] ** 0.5
    log = FidelityANN(topologies=((5,),), n_trainings=3, seed=0).fit(x, y)
    lin = FidelityANN(topologies=((5,),), n_trainings=3, seed=0, transform="linear").fit(x, y)
    assert log.transform == "log" and log.to_dict()["transform"] == "log"
    assert log.compress.log_cols == (True, True, False) and log.compress.log_y
    r_log, r_lin = log.scores(x, y)["r_test"], lin.scores(x, y)["r_test"]
    assert r_log > 0.99 and r_log > r_lin
    assert np.isfinite(log.predict(x[:5] * [1, 1, -3], warn=False)).all()


def test_bypass_jacobian_matches_autograd() -> None:
    """With the linear bypass the analytic LM Jacobian still equals torch autograd's."""
    topo = Topology(3, (4, 3), bypass=True)
    assert topo.n_weights == Topology(3, (4, 3)).n_weights + 3 and topo.label() == "4x3+lin"
    w = init_weights(topo, np.random.default_rng(0)) * 1.5
    w[-3:] = torch.tensor([0.3, -0.2, 0.5], dtype=torch.float64)
    x = torch.as_tensor(np.random.default_rng(1).uniform(-1, 1, (40, 3)), dtype=torch.float64)
    a, j = jacobian(topo, w, x)
    assert torch.allclose(a, forward(topo, w, x), atol=1e-14)
    assert torch.allclose(j, jacrev(lambda v: forward(topo, v, x))(w), atol=1e-12)


def test_three_hidden_layer_bypass_jacobian_matches_autograd() -> None:
    """For three hidden layers with the bypass (the 20x20x20 nets of docs/ann.md, scaled
    down) the analytic LM Jacobian equals torch autograd's, saturated units included."""
    from rths3d.ann import parse_topologies

    assert parse_topologies("20x20x20") == ((20, 20, 20),)
    topo = Topology(4, (5, 4, 3), bypass=True)
    w = init_weights(topo, np.random.default_rng(2)) * 2.0  # drives some units into ±1
    x = torch.as_tensor(np.random.default_rng(3).uniform(-1, 1, (60, 4)), dtype=torch.float64)
    a, j = jacobian(topo, w, x)
    assert torch.allclose(a, forward(topo, w, x), atol=1e-14)
    assert torch.allclose(j, jacrev(lambda v: forward(topo, v, x))(w), atol=1e-12)
    assert j.shape == (60, 4 * 5 + 5 + 5 * 4 + 4 + 4 * 3 + 3 + 3 + 1 + 4)


def test_bypass_extrapolates_beyond_training_range(tmp_path) -> None:
    """A plain satlins net flattens beyond the largest training target; the bypass net (the
    default) follows the trend there, and save/load keeps it (old files load as plain nets)."""
    rng = np.random.default_rng(5)
    x = 10.0 ** rng.uniform(-3.0, 0.0, (300, 2))
    y = 0.5 * x[:, 0] ** 1.5 * x[:, 1] ** 0.5
    x_far = np.array([[2.0, 2.0], [4.0, 3.0]])  # targets 1.4 and 6.9, training max ~0.5
    y_far = 0.5 * x_far[:, 0] ** 1.5 * x_far[:, 1] ** 0.5
    kw = dict(topologies=((5,),), n_trainings=3, seed=0)
    by = FidelityANN(**kw).fit(x, y)
    plain = FidelityANN(bypass=False, **kw).fit(x, y)
    assert by.topology.bypass and not plain.topology.bypass
    err_by = np.abs(np.log10(by.predict(x_far, warn=False) / y_far))
    err_plain = np.abs(np.log10(plain.predict(x_far, warn=False) / y_far))
    assert err_by.max() < 0.05 and err_plain.max() > 0.3
    back = FidelityANN.load(by.save(tmp_path / "m.json"))
    assert np.array_equal(back.predict(x_far, warn=False), by.predict(x_far, warn=False))
    old = plain.to_dict()
    old.pop("bypass")
    assert not FidelityANN.from_dict(old).topology.bypass


def test_lm_survives_singular_normal_matrix() -> None:
    """A dead hidden unit (zero Jacobian columns) with μ near zero makes JᵀJ + μI singular;
    LM treats it as a failed step and raises μ instead of aborting the training."""
    x, y = smooth_data(120, 2)
    topo = Topology(2, (3,))
    w0 = init_weights(topo, np.random.default_rng(0))
    w0[6:9] = torch.tensor([50.0, 0.0, 0.0], dtype=torch.float64)  # hidden unit 0 saturated...
    w0[0:2] = 0.0                                                   # ...for every input
    xn, tn = MinMax.fit(x).transform(x), MinMax.fit(y[:, None]).transform(y[:, None])[:, 0]
    r = train_lm(topo, xn[:90], tn[:90], xn[90:], tn[90:], w0=w0,
                 config=LMConfig(mu=1e-300, mu_dec=1e-10))
    assert np.isfinite(r.train_mse) and r.epochs >= 1


def test_parse_topologies_reads_both_spellings_and_names_the_field() -> None:
    """'10x10;20' and '10,10;20' give the same candidates; bad text names the option."""
    from rths3d.ann import parse_topologies

    assert parse_topologies("10x10;20") == parse_topologies("10,10;20") == ((10, 10), (20,))
    assert parse_topologies("") is None and parse_topologies(None) is None
    with pytest.raises(ConfigError, match="--topologies"):
        parse_topologies("10xa")
    with pytest.raises(ConfigError, match="width must be >= 1"):
        parse_topologies("5;0")


def test_damaged_model_file_is_a_config_error(fitted, tmp_path) -> None:
    """Every damaged model file (not a dict, keys missing, wrong sizes) is a ConfigError naming
    the file, never an AttributeError, KeyError or torch size mismatch."""
    import copy
    import json

    model, _, _ = fitted
    good = json.loads(json.dumps(model.to_dict()))

    def damaged(edit):
        d = copy.deepcopy(good)
        edit(d)
        return d

    cases = {
        "list": [good],
        "no members": damaged(lambda d: d.pop("members")),
        "short member": damaged(lambda d: d["members"][0].pop()),
        "hidden changed": damaged(lambda d: d.update(hidden=[7])),
        "no hi": damaged(lambda d: d["x_range"].pop("hi")),
        "no members left": damaged(lambda d: d.update(members=[])),
        "n_in vs names": damaged(lambda d: d.update(feature_names=d["feature_names"][:3])),
        "range length": damaged(lambda d: d["raw_range"]["lo"].pop()),
        "member not numbers": damaged(lambda d: d["members"].__setitem__(0, "abc")),
    }
    for name, content in cases.items():
        path = tmp_path / f"{name}.json"
        path.write_text(json.dumps(content))
        with pytest.raises(ConfigError, match=f"^model: '{path}'"):
            FidelityANN.load(path)


def test_nonfinite_inputs_warn_and_predict_nan_and_scores_skip_nan_targets(fitted) -> None:
    """NaN/inf inputs give a warning naming their rows and columns and NaN predictions for
    those rows only; scores() leaves out samples with a NaN target instead of returning NaN."""
    model, x, y = fitted
    bad = x[:5].copy()
    bad[1, 2] = np.nan
    bad[3, 0] = np.inf
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        p = model.predict(bad)
    assert [w.category for w in caught] == [NonFiniteInputWarning]
    assert "rows 1, 3" in str(caught[0].message)
    assert "relevant, noise1" in str(caught[0].message)
    assert np.isnan(p[[1, 3]]).all() and np.isfinite(p[[0, 2, 4]]).all()
    t = y.copy()
    t[model.indices["test"][0]] = np.nan
    sc = model.scores(x, t)
    assert np.isfinite([sc["r_test"], sc["r_all"], sc["mse"], sc["mse_test"]]).all()


def test_constant_column_and_constant_target_invert_to_their_value() -> None:
    """A constant column maps to 0 and back to its value; a constant target is predicted
    as that constant (log and linear transforms)."""
    s = MinMax.fit(np.array([[2.0, 1.0], [2.0, 3.0]]))
    assert np.array_equal(s.inverse(s.transform(np.array([[2.0, 2.0]]))), [[2.0, 2.0]])
    x = np.random.default_rng(0).uniform(1.0, 2.0, (30, 2))
    for transform in ("log", "linear"):
        m = FidelityANN(topologies=((2,),), n_trainings=1, transform=transform)
        assert m.fit(x, np.full(30, 0.05)).predict(x[:3]) == pytest.approx(0.05, rel=1e-12)


def test_given_split_is_validated_and_scores_need_the_fit_samples(fitted, tmp_path) -> None:
    """fit(indices=...) needs exactly train/val/test, non-empty, disjoint, integer rows in
    [0, N); scores() on another number of samples is a ConfigError; old files still load."""
    x, y = smooth_data(30, 2)
    ok = {"train": np.arange(20), "val": np.arange(20, 25), "test": np.arange(25, 30)}
    bad = [
        ({"train": ok["train"], "val": ok["val"]}, "exactly the keys"),
        (ok | {"extra": [0]}, "exactly the keys"),
        (ok | {"test": []}, "non-empty"),
        (ok | {"test": np.arange(24, 30)}, "both val and test"),
        (ok | {"test": [25, 30]}, r"\[0, 30\)"),
        (ok | {"test": [-1, 26]}, r"\[0, 30\)"),
        (ok | {"test": [25.0, 26.0]}, "integers"),
    ]
    for indices, why in bad:
        with pytest.raises(ConfigError, match=why):
            FidelityANN(topologies=((2,),), n_trainings=1).fit(x, y, indices=indices)
    model, xf, yf = fitted
    assert model.n_samples == len(yf)
    with pytest.raises(ConfigError, match="scores"):
        model.scores(xf[:-1], yf[:-1])
    old = model.to_dict()
    old.pop("n_samples")
    assert FidelityANN.from_dict(old).scores(xf, yf)["r_test"] == model.scores(xf, yf)["r_test"]


def test_failed_save_is_a_config_error_and_leaves_no_temp_file(fitted, tmp_path) -> None:
    """Saving onto a folder or below a file raises ConfigError and leaves no temp file."""
    model, _, _ = fitted
    (tmp_path / "folder").mkdir()
    (tmp_path / "file").write_text("")
    for target in (tmp_path / "folder", tmp_path / "file" / "m.json"):
        with pytest.raises(ConfigError, match="cannot write the model"):
            model.save(target)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file", "folder"]


def test_one_sample_as_a_1d_row(fitted) -> None:
    """A 1-D row of the n_in inputs (numpy row or DataFrame row) is one sample."""
    import pandas as pd

    model, x, _ = fitted
    one = model.predict(x[:1])
    assert model.predict(x[0]).tolist() == one.tolist()
    row = pd.DataFrame(x, columns=model.feature_names)[model.feature_names[::-1]].iloc[0]
    assert model.predict(row) == pytest.approx(one, rel=1e-12)
    with pytest.raises(ConfigError, match="feature"):
        model.predict(x[0, :3])
