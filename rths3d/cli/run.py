"""CLI command ``rths3d run SCENE``: one vRTHS test, a summary, a record and a plot."""

from __future__ import annotations

import contextlib
import math
import signal
import threading
from pathlib import Path

import typer

from ..figures import new_figure, save_figure
from ._app import app, json_line
from ._output import Keeper, check_file, check_folder

RECORD_SUFFIXES = (".parquet", ".csv")


def _plot(record, path: Path) -> Path:
    """z, z', z^r over time and the synchronisation subspace plot (z' against z); with an
    OpenSees model's element signals, a row more: the interface loop (F'_m against z') and
    the elements' hysteresis loops (force against deformation)."""
    import numpy as np

    dofs = record.dofs
    elements = [c.split(".", 1)[1] for c in record.columns if c.startswith("ele_force.")]
    rows = len(dofs) + bool(elements)
    fig = new_figure((11, 3.6 * rows))
    axes = fig.subplots(rows, 2, squeeze=False, gridspec_kw={"width_ratios": [2.2, 1]})
    if elements:
        _loops(record, dofs, elements, axes[-1])
    t = record.t
    for i, d in enumerate(dofs):
        unit, scale = ("mrad", 1e3) if d.startswith("r") else ("mm", 1e3)
        ax = axes[i, 0]
        z = record.columns[f"z_cmd.{d}"] * scale
        zm = record.columns[f"z_meas.{d}"] * scale
        ax.plot(t, z, label="z (command)", lw=1.2)
        ax.plot(t, zm, label="z' (achieved)", lw=1.0, ls="--")
        if f"z_ref.{d}" in record.columns:
            ax.plot(t, record.columns[f"z_ref.{d}"] * scale, label="z^r (reference)", lw=1.0,
                    ls=":", color="k")
        ax.set_xlabel("t (s)")
        ax.set_ylabel(f"{d} ({unit})")
        ax.legend(loc="upper left", fontsize=8)
        # the errors are thousands of times smaller than the motion: own axis, in µ-units
        axe = ax.twinx()
        axe.plot(t, (z - zm) * 1e3, color="C3", lw=0.6, alpha=0.7, label="z − z' (tracking)")
        if f"z_ref.{d}" in record.columns:
            axe.plot(t, (z - record.columns[f"z_ref.{d}"] * scale) * 1e3, color="C2", lw=0.6,
                     alpha=0.7, label="z − z^r (reference)")
        axe.set_ylabel(f"error ({'µrad' if d.startswith('r') else 'µm'})")
        axe.legend(loc="upper right", fontsize=8)
        ax.grid(alpha=0.3)
        ax2 = axes[i, 1]
        ax2.plot(z, zm, lw=0.8)
        lo, hi = float(np.min(z)), float(np.max(z))
        ax2.plot([lo, hi], [lo, hi], "k:", lw=0.8, label="perfect tracking")
        ax2.set_xlabel(f"{d}: z ({unit})")
        ax2.set_ylabel(f"{d}: z' ({unit})")
        ax2.set_title("SSP")
        ax2.legend(fontsize=8)
        ax2.grid(alpha=0.3)
    meta = record.meta
    fig.suptitle(f"{meta.get('scene', '')} — transfer: {meta.get('transfer', '')} — "
                 f"{meta.get('status', '')} {meta.get('reason', '')}"[:140], fontsize=10)
    return save_figure(fig, path)


def _loops(record, dofs, elements, axes) -> None:
    """The interface force-displacement loop and the elements' hysteresis loops."""
    ax = axes[0]
    for d in dofs:
        unit = "mrad" if d.startswith("r") else "mm"
        ax.plot(record.columns[f"z_meas.{d}"] * 1e3, record.columns[f"f_meas.{d}"], lw=0.8,
                label=f"{d}: F'_m against z' ({unit})")
    ax.set_xlabel("z' (mm, mrad)")
    ax.set_ylabel("F'_m (N, N·m)")
    ax.set_title("interface loop")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    ax = axes[1]
    for e in elements:
        ax.plot(record.columns[f"ele_deformation.{e}"] * 1e3, record.columns[f"ele_force.{e}"],
                lw=0.8, label=f"element {e}")
    ax.set_xlabel("deformation (mm, mrad)")
    ax.set_ylabel("force (N, N·m)")
    ax.set_title("numerical model: hysteresis")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)


