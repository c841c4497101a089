"""Sweep specifications: which tests to run, read from TOML.

A sweep is one or more *families*; each family is a base scene plus parameter values. Values
come from a ``grid`` (Cartesian product of lists, e.g. the paper's Table 1) and/or a random
``sample`` (ranges drawn with a fixed seed, uniform or log-uniform), optionally reduced to a
random ``subset`` of fixed size (e.g. the paper's 280 tests). Parameter keys are dotted paths
into the scene TOML (``"numerical.k"``), so any scene value — including transfer-system
settings such as controller gains, velocity feed-forward or delays — can be swept.

Example::

    [sweep]
    name = "paper_contact"
    duration = 10.0        # s, simulated per test
    seed = 0
    batch_size = 16        # tests stepped together and stored as one part

    [[family]]
    name = "contact"
    scene = "contact_1d"   # a scene name under scenes/ or a path relative to this file
    transfer = "lti"
    subset = 280
    [family.grid]
    "numerical.k" = [250.0, 500.0, 1e3]
    [family.sample]
    n = 50
    "transfer.delay" = { loguniform = [1e-3, 2e-2] }
    "transfer.compensation" = { choice = ["none", "velocity"] }

The enumeration is deterministic per ``seed``: each test gets a stable ``test_id`` (family
name + a hash of its parameters) and an integer ``seed`` for its own randomness.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import math
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError
from ..transfer import batch_key, transfer_kinds

SWEEP_KEYS = ("name", "duration", "seed", "batch_size", "keep_records", "surrogate")
FAMILY_KEYS = ("name", "scene", "transfer", "subset", "fixed", "grid", "sample")


@dataclass(frozen=True)
class Family:
    """One system family: a base scene and the parameter values to sweep over it."""

    name: str
    scene: str
    transfer: str | None = None
    grid: Mapping[str, tuple[Any, ...]] = field(default_factory=dict)
    sample: Mapping[str, tuple[str, Any, Any]] = field(default_factory=dict)
    """Random draws: key → (``uniform`` | ``loguniform``, lo, hi) or (``choice``, values, None)."""
    n_sample: int = 0
    subset: int | None = None
    fixed: Mapping[str, Any] = field(default_factory=dict)
    """Parameters set for every test of the family (not swept)."""


@dataclass(frozen=True)
class SweepSpec:
    """A whole sweep: families and shared settings (durations in s)."""

    name: str
    families: tuple[Family, ...]
    duration: float | None = None
    seed: int = 0
    batch_size: int = 16
    keep_records: bool = False
    surrogate: bool = True
    """Every row carries the surrogate reference's estimate (``feature.e_rel_ref_hat`` …,
    :mod:`rths3d.surrogate`): about 0.1–0.2 s per 8 s test, several times a 1-D LTI test's
    own cost; ``false`` leaves those columns NaN (the paper's Table-3 sets do not use them)."""
    base_dir: str = "."
    """Folder the scene paths are relative to (the spec file's folder)."""
    scenes: Mapping[str, Any] = field(default_factory=dict, compare=False, repr=False)
    """Base scenes by family name, loaded by the submitting process
    (:func:`~rths3d.dataset.execute.prepare`); empty: loaded from their files where needed."""

    def tests(self) -> list[dict[str, Any]]:
        """All tests of the sweep in a deterministic order (see :func:`enumerate_tests`)."""
        return enumerate_tests(self)

    def digest(self) -> str:
        """Hash of everything that determines the results (guards resuming a changed spec)."""
        d = {"name": self.name, "duration": self.duration, "seed": self.seed,
             "families": [_family_dict(f) for f in self.families]}
        if not self.surrogate:  # the rows' estimate columns (absent key: the default, on)
            d["surrogate"] = False
        return hashlib.sha256(json.dumps(d, sort_keys=True, default=str).encode()).hexdigest()[:16]

    def scene_path(self, family: Family) -> Path:
        """Resolve a family's scene: a bare name (``paper_contact``) is a scene of the
        repository's ``scenes/``; a path (``my/scene.toml``) is relative to the spec file."""
        p = Path(family.scene)
        scenes = Path(__file__).resolve().parents[2] / "scenes"
        base = Path(self.base_dir)
        if p.suffix == ".toml" or len(p.parts) > 1:
            cands = [p if p.is_absolute() else base / p]
        else:
            cands = [scenes / f"{family.scene}.toml", base / f"{family.scene}.toml"]
        for c in cands:
            if c.is_file():
                return c
        raise ConfigError(f"family {family.name!r}.scene", family.scene,
                          "no such scene (a name in scenes/ or a .toml path relative to "
                          "the spec)")


def _family_dict(f: Family) -> dict[str, Any]:
    return {"name": f.name, "scene": f.scene, "transfer": f.transfer,
            "grid": {k: list(v) for k, v in f.grid.items()},
            "sample": {k: [v[0], list(v[1]) if v[0] == "choice" else v[1], v[2]]
                       for k, v in f.sample.items()}, "n": f.n_sample,
            "subset": f.subset, "fixed": dict(f.fixed)}


def _stable_seed(*parts: Any) -> int:
    h = hashlib.sha256(json.dumps(parts, sort_keys=True, default=str).encode()).digest()
    return int.from_bytes(h[:4], "little")


def enumerate_tests(spec: SweepSpec) -> list[dict[str, Any]]:
    """Expand the families into test dicts ``{test_id, family, scene, transfer, seed, params}``.

    Grid values form the Cartesian product (keys in file order, last varying fastest); a
    ``sample`` block adds ``n`` random draws per grid point; ``subset`` then keeps a random
    subset of that many tests (seeded). ``params`` maps dotted scene keys to values.
    """
    out: list[dict[str, Any]] = []
    for fi, fam in enumerate(spec.families):
        keys = list(fam.grid)
        combos = [dict(zip(keys, vals, strict=True))
                  for vals in itertools.product(*(fam.grid[k] for k in keys))] or [{}]
        rng = np.random.default_rng(_stable_seed(spec.seed, fam.name, "sample"))
        points: list[dict[str, Any]] = []
        for c in combos:
            if fam.sample and fam.n_sample > 0:
                for _ in range(fam.n_sample):
                    p = dict(c)
                    for k, (kind, lo, hi) in fam.sample.items():
                        u = float(rng.uniform())
                        if kind == "choice":
                            p[k] = lo[min(int(u * len(lo)), len(lo) - 1)]
                        elif kind == "loguniform":
                            p[k] = float(math.exp(math.log(lo) + u * (math.log(hi) - math.log(lo))))
                        else:
                            p[k] = float(lo + u * (hi - lo))
                    points.append(p)
            else:
                points.append(c)
        if fam.subset is not None and fam.subset > len(points):
            raise ConfigError(f"family {fam.name!r}.subset", fam.subset,
                              f"more than the family's {len(points)} tests")
        if fam.subset is not None and fam.subset < len(points):
            pick = np.random.default_rng(_stable_seed(spec.seed, fam.name, "subset")).choice(
                len(points), size=fam.subset, replace=False)
            points = [points[i] for i in sorted(pick)]
        # the spec's test order (and so the table's): by transfer/sensor/safety settings and
        # time grid (batches_of regroups them by what the loop steps together)
        points.sort(key=_group_sort_key)
        seen: set[str] = set()
        for p in points:
            params = {**fam.fixed, **p}
            tid = f"{fam.name}-{_stable_seed(fi, fam.name, params):08x}"
            while tid in seen:  # identical parameter points (e.g. repeated grid values)
                tid += "b"
            seen.add(tid)
            out.append({"test_id": tid, "family": fam.name, "scene": fam.scene,
                        "transfer": fam.transfer, "params": params,
                        "seed": _stable_seed(spec.seed, tid)})
    return out


_GROUP_PREFIXES = ("transfer.", "sensor.", "safety.")


def _group_sort_key(params: Mapping[str, Any]) -> str:
    items = sorted((k, params[k]) for k in params
                   if k.startswith(_GROUP_PREFIXES) or k in ("dt", "duration"))
    return json.dumps(items, default=str)


def batch_group_key(test: Mapping[str, Any], base: Mapping[str, Any]) -> str:
    """Tests with equal keys can be stepped together: the family, and the transfer system's
    own rule (:func:`rths3d.transfer.batch_key`, the one the loop groups by) on the test's
    parameters over its family's base-scene settings ``base``
    (:meth:`~rths3d.config.Scene.params`). A test whose settings the rule cannot read keeps a
    key of its own (it fails, with its reason, when its batch runs)."""
    settings = {**base, **test["params"]}
    if test.get("transfer"):
        settings["transfer.kind"] = test["transfer"]
    try:
        key: Any = batch_key(settings)
    except ConfigError as exc:
        raise ConfigError(f"family {test['family']!r} {exc.field}", exc.value,
                          exc.limit) from None
    except (TypeError, ValueError):
        key = ("unreadable", _group_sort_key(test["params"]))
    return f"{test['family']}|{key!r}"


# ---------------------------------------------------------------------------- parsing
def _require(d: Mapping[str, Any], key: str, where: str, kind: type | tuple) -> Any:
    if key not in d:
        raise ConfigError(f"{where}.{key}", None, "required")
    v = d[key]
    if not isinstance(v, kind) or isinstance(v, bool) and kind is not bool:
        raise ConfigError(f"{where}.{key}", v, f"must be {getattr(kind, '__name__', kind)}")
    return v


def _table(d: Mapping[str, Any], key: str, where: str) -> dict[str, Any]:
    v = d.get(key, {})
    if not isinstance(v, Mapping):
        raise ConfigError(f"{where}.{key}", v, "must be a table")
    return dict(v)


def _known_keys(d: Mapping[str, Any], where: str, known: tuple[str, ...]) -> None:
    for k in d:
        if k not in known:
            raise ConfigError(f"{where}.{k}", d[k], f"unknown key (known: {', '.join(known)})")


def _is_int(v: Any) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def _is_number(v: Any) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def _parse_family(d: Mapping[str, Any], where: str) -> Family:
    if not isinstance(d, Mapping):
        raise ConfigError(where, d, "must be a table ([[family]])")
    _known_keys(d, where, FAMILY_KEYS)
    name = _require(d, "name", where, str)
    scene = _require(d, "scene", where, str)
    transfer = d.get("transfer")
    if transfer is not None and transfer not in transfer_kinds():
        raise ConfigError(f"{where}.transfer", transfer, f"one of {', '.join(transfer_kinds())}")
    fam_where = f"family {name!r}"
    graw = _table(d, "grid", where)
    if "grid" in d and not graw:
        raise ConfigError(f"{fam_where}.grid", {}, "is empty: give each swept key a list of "
                          "values")
    grid: dict[str, tuple[Any, ...]] = {}
    for k, v in graw.items():
        vals = v if isinstance(v, list) else [v]
        if not vals:
            raise ConfigError(f"{where}.grid.{k}", v, "needs at least one value")
        grid[str(k)] = tuple(vals)
    sample: dict[str, tuple[str, Any, Any]] = {}
    sraw = _table(d, "sample", where)
    n_sample = sraw.pop("n", 0)
    if not _is_int(n_sample):
        raise ConfigError(f"{where}.sample.n", n_sample, "must be an integer")
    for k, v in sraw.items():
        if not isinstance(v, dict) or len(v) != 1:
            raise ConfigError(f"{where}.sample.{k}", v,
                              "write {uniform = [lo, hi]}, {loguniform = [lo, hi]} or "
                              "{choice = [...]}")
        kind, rng = next(iter(v.items()))
        if kind == "choice":
            if not isinstance(rng, list) or not rng:
                raise ConfigError(f"{where}.sample.{k}", v, "choice needs a non-empty list")
            sample[str(k)] = ("choice", tuple(rng), None)
            continue
        if kind not in ("uniform", "loguniform") or not isinstance(rng, list) or len(rng) != 2:
            raise ConfigError(f"{where}.sample.{k}", v,
                              "write {uniform = [lo, hi]} or {loguniform = [lo, hi]}")
        if not all(_is_number(x) for x in rng):
            raise ConfigError(f"{where}.sample.{k}", rng, "lo and hi must be finite numbers")
        lo, hi = float(rng[0]), float(rng[1])
        if not hi >= lo or (kind == "loguniform" and lo <= 0):
            raise ConfigError(f"{where}.sample.{k}", rng,
                              "need lo <= hi (and lo > 0 for loguniform)")
        sample[str(k)] = (kind, lo, hi)
    if sample and n_sample < 1:
        raise ConfigError(f"{where}.sample.n", n_sample, "must be >= 1 when ranges are given")
    if "sample" in d and not sample:
        raise ConfigError(f"{fam_where}.sample", dict(d["sample"]), "has no ranges: give "
                          "{uniform = [lo, hi]}, {loguniform = [lo, hi]} or {choice = [...]}")
    if not grid and not sample:
        raise ConfigError(f"{fam_where}.grid", None, "the family sweeps nothing: give "
                          "[family.grid] lists of values or [family.sample] ranges")
    subset = d.get("subset")
    if subset is not None and (not _is_int(subset) or subset < 1):
        raise ConfigError(f"{where}.subset", subset, "must be an integer >= 1")
    fixed = _table(d, "fixed", where)
    return Family(name, scene, transfer, grid, sample, n_sample, subset, fixed)


def parse_spec(data: Mapping[str, Any], base_dir: str | os.PathLike = ".") -> SweepSpec:
    """Build a :class:`SweepSpec` from parsed TOML; ConfigError names any bad field."""
    _known_keys(data, "spec", ("sweep", "family"))
    sw = _table(data, "sweep", "spec")
    _known_keys(sw, "sweep", SWEEP_KEYS)
    name = _require(sw, "name", "sweep", str)
    duration = sw.get("duration")
    if duration is not None and (not _is_number(duration) or duration <= 0):
        raise ConfigError("sweep.duration", duration, "must be > 0 s")
    batch = sw.get("batch_size", 16)
    if not _is_int(batch) or batch < 1:
        raise ConfigError("sweep.batch_size", batch, "must be an integer >= 1")
    seed = sw.get("seed", 0)
    if not _is_int(seed):
        raise ConfigError("sweep.seed", seed, "must be an integer")
    keep = sw.get("keep_records", False)
    if not isinstance(keep, bool):
        raise ConfigError("sweep.keep_records", keep, "must be true or false")
    surrogate = sw.get("surrogate", True)
    if not isinstance(surrogate, bool):
        raise ConfigError("sweep.surrogate", surrogate, "must be true or false")
    fams_raw = data.get("family", [])
    if not isinstance(fams_raw, list) or not fams_raw:
        raise ConfigError("family", None, "at least one [[family]] table is required")
    fams = tuple(_parse_family(f, f"family[{i}]") for i, f in enumerate(fams_raw))
    names = [f.name for f in fams]
    dup = {n for n in names if names.count(n) > 1}
    if dup:
        raise ConfigError("family.name", sorted(dup)[0], "family names must be unique")
    return SweepSpec(name, fams, None if duration is None else float(duration), seed, batch,
                     keep, surrogate, str(base_dir))


def load_spec(path: str | os.PathLike) -> SweepSpec:
    """Read a sweep spec TOML file."""
    path = Path(path)
    if not path.is_file():
        raise ConfigError("spec", str(path), "file does not exist")
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError("spec", str(path), f"invalid TOML: {exc}") from exc
    return parse_spec(data, path.parent)
