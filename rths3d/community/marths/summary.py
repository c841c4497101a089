"""Runs of several compensators over records and perturbed plants, summarised as the
benchmark reports them (used by ``rths3d benchmark marths`` and the comparison script)."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from .calibration import calibration_record, compensator_configs
from .criteria import J_COUNTS, report
from .data import load_record
from .engine import MarthsConfig, MarthsResult, default_config, run_marths
from .plant import NOMINAL, perturbed_plants

__all__ = ["COMPARED", "configs_for", "entry", "run_set"]

COMPARED = ("none", "polynomial", "ats", "inverse", "rls", "model_based", "rodeac")
"""The compensators scored against RoDeAC (``--compensator all``)."""

MARTHS_PARAMS: dict[str, dict[str, Any]] = {"ats": {"a2_bounds": [-0.0032, 0.0032]}}
"""Settings of the project's compensators for this plant, beside their defaults: ATS's a2
may be negative (actuator 2's zero at 5 Hz makes the best second-order fit's a2 < 0 while
the motion is small; with a2 ≥ 0 ATS stops at 6.3 s of El Centro)."""


def configs_for(name: str, params: Mapping[str, Any] | None, calibrate: bool, initial: str,
                fs: float, data_path: str | None, record: Any = None) -> Any:
    """The config(s) of compensator ``name`` on maRTHS: RoDeAC's θ₀/P₀ from ``initial``; the
    others calibrated per actuator (a pair of configs) when ``calibrate``."""
    from ...compensation import config_from_dict

    p = {**MARTHS_PARAMS.get(name, {}), **dict(params or {})}
    if name == "rodeac":
        return default_config(name, p, initial, data_path)
    if calibrate:
        return compensator_configs(name, p, fs, record, data_path)
    return config_from_dict(name, p, "--comp-set")


def entry(results: Sequence[MarthsResult]) -> dict[str, Any]:
    """The nominal run (first) and, with more, the perturbed trials' mean (as reported)."""
    r0 = results[0]
    e: dict[str, Any] = {"status": r0.status, "reason": r0.reason,
                         "J": report([r0.j]) if r0.j else None,
                         "J_raw": r0.j or None,
                         "max_cmd_V": [round(float(v), 3) for v in
                                       np.abs(r0.command_volts).max(axis=0)]}
    tr = results[1:]
    if tr:
        ok = [r for r in tr if r.status == "ok"]
        t: dict[str, Any] = {"n": len(tr), "ok": len(ok),
                             "stopped": [r.reason for r in tr if r.status != "ok"],
                             "J": report([r.j for r in ok]) if ok else None}
        if ok:
            t["J_max"] = {k: [round(float(max(r.j[k][i] for r in ok)), 3) for i in range(n)]
                          for k, n in J_COUNTS.items()}
        volts = [np.abs(r.command_volts).max(axis=0) for r in tr]
        t["realizable"] = not any(bool(v[0] > 3.8 and v[1] > 3.8) for v in volts)
        e["trials"] = t
    return e


def run_set(names: Sequence[str], records: Sequence[str], intensity: float = 0.4,
            trials: int = 0, seed: int = 123, initial: str = "stored", calibrate: bool = True,
            params: Mapping[str, Mapping[str, Any]] | None = None, noise: bool = True,
            t_end: float | None = None, fs: float = 1024.0, data_path: str | None = None,
            keep: Callable[[str, str, MarthsResult], None] | None = None,
            progress: Callable[[str, str], None] | None = None,
            numerical: Any = None) -> dict[str, Any]:
    """Every compensator in ``names`` on every record, nominal plant plus ``trials``
    perturbed ones (drawn with ``seed``, the same for all), stepped together. Returns
    ``{record: {name: entry}}``; ``keep(record, name, nominal_result)`` sees each nominal run.
    ``numerical``: an outside numerical substructure (:func:`.engine.run_marths`)."""
    params = params or {}
    plants = [NOMINAL, *perturbed_plants(trials, seed)]
    rec = None
    if calibrate and any(n not in ("rodeac", "none") for n in names):
        rec = calibration_record(fs, data_path=data_path)
    confs = {n: configs_for(n, params.get(n), calibrate, initial, fs, data_path, rec)
             for n in names}
    out: dict[str, Any] = {}
    for record in records:
        cfg = MarthsConfig(record=record, intensity=intensity, fs=fs, noise=noise, t_end=t_end)
        gm = load_record(record, 1.0, data_path)
        out[cfg.record] = {}
        for n in names:
            if progress is not None:
                progress(cfg.record, n)
            rs = run_marths(cfg, n, confs[n], plants=plants, data_path=data_path, gm=gm,
                            initial=initial, numerical=numerical)
            out[cfg.record][n] = entry(rs)
            if keep is not None:
                keep(cfg.record, n, rs[0])
    return out
