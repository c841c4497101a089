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
    rows = reproduce(lti, stewart, linear, fams, left_out="linear", n_trainings=2,
                     topologies=((5,),), feature_sets=(3,))
    systems = [r.system for r in rows]
    assert systems == ["contact, 1-D LTI transfer (vRTHS)", "contact, MuJoCo Stewart platform",
                       "linear Table 2 (contact-trained)", "families without 'linear'",
                       "family 'linear' (left out)", "linear Table 2 (families-trained)"]
    for r in rows:
        assert r.r_eval_worst > 0.98, r
        assert len(r.members) == 2 and r.r_eval_worst == min(r.members)
    assert rows[0].n_train == 140 and rows[0].n_eval == 30
    md = rows_to_markdown(rows)
    assert md.count("\n") == len(rows) + 1 and "| 3 |" in md