@contextlib.contextmanager
def _stop_on_sigint(control):
    """While the block runs, SIGINT calls ``control.stop()`` (the loop ends at the next check
    and keeps what it computed) instead of raising KeyboardInterrupt; the handler before is
    restored afterwards, and at once on the first SIGINT so that a second one interrupts."""
    if threading.current_thread() is not threading.main_thread():
        yield  # signal handlers can only be set from the main thread
        return
    previous = signal.getsignal(signal.SIGINT)
    if previous is None:  # set outside Python: restore the default
        previous = signal.SIG_DFL

    def handler(signum, frame):
        signal.signal(signal.SIGINT, previous)
        control.stop()

    signal.signal(signal.SIGINT, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)


@app.command()
def run(
    scene: str = typer.Argument(..., help="Scene TOML file (or a name from scenes/)."),
    transfer: str = typer.Option(None, "--transfer", "-t",
                                 help="Transfer system: ideal | delay | lti | stewart "
                                      "(default: the scene's)."),
    set_: list[str] = typer.Option([], "--set", "-s",
                                   help="Override a scene value, e.g. --set numerical.k=5000."),
    out: Path = typer.Option(None, "--out", "-o", help="Write the record (.parquet or .csv)."),
    plot: Path = typer.Option(None, "--plot", help="Directory for a PNG of z, z', z^r and "
                                                    "the SSP."),
    json_: bool = typer.Option(False, "--json", help="Print one JSON object instead of a "
                                                     "summary."),
    no_reference: bool = typer.Option(False, "--no-reference",
                                      help="Skip the reference solution z^r."),
    realtime: bool = typer.Option(False, "--realtime", help="Pace every step on the wall "
                                                            "clock (1 kHz at dt = 1 ms); "
                                                            "jitter, latency and overruns "
                                                            "in the record's meta."),
    max_overruns: int = typer.Option(0, "--max-overruns",
                                     help="With --realtime: stop the test safely at the N-th "
                                          "step that overran its slot (0: count only)."),
    rt_priority: int = typer.Option(0, "--rt-priority",
                                    help="With --realtime: run the paced loop under the "
                                         "real-time FIFO scheduler at this priority (1-99; "
                                         "root or CAP_SYS_NICE); 0: the normal scheduler."),
) -> None:
    """Run one vRTHS test of SCENE and print its accuracy measures."""
    from ..errors import ConfigError
    from ..loop import LoopControl
    from ..loop import run as run_loop
    from ..scene import load_scene, transfer_kinds

    if transfer is not None and transfer not in transfer_kinds():
        raise ConfigError("--transfer", transfer, f"must be one of {', '.join(transfer_kinds())}")
    if out is not None and out.suffix.lower() not in RECORD_SUFFIXES:
        raise ConfigError("--out", str(out), "must end in .parquet or .csv")
    sc = load_scene(scene, set_)
    # the outputs are checked before the test runs, not after
    if out is not None:
        check_file(out, "--out", RECORD_SUFFIXES)
    if plot is not None:
        check_folder(plot, "--plot")
    keeper = Keeper()
    # Ctrl-C stops the test like the bench's stop button: the partial record is kept (and
    # written with --out); a second Ctrl-C interrupts as usual. Without pacing, checked
    # every 200 steps (0.2 s of a 1 kHz test), which costs the loop < 1 %
    if max_overruns < 0:
        raise ConfigError("--max-overruns", max_overruns, "must be >= 0 (0: count only)")
    if not 0 <= rt_priority <= 99:
        raise ConfigError("--rt-priority", rt_priority, "must be in 0..99 (0: the normal "
                          "scheduler)")
    pacer = None
    if realtime:
        from ..network.pacing import Pacer

        pacer = Pacer(sc.dt, sc.n_steps, max_overruns=max_overruns, priority=rt_priority)
    control = LoopControl(realtime=realtime, every=200, pacer=pacer)
    with _stop_on_sigint(control):
        try:
            res = run_loop(sc, transfer, reference=not no_reference, control=control,
                           progress=not json_)
        except PermissionError as exc:  # the real-time scheduler refused, before step 0
            if not rt_priority:
                raise
            raise ConfigError("--rt-priority", rt_priority, f"the process may not use the "
                              f"real-time scheduler ({exc.strerror}): run as root or with "
                              f"CAP_SYS_NICE, or 0") from None
    if out is not None:
        # a record the target refuses now is kept in a temporary folder (the error says where)
        res.out = str(keeper.write(res.record.save, out, "--out"))
    measures: dict = {}
    try:
        from ..metrics import compute_measures

        measures = compute_measures(res.record)
        if "aggregate" in measures:  # multi-DOF: dimensionless aggregate over DOFs
            measures = dict(measures["aggregate"])
    except ImportError:
        pass
    except Exception as exc:  # a record too short after an early stop has no measures
        measures = {"measures_error": str(exc)}
    plot_path = None
    if plot is not None:
        name = f"{res.record.meta.get('scene', 'run')}_{res.record.meta.get('transfer', '')}.png"
        plot_path = str(keeper.write(lambda d: _plot(res.record, d / name), plot, "--plot",
                                     folder=True))

    def num(key: str):
        v = measures.get(key)
        if v is None:
            return None
        try:
            v = float(v)
        except (TypeError, ValueError):
            return None
        return v if math.isfinite(v) else None

    summary = {
        "status": res.status, "reason": res.reason, "scene": sc.name,
        "transfer": res.record.meta.get("transfer"),
        "e_rel_ref": num("e_rel_ref"), "e_rel_track": num("e_rel_track"),
        "fei_d": num("fei_d"), "rtf": res.rtf, "out": res.out, "plot": plot_path,
        "duration": float(res.record.duration),
        "omega_num_max": res.record.meta.get("omega_num_max"),
        "omega_dyn_max": res.record.meta.get("omega_dyn_max"),
        "fidelity": res.record.meta.get("fidelity"),
        "pacing": res.record.meta.get("pacing"),
    }
    pac = summary["pacing"]
    if pac and pac["overruns"]:  # the count-only policy's warning (stderr, with --json too)
        typer.echo(f"warning: {pac['overruns']} steps overran their "
                   f"{1e3 / pac['rate_hz']:g} ms slot (first at step "
                   f"{pac['first_overrun']})", err=True)
    if json_:
        typer.echo(json_line(summary))
        keeper.finish()
        return
    typer.echo(f"{sc.name} with transfer '{summary['transfer']}': {res.status}"
               + (f" — {res.reason}" if res.reason else ""))
    for key, label, unit in (("e_rel_ref", "e_rel,ref", ""), ("e_rel_track", "e_rel,track", ""),
                             ("fei_d", "FEI delay d", " s")):
        v = summary[key]
        typer.echo(f"  {label:12s} = {v:.4g}{unit}" if v is not None else f"  {label:12s} = n/a")
    fid = summary["fidelity"]
    if fid:  # the online fidelity monitor ([safety] fidelity_limit)
        peak = ", ".join(f"{p:.3g}" for p in fid["peak"])
        cross = fid["crossed"]
        typer.echo(f"  fidelity     : running RMS of ê peaked at {peak} (limit "
                   f"{fid['limit']:g}, part model {fid['model']})"
                   + (f"; crossed at t = {cross['t']:.3f} s ({cross['dof']})" if cross
                      else "; never crossed"))
        if fid.get("unreliable"):
            typer.echo(f"  fidelity     : from t = {fid['unreliable']['t']:.3f} s "
                       f"{fid['unreliable']['reason']}")
    typer.echo(f"  RTF          = {res.rtf:.1f} (simulated s per wall s)")
    if pac:
        typer.echo(f"  paced        : {pac['rate_hz']:g} Hz, jitter p99 "
                   f"{pac['jitter_p99_s'] * 1e6:.0f} µs (max {pac['jitter_max_s'] * 1e6:.0f}),"
                   f" step latency mean {pac['latency_mean_s'] * 1e6:.0f} µs (p99 "
                   f"{pac['latency_p99_s'] * 1e6:.0f}), overruns {pac['overruns']} of "
                   f"{pac['steps']}")
    if res.out:
        typer.echo(f"  record       → {res.out}")
    if plot_path:
        typer.echo(f"  plot         → {plot_path}")
    keeper.finish()
