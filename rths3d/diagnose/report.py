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


def _unit(c: str) -> str:
    sig, _, lab = c.partition(".")
    if sig in ("z_meas", "pose_meas"):
        return "rad" if lab.startswith("r") else "m"
    if sig == "leg_len":
        return "m"
    if sig == "leg_force":
        return "N"
    if sig == "fts":
        return "N·m" if lab.startswith("t") else "N"
    if sig == "f_meas":
        return "N·m" if lab.startswith("r") else "N"
    return ""



def replay_record(diag: Diagnosis) -> Record:
    """The measurement with the model replay (accepted effects) as ``model.<column>``
    columns for every compared channel and the model's plate pose ``model.pose_meas.<dof>``
    (m, rad), for side-by-side viewing (``rths3d view``)."""
    out = diag.predict()
    cols = dict(diag.record.columns)
    names = list(diag.channels)
    for d in DOFS:
        if f"pose_meas.{d}" not in names:
            names.append(f"pose_meas.{d}")
    for c in names:
        cols[f"model.{c}"] = np.asarray(out[c], dtype=float)
    res = diag.residuals()
    for c in diag.channels:
        cols[f"residual.{c}"] = res[c]
    meta = dict(diag.record.meta)
    meta["diagnosis"] = {"accepted": dict(diag.accepted), "channels": list(diag.channels),
                         "model_columns": [f"model.{c}" for c in names],
                         "residual_columns": [f"residual.{c}" for c in diag.channels],
                         "noise_sigma": dict(diag.sigma)}
    return Record(diag.record.t, cols, meta)


def _worst(diag: Diagnosis, n: int = 6) -> list[str]:
    res = diag.residuals()
    rms = {c: float(np.sqrt(np.nanmean(res[c][1:] ** 2))) for c in diag.channels}
    return sorted(rms, key=lambda c: -rms[c])[:n]


def localisation(diag: Diagnosis) -> dict[str, Any]:
    """Residual localisation of the current model: FEI of measurement against model per
    channel and the operating-condition table of the worst channels (noise units)."""
    out = diag.predict()
    res = diag.residuals()
    dt = diag.dt
    d0 = diag.scene.dofs[0]
    cmd = diag.replay.poses[:, DOFS.index(d0)]
    v = np.gradient(cmd, dt)
    a = np.gradient(v, dt)
    fname = f"f_meas.{d0}"
    force = diag.measured.get(fname, out.get(fname, np.zeros_like(cmd)))
    info: dict[str, Any] = {"fei": {}, "conditions": {}}
    for c in diag.channels:
        if np.any(out[c][1:] - np.mean(out[c][1:])):
            info["fei"][c] = fei(out[c][1:], diag.measured[c][1:], dt)
    for c in _worst(diag):
        info["conditions"][c] = condition_table(
            res[c], {"velocity (m/s)": v, "acceleration (m/s²)": a, "force (N)": force})
    return info


def _plot_localisation(diag: Diagnosis, path: Path) -> None:
    out = diag.predict()
    res = diag.residuals()
    t = diag.record.t
    dt = diag.dt
    chans = _worst(diag)
    fig = new_figure((15, 2.8 * len(chans)))
    axes = fig.subplots(len(chans), 3, squeeze=False)
    for i, c in enumerate(chans):
        ax = axes[i, 0]
        ax.plot(t, diag.measured[c], lw=0.8, label="measured")
        ax.plot(t, out[c], lw=0.8, ls="--", label="model")
        ax.set_ylabel(f"{c} ({_unit(c)})")
        ax.legend(loc="upper right", fontsize=7)
        ax = axes[i, 1]
        ax.plot(t, res[c], lw=0.5, color="0.5", label="residual / σ")
        tw, rms = window_rms(res[c], dt, 0.25)
        ax.plot(tw + t[0], rms, color="C3", lw=1.5, label="window RMS")
        ax.axhline(1.0, color="k", lw=0.6, ls=":")
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
    save_figure(fig, path, title="Where the model fails: time, frequency (worst channels)",
                dpi=90, rect=(0, 0, 1, 0.97))


def _plot_signatures(result: RoundResult, channels: tuple[str, ...], path: Path) -> None:
    cands = [c for c in result.candidates if math.isfinite(c.score)][:30]
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
    ax2.set_title("held-out ΔIC (green: significant)")
    save_figure(fig, path, dpi=90)


