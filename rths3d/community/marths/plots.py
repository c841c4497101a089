"""Figures of maRTHS runs (matplotlib, Agg): the benchmark's figures — tracking in x and θ
(target, measured, reference) and the storey drifts of the numerical substructure against
the reference structure."""

from __future__ import annotations

from pathlib import Path

from ...figures import new_figure, save_figure
from .criteria import report
from .engine import MarthsResult

__all__ = ["plot_run"]


def plot_run(res: MarthsResult, path: str | Path, window: tuple[float, float] | None = None
             ) -> Path:
    """Five panels over time: x (mm) and θ (mrad) — numerical target, measured x̂/θ̂ and
    reference — then the drift of storeys 1, 2, 3 (mm), numerical against reference;
    ``window`` (s) zooms into a part of the record."""
    c = res.config
    fig = new_figure((10, 11))
    ax = fig.subplots(5, 1, sharex=True)
    ax[0].plot(res.t, res.num[:, 0], lw=1.0, label="target $x_{num}$")
    ax[0].plot(res.t, res.x_hat[:, 0], "--", lw=1.0, label="measured $\\hat x$")
    ax[0].plot(res.t, res.ref[:, 0], ":", lw=1.0, label="reference $x_{ref}$")
    ax[0].set_ylabel("x (mm)")
    ax[1].plot(res.t, 1e3 * res.num[:, 1], lw=1.0, label="target $\\theta_{num}$")
    ax[1].plot(res.t, 1e3 * res.x_hat[:, 1], "--", lw=1.0, label="measured $\\hat\\theta$")
    ax[1].plot(res.t, 1e3 * res.ref[:, 1], ":", lw=1.0, label="reference $\\theta_{ref}$")
    ax[1].set_ylabel("θ (mrad)")
    floors = [(res.num[:, 0], res.ref[:, 0]), (1e3 * res.num[:, 2], 1e3 * res.ref[:, 2]),
              (1e3 * res.num[:, 4], 1e3 * res.ref[:, 4])]
    below = (0.0 * res.t, 0.0 * res.t)
    for s, (n, r) in enumerate(floors):
        a = ax[2 + s]
        a.plot(res.t, r - below[1], lw=1.0, label="reference")
        a.plot(res.t, n - below[0], "--", lw=1.0, label="numerical (hybrid)")
        a.set_ylabel(f"drift storey {s + 1} (mm)")
        below = (n, r)
    for a in ax:
        a.legend(loc="upper right", fontsize=8)
    ax[-1].set_xlabel("t (s)")
    title = f"maRTHS, {c.record} × {c.intensity}, {res.compensator}"
    if res.status != "ok":
        title += f": STOPPED at {res.t[-1]:.3f} s ({res.reason})"
    else:
        j = report([res.j])
        title += (f": J1 = {j['J1'][0]:.1f}/{j['J1'][1]:.1f} ms, J2 = {j['J2'][0]:.1f}/"
                  f"{j['J2'][1]:.1f} %, J7 = {j['J7'][0]:.1f}/{j['J7'][1]:.1f} %")
    ax[0].set_title(title, fontsize=10)
    if window is not None:
        ax[0].set_xlim(*window)
    return save_figure(fig, path)
