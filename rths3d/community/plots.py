"""Figures of benchmark runs (matplotlib, Agg backend): time histories and trial spread."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ..figures import new_figure, save_figure
from .simulate import BenchmarkResult

__all__ = ["plot_compensator", "plot_result", "plot_trials"]


def plot_result(res: BenchmarkResult, path: str | Path, window: tuple[float, float] | None = None
                ) -> Path:
    """Floor-1 tracking (y_n, x_m, x_r1), floor 2–3 errors and the actuator force of a run."""
    c = res.config
    fig = new_figure((9, 8))
    ax = fig.subplots(3, 1, sharex=True)
    ax[0].plot(res.t, 1e3 * res.x_num[:, 0], label="desired $y_n = x_{n1}$")
    ax[0].plot(res.t, 1e3 * res.x_m, "--", label="measured $x_m$")
    ax[0].plot(res.t, 1e3 * res.x_ref[:, 0], ":", label="reference $x_{r1}$")
    ax[0].set_ylabel("floor 1 (mm)")
    ax[0].legend(loc="upper right")
    for f, style in ((2, "-"), (1, "--")):  # floor 3 first: floor 2's smaller error on top
        ax[1].plot(res.t, 1e3 * (res.x_num[:, f] - res.x_ref[:, f]), style, lw=0.9,
                   label=f"floor {f + 1}")
    ax[1].set_ylabel("$x_n - x_r$ (mm)")
    ax[1].legend(loc="upper right")
    ax[2].plot(res.t, 1e-3 * res.f_act)
    for s in (-1, 1):
        ax[2].axhline(s * 1e-3 * c.force_limit, color="r", lw=0.8)
    ax[2].set_ylabel("$F_{act}$ (kN)")
    ax[2].set_xlabel("t (s)")
    row = res.table_row()
    title = (f"case {c.case}, {c.excitation} × {c.intensity}: J1 = {row['J1']:.1f} ms, "
             f"J2 = {row['J2']:.2f} %, J4 = {row['J4']:.2f} %")
    if res.status != "ok":
        title = f"case {c.case}, {c.excitation} × {c.intensity}: STOPPED at {res.t[-1]:.3f} s"
    ax[0].set_title(title)
    if window is not None:
        ax[0].set_xlim(*window)
    return save_figure(fig, path)


def plot_trials(rows: Mapping[int, Sequence[Mapping[str, float]]], path: str | Path,
                published: Mapping[int, Mapping[str, float]] | None = None) -> Path:
    """Box plots of J2–J9 over perturbed trials per case (``rows[case]`` = table rows), with
    the published nominal values as markers where given."""
    keys = [f"J{i}" for i in range(2, 10)]
    cases = sorted(rows)
    fig = new_figure((3.2 * len(cases), 4))
    axes = fig.subplots(1, len(cases), sharey=True, squeeze=False)
    for ax, c in zip(axes[0], cases, strict=True):
        data = np.array([[r[k] for k in keys] for r in rows[c]])
        ax.boxplot(data, tick_labels=keys)
        if published and c in published:
            ax.plot(range(1, len(keys) + 1), [published[c][k] for k in keys], "r*",
                    label="published (nominal)")
            ax.legend(loc="upper right", fontsize=8)
        ax.set_title(f"case {c} ({len(rows[c])} trials)")
        ax.tick_params(axis="x", labelrotation=60)
    axes[0][0].set_ylabel("criterion (%)")
    return save_figure(fig, path)


def plot_compensator(res: BenchmarkResult, bench: BenchmarkResult | None, path: str | Path,
                     window: tuple[float, float] = (5.0, 15.0)) -> Path:
    """A run with a compensator: its tracking error beside the benchmark controller's (same
    case), the compensator's command against the desired displacement, and its coefficients
    over the run (``res.history``)."""
    hist = {k: v for k, v in res.history.items() if k != "t"}
    if "gain" in hist and "lead" in hist:
        hist = {"gain": hist["gain"], "lead (s)": hist["lead"]}
    units = {"a1": " (s)", "a2": " (s²)", "u_fb": " (m)", "tau": " (s)"}
    keys = list(hist)[:3]
    fig = new_figure((9, 3.0 * (2 + len(keys))))
    ax = fig.subplots(2 + len(keys), 1, sharex=True, squeeze=False)[:, 0]
    sel = (res.t >= window[0]) & (res.t <= window[1])
    ax[0].plot(res.t[sel], 1e3 * res.x_num[sel, 0], label="desired $y_n$")
    if res.y_p is not None:
        ax[0].plot(res.t[sel], 1e3 * res.y_p[sel], "--", label=f"command $y_p$ ({res.compensator})")
    ax[0].plot(res.t[sel], 1e3 * res.x_m[sel], ":", label="measured $x_m$")
    ax[0].set_ylabel("floor 1 (mm)")
    ax[0].legend(loc="upper right")
    if bench is not None:
        bs = (bench.t >= window[0]) & (bench.t <= window[1])
        ax[1].plot(bench.t[bs], 1e3 * (bench.x_m[bs] - bench.x_num[bs, 0]), lw=0.8,
                   label="benchmark controller")
    ax[1].plot(res.t[sel], 1e3 * (res.x_m[sel] - res.x_num[sel, 0]), lw=0.8,
               label=res.compensator)
    ax[1].set_ylabel("$x_m - y_n$ (mm)")
    ax[1].legend(loc="upper right")
    if "t" in res.history:
        th = res.history["t"]
        hs = (th >= window[0]) & (th <= window[1])
        for a, k in zip(ax[2:], keys, strict=True):
            a.plot(th[hs], hist[k][hs])
            a.set_ylabel(k + units.get(k, ""))
    ax[-1].set_xlabel("t (s)")
    row = res.table_row()
    c = res.config
    ax[0].set_title(f"case {c.case}, {res.compensator}: J1 = {row['J1']:.1f} ms, "
                    f"J2 = {row['J2']:.2f} %, J4 = {row['J4']:.2f} %" if res.status == "ok"
                    else f"case {c.case}, {res.compensator}: STOPPED — {res.reason}")
    return save_figure(fig, path)
