"""Tests of sweep specs and the resumable part store (rths3d.dataset.spec / .store)."""

from __future__ import annotations

import pandas as pd
import pytest

from rths3d.dataset import batches_of, load_spec, parse_spec
from rths3d.dataset.store import SweepStore, read_table
from rths3d.errors import ConfigError

TABLE1 = {
    "h0": [0.002, 0.005, 0.01], "fd": [0.25, 0.5, 1.0],
    "dz": [0.003, 0.005, 0.006, 0.007, 0.009],
    "d": [50.0, 75.0, 100.0, 150.0, 200.0, 250.0, 500.0],
    "k": [250.0, 500.0, 1e3, 2.5e3, 5e3, 7.5e3, 1e4, 1.5e4, 2e4, 2.5e4, 5e4, 1e5, 5e5, 2e6],
    "m": [4.81, 9.62, 19.24],
}


def spec_dict(**family) -> dict:
    fam = {"name": "contact", "scene": "contact", "grid": TABLE1} | family
    return {"sweep": {"name": "t", "seed": 3, "batch_size": 7}, "family": [fam]}


def test_full_table1_grid_has_13230_tests_and_unique_ids() -> None:
    """The paper's Table 1 grid expands to 3·3·5·7·14·3 = 13230 tests with unique ids."""
    tests = parse_spec(spec_dict()).tests()
    assert len(tests) == 13230
    assert len({t["test_id"] for t in tests}) == 13230
    assert {t["params"]["k"] for t in tests} == set(TABLE1["k"])


def test_subset_picks_280_deterministically() -> None:
    """subset = 280 keeps 280 distinct grid points, the same ones for the same seed."""
    a = parse_spec(spec_dict(subset=280)).tests()
    b = parse_spec(spec_dict(subset=280)).tests()
    assert len(a) == 280 and [t["test_id"] for t in a] == [t["test_id"] for t in b]
    c = parse_spec(spec_dict(subset=280) | {"sweep": {"name": "t", "seed": 4}}).tests()
    assert [t["test_id"] for t in a] != [t["test_id"] for t in c]


def test_random_sample_ranges_and_fixed_values() -> None:
    """sample draws n values inside [lo, hi] per grid point (log-uniform > 0); fixed is set."""
    d = spec_dict(grid={"m": [1.0, 2.0]}, sample={"n": 20, "k": {"loguniform": [1e3, 1e5]},
                                                   "c": {"uniform": [-1.0, 1.0]}},
                  fixed={"transfer.vff": True})
    tests = parse_spec(d).tests()
    assert len(tests) == 40
    ks = [t["params"]["k"] for t in tests]
    assert min(ks) >= 1e3 and max(ks) <= 1e5
    assert all(-1 <= t["params"]["c"] <= 1 for t in tests)
    assert all(t["params"]["transfer.vff"] is True for t in tests)
    assert [t["params"] for t in parse_spec(d).tests()] == [t["params"] for t in tests]


def test_batches_are_fixed_chunks() -> None:
    """Batches are consecutive chunks of batch_size tests with stable ids."""
    spec = parse_spec(spec_dict(subset=20))
    b = batches_of(spec)
    assert [len(t) for _, t in b] == [7, 7, 6]
    assert [bid for bid, _ in b] == ["b00000", "b00001", "b00002"]


def test_batches_never_straddle_two_transfer_settings() -> None:
    """Each batch holds one setting the loop steps together, at most batch_size tests."""
    sample = {"n": 1, "transfer.substeps": {"choice": [1, 2]},
              "transfer.velocity_ff": {"choice": [True, False]}}
    spec = parse_spec(spec_dict(subset=40, transfer="lti", sample=sample))
    b = batches_of(spec)
    assert all(len(t) <= 7 for _, t in b)
    assert sorted(x["test_id"] for _, t in b for x in t) == \
        sorted(x["test_id"] for x in spec.tests())
    for _, t in b:
        assert len({x["params"]["transfer.substeps"] for x in t}) == 1
    # two settings of ~20 tests, feed-forward per test: three balanced batches each, not 7+7+6
    # and a straggler
    assert len(b) == 6 and min(len(t) for _, t in b) >= 6
    assert any(len({x["params"]["transfer.velocity_ff"] for x in t}) == 2 for _, t in b)


