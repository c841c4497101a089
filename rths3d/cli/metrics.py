"""CLI commands: metrics (registered on the shared app)."""

from __future__ import annotations

from pathlib import Path

import typer

from ._app import app, json_line, warn_implausible
from ._output import Keeper, check_folder

# measure key → (symbol, unit) for the readable table
_LABELS: dict[str, tuple[str, str]] = {
    "e_rel_track": ("e_rel,track (eq. 1)", ""), "e_mte_track": ("e_MTE,track (eq. 2)", ""),
    "e_peak_track": ("e_peak,track (eq. 3)", ""),
    "e_rel_track_f": ("e_rel,track,f (eq. 4)", ""),
    "ti": ("TI", "unit²"), "theta_pc": ("Θ_PC slope", ""), "paei_phase": ("PAEI φ", "rad"),
    "paei_amp": ("PAEI B/A", ""), "fei_A": ("FEI A (eq. 7)", ""),
    "fei_phi": ("FEI Φ (eq. 8)", "rad"), "fei_d": ("FEI d (eq. 8)", "s"),
    "f_eq": ("f_eq (eq. 6)", "Hz"), "e_error": ("E_error (eq. 9)", "J"),
    "e_input": ("E_input (eq. 10)", "J"), "e_strain": ("E_strain (eq. 10)", "J"),
    "hsem_s": ("HSEM^S (eq. 11)", ""), "hsem_i": ("HSEM^I (eq. 11)", ""), "eei": ("EEI", ""),
    "e_rel_ref": ("e_rel,ref", ""), "e_mre_ref": ("e_MRE,ref", ""),
    "e_peak_ref": ("e_peak,ref", ""), "e_rel_ref_f": ("e_rel,ref,f", ""),
    "j1": ("J1 delay", "s"), "phi": ("φ = m_NUM/m_EXP", ""), "kappa": ("κ = k_NUM/k_EXP", ""),
    "zeta": ("ζ", ""), "omega_num": ("ω_0,NUM", "rad/s"), "omega_dyn": ("ω_0,DYN", "rad/s"),
    "tau_ratio_num": ("τ_ratio,NUM (eq. 13)", ""), "tau_ratio_dyn": ("τ_ratio,DYN (eq. 12)", ""),
    "tau_max": ("τ_max = PM/ω_c", "s"), "tau_ratio_max": ("τ_ratio,max (eq. 14)", ""),
    "tau_cr": ("τ_cr (critical delay)", "s"), "psi": ("PSI", ""),
    # bench load: translations in m, m/s, N; rotations in rad, rad/s, N·m
    "stroke_peak": ("peak stroke max|z|", "m, rad"),
    "velocity_peak": ("peak velocity max|ż|", "m/s, rad/s"),
    "force_peak": ("peak force max|F'_m|", "N, N·m"),
}
# the surrogate estimate (reference errors without the reference, rths3d.metrics.fidelity)
_LABELS.update({
    "e_rel_ref_hat": ("ê_rel,ref (surrogate estimate)", ""),
    "e_mre_ref_hat": ("ê_MRE,ref (surrogate)", ""),
    "e_peak_ref_hat": ("ê_peak,ref (surrogate)", ""),
    "e_rel_ref_f_hat": ("ê_rel,ref,f (surrogate)", ""),
    "e_rel_ref_hat_std": ("spread of ê_rel,ref over members", ""),
    "surrogate_validation": ("part model output error, held out", ""),
    "surrogate_members": ("surrogate members coupled", ""),
    "e_rel_ref_hat_lo": ("band of ê_rel,ref: low", ""),
    "e_rel_ref_hat_hi": ("band of ê_rel,ref: high", ""),
    "surrogate_flag": ("estimate unreliable (1) or reliable (0)", ""),
    "surrogate_reason": ("surrogate status and why", ""),
})
for _i in range(2, 10):
    _LABELS[f"j{_i}"] = (f"J{_i}", "%")