def _plot_waterfall(waterfall: list[dict[str, Any]], path: Path,
                    hybrid: dict[str, Any] | None = None) -> None:
    labels = [w["step"] for w in waterfall]
    x = np.arange(len(labels))
    fig = new_figure((max(6, 2.2 * len(labels)) + (5 if hybrid else 0), 4))
    if hybrid:
        ax, axh = fig.subplots(1, 2, gridspec_kw={"width_ratios": [max(2, len(labels)), 2]})
        names = ["measured", "uncalibrated", "calibrated"]
        e = [hybrid[n]["e_rel_track"] * 100 for n in names]
        d = [hybrid[n]["fei_d"] * 1e3 for n in names]
        xh = np.arange(3)
        axh.bar(xh - 0.2, e, 0.4, color="C0", label="e_rel,track (%)")
        axh2 = axh.twinx()
        axh2.bar(xh + 0.2, d, 0.4, color="C3", label="FEI delay (ms)")
        axh.set_xticks(xh, names, fontsize=8)
        axh.set_ylabel("e_rel,track (%)")
        axh2.set_ylabel("FEI delay (ms)")
        axh.set_title("hybrid test: run of each scene")
        axh.legend(loc="upper left", fontsize=7)
        axh2.legend(loc="upper right", fontsize=7)
    else:
        ax = fig.subplots()
    ax.bar(x - 0.2, [w["error_train"] for w in waterfall], 0.4, label="training")
    ax.bar(x + 0.2, [w["error_val"] for w in waterfall], 0.4, label="validation")
    ax.axhline(1.0, color="k", ls=":", lw=1, label="noise floor")
    ax.set_xticks(x, labels, rotation=15, ha="right", fontsize=8)
    ax.set_ylabel("RMS error (noise units)")
    ax.set_title("Error effect by effect")
    ax.legend()
    save_figure(fig, path, dpi=90)


def hybrid_figures(diag: Diagnosis) -> dict[str, Any]:
    """The hybrid test's tracking error e_rel,track (eq. (1)) and FEI delay (s) of the
    measured record, of ``rths3d run`` of the uncalibrated bench scene and of the calibrated
    one (the accepted effects added): the waterfall's last column."""
    import dataclasses

    from ..loop import run
    from ..metrics import compute_measures

    rec = diag.record
    out: dict[str, Any] = {}
    m = compute_measures(rec)
    out["measured"] = {"e_rel_track": float(m["e_rel_track"]), "fei_d": float(m["fei_d"])}
    base = dataclasses.replace(diag.scene, duration=round(rec.duration / diag.dt) * diag.dt)
    for name, sc in (("uncalibrated", base),
                     ("calibrated", dataclasses.replace(diag.calibrated_scene(),
                                                        duration=base.duration))):
        mm = compute_measures(run(sc, reference=False).record)
        out[name] = {"e_rel_track": float(mm["e_rel_track"]), "fei_d": float(mm["fei_d"])}
    return out


def _verdict(result: RoundResult) -> list[str]:
    if result.status == "noise_only":
        return ["**Only noise remains**: no candidate effect explains the residual "
                "significantly.", ""]
    lines = []
    if result.proposal is not None:
        p = result.proposal
        val = f"{p.param} = {p.value:.4g} {p.unit}, 95 % interval [{p.ci[0]:.4g}, " \
              f"{p.ci[1]:.4g}]" if math.isfinite(p.value) else f"{len(p.values)} parameters"
        head = "Proposal" if result.status == "effect_proposed" else "Partly explained by"
        lines += [f"**{head}: `{p.effect}`** ({val}): validation error "
                  f"{p.error_before:.3f} → {p.error_after:.3f} noise units.", ""]
        if p.evidence:
            lines += [f"This {p.evidence}.", ""]
    elif result.status == "unexplained":
        lines += [f"**Unexplained systematic residual of {result.systematic_sigma:.3g} σ** "
                  f"(validation error {result.error_val:.3g} noise units): no effect of the "
                  "library, and no revision of the description, takes it most of the way to "
                  "noise, alone or with the next candidates. Detection limit "
                  f"{result.detection_limit:.3g} σ: an effect whose signature (RMS on the "
                  "validation blocks) is smaller is not told apart from this residual."]
        if result.absorbed:
            lines.append("Candidates that would absorb part of it (not proposed: their "
                         "estimates would be biased by it): " + ", ".join(
                             f"`{k}` ({v:.0%} of the excess)" for k, v in
                             list(result.absorbed.items())[:4]) + ".")
        lines += ["Check what the scene cannot state (docs/bench.md), or diagnose against a "
                  "record of the healthy bench (`--baseline HEALTHY`), which takes out what "
                  "both records share.", ""]
    else:
        lines += ["**Partly explained**: the accepted effects leave structure that no "
                  "further library effect explains.", ""]
    if result.remaining:
        r = result.remaining
        lines += ["Where the residual remains: channels " + ", ".join(
            f"{c} ({v:.3g} σ)" for c, v in r.get("channels", {}).items())]
        if r.get("windows_s"):
            lines.append("; windows " + ", ".join(f"{a:.2f}–{b:.2f} s" for a, b, _ in
                                                  r["windows_s"]))
        if r.get("band_hz"):
            lo, hi, ex = r["band_hz"]
            lines.append(f"; band {lo:.3g}–{hi:.3g} Hz ({ex:.3g}× the noise floor)")
        if r.get("state_correlation"):
            lines.append("; correlated with " + ", ".join(
                f"{k} ({v:+.2f})" for k, v in r["state_correlation"].items()))
        lines += ["", ""]
    return lines


