"""Running a sweep: batches of tests on local cores (process pool) or a Dask cluster.

The test list of a spec is cut into fixed batches (at most ``batch_size`` tests of one
setting the loop steps together, batch id ``b00000``…); batches are the unit of work, of
storage and of resumption. Each batch is run by :func:`rths3d.dataset.runner.run_rows` (the
loop's K-tests-stepped-together path), wherever it executes; the rows come back to this
process, which writes the part atomically. Workers never write to the table, so a Dask
cluster needs no shared file system (except for ``keep_records``).
"""

from __future__ import annotations

import dataclasses
import hashlib
import inspect
import itertools
import os
import pickle
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .._lifeline import worker_init
from ..errors import ConfigError
from .runner import add_progress, warm_tests
from .spec import SweepSpec, batch_group_key
from .store import SweepStore

if TYPE_CHECKING:
    import pandas as pd

RowsFn = Callable[[SweepSpec, list[dict[str, Any]], str | None], list[dict[str, Any]]]


def batches_of(spec: SweepSpec) -> list[tuple[str, list[dict[str, Any]]]]:
    """The sweep's tests cut into its fixed batches: ``[(batch_id, tests), …]``.

    The tests are gathered by the setting the loop steps together
    (:func:`~rths3d.dataset.spec.batch_group_key`; stable, so the spec's order holds within a
    setting) and each group is cut into the fewest batches of at most ``batch_size``, of
    nearly equal size, so that no batch straddles two settings (a straddling batch runs as
    two smaller ones, which costs a step overhead each). The merged table keeps the spec's
    test order whatever the batches.
    """
    from ..scene import load_scene

    def base_of(fam) -> dict[str, Any]:
        try:  # an unreadable scene fails when the batch runs
            scene = spec.scenes.get(fam.name) or load_scene(spec.scene_path(fam))
        except ConfigError:
            return {}
        settings = scene.params()
        if fam.transfer:
            settings["transfer.kind"] = fam.transfer
        return settings

    bases = {f.name: base_of(f) for f in spec.families}

    def key(test: dict[str, Any]) -> str:
        return batch_group_key(test, bases[test["family"]])

    b = spec.batch_size
    chunks: list[list[dict[str, Any]]] = []
    for _, group in itertools.groupby(sorted(spec.tests(), key=key), key=key):
        run = list(group)
        n = -(-len(run) // b)
        size, extra = divmod(len(run), n)  # the first `extra` batches take one test more
        start = [j * size + min(j, extra) for j in range(n + 1)]
        chunks.extend(run[start[j]:start[j + 1]] for j in range(n))
    return [(f"b{i:05d}", c) for i, c in enumerate(chunks)]


_UNKNOWN_NAME = ("unknown field", "is not a table")


def prepare(spec: SweepSpec) -> SweepSpec:
    """``spec`` with every family's base scene loaded here, in the submitting process.

    A missing or invalid scene, or a parameter name the scene does not have (each family's
    fixed, grid and sample keys are applied to its base scene once), is one ConfigError
    before anything runs; the workers get the scenes with the spec, so they need neither the
    scene files nor this process's working folder. Bad parameter *values* stay per-test
    ``error`` rows.
    """
    from ..scene import load_scene, scene_with

    scenes = {}
    for fam in spec.families:
        path = spec.scene_path(fam).resolve()
        try:
            base = load_scene(path)
        except ConfigError as exc:
            raise ConfigError(exc.field, exc.value, exc.limit,
                              message=f"family {fam.name!r}: {exc}") from None
        probe = base.with_transfer(fam.transfer) if fam.transfer else base
        firsts = {**{k: v[0] for k, v in fam.grid.items()}, **fam.fixed,
                  **{k: (lo[0] if kind == "choice" else lo)
                     for k, (kind, lo, _) in fam.sample.items()}}
        for key, value in firsts.items():
            try:
                scene_with(probe, {key: value})
            except ConfigError as exc:
                if any(u in exc.limit for u in _UNKNOWN_NAME):
                    raise ConfigError(f"family {fam.name!r} parameter", key,
                                      f"scene {fam.scene!r} has no such key; {exc.field}: "
                                      f"{exc.limit}") from None
        scenes[fam.name] = base
    return dataclasses.replace(spec, base_dir=str(Path(spec.base_dir).resolve()),
                               scenes=scenes)


def scene_hashes(spec: SweepSpec) -> dict[str, str]:
    """Hash of each family's base scene file (guards resuming after a scene was edited)."""
    return {f.name: hashlib.sha256(spec.scene_path(f).read_bytes()).hexdigest()[:16]
            for f in spec.families}


def run_sweep(spec: SweepSpec, out: str | os.PathLike, *, workers: int | None = None,
              scheduler: str | None = None, progress: bool = True,
              max_batches: int | None = None, rows_fn: RowsFn | None = None
              ) -> pd.DataFrame | None:
    """Run every unfinished batch of ``spec`` and merge the table; returns the DataFrame.

    ``workers``: local processes (default: all cores; 1 runs in this process).
    ``scheduler``: address of a Dask distributed scheduler (``tcp://host:port``); when given,
    batches are submitted to that cluster instead. ``max_batches`` stops after that many new
    batches (for tests and staged runs; the table is then not merged). The merged table is
    written to ``out/<name>.parquet`` once every batch is done. If a batch fails, the batches
    that finished are written before the error is raised.
    """
    from .runner import run_rows

    # every mistake is reported before the output folder is created or touched
    if workers is not None and (isinstance(workers, bool) or workers < 1):
        raise ConfigError("workers", workers, "must be >= 1")
    _start_method()
    rows_fn = rows_fn or run_rows
    spec = prepare(spec)
    if scheduler:
        _probe_scheduler(scheduler)
    all_batches = batches_of(spec)
    store = SweepStore(out, spec.name, spec.digest(), spec.batch_size,
                       sum(len(t) for _, t in all_batches), scene_hashes(spec)).open()
    done = store.done()
    todo = [(bid, tests) for bid, tests in all_batches if bid not in done]
    if max_batches is not None:
        todo = todo[:max_batches]
    rec_dir = str(store.records) if spec.keep_records else None
    n_total = store.n_tests
    n_done = sum(len(t) for bid, t in all_batches if bid in done)
    bar = None
    counts = {"stopped": 0, "error": 0}
    if progress:
        from tqdm import tqdm

        class _Bar(tqdm):  # type: ignore[misc, type-arg]
            monitor_interval = 0  # no monitor thread: the workers can be forked (fork_is_safe)

        # the bar moves within a batch too (by simulated time), so it counts fractions
        bar = _Bar(total=n_total, initial=n_done, desc=f"sweep {spec.name}", unit="test",
                   dynamic_ncols=True,
                   bar_format="{l_bar}{bar}| {n:.0f}/{total_fmt} [{elapsed}<{remaining}, "
                              "{rate_fmt}{postfix}]")

    def advance(tests: float) -> None:
        if bar is not None:
            bar.update(tests)

    def finished(bid: str, rows: list[dict[str, Any]]) -> None:
        store.write_part(bid, rows)
        for r in rows:
            if r.get("status") in counts:
                counts[r["status"]] += 1
        if bar is not None:
            # the names of the closing summary: a stopped test is not an error
            bar.set_postfix(counts, refresh=False)

    try:
        if not todo:
            pass
        elif scheduler:
            _run_dask(spec, todo, scheduler, rec_dir, rows_fn, finished, advance)
        else:
            n = workers if workers is not None else (os.cpu_count() or 1)
            if n == 1 or len(todo) == 1:
                for bid, tests in todo:
                    finished(bid, _rows_reporting(rows_fn, spec, tests, rec_dir, advance))
            else:
                _run_pool(spec, todo, n, rec_dir, rows_fn, finished, bar)
    finally:
        if bar is not None:
            bar.close()
    if store.done() >= {bid for bid, _ in all_batches}:
        meta = {"name": spec.name, "digest": spec.digest(), "n_tests": n_total,
                "written": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime())}
        return store.merge([bid for bid, _ in all_batches], meta,
                           order=[t["test_id"] for t in spec.tests()])
    return None