@app.command()
def metrics(
    record: Path = typer.Argument(..., help="Record file (.parquet or .csv; bare single-DOF "
                                  "names t, z_cmd, z_meas, f_meas, f_ext, z_ref accepted)."),
    as_json: bool = typer.Option(False, "--json", help="Print one JSON object (NaN/inf → "
                                 "null) instead of a table."),
    plot: Path | None = typer.Option(None, "--plot", help="Write ssp.png, fei.png and "
                                     "time.png (SSP, FEI spectrum, time histories) here, and "
                                     "fidelity.png (the surrogate estimate at every step)."),
    surrogate: bool = typer.Option(True, "--surrogate/--no-surrogate",
                                   help="Estimate the reference errors without the reference "
                                        "(the part identified from the record, coupled to "
                                        "the numerical substructure); needs f_meas, the "
                                        "numerical model and its load in the record."),
    save_estimate: Path | None = typer.Option(
        None, "--save-estimate", help="Write the record with the per-step estimate columns "
                                      "(z_ref_hat, e_hat, e_hat_rms and its band) here "
                                      "(.parquet or .csv)."),
) -> None:
    """Compute every accuracy measure of a RECORD (tracking, SSP, FEI, energy, reference,
    susceptibility, J1–J9 and the surrogate estimate where their inputs exist)."""

    from ..metrics import compute_measures
    from ..record import Record

    rec = Record.load(record)
    warn_implausible(rec, record)
    if plot is not None:
        check_folder(plot, "--plot")
    keeper = Keeper()
    result = compute_measures(rec)
    if surrogate or save_estimate is not None:
        from ..errors import ConfigError
        from ..metrics.fidelity import _flat, can_estimate
        from ..surrogate import surrogate_reference

        if can_estimate(rec):
            rec, est = surrogate_reference(rec)
            (result["aggregate"] if "aggregate" in result else result).update(_flat(est))
        elif save_estimate is not None:
            raise ConfigError("--save-estimate", str(save_estimate),
                              "the record lacks f_meas, meta['numerical'] or its load "
                              "p_num.<i>: no surrogate estimate")
    if save_estimate is not None:
        rec.save(save_estimate)
    paths = []
    if plot is not None:
        from ..metrics.plots import plot_record

        paths = keeper.write(lambda d: plot_record(rec, d), plot, "--plot", folder=True)
    if as_json:
        typer.echo(json_line(result))
        keeper.finish()
        return
    _table(rec, result, record)
    agg = result.get("aggregate", result)
    if agg.get("surrogate_flag") == 1.0:
        typer.echo(f"warning: the surrogate estimate is not to be trusted — "
                   f"{agg.get('surrogate_reason')} (docs/surrogate.md: what to do with a "
                   "flagged test)", err=True)
    if save_estimate is not None:
        typer.echo(f"wrote {save_estimate}")
    for p in paths:
        typer.echo(f"wrote {p}")
    keeper.finish()


def _fmt(v) -> str:
    if isinstance(v, str):
        return v
    if v is None:
        return "—"
    return f"{v:.6g}"


def _table(rec, result: dict, path: Path) -> None:
    from rich.console import Console
    from rich.table import Table

    multi = "dofs" in result
    title = f"{path.name}: {rec.n} samples, {rec.duration:.3f} s, DOF {', '.join(rec.dofs)}"
    table = Table(title=title)
    table.add_column("key", style="cyan")
    table.add_column("measure")
    table.add_column("unit")
    if multi:
        cols = list(result["dofs"])
        for d in cols:
            table.add_column(d, justify="right")
        table.add_column(f"aggregate ({result['aggregate'].get('dominant_dof')})",
                         justify="right")
        keys = list(dict.fromkeys(
            [k for d in cols for k in result["dofs"][d]] +
            [k for k in result["aggregate"] if k != "dominant_dof"]))
        for k in keys:
            sym, unit = _LABELS.get(k, (k, ""))
            row = [_fmt(result["dofs"][d].get(k)) for d in cols]
            table.add_row(k, sym, unit, *row, _fmt(result["aggregate"].get(k)))
    else:
        table.add_column("value", justify="right")
        for k, v in result.items():
            sym, unit = _LABELS.get(k, (k, ""))
            table.add_row(k, sym, unit, _fmt(v))
    console = Console()
    if not console.is_terminal:  # piped: do not squeeze the DOF columns into 80 characters
        console = Console(width=220)
    console.print(table)