def write_report(diag: Diagnosis, result: RoundResult, out_dir: str | Path,
                 warnings: list[str] | None = None, first_round: RoundResult | None = None,
                 hybrid: dict[str, Any] | None = None) -> Path:
    """Write ``report.md``, the three PNG plots and ``replay.parquet`` to ``out_dir``.

    ``result`` is the latest round; ``first_round`` (when several rounds ran) is the one whose
    signatures are plotted; ``hybrid`` (:func:`hybrid_figures`) adds the hybrid test's
    column to the waterfall."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    replay_record(diag).save(out_dir / "replay.parquet")
    _plot_localisation(diag, out_dir / "localisation.png")
    sig_round = first_round or result
    _plot_signatures(sig_round, diag.channels, out_dir / "signatures.png")
    _plot_waterfall(diag.waterfall, out_dir / "waterfall.png", hybrid)
    loc = localisation(diag)
    lines = ["# Model versus measurement", ""]
    lines += [f"- samples: {diag.record.n} at dt = {diag.dt:g} s "
              f"({diag.record.duration:.3g} s); bench: scene {diag.scene.name!r}, part "
              f"{diag.scene.experiment.kind}; {len(diag.channels)} channels"]
    for w in [*diag.warnings, *(warnings or [])]:
        lines.append(f"- warning: {w}")
    acc = ", ".join(f"{k} = {v:.4g}" for k, v in diag.accepted.items()) or "none"
    for r in diag.revisions:
        lines.append("- description revised: " + "; ".join(
            f"`{k}`: {v['stated']!r} → {v['revised']!r}" for k, v in r["changes"].items())
            + (f" — {r['evidence']}" if r.get("evidence") else ""))
    lines += [f"- accepted effects: {acc}",
              f"- error (noise units, 1 = only noise): training {result.error_train:.3f}, "
              f"validation {result.error_val:.3f}; status **{result.status}**"]
    if result.seconds:
        t = result.seconds
        lines.append(f"- round time: {t['round']:.1f} s (screening {t['screen']:.1f} s, refits "
                     f"{t['refit']:.1f} s, ranking {t['rank']:.2f} s; "
                     f"{t['simulations']:.0f} replays on {t['threads']:.0f} threads)")
    lines.append("")
    lines += _verdict(result)
    lines += ["## Per-channel residual", "", "| channel | RMS residual | noise σ | FEI amplitude "
              "| FEI delay (ms) |", "|---|---|---|---|---|"]
    for c in diag.channels:
        f = loc["fei"].get(c, {})
        lines.append(f"| {c} | {result.channel_rms[c]:.4g} {_unit(c)} | "
                     f"{result.noise_sigma[c]:.3g} | {f.get('amplitude', float('nan')):.4f} | "
                     f"{1e3 * f.get('delay', float('nan')):.3f} |")
    lines += ["", "![localisation](localisation.png)", "", "## Candidates", "",
              "| rank | effect | value | 95 % interval | share | ΔIC | val. error before → after "
              "| significant | note |", "|---|---|---|---|---|---|---|---|---|"]
    for i, c in enumerate(result.candidates[:40], 1):
        if math.isfinite(c.value):
            val = f"{c.value:.4g} {c.unit}"
        else:
            val = f"{len(c.values)} parameters" if c.values else "–"
        ci = f"[{c.ci[0]:.3g}, {c.ci[1]:.3g}]" if c.fitted and math.isfinite(c.ci[0]) else "–"
        sc = f"{c.score:.1f}" if math.isfinite(c.score) else "–"
        err = f"{c.error_before:.3f} → {c.error_after:.3f}" if math.isfinite(c.error_after) \
            else "–"
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
    if hybrid:
        lines += ["", "Hybrid test (`rths3d run` of each bench scene, closed loop):", "",
                  "| | e_rel,track (%) | FEI delay (ms) |", "|---|---|---|"]
        lines += [f"| {n} | {100 * hybrid[n]['e_rel_track']:.4f} | "
                  f"{1e3 * hybrid[n]['fei_d']:.4f} |"
                  for n in ("measured", "uncalibrated", "calibrated")]
    lines += ["", "![waterfall](waterfall.png)", "", "## Operating condition", "",
              "RMS residual (noise units) by condition; rows `corr` give correlations.", ""]
    for c, rows in loc["conditions"].items():
        lines += [f"### {c}", "", "| condition | bin | RMS / corr | share |", "|---|---|---|---|"]
        lines += [f"| {r['condition']} | {r['bin']} | {r['rms']:.3f} | {r['share']:.2f} |"
                  for r in rows]
        lines.append("")
    lines += ["Replay with the model as `model.<column>` and the residual (noise units) as "
              "`residual.<column>` columns: `replay.parquet` (`rths3d view`).", ""]
    path = out_dir / "report.md"
    path.write_text("\n".join(lines))
    return path