def _rows_reporting(rows_fn: RowsFn, spec: SweepSpec, tests: list[dict[str, Any]],
                    rec_dir: str | None, report: Callable[[float], None]
                    ) -> list[dict[str, Any]]:
    """``rows_fn`` on one batch, reporting its progress in tests (fractions within the
    batch, when ``rows_fn`` takes a ``progress`` callback); exactly ``len(tests)`` in all
    once it has finished."""
    done = 0.0

    def step(x: float) -> None:
        nonlocal done
        x = min(float(x), len(tests) - done)
        if x > 0:
            done += x
            report(x)

    if "progress" in inspect.signature(rows_fn).parameters:
        rows = rows_fn(spec, tests, rec_dir, progress=step)
    else:
        rows = rows_fn(spec, tests, rec_dir)
    step(len(tests) - done)
    return rows


def _rows_in_worker(rows_fn: RowsFn, spec: SweepSpec, tests: list[dict[str, Any]],
                    rec_dir: str | None) -> list[dict[str, Any]]:
    return _rows_reporting(rows_fn, spec, tests, rec_dir, add_progress)


def fork_is_safe() -> bool:
    """Whether this process can start its sweep workers by ``fork``: a POSIX ``fork`` start
    method, no Python thread but this one (a thread holding a lock at the fork would leave
    it held in the child) and no torch (its OpenMP pool is not fork-safe once used)."""
    import multiprocessing as mp
    import sys

    return ("fork" in mp.get_all_start_methods() and threading.active_count() == 1
            and "torch" not in sys.modules)


