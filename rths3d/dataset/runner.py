"""One batch of a sweep → table rows: the loop's batch API, then the measures.

This is the function a local worker process or a Dask worker executes. It loads each family's
base scene, applies the test's dotted-key overrides (and the sweep's duration and transfer
kind), runs the batch through :func:`rths3d.loop.run_batch` (compatible tests stepped
together) and turns every record into one row: ``param.*``, ``feature.*`` (Table-3 set 1,
which contains sets 2 and 3, and the surrogate inputs :data:`~rths3d.metrics.SURROGATE`:
the reference error estimated from a surrogate of the part identified from the record,
:mod:`rths3d.metrics.fidelity`), ``target.*`` (reference errors), ``measure.*`` (every
other scalar measure) and ``status``/``reason``. A test that stops (safety limit, divergence) or
whose parameters are invalid is kept as a row with its reason.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import RthsError
from ..metrics.features import INPUTS
from ..metrics.fidelity import KEYS as SURROGATE_MEASURES
from .spec import SweepSpec
from .table import COMP, FEATURE, MEASURE, PARAM, TARGET, TARGETS, compensator_columns

THREADS_ENV = "RTHS3D_THREADS"
"""Environment variable: threads of a batch's MuJoCo thread pool (0 or unset: 2). Local
worker processes set it to 1."""


_progress: Any = None
"""In a pool worker: the sweep's shared progress counter (tests' worth of work done)."""


def worker_setup(progress=None, warm: bytes | None = None) -> None:
    """The rest of a pool worker's start, after :func:`rths3d._lifeline.worker_init` has
    bound its life to the sweep's: one core per worker, the shared progress counter, and a
    warm start — ``warm`` (pickled ``(spec, tests)``, :func:`warm_tests`) runs those tests
    for a few steps, so that the imports and compiled kernels of the sweep's settings are
    loaded once per worker and kept for the sweep."""
    global _progress
    # One core per worker process: the parallelism is across processes (MuJoCo batches too:
    # two 2-thread batches on 2 cores thrash, one thread each does not).
    # torch, imported only by a sweep that needs it (the surrogate), takes its thread count
    # from OMP_NUM_THREADS then; importing it here cost each worker 2 s of its start
    os.environ.setdefault("OMP_NUM_THREADS", "1")
    os.environ.setdefault(THREADS_ENV, "1")
    _progress = progress
    if warm is not None:
        import pickle

        spec, tests = pickle.loads(warm)
        warm_up(spec, tests)


def add_progress(x: float) -> None:
    """Add ``x`` tests' worth of work to the sweep's shared counter (in a pool worker)."""
    if _progress is not None:
        with _progress.get_lock():
            _progress.value += x


def warm_tests(batches: Sequence[tuple[str, list[dict[str, Any]]]]) -> list[dict[str, Any]]:
    """One test of each family and transfer system among ``batches`` (``[(id, tests)]``)."""
    seen: dict[tuple, dict[str, Any]] = {}
    for _, tests in batches:
        for t in tests:
            seen.setdefault((t["family"], t.get("transfer") or "",
                             t["params"].get("transfer.kind", "")), t)
    return list(seen.values())


WARM_DURATION = 0.05
"""Simulated time (s) of a worker's warm-up tests."""


def warm_up(spec: SweepSpec, tests: list[dict[str, Any]]) -> None:
    """Run ``tests`` of ``spec`` for :data:`WARM_DURATION` and drop their rows: the loop,
    the reference, the measures and their compiled kernels are loaded. A warm-up that fails
    leaves the loading to the first batch (which reports its own errors)."""
    import dataclasses

    short = dataclasses.replace(spec, duration=WARM_DURATION)
    for t in tests:
        params = {k: v for k, v in t["params"].items() if k != "duration"}
        try:
            run_rows(short, [{**t, "params": params}])
        except Exception:  # noqa: BLE001 - the batch itself runs and reports
            pass


def _overrides(spec: SweepSpec, test: dict[str, Any], base=None) -> dict[str, Any]:
    ov = dict(test["params"])
    if spec.duration is not None:
        ov.setdefault("duration", spec.duration)
    if test.get("transfer"):
        ov["transfer.kind"] = test["transfer"]
    noise = ov.get("sensor.noise_std", base.sensor.noise_std if base is not None else 0.0)
    if noise:
        # the test's own seed, so that its noise does not depend on its batch-mates; only for
        # noisy tests (the seed does nothing without noise)
        ov.setdefault("sensor.seed", int(test["seed"]))
    return ov


def _param_value(v: Any) -> Any:
    # Parquet columns need one type: booleans and numbers as float, the rest as text
    if isinstance(v, bool):
        return float(v)
    if isinstance(v, int | float):
        return float(v)
    return str(v)


def record_features(record) -> dict[str, float]:
    """Flat scalar measures of one record (aggregate for multi-DOF records)."""
    from ..metrics import compute_measures

    m = compute_measures(record)
    flat = m.get("aggregate", m) if isinstance(m, dict) else {}
    out: dict[str, float] = {}
    for k, v in flat.items():
        if isinstance(v, bool):
            continue
        if isinstance(v, int | float):
            out[k] = float(v)
    return out