def test_lti_batches_mix_actuator_settings() -> None:
    """On the LTI path delay, feed-forward, lag and compensation none/velocity are per test;
    polynomial compensation is a setting of its own."""
    sample = {"n": 1, "transfer.delay": {"choice": [1e-3, 4e-3]},
              "transfer.velocity_ff": {"choice": [True, False]},
              "transfer.timeconst": {"choice": [0.0, 3e-3]},
              "transfer.compensation": {"choice": ["none", "velocity", "polynomial"]}}
    spec = parse_spec(spec_dict(subset=60, transfer="lti", sample=sample))
    b = batches_of(spec)
    assert sorted(x["test_id"] for _, t in b for x in t) == \
        sorted(x["test_id"] for x in spec.tests())
    n_poly = sum(x["params"]["transfer.compensation"] == "polynomial" for x in spec.tests())
    assert len(b) == -(-n_poly // 7) + -(-(60 - n_poly) // 7)
    for _, t in b:
        assert len({x["params"]["transfer.compensation"] == "polynomial" for x in t}) == 1
    assert any(len({x["params"]["transfer.delay"] for x in t}) == 2 for _, t in b)
    # the Stewart platform steps feed-forward and the actuator delay (a controller block)
    # together
    stew = batches_of(parse_spec(spec_dict(subset=40, transfer="stewart", sample={
        "n": 1, "transfer.delay": {"choice": [1e-3, 4e-3]},
        "transfer.velocity_ff": {"choice": [True, False]}})))
    assert len(stew) == 6
    assert any(len({x["params"]["transfer.delay"] for x in t}) == 2 for _, t in stew)
    assert any(len({x["params"]["transfer.velocity_ff"] for x in t}) == 2 for _, t in stew)


@pytest.mark.parametrize("patch, field", [
    ({"subset": 0}, "subset"),
    ({"transfer": "hydraulic"}, "transfer"),
    ({"sample": {"n": 3, "k": {"loguniform": [0.0, 1.0]}}}, "sample.k"),
    ({"sample": {"k": {"uniform": [0.0, 1.0]}}}, "sample.n"),
    ({"grid": {"k": []}}, "grid.k"),
])
def test_bad_spec_values_name_the_field(patch, field) -> None:
    """Bad family values raise ConfigError naming the field."""
    with pytest.raises(ConfigError, match=field.replace(".", r"\.")):
        parse_spec(spec_dict(**patch))


def test_spec_file_errors(tmp_path) -> None:
    """A missing file, invalid TOML and a missing [[family]] are ConfigErrors."""
    with pytest.raises(ConfigError, match="does not exist"):
        load_spec(tmp_path / "nope.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[sweep\n")
    with pytest.raises(ConfigError, match="invalid TOML"):
        load_spec(bad)
    nofam = tmp_path / "nofam.toml"
    nofam.write_text('[sweep]\nname = "x"\n')
    with pytest.raises(ConfigError, match="family"):
        load_spec(nofam)


def test_store_parts_atomic_and_guarded(tmp_path) -> None:
    """Parts are listed once written, merge concatenates in batch order, and a folder of
    another spec is refused."""
    st = SweepStore(tmp_path, "s", "abc", 2, 4).open()
    st.write_part("b00001", [{"test_id": "c", "v": 3.0}, {"test_id": "d", "v": 4.0}])
    st.write_part("b00000", [{"test_id": "a", "v": 1.0}, {"test_id": "b", "v": 2.0}])
    assert st.done() == {"b00000", "b00001"}
    assert not list((tmp_path / "parts").glob(".*"))  # no temporary leftovers
    frame = st.merge(["b00000", "b00001"], {"name": "s"})
    assert frame["test_id"].tolist() == ["a", "b", "c", "d"]
    pd.testing.assert_frame_equal(read_table(tmp_path / "s.parquet"), frame)
    with pytest.raises(ConfigError, match="another sweep"):
        SweepStore(tmp_path, "s", "zzz", 2, 4).open()
    # merged in the order of given test ids whatever the batches; a folder that another
    # batching scheme cut is refused (its batch ids name other tests)
    frame = st.merge(["b00000", "b00001"], {"name": "s"}, order=["d", "a", "c", "b"])
    assert frame["test_id"].tolist() == ["d", "a", "c", "b"]
    assert frame["v"].tolist() == [4.0, 1.0, 3.0, 2.0]
    man = tmp_path / "manifest.json"
    man.write_text(man.read_text().replace('"group-aligned/2"', '"group-aligned/1"'))
    with pytest.raises(ConfigError, match="another rths3d version"):
        SweepStore(tmp_path, "s", "abc", 2, 4).open()


def test_shipped_specs_parse_and_resolve_their_scenes() -> None:
    """Every spec in scenes/sweeps parses, its scenes exist and take its overrides, and the
    paper's sizes hold."""
    from pathlib import Path

    from rths3d.dataset.runner import _overrides
    from rths3d.scene import load_scene, scene_with

    folder = Path(__file__).resolve().parents[1] / "scenes" / "sweeps"
    sizes = {}
    for path in sorted(folder.glob("*.toml")):
        spec = load_spec(path)
        tests = spec.tests()
        for fam in spec.families:
            base = load_scene(spec.scene_path(fam))
            first = next(t for t in tests if t["family"] == fam.name)
            scene_with(base, _overrides(spec, first))  # its overrides validate
        sizes[spec.name] = len(tests)
    assert sizes["table1_lti"] == 13230
    assert sizes["table1_lti_large"] == 100_000
    assert sizes["families_wide"] == 1720
    assert sizes["families_large"] == 4240
    assert sizes["paper280_lti"] == sizes["paper280_stewart"] == 280
    assert sizes["table2_linear"] == 108


def test_table1_lti_large_holds_distinct_tests_over_the_whole_grid() -> None:
    """table1_lti_large: 100000 distinct tests of Table 1 × 60 transfer settings, every
    setting used, almost every Table-1 point (7.6 draws each on average)."""
    from pathlib import Path

    spec = load_spec(Path(__file__).resolve().parents[1] / "scenes" / "sweeps"
                     / "table1_lti_large.toml")
    points, settings, grid = set(), set(), set()
    for t in spec.tests():
        p = t["params"]
        points.add(tuple(sorted(p.items())))
        settings.add(tuple(p[k] for k in p if k.startswith("transfer.")))
        grid.add(tuple(p[k] for k in p if not k.startswith("transfer.")))
    assert len(points) == 100_000
    assert len(settings) == 60
    assert 13_150 <= len(grid) <= 13_230


def test_families_large_draws_every_servo_setting_in_every_family() -> None:
    """families_large: each of its six families sees all 6 leg-servo settings and 10 delays."""
    from pathlib import Path

    spec = load_spec(Path(__file__).resolve().parents[1] / "scenes" / "sweeps"
                     / "families_large.toml")
    seen: dict[str, set] = {}
    delays: dict[str, set] = {}
    for t in spec.tests():
        p = t["params"]
        seen.setdefault(t["family"], set()).add((p["transfer.timeconst"],
                                                 p["transfer.velocity_ff"]))
        delays.setdefault(t["family"], set()).add((p["transfer.delay"],
                                                   p["transfer.compensation"]))
    assert sorted(seen) == ["contact", "contact_force", "kelvin", "linear", "multidof",
                            "support"]
    assert all(len(v) == 6 for v in seen.values())
    assert all(len(v) == 10 for v in delays.values())


def test_paper280_lti_and_stewart_share_dynamics() -> None:
    """The Stewart 280 sweep uses the same 280 Table-1 parameter points as the LTI one."""
    from pathlib import Path

    folder = Path(__file__).resolve().parents[1] / "scenes" / "sweeps"

    def points(name: str) -> set:
        tests = load_spec(folder / f"{name}.toml").tests()
        return {tuple(sorted((k, v) for k, v in t["params"].items()
                             if not k.startswith("transfer."))) for t in tests}

    assert points("paper280_lti") == points("paper280_stewart")


@pytest.mark.parametrize("patch, field", [
    ({"grid": 5}, "grid"),
    ({"fixed": 3}, "fixed"),
    ({"sample": {"n": 1, "k": {"uniform": ["a", 1]}}}, "sample.k"),
    ({"sample": {"n": "x", "k": {"uniform": [0.0, 1.0]}}}, "sample.n"),
    ({"sample": {"n": 2.7, "k": {"uniform": [0.0, 1.0]}}}, "sample.n"),
    ({"subset": True}, "subset"),
    ({"grids": {"k": [1.0]}}, "grids"),
])
def test_malformed_family_values_are_config_errors(patch, field) -> None:
    """Tables given as scalars, non-numeric ranges, non-integer n/subset and unknown family
    keys are ConfigErrors naming the field, not tracebacks or silently ignored."""
    with pytest.raises(ConfigError, match=field.replace(".", r"\.")):
        parse_spec(spec_dict(**patch))


@pytest.mark.parametrize("sweep, field", [
    ({"batchsize": 2}, "sweep.batchsize"),
    ({"keep_records": "false"}, "sweep.keep_records"),
    ({"surrogate": "no"}, "sweep.surrogate"),
    ({"batch_size": True}, "sweep.batch_size"),
    ({"duration": True}, "sweep.duration"),
])
def test_malformed_sweep_settings_are_config_errors(sweep, field) -> None:
    """Unknown [sweep] keys, a non-boolean keep_records and booleans for numbers are refused."""
    d = spec_dict()
    d["sweep"] = d["sweep"] | sweep
    with pytest.raises(ConfigError, match=field.replace(".", r"\.")):
        parse_spec(d)


def test_sweep_given_as_array_of_tables_is_a_config_error() -> None:
    """[[sweep]] (a list) instead of [sweep] names the section."""
    d = spec_dict()
    d["sweep"] = [d["sweep"]]
    with pytest.raises(ConfigError, match="sweep"):
        parse_spec(d)


def test_subset_larger_than_the_family_is_refused() -> None:
    """subset above the number of a family's tests is a ConfigError naming the count."""
    spec = parse_spec(spec_dict(grid={"k": [1.0, 2.0, 3.0]}, subset=4))
    with pytest.raises(ConfigError, match=r"subset.*3 tests"):
        spec.tests()


def test_delay_transfer_is_accepted() -> None:
    """transfer = "delay", a transfer kind of scenes, is a valid family transfer."""
    assert parse_spec(spec_dict(transfer="delay")).families[0].transfer == "delay"


def test_stewart_timeconst_text_is_a_config_error() -> None:
    """A non-numeric transfer.timeconst on the Stewart path is a ConfigError when batching."""
    spec = parse_spec(spec_dict(grid={"k": [1.0]}, transfer="stewart",
                                fixed={"transfer.timeconst": "fast"}))
    with pytest.raises(ConfigError, match="transfer.timeconst"):
        batches_of(spec)


def test_mixed_value_types_in_a_column_are_stored_as_text(tmp_path) -> None:
    """A parameter that is a number in one part and text in another (or both in one part)
    is written and merged as text; missing values stay missing."""
    st = SweepStore(tmp_path, "s", "abc", 2, 4).open()
    st.write_part("b00000", [{"test_id": "a", "p": 1.0}, {"test_id": "b", "p": "[[1.0]]"}])
    st.write_part("b00001", [{"test_id": "c", "p": 2.0}, {"test_id": "d", "p": float("nan")}])
    frame = st.merge(["b00000", "b00001"], {"name": "s"})
    assert frame["p"].tolist()[:3] == ["1.0", "[[1.0]]", "2.0"]
    assert pd.isna(frame["p"].iloc[3])
    pd.testing.assert_frame_equal(read_table(tmp_path / "s.parquet"), frame)


def test_store_refuses_edited_scene_and_names_batch_size(tmp_path) -> None:
    """Resuming with a changed scene hash or batch size is refused with a one-line reason;
    a manifest without scene hashes (older rths3d) is accepted."""
    import json

    SweepStore(tmp_path, "s", "abc", 2, 4, {"f": "h1"}).open()
    with pytest.raises(ConfigError, match="scene file changed"):
        SweepStore(tmp_path, "s", "abc", 2, 4, {"f": "h2"}).open()
    with pytest.raises(ConfigError, match="batch_size differs"):
        SweepStore(tmp_path, "s", "abc", 3, 4, {"f": "h1"}).open()
    man = tmp_path / "manifest.json"
    old = json.loads(man.read_text())
    del old["scenes"]
    man.write_text(json.dumps(old))
    SweepStore(tmp_path, "s", "abc", 2, 4, {"f": "h2"}).open()


def test_store_bad_folder_and_corrupt_manifest_are_config_errors(tmp_path) -> None:
    """--out naming a file and an unreadable manifest.json are ConfigErrors."""
    afile = tmp_path / "afile"
    afile.write_text("x")
    with pytest.raises(ConfigError, match="out"):
        SweepStore(afile, "s", "abc", 2, 4).open()
    (tmp_path / "d").mkdir()
    (tmp_path / "d" / "manifest.json").write_text("{bad")
    with pytest.raises(ConfigError, match="unreadable manifest"):
        SweepStore(tmp_path / "d", "s", "abc", 2, 4).open()


def test_join_tables_unites_columns_and_keeps_each_test_once() -> None:
    """join_tables stacks rows, fills a column one sweep lacks with NaN and drops a test
    given twice, with a warning; no rows at all is a ConfigError."""
    import warnings

    import numpy as np

    from rths3d.dataset import join_tables

    a = pd.DataFrame({"test_id": ["x", "y"], "param.k": [1.0, 2.0]})
    b = pd.DataFrame({"test_id": ["y", "z"], "param.k": [2.0, 3.0], "param.m": [5.0, 6.0]})
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        j = join_tables([a, b])
    assert list(j["test_id"]) == ["x", "y", "z"]
    assert np.isnan(j["param.m"][0]) and j["param.m"][2] == 6.0
    assert any("1 tests appear in more than one table" in str(w.message) for w in caught)
    with pytest.raises(ConfigError):
        join_tables([])


def test_parse_feature_sets_keeps_order_and_names_the_option() -> None:
    """'3,1,3' → (3, 1); an empty, unknown or non-integer set is a ConfigError naming the
    option."""
    from rths3d.dataset import parse_feature_sets

    assert parse_feature_sets("3,1,3") == (3, 1)
    for bad in ("", "4", "1,x"):
        with pytest.raises(ConfigError, match="--sets: .*feature sets 1, 2, 3"):
            parse_feature_sets(bad, "--sets")


def test_parse_features_takes_a_set_or_table3_names_in_order() -> None:
    """'2' → 2; 'zeta, e_rel_track' → those names in that order; training_data then gives
    X exactly those columns; a set beyond 3, an unknown or a repeated name is a ConfigError
    naming the option."""
    import pandas as pd

    from rths3d.dataset import parse_features, training_data
    from rths3d.dataset.table import SET_1

    assert parse_features("2") == 2
    assert parse_features(" zeta , e_rel_track") == ("zeta", "e_rel_track")
    frame = pd.DataFrame({**{f"feature.{k}": [1.0, 2.0] for k in SET_1},
                          "target.e_rel_ref": [0.1, 0.2]})
    X, y, _ = training_data(frame, parse_features("zeta,e_rel_track"))
    assert list(X.columns) == ["zeta", "e_rel_track"] and len(y) == 2
    for bad in ("4", "zeta,nope", "zeta,zeta", ""):
        with pytest.raises(ConfigError, match="--features"):
            parse_features(bad)


def test_parse_ratings_names_the_option_and_the_limit() -> None:
    """'velocity=0.2, force=200' → SI floats; an unknown name, a non-positive value or an
    empty text is a ConfigError naming the option."""
    from rths3d.dataset import parse_ratings

    assert parse_ratings("velocity=0.2, force=200") == {"velocity": 0.2, "force": 200.0}
    for bad, msg in (("speed=1", "--ratings: .*stroke, velocity, force"),
                     ("velocity=-1", "--ratings velocity: .*> 0 \\(m/s\\)"),
                     ("force=x", "--ratings force: .*> 0 \\(N\\)"),
                     ("", "at least one")):
        with pytest.raises(ConfigError, match=msg):
            parse_ratings(bad)


def test_within_ratings_refuses_a_table_without_bench_load() -> None:
    """A table swept before the bench-load measures: the error says to sweep it again."""
    import pandas as pd

    from rths3d.dataset import within_ratings

    old = pd.DataFrame({"test_id": ["a"], "status": ["ok"], "measure.f_eq": [1.0]})
    with pytest.raises(ConfigError, match="measure.velocity_peak.*sweep it again"):
        within_ratings(old, {"velocity": 0.1})


def test_within_ratings_refuses_a_partly_old_table() -> None:
    """Finished tests without the peak (a sweep resumed across versions) are an error, not
    silently dropped; a stopped test without it is simply not kept."""
    import numpy as np
    import pandas as pd

    from rths3d.dataset import within_ratings

    mixed = pd.DataFrame({"test_id": ["a", "b", "c"], "status": ["ok", "ok", "stopped"],
                          "measure.velocity_peak": [0.05, np.nan, np.nan]})
    with pytest.raises(ConfigError, match="1 finished tests have no"):
        within_ratings(mixed, {"velocity": 0.1})
    fine = mixed.drop(index=1)
    assert list(within_ratings(fine, {"velocity": 0.1})["test_id"]) == ["a"]


def test_within_ratings_checks_every_rating_on_every_row_without_status() -> None:
    """Without a status column every row is finished: a row that fails the first rating and
    lacks the second rating's peak still makes the table refused (no narrowing between
    ratings)."""
    import numpy as np
    import pandas as pd

    from rths3d.dataset import within_ratings

    rows = pd.DataFrame({"test_id": ["a", "b"], "measure.velocity_peak": [0.05, 0.5],
                         "measure.force_peak": [10.0, np.nan]})
    with pytest.raises(ConfigError, match="1 finished tests have no 'measure.force_peak'"):
        within_ratings(rows, {"velocity": 0.1, "force": 100.0})


@pytest.mark.parametrize("patch, message", [
    ({"grid": {}}, "family 'contact'.grid: {} (is empty"),
    ({"grid": {}, "sample": {"n": 3}}, "family 'contact'.grid: {} (is empty"),
    ({"sample": {"n": 3}}, "family 'contact'.sample: {'n': 3} (has no ranges"),
])
def test_a_family_that_sweeps_nothing_is_refused(patch, message) -> None:
    """An empty [family.grid] (or a sample without ranges, or neither) would quietly run one
    test of the base scene: a ConfigError naming the family instead."""
    fam = {"name": "contact", "scene": "contact"} | patch
    with pytest.raises(ConfigError) as err:
        parse_spec({"sweep": {"name": "t"}, "family": [fam]})
    assert str(err.value).startswith(message)
    with pytest.raises(ConfigError, match=r"^family 'contact'\.grid: missing \(the family "
                                          r"sweeps nothing"):
        parse_spec({"sweep": {"name": "t"}, "family": [{"name": "contact",
                                                         "scene": "contact"}]})