def _stop_tqdm_monitor() -> None:
    """End tqdm's monitor thread (it watches open bars every 10 s and starts again with the
    next bar): a thread this process need not have while it forks its workers."""
    import sys

    std = sys.modules.get("tqdm.std")
    monitor = getattr(getattr(std, "tqdm", None), "monitor", None)
    if monitor is not None:
        monitor.exit()  # sets its event and joins it
        std.tqdm.monitor = None  # type: ignore[union-attr]


START_ENV = "RTHS3D_START_METHOD"
"""Environment variable: how local sweep workers start — ``auto`` (default: forked from the
warm sweep process where :func:`fork_is_safe`, else from a forkserver) or ``forkserver``
(always a clean process)."""


def _start_method() -> str:
    how = os.environ.get(START_ENV, "auto") or "auto"
    if how not in ("auto", "forkserver"):
        raise ConfigError(START_ENV, how, "auto or forkserver")
    return how


def _pool_context(spec: SweepSpec, todo: list) -> tuple[Any, bytes | None]:
    """The workers' start method and their warm-up.

    Where :func:`fork_is_safe` (and :data:`START_ENV` is not ``forkserver``), this process
    loads the sweep's imports and compiled kernels once (:func:`~rths3d.dataset.runner.
    warm_up` of one test per setting, single-threaded) and the workers are forked from it:
    they start warm, sharing that memory, in milliseconds. Otherwise they start from a
    forkserver (a clean process: no inherited threads of MuJoCo or torch) and each warms
    itself before its first batch (the pickled warm-up, unpickled after its lifeline is
    armed): ≈ 2 s each on this machine.
    """
    import multiprocessing as mp

    from .runner import THREADS_ENV, warm_up

    if _start_method() == "auto" and fork_is_safe():
        threads = os.environ.get(THREADS_ENV)
        os.environ[THREADS_ENV] = "1"  # no MuJoCo thread pool in the process to fork
        try:
            warm_up(spec, warm_tests(todo))
        finally:
            if threads is None:
                os.environ.pop(THREADS_ENV, None)
            else:
                os.environ[THREADS_ENV] = threads
        import gc

        _stop_tqdm_monitor()  # a progress bar's monitor thread, started by the warm-up
        gc.collect()  # the warm-up's objects (a MuJoCo batch ends its threads) go first
        if fork_is_safe():  # the warm-up started no other thread
            # what this process holds moves to the collector's permanent generation: a
            # worker's collections then do not walk (and so copy) the pages it inherited
            gc.freeze()
            return mp.get_context("fork"), None
    return mp.get_context("forkserver"), pickle.dumps((spec, warm_tests(todo)))