def _row(test: dict[str, Any], status: str, reason: str, measures: dict[str, float],
         all_params: Sequence[str], comp: dict[str, Any] | None = None) -> dict[str, Any]:
    row: dict[str, Any] = {"test_id": test["test_id"], "family": test["family"],
                           "scene": test["scene"], "transfer": test.get("transfer") or "",
                           "seed": int(test["seed"]), "status": status, "reason": reason}
    row.update(comp or {})
    for k in all_params:
        v = test["params"].get(k)
        row[PARAM + k] = math.nan if v is None else _param_value(v)
    for k in INPUTS:
        row[FEATURE + k] = measures.get(k, math.nan)
    for k in TARGETS:
        row[TARGET + k] = measures.get(k, math.nan)
    for k in SURROGATE_MEASURES:
        if k not in INPUTS:
            row[MEASURE + k] = measures.get(k, math.nan)
    for k, v in sorted(measures.items()):
        if k not in INPUTS and k not in TARGETS and k not in SURROGATE_MEASURES:
            row[MEASURE + k] = v
    return row


def _measure(res) -> tuple[str, str, dict[str, float]]:
    status, reason = res.status, res.reason
    try:
        meas = record_features(res.record)
    except (RthsError, ValueError, FloatingPointError) as exc:
        # a test stopped in its first samples has too short a record for the measures
        meas = {}
        if status == "ok":
            status, reason = "error", f"measures failed: {exc}"
    return status, reason, meas


def run_rows(spec: SweepSpec, tests: list[dict[str, Any]], records_dir: str | None = None,
             progress: Callable[[float], None] | None = None) -> list[dict[str, Any]]:
    """Run ``tests`` (one batch of ``spec``) and return one row per test, in order.

    ``progress``: called now and then with the tests' worth of work done since its last call
    (simulated time over the duration; see :func:`rths3d.loop.run_batch`)."""
    # NaN/inf of unstable tests are detected and reported, not raised
    with np.errstate(all="ignore"):
        return _run_rows(spec, tests, records_dir, progress)


def _run_rows(spec: SweepSpec, tests: list[dict[str, Any]], records_dir: str | None,
              progress: Callable[[float], None] | None = None) -> list[dict[str, Any]]:
    from ..loop import run_batch
    from ..scene import load_scene

    # every row carries all parameter columns of the families in this batch (NaN where unset)
    keys = {k for t in tests for k in t["params"]}
    for fam in spec.families:
        if any(t["family"] == fam.name for t in tests):
            keys |= set(fam.grid) | set(fam.sample) | set(fam.fixed)
    all_params = sorted(keys)
    rows: list[dict[str, Any] | None] = [None] * len(tests)
    by_family: dict[str, list[int]] = {}
    for i, t in enumerate(tests):
        by_family.setdefault(t["family"], []).append(i)
    for fam_name, idx in by_family.items():
        fam = next(f for f in spec.families if f.name == fam_name)
        base = spec.scenes.get(fam.name) or load_scene(spec.scene_path(fam))
        sets = [_overrides(spec, tests[i], base) for i in idx]
        nthread = int(os.environ.get(THREADS_ENV) or 0)
        try:
            results = run_batch(base, sets, nthread=nthread,
                                progress=progress if progress is not None else False)
        except RthsError:
            # isolate the offending test(s); the others still run
            results = []
            for ps in sets:
                try:
                    results.append(run_batch(base, [ps], nthread=nthread)[0])
                except RthsError as exc:
                    results.append(exc)
        measured = {}
        for i, res in zip(idx, results, strict=True):
            if isinstance(res, Exception):
                # a test that did not run: its compensator as its parameters name it
                name = tests[i]["params"].get("transfer.compensation",
                                              base.transfer.compensation)
                rows[i] = _row(tests[i], "error", str(res), {}, all_params,
                               {COMP + "name": str(name)})
                continue
            measured[i] = _measure(res)
        # the surrogate estimate of every finished test, identified one by one and coupled
        # together (one interface iteration for the batch)
        done = [i for i, (status, _, _) in measured.items()
                if status == "ok" and spec.surrogate]
        for i, extra in zip(done, _surrogate([results[idx.index(i)].record for i in done]),
                            strict=True):
            measured[i][2].update(extra)
        for i, (status, reason, meas) in measured.items():
            res = results[idx.index(i)]
            rows[i] = _row(tests[i], status, reason, meas, all_params,
                           compensator_columns(res.record))
            if records_dir:
                res.record.save(Path(records_dir) / f"{tests[i]['test_id']}.parquet")
    return rows  # type: ignore[return-value]


def _surrogate(records: list) -> list[dict[str, float]]:
    """Surrogate estimates of finished tests (:func:`rths3d.metrics.surrogate_measures`);
    a failure leaves that test's estimate out (NaN columns), not the batch."""
    from ..metrics.fidelity import surrogate_measures

    if not records:
        return []
    try:
        return surrogate_measures(records)  # type: ignore[return-value]
    except (RthsError, ValueError, ArithmeticError, np.linalg.LinAlgError):
        out = []
        for r in records:
            try:
                out.append(surrogate_measures(r))
            except (RthsError, ValueError, ArithmeticError, np.linalg.LinAlgError):
                out.append({})
        return out
