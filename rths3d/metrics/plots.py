"""Pictures of a record's tracking: SSP, FEI spectrum, time histories and the estimated
fidelity at every time step (matplotlib, Agg).

Each function writes one PNG with one row of panels per interface DOF and returns its path.
The SSP is drawn with z on the horizontal axis and z' on the vertical axis (a lagging
transfer system traces it counter-clockwise; see :mod:`rths3d.metrics.ssp`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..figures import new_figure, save_figure
from ..record import Record
from .frequency import fei
from .ssp import fit_ellipse, paei
from .tracking import one_sided_amplitude

UNITS = {"x": "m", "y": "m", "z": "m", "rx": "rad", "ry": "rad", "rz": "rad"}
FORCE_UNITS = {"x": "N", "y": "N", "z": "N", "rx": "N·m", "ry": "N·m", "rz": "N·m"}


def _figure(rows: int, cols: int, height: float = 3.2, width: float = 5.0):
    fig = new_figure((width * cols, height * rows))
    axes = fig.subplots(rows, cols, squeeze=False)
    return fig, axes


def plot_ssp(record: Record, path: str | Path) -> Path:
    """Synchronization Subspace Plot z' against z per DOF, with the unit-slope line of perfect
    tracking, the fitted PAEI ellipse and the direction of travel; below, the gap z' − z
    against z, which shows a small lag as an open loop."""
    dofs = record.dofs
    z, zp = record.signal("z_cmd", dofs), record.signal("z_meas", dofs)
    fig, axes = _figure(2, len(dofs), height=4.0, width=4.4)
    for j, d in enumerate(dofs):
        # lower row: the gap z' − z against z magnifies a small lag into a visible loop
        axg = axes[1, j]
        axg.plot(z[:, j], zp[:, j] - z[:, j], lw=0.8, color="tab:purple")
        axg.axhline(0.0, color="k", lw=0.7, ls="--")
        axg.set_xlabel(f"commanded z ({UNITS.get(d, '')})")
        axg.set_ylabel(f"z' − z ({UNITS.get(d, '')})")
        axg.set_title(f"tracking error against command, {d}", fontsize=9)
        axg.grid(alpha=0.3)
        ax = axes[0, j]
        a, b = z[:, j], zp[:, j]
        ax.plot(a, b, lw=0.8, color="tab:blue", label="z' against z")
        lim = max(np.max(np.abs(a)), np.max(np.abs(b)), 1e-12) * 1.1
        ax.plot([-lim, lim], [-lim, lim], "k--", lw=0.7, label="perfect tracking")
        coef = fit_ellipse(a, b)
        if coef is not None:
            xs = np.linspace(a.min(), a.max(), 200)
            ys = np.linspace(b.min(), b.max(), 200)
            gx, gy = np.meshgrid(xs, ys)
            q = (coef[0] * gx**2 + coef[1] * gx * gy + coef[2] * gy**2 + coef[3] * gx
                 + coef[4] * gy + coef[5])
            ax.contour(gx, gy, q, levels=[0.0], colors="tab:orange", linewidths=1.0)
        k = max(1, len(a) // 200)  # a short arrow: the direction of travel
        i0 = int(np.argmax(np.abs(np.diff(a)) + np.abs(np.diff(b))))
        i1 = min(i0 + k, len(a) - 1)
        ax.annotate("", xy=(a[i1], b[i1]), xytext=(a[i0], b[i0]),
                    arrowprops={"arrowstyle": "->", "color": "tab:red"})
        ph, am = paei(a, b)
        u = UNITS.get(d, "")
        ax.set_title(f"SSP {d}: PAEI φ = {float(ph):.3g} rad, B/A = {float(am):.3g}", fontsize=9)
        ax.set_xlabel(f"commanded z ({u})")
        ax.set_ylabel(f"achieved z' ({u})")
        ax.set_xlim(min(a.min(), b.min()) * 1.1 - 1e-12, max(a.max(), b.max()) * 1.1 + 1e-12)
        ax.set_ylim(min(a.min(), b.min()) * 1.1 - 1e-12, max(a.max(), b.max()) * 1.1 + 1e-12)
        ax.set_aspect("equal", adjustable="box")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper left")
    return save_figure(fig, path)


def plot_fei(record: Record, path: str | Path, l: float = 2.0) -> Path:
    """One-sided amplitude spectra |Z| and |Z'| per DOF with the FEI weights |Z|^l, f_eq, A
    and d."""
    dofs = record.dofs
    z, zp = record.signal("z_cmd", dofs), record.signal("z_meas", dofs)
    dt = record.dt
    freqs = np.fft.rfftfreq(z.shape[0], dt)[1:]
    sz = np.abs(one_sided_amplitude(z))[1:]
    sp = np.abs(one_sided_amplitude(zp))[1:]
    res = fei(z, zp, dt, l)
    fig, axes = _figure(len(dofs), 1, height=3.0, width=8.0)
    for j, d in enumerate(dofs):
        ax = axes[j, 0]
        ax.loglog(freqs, np.maximum(sz[:, j], 1e-300), lw=0.8, label="|Z| commanded")
        ax.loglog(freqs, np.maximum(sp[:, j], 1e-300), lw=0.8, label="|Z'| achieved")
        w = sz[:, j] ** l
        if w.max() > 0:
            ax.loglog(freqs, np.maximum(w / w.max() * sz[:, j].max(), 1e-300), lw=0.6,
                      color="grey", alpha=0.7, label=f"weight |Z|^{l:g} (scaled)")
        f_eq = float(np.atleast_1d(res.f_eq)[j])
        if np.isfinite(f_eq):
            ax.axvline(f_eq, color="tab:red", lw=0.8, label=f"f_eq = {f_eq:.3g} Hz")
        a_ = float(np.atleast_1d(res.A)[j])
        d_ = float(np.atleast_1d(res.d)[j])
        peak = sz[:, j].max()
        if peak > 0:
            ax.set_ylim(peak * 1e-6, peak * 3)
        ax.set_title(f"FEI {d}: A = {a_:.4g}, d = {d_ * 1e3:.3g} ms", fontsize=9)
        ax.set_xlabel("frequency (Hz)")
        ax.set_ylabel(f"amplitude ({UNITS.get(d, '')})")
        ax.grid(alpha=0.3, which="both")
        ax.legend(fontsize=7)
    return save_figure(fig, path)


def plot_time(record: Record, path: str | Path) -> Path:
    """Time histories per DOF: z, z', z^r (if present) and, on its own axis, the gap z − z';
    F'_m and F_ext beside."""
    dofs = record.dofs
    t = record.t
    has_f = record.has("f_meas", dofs)
    fig, axes = _figure(len(dofs), 2 if has_f else 1, height=2.8, width=6.5)
    for j, d in enumerate(dofs):
        ax = axes[j, 0]
        u = UNITS.get(d, "")
        z = record.columns[f"z_cmd.{d}"]
        zp = record.columns[f"z_meas.{d}"]
        ax.plot(t, z, lw=0.9, label="z commanded")
        ax.plot(t, zp, lw=0.9, ls="--", label="z' achieved")
        if f"z_ref.{d}" in record.columns:
            ax.plot(t, record.columns[f"z_ref.{d}"], lw=0.8, ls=":", color="k",
                    label="z^r reference")
        ax.set_xlabel("t (s)")
        ax.set_ylabel(f"{d} ({u})")
        ax.grid(alpha=0.3)
        # the gap is usually orders of magnitude smaller: its own axis on the right
        axr = ax.twinx()
        axr.plot(t, z - zp, lw=0.7, color="tab:red", alpha=0.8, label="gap z − z' (right)")
        axr.set_ylabel(f"gap z − z' ({u})", color="tab:red")
        axr.tick_params(axis="y", colors="tab:red")
        lines = ax.get_lines() + axr.get_lines()
        ax.legend(lines, [ln.get_label() for ln in lines], fontsize=7, loc="upper right")
        if has_f:
            axf = axes[j, 1]
            axf.plot(t, record.columns[f"f_meas.{d}"], lw=0.8, color="tab:green",
                     label="F'_m measured")
            if f"f_ext.{d}" in record.columns:
                axf.plot(t, record.columns[f"f_ext.{d}"], lw=0.8, color="tab:purple",
                         label="F_ext")
            axf.set_xlabel("t (s)")
            axf.set_ylabel(f"force {d} ({FORCE_UNITS.get(d, '')})")
            axf.grid(alpha=0.3)
            axf.legend(fontsize=7, loc="upper right")
    return save_figure(fig, path)