def _run_pool(spec, todo, n, rec_dir, rows_fn, finished, bar) -> None:
    from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait

    ctx, warm = _pool_context(spec, todo)
    done = ctx.Value("d", 0.0)  # tests' worth of work the workers have done
    start = bar.n if bar is not None else 0.0
    # Lifeline: only this process holds the pipe's write end. Each worker watches the read
    # end; EOF means this process has gone (even by SIGKILL), and the worker exits, so that
    # nothing is left running: with the workers gone, the forkserver (if any) and the
    # resource tracker end too. A forked worker inherits a copy of the write end: it closes
    # it first thing, else the pipe would never see EOF while a worker lives.
    lifeline_r, lifeline_w = ctx.Pipe(duplex=False)
    inherited = lifeline_w if ctx.get_start_method() == "fork" else None
    try:
        with ProcessPoolExecutor(max_workers=n, mp_context=ctx, initializer=worker_init,
                                 initargs=(lifeline_r, done, warm, inherited)) as pool:
            pending = {}
            it = iter(todo)
            # keep at most 2 batches per worker in flight so finished ones are written
            # promptly
            for bid, tests in it:
                pending[pool.submit(_rows_in_worker, rows_fn, spec, tests, rec_dir)] = bid
                if len(pending) >= 2 * n:
                    break
            error: BaseException | None = None
            while pending:
                ready, _ = wait(pending, timeout=0.5, return_when=FIRST_COMPLETED)
                if bar is not None:
                    bar.n = start + done.value
                    bar.refresh()
                for fut in ready:
                    bid = pending.pop(fut)
                    if fut.cancelled():
                        continue
                    if fut.exception() is not None:
                        if error is None:
                            # stop submitting; the batches under way still finish and are kept
                            error = fut.exception()
                            for other in pending:
                                other.cancel()
                        continue
                    finished(bid, fut.result())
                    nxt = next(it, None) if error is None else None
                    if nxt is not None:
                        pending[pool.submit(_rows_in_worker, rows_fn, spec, nxt[1],
                                            rec_dir)] = nxt[0]
            if error is not None:
                raise error
    finally:
        lifeline_w.close()
        lifeline_r.close()
        if inherited is not None:
            import gc

            gc.unfreeze()  # frozen before the fork (_pool_context)


SCHEDULER_TIMEOUT = 10.0
"""Seconds a Dask scheduler has to answer (connection and handshake)."""


def _probe_scheduler(address: str, timeout: float = SCHEDULER_TIMEOUT) -> None:
    """ConfigError unless a Dask scheduler answers at ``address`` within ``timeout`` s.

    distributed's own connect waits forever for the handshake of a server that accepts the
    connection but is not a Dask scheduler (its timeout covers the connection only), so the
    whole exchange runs under one deadline, in a thread of its own (the caller may have an
    event loop running)."""
    import asyncio

    try:
        from distributed.comm import connect
    except ImportError as exc:  # pragma: no cover - dask[distributed] is a dependency
        raise ConfigError("scheduler", address, "needs dask[distributed] installed") from exc
    failed: list[BaseException] = []

    async def handshake() -> None:
        comm = await asyncio.wait_for(connect(address, timeout=timeout), timeout)
        await comm.close()

    def probe() -> None:
        try:
            asyncio.run(handshake())
        except BaseException as exc:  # noqa: BLE001 - reported below as one line
            failed.append(exc)

    worker = threading.Thread(target=probe, name="rths3d-scheduler-probe", daemon=True)
    worker.start()
    worker.join(timeout + 5.0)
    if worker.is_alive() or failed:
        why = (f"no answer within {timeout:g} s" if worker.is_alive() or
               isinstance(failed[0], TimeoutError) else str(failed[0]) or type(failed[0]).__name__)
        raise ConfigError("scheduler", address, f"no Dask scheduler answers there ({why})")


def _run_dask(spec, todo, scheduler, rec_dir, rows_fn, finished, advance) -> None:
    try:
        from distributed import Client, as_completed
    except ImportError as exc:  # pragma: no cover - dask[distributed] is a dependency
        raise ConfigError("scheduler", scheduler, "needs dask[distributed] installed") from exc
    try:
        client = Client(scheduler, timeout="10s")
    except (OSError, TimeoutError, ValueError, TypeError) as exc:
        # a malformed address is a ValueError/TypeError of the comm layer
        raise ConfigError("scheduler", scheduler, f"cannot connect: {exc}") from None
    try:
        futs = {client.submit(rows_fn, spec, tests, rec_dir, key=f"rths3d-{spec.name}-"
                              f"{spec.digest()}-{bid}", pure=False): bid
                for bid, tests in todo}
        written: set[str] = set()
        try:
            for fut in as_completed(list(futs)):
                rows = fut.result()
                finished(futs[fut], rows)
                advance(len(rows))
                written.add(futs[fut])
        except BaseException:
            # keep every batch the cluster has already finished, then report the failure
            for fut, bid in futs.items():
                if fut.status == "finished" and bid not in written:
                    rows = fut.result()
                    finished(bid, rows)
                    advance(len(rows))
            raise
    finally:
        client.close()


def table_path(spec: SweepSpec, out: str | os.PathLike) -> Path:
    """Where :func:`run_sweep` writes the merged table."""
    return Path(out) / f"{spec.name}.parquet"
