"""Tests of the Table-4 protocol driver (rths3d.ann.protocol) on tables with known structure."""

from __future__ import annotations

import numpy as np
import pandas as pd

from rths3d.ann.protocol import reproduce, rows_to_markdown
from rths3d.dataset.table import SET_1


def table(n: int, family: str, seed: int, shift: float = 0.0) -> pd.DataFrame:
    """Features uniform in [0, 1]; target a smooth function of three set-3 features."""
    rng = np.random.default_rng(seed)
    d = {f"feature.{k}": rng.uniform(0, 1, n) for k in SET_1}
    d["target.e_rel_ref"] = (0.02 + 0.1 * d["feature.e_rel_track"] ** 2
                             + 0.05 * d["feature.fei_d"] * d["feature.tau_ratio_num"] + shift)
    d["family"] = [family] * n
    d["status"] = ["ok"] * n
    return pd.DataFrame(d)


def test_reproduce_rows_and_scores() -> None:
    """The protocol yields one row per set and step; a shared smooth relation gives ρ > 0.99
    on the test set, on the 'Stewart' table and on the left-out family, for every training."""
    lti = table(200, "contact", 0)
    stewart = table(80, "contact", 1)
    linear = table(40, "linear", 2)
    fams = pd.concat([table(150, "contact", 3), table(150, "kelvin", 4), table(60, "linear", 5)])
    models: dict = {}
    rows = reproduce(lti, stewart, linear, fams, left_out="linear", n_trainings=2,
                     topologies=((5,),), feature_sets=(3,), transform="linear",
                     models_out=models)
    systems = [r.system for r in rows]
    assert systems == ["contact, 1-D LTI transfer (vRTHS)", "contact, MuJoCo Stewart platform",
                       "Stewart, inside the training ranges", "linear Table 2 (contact-trained)", "families without 'linear'",
                       "family 'linear' (left out)", "linear Table 2 (families-trained)"]
    for r in rows:
        assert r.r_eval_worst > 0.98, r
        assert len(r.members) == 2 and r.r_eval_worst == min(r.members)
    assert rows[0].n_train == 140 and rows[0].n_eval == 30
    assert 2 < rows[2].n_eval < rows[1].n_eval == 80  # Stewart samples inside the ranges
    md = rows_to_markdown(rows)
    assert md.count("\n") == len(rows) + 1 and "| 3 |" in md
    # the trained estimators come back: the contact one reproduces its row's test ρ
    assert sorted(models) == ["contact_set3", "families_set3"]
    from rths3d.dataset.table import training_data

    m = models["contact_set3"][0]
    X, y, _ = training_data(lti, 3)
    assert m.scores(X, y)["members_r_test"] == rows[0].members


def test_split_seeds_pool_trainings_of_all_splits() -> None:
    """With split_seeds the trained and applied rows pool every training of every split
    (median and worst over splits × trainings) and the splits' test sets differ."""
    from rths3d.ann.protocol import fit_and_score_splits
    from rths3d.dataset.table import training_data

    X, y, _ = training_data(table(120, "contact", 0), 3)
    models, row = fit_and_score_splits(X, y, "contact", 3, split_seeds=(0, 1, 2),
                                       n_trainings=2, topologies=((5,),))
    assert len(models) == 3 and len(row.members) == 6
    assert row.r_eval_worst == min(row.members)
    assert row.r_eval_median == float(np.median(row.members))
    assert len(row.members_log) == 6 and row.r_log_worst == min(row.members_log) <= 1.0
    assert not np.array_equal(models[0].indices["test"], models[1].indices["test"])
    Xs, ys, _ = training_data(table(50, "contact", 1), 3)
    applied = reproduce(table(120, "contact", 0), table(50, "contact", 1), n_trainings=2,
                        topologies=((5,),), feature_sets=(3,), split_seeds=(0, 1, 2))
    assert [len(r.members) for r in applied][:2] == [6, 6]
    assert "3 splits" in applied[1].note
    assert applied[0].members == row.members


def test_progress_bar_names_each_training_run(capsys) -> None:
    """With progress=True every fit shows a bar labelled with its system, set and split,
    counting its trainings; the rows are those of a silent run."""
    lti = table(120, "contact", 0)
    loud = reproduce(lti, n_trainings=2, topologies=((5,),), feature_sets=(3,),
                     split_seeds=(0, 1), progress=True)
    err = capsys.readouterr().err
    for s in (0, 1):
        assert f"contact, 1-D LTI transfer (vRTHS), set 3, split {s}" in err
    assert "2/2" in err
    quiet = reproduce(lti, n_trainings=2, topologies=((5,),), feature_sets=(3,),
                      split_seeds=(0, 1))
    assert capsys.readouterr().err == ""
    assert loud[0].members == quiet[0].members


def test_extra_parameter_supplies_what_the_features_miss() -> None:
    """A target that depends on a test parameter the features do not hold: ρ rises above
    0.99 with the parameter as an extra input, the rows say so, and a table without the
    parameter (the linear system) is left out."""
    def with_gap(n: int, seed: int) -> pd.DataFrame:
        t = table(n, "contact", seed)
        h0 = np.random.default_rng(seed + 10).uniform(0.002, 0.01, n)  # m
        t["param.experiment.h0"] = h0
        t["target.e_rel_ref"] = 0.02 + 0.1 * t["feature.e_rel_track"] + 20.0 * h0
        return t

    lti, stewart = with_gap(240, 0), with_gap(80, 1)
    common = dict(n_trainings=2, topologies=((5,),), feature_sets=(3,), transform="linear",
                  stewart_in_range=False)
    plain = reproduce(lti, **common)
    rows = reproduce(lti, stewart, table(40, "linear", 2), extra=("experiment.h0",), **common)
    assert plain[0].r_eval_median < 0.9
    assert [r.system for r in rows] == ["contact, 1-D LTI transfer (vRTHS) + experiment.h0",
                                        "contact, MuJoCo Stewart platform + experiment.h0"]
    assert min(rows[0].members) > 0.99 and rows[1].r_eval_worst > 0.99