def plot_fidelity(record: Record, path: str | Path, window: float = 0.25) -> Path:
    """Fidelity at every time step, per DOF: z' with the surrogate reference ẑ^r (and z^r if
    the record has it); the estimated error ê = z' − ẑ^r; its running RMS over ``window`` s
    with the band over the surrogate's members (and the true running RMS of z' − z^r beside
    it, when z^r is known). Needs the columns of
    :func:`rths3d.surrogate.fidelity_columns` (``z_ref_hat``, ``e_hat``, ``e_hat_rms``)."""
    from ..surrogate.running import running_rms

    dofs = record.dofs
    t = record.t
    fig, axes = _figure(3, len(dofs), height=2.6, width=7.0)
    for j, d in enumerate(dofs):
        u = UNITS.get(d, "")
        c = record.columns
        zp, zh, eh = c[f"z_meas.{d}"], c[f"z_ref_hat.{d}"], c[f"e_hat.{d}"]
        zr = c.get(f"z_ref.{d}")
        ax = axes[0, j]
        ax.plot(t, zp, lw=0.9, label="z' achieved")
        ax.plot(t, zh, lw=0.9, ls="--", label="ẑ^r surrogate reference")
        if zr is not None:
            ax.plot(t, zr, lw=0.8, ls=":", color="k", label="z^r reference")
        ax.set_ylabel(f"{d} ({u})")
        ax.set_title(f"interface displacement, {d}", fontsize=9)
        ax = axes[1, j]
        ax.plot(t, eh, lw=0.8, color="tab:red", label="ê = z' − ẑ^r")
        if zr is not None:
            ax.plot(t, zp - zr, lw=0.8, ls=":", color="k", label="e = z' − z^r")
        ax.set_ylabel(f"error ({u})")
        ax = axes[2, j]
        if f"e_hat_rms_lo.{d}" in c:
            ax.fill_between(t, c[f"e_hat_rms_lo.{d}"], c[f"e_hat_rms_hi.{d}"],
                            color="tab:red", alpha=0.25, lw=0, label="members' band")
        ax.plot(t, c[f"e_hat_rms.{d}"], lw=1.0, color="tab:red",
                label=f"running RMS of ê ({window:g} s)")
        if zr is not None:
            ax.plot(t, running_rms(zp - zr, record.dt, window), lw=0.9, ls=":", color="k",
                    label="running RMS of z' − z^r")
        ax.set_ylabel(f"running RMS ({u})")
        ax.set_xlabel("t (s)")
        for a in axes[:, j]:
            a.grid(alpha=0.3)
            a.legend(fontsize=7, loc="upper right")
    return save_figure(fig, path)


def plot_record(record: Record, out_dir: str | Path) -> list[Path]:
    """Write ``ssp.png``, ``fei.png`` and ``time.png`` into ``out_dir`` (and ``fidelity.png``
    when the record carries the surrogate's per-step columns); return the paths."""
    d = Path(out_dir)
    d.mkdir(parents=True, exist_ok=True)
    paths = [plot_ssp(record, d / "ssp.png"), plot_fei(record, d / "fei.png"),
             plot_time(record, d / "time.png")]
    if record.has("e_hat_rms"):
        window = (record.meta.get("surrogate") or {}).get("window", 0.25)
        paths.append(plot_fidelity(record, d / "fidelity.png", float(window)))
    return paths
