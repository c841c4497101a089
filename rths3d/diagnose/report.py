"""The diagnosis report: Markdown with PNG plots, and the replay record for the viewer.

Files written to the report directory:

``report.md``
    summary, per-channel errors, ranked candidates, confounded pairs, waterfall, FEI,
    operating-condition table and the plots below.
``localisation.png``
    measured vs model, residual in noise units with its sliding-window RMS and the contact
    phases shaded, residual spectra and the measured-vs-model transfer estimate.
``signatures.png``
    share of each channel's residual that each candidate's sensitivity explains.
``waterfall.png``
    error (noise units) effect by effect, on training and validation samples.
``replay.parquet``
    the measurement plus the model replay as extra columns ``model.<column>``.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from ..figures import new_figure, save_figure
from ..record import DOFS, Record
from .engine import Diagnosis, RoundResult
from .localise import condition_table, fei, residual_spectrum, transfer_estimate, window_rms

UNITS = {"z_meas.z": "m", "f_meas.z": "N", "f_meas.x": "N",
         **{f"leg_force.{i}": "N" for i in range(6)}}


def replay_record(diag: Diagnosis) -> Record:
    """The measurement with the model replay (accepted effects) as ``model.<column>``
    columns, ``model.contact`` (N) and ``model.pose_meas.<dof>`` (m, rad), for side-by-side
    viewing."""
    out = diag.predict()
    cols = dict(diag.record.columns)
    for c in diag.channels:
        cols[f"model.{c}"] = out[c]
    cols["model.contact"] = out["contact"]
    # the model's plate pose, for the viewer's plate twin (heave replay: other DOFs zero)
    for dof in DOFS:
        cols[f"model.pose_meas.{dof}"] = out["z_meas.z"] if dof == "z" else \
            np.zeros(diag.record.n)
    meta = dict(diag.record.meta)
    meta["diagnosis"] = {"accepted": dict(diag.accepted), "model_columns":
                         [f"model.{c}" for c in diag.channels] + ["model.contact"]
                         + [f"model.pose_meas.{d}" for d in DOFS]}
    return Record(diag.record.t, cols, meta)


def localisation(diag: Diagnosis) -> dict[str, Any]:
    """Residual localisation of the current model: FEI per channel, error in and out of
    contact, and the operating-condition table (noise units)."""
    out = diag.predict()
    res = diag.residuals()
    dt = diag.dt
    v = np.gradient(diag.command, dt)
    a = np.gradient(v, dt)
    force = diag.measured.get("f_meas.z", out["f_meas.z"])
    contact = out["contact"] > 0
    info: dict[str, Any] = {"fei": {}, "contact": {}, "conditions": {}}
    for c in diag.channels:
        if np.any(out[c]):
            info["fei"][c] = fei(out[c], diag.measured[c], dt)
        r = res[c]
        info["contact"][c] = {
            "in_contact": float(np.sqrt(np.mean(r[contact] ** 2))) if contact.any() else None,
            "free": float(np.sqrt(np.mean(r[~contact] ** 2))) if (~contact).any() else None,
            "contact_share": float(contact.mean())}
        info["conditions"][c] = condition_table(
            r, {"velocity (m/s)": v, "acceleration (m/s²)": a, "force (N)": force})
    return info


def _plot_localisation(diag: Diagnosis, path: Path) -> None:
    out = diag.predict()
    res = diag.residuals()
    t = diag.record.t
    dt = diag.dt
    contact = out["contact"] > 0
    chans = diag.channels
    fig = new_figure((15, 2.8 * len(chans)))
    axes = fig.subplots(len(chans), 3, squeeze=False)
    for i, c in enumerate(chans):
        ax = axes[i, 0]
        ax.plot(t, diag.measured[c], lw=0.8, label="measured")
        ax.plot(t, out[c], lw=0.8, ls="--", label="model")
        ax.set_ylabel(f"{c} ({UNITS.get(c, '')})")
        ax.legend(loc="upper right", fontsize=7)
        ax = axes[i, 1]
        ax.plot(t, res[c], lw=0.5, color="0.5", label="residual / σ")
        tw, rms = window_rms(res[c], dt, 0.25)
        ax.plot(tw + t[0], rms, color="C3", lw=1.5, label="window RMS")
        ax.axhline(1.0, color="k", lw=0.6, ls=":")
        if contact.any():
            ax.fill_between(t, 0, 1, where=contact, transform=ax.get_xaxis_transform(),
                            color="C1", alpha=0.15, label="contact")
        ax.set_ylabel("noise units")
        ax.legend(loc="upper right", fontsize=7)
        ax = axes[i, 2]
        f, p = residual_spectrum(res[c], dt)
        ax.loglog(f[1:], p[1:], lw=0.8, label="residual PSD (σ²/Hz)")
        if np.any(out[c]):
            fh, h, coh = transfer_estimate(out[c], diag.measured[c], dt)
            good = (coh > 0.8) & (fh > 0)
            ax2 = ax.twinx()
            ax2.semilogx(fh[good], np.abs(h[good]), "C2.", ms=3, label="|H| meas/model")
            ax2.set_ylim(0.5, 1.5)
            ax2.set_ylabel("|H|")
        ax.set_ylabel("PSD")
        ax.legend(loc="lower left", fontsize=7)
    for ax in axes[-1]:
        ax.set_xlabel("t (s)")
    axes[-1, 2].set_xlabel("f (Hz)")
    save_figure(fig, path, title="Where the model fails: time, contact phases, frequency",
                dpi=90, rect=(0, 0, 1, 0.97))


def _plot_signatures(result: RoundResult, channels: tuple[str, ...], path: Path) -> None:
    cands = result.candidates
    mat = np.array([[c.channel_share.get(ch, 0.0) for ch in channels] for c in cands])
    fig = new_figure((12, 0.35 * len(cands) + 1.5))
    ax, ax2 = fig.subplots(1, 2, gridspec_kw={"width_ratios": [2, 1]})
    im = ax.imshow(mat, aspect="auto", cmap="viridis", vmin=0, vmax=1)
    ax.set_xticks(range(len(channels)), channels, rotation=20)
    ax.set_yticks(range(len(cands)), [c.effect for c in cands])
    ax.set_title("share of each channel's residual explained by the effect")
    fig.colorbar(im, ax=ax)
    scores = [c.score if c.fitted and math.isfinite(c.score) else 0.0 for c in cands]
    colors = ["C2" if c.significant else "0.6" for c in cands]
    ax2.barh(range(len(cands)), scores, color=colors)
    ax2.set_yticks(range(len(cands)), [])
    ax2.invert_yaxis()
    ax.set_ylim(len(cands) - 0.5, -0.5)
    ax2.set_xscale("symlog")
    ax2.set_title("held-out ΔBIC (green: significant)")
    save_figure(fig, path, dpi=90)


def _plot_waterfall(waterfall: list[dict[str, Any]], path: Path) -> None:
    labels = [w["step"] for w in waterfall]
    x = np.arange(len(labels))
    fig = new_figure((max(6, 2.2 * len(labels)), 4))
    ax = fig.subplots()
    ax.bar(x - 0.2, [w["error_train"] for w in waterfall], 0.4, label="training")
    ax.bar(x + 0.2, [w["error_val"] for w in waterfall], 0.4, label="validation")
    ax.axhline(1.0, color="k", ls=":", lw=1, label="noise floor")
    ax.set_xticks(x, labels, rotation=15, ha="right", fontsize=8)
    ax.set_ylabel("RMS error (noise units)")
    ax.set_title("Error effect by effect")
    ax.legend()
    save_figure(fig, path, dpi=90)


def write_report(diag: Diagnosis, result: RoundResult, out_dir: str | Path,
                 warnings: list[str] | None = None, first_round: RoundResult | None = None
                 ) -> Path:
    """Write ``report.md``, the three PNG plots and ``replay.parquet`` to ``out_dir``.

    ``result`` is the latest round; ``first_round`` (when several rounds ran) is the one whose
    signatures are plotted, since after the last accepted effect only noise is left to
    explain."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    replay_record(diag).save(out_dir / "replay.parquet")
    _plot_localisation(diag, out_dir / "localisation.png")
    sig_round = first_round or result
    _plot_signatures(sig_round, diag.channels, out_dir / "signatures.png")
    _plot_waterfall(diag.waterfall, out_dir / "waterfall.png")
    loc = localisation(diag)
    lines = ["# Model versus measurement", ""]
    lines += [f"- samples: {diag.record.n} at dt = {diag.dt:g} s "
              f"({diag.record.duration:.3g} s); channels: {', '.join(diag.channels)}"]
    for w in warnings or []:
        lines.append(f"- warning: {w}")
    acc = ", ".join(f"{k} = {v:.4g}" for k, v in diag.accepted.items()) or "none"
    lines += [f"- accepted effects: {acc}",
              f"- error (noise units, 1 = only noise): training {result.error_train:.3f}, "
              f"validation {result.error_val:.3f}", ""]
    if result.noise_only:
        lines += ["**Only noise remains**: no candidate effect explains the residual "
                  "significantly.", ""]
    elif result.proposal is None:
        lines += ["**Unexplained residual**: no effect of the library explains it "
                  f"significantly, yet it is not noise (validation error {result.error_val:.3g}"
                  " noise units, whiteness " + ", ".join(f"{c} {w:.2f}" for c, w in
                                                         result.whiteness.items())
                  + "). Check the scene (bench parameters) or add a new effect.", ""]
    else:
        p = result.proposal
        lines += [f"**Proposal: add `{p.effect}`** ({p.param} = {p.value:.4g} {p.unit}, 95 % "
                  f"interval [{p.ci[0]:.4g}, {p.ci[1]:.4g}]): validation error "
                  f"{p.error_before:.3f} → {p.error_after:.3f}.", ""]
    lines += ["## Per-channel residual", "", "| channel | RMS residual | noise σ | FEI amplitude "
              "| FEI delay (ms) | RMS in contact / free (σ) |", "|---|---|---|---|---|---|"]
    for c in diag.channels:
        f = loc["fei"].get(c, {})
        ct = loc["contact"][c]
        inc = f"{ct['in_contact']:.2f}" if ct["in_contact"] is not None else "–"
        fre = f"{ct['free']:.2f}" if ct["free"] is not None else "–"
        lines.append(f"| {c} | {result.channel_rms[c]:.4g} {UNITS.get(c, '')} | "
                     f"{result.noise_sigma[c]:.3g} | {f.get('amplitude', float('nan')):.4f} | "
                     f"{1e3 * f.get('delay', float('nan')):.3f} | {inc} / {fre} |")
    lines += ["", "![localisation](localisation.png)", "", "## Candidates", "",
              "| rank | effect | value | 95 % interval | share | ΔBIC | val. error before → after "
              "| significant | note |", "|---|---|---|---|---|---|---|---|---|"]
    for i, c in enumerate(result.candidates, 1):
        val = f"{c.value:.4g} {c.unit}" if c.fitted and math.isfinite(c.value) else "–"
        ci = f"[{c.ci[0]:.3g}, {c.ci[1]:.3g}]" if c.fitted else "–"
        sc = f"{c.score:.1f}" if c.fitted else "not refitted"
        err = f"{c.error_before:.3f} → {c.error_after:.3f}" if c.fitted else "–"
        lines.append(f"| {i} | {c.effect} | {val} | {ci} | {c.share:.3f} | {sc} | {err} | "
                     f"{'yes' if c.significant else 'no'} | {c.note} |")
    if result.confounded:
        lines += ["", "Confounded pairs (their fitted changes are nearly parallel; the data "
                  "cannot tell them apart well):", ""]
        lines += [f"- {a} ↔ {b} (cos = {cos:.3f})" for a, b, cos in result.confounded]
    if first_round is not None and first_round is not result:
        lines += ["", "Signatures below are from the first round (nominal model):"]
    lines += ["", "![signatures](signatures.png)", "", "## Waterfall", "",
              "| step | training error | validation error |", "|---|---|---|"]
    lines += [f"| {w['step']} | {w['error_train']:.3f} | {w['error_val']:.3f} |"
              for w in diag.waterfall]
    lines += ["", "![waterfall](waterfall.png)", "", "## Operating condition", "",
              "RMS residual (noise units) by condition; rows `corr` give correlations.", ""]
    for c in diag.channels:
        lines += [f"### {c}", "", "| condition | bin | RMS / corr | share |", "|---|---|---|---|"]
        lines += [f"| {r['condition']} | {r['bin']} | {r['rms']:.3f} | {r['share']:.2f} |"
                  for r in loc["conditions"][c]]
        lines.append("")
    lines += ["Replay with the model as `model.<column>` columns: `replay.parquet`.", ""]
    path = out_dir / "report.md"
    path.write_text("\n".join(lines))
    return path
