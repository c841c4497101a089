"""Regression and prediction plots like the paper's Figs. 6–9 (matplotlib, Agg-safe).

Regression plot: net output against target with the unit-slope line of perfect prediction and
ρ (eq. 15) in the title. Prediction plot: targets and net outputs per sample (with the ensemble
spread as error bars when given).
"""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from ..figures import new_figure, save_figure
from .scores import pearson_rho


def regression_axes(ax, targets: np.ndarray, outputs: np.ndarray, title: str = "") -> None:
    """Draw one regression plot (targets on x, net outputs on y) into ``ax``."""
    t = np.asarray(targets, dtype=float)
    a = np.asarray(outputs, dtype=float)
    lo = float(min(t.min(), a.min()))
    hi = float(max(t.max(), a.max()))
    ax.plot([lo, hi], [lo, hi], "k-", lw=1, label="perfect prediction")
    ax.plot(t, a, "o", mfc="none", ms=4, label="samples")
    ax.set_xlabel("target e_rel,ref (-)")
    ax.set_ylabel("net output (-)")
    ax.set_title(f"{title}  ρ = {pearson_rho(a, t):.4f}".strip())
    ax.legend(loc="upper left", fontsize="small")
    ax.grid(alpha=0.3)


def prediction_axes(ax, targets: np.ndarray, outputs: np.ndarray,
                    spread: np.ndarray | None = None, title: str = "",
                    sort_above: int = 200) -> None:
    """Draw targets and predictions per sample into ``ax`` (paper Fig. 7 style).

    Up to ``sort_above`` samples are drawn in their order, each with its ensemble ``spread``
    as an error bar. Larger sets (thousands of tests) are drawn sorted by target, the
    predictions as small dots (with thin error bars) around the target curve, on a log scale
    when all values are positive: one marker per sample in table order would hide everything.
    ``spread`` (same length as the targets): the ensemble's standard deviation.
    """
    t = np.asarray(targets, dtype=float)
    a = np.asarray(outputs, dtype=float)
    k = np.arange(1, t.size + 1)
    if t.size <= sort_above:
        ax.plot(k, t, "ks", mfc="none", ms=5, label="target")
        if spread is not None:
            ax.errorbar(k, a, yerr=np.asarray(spread), fmt="o", ms=3, capsize=2,
                        label="net output ± ensemble spread")
        else:
            ax.plot(k, a, "o", ms=3, label="net output")
        ax.set_xlabel("sample")
    else:
        order = np.argsort(t, kind="stable")
        t, a = t[order], a[order]
        if spread is not None:
            ax.errorbar(k, a, yerr=np.asarray(spread, dtype=float)[order], fmt=".", ms=2,
                        elinewidth=0.5, alpha=0.4, label="net output ± ensemble spread")
        else:
            ax.plot(k, a, ".", ms=2, alpha=0.4, label="net output")
        ax.plot(k, t, "k-", lw=1.2, label="target", zorder=3)
        ax.locator_params(axis="x", nbins=5)
        if t.min() > 0 and a.min() > 0:
            ax.set_yscale("log")
        ax.set_xlabel("sample, sorted by target")
    ax.set_ylabel("e_rel,ref (-)")
    if title:
        ax.set_title(title)
    ax.legend(fontsize="small")
    ax.grid(alpha=0.3)


def save_figures(path: str | os.PathLike, sets: Mapping[str, tuple[np.ndarray, np.ndarray]],
                 spread: Mapping[str, np.ndarray] | None = None, title: str = "") -> Path:
    """One figure: a regression plot per set and a prediction plot of the last set.

    ``sets`` maps a set name (e.g. ``"training"``, ``"test"``) to (targets, outputs).
    """
    names = list(sets)
    fig = new_figure((4.2 * (len(names) + 1), 4.0))
    axes = fig.subplots(1, len(names) + 1)
    for ax, name in zip(axes, names, strict=False):
        regression_axes(ax, *sets[name], title=name)
    last = names[-1]
    prediction_axes(axes[-1], *sets[last],
                    spread=None if spread is None else spread.get(last), title=last)
    return save_figure(fig, path, title=title)


def save_learning_curve(path: str | os.PathLike, curves: Mapping[str, Sequence], title: str = ""
                        ) -> Path:
    """Learning curves (:func:`rths3d.ann.learning_curve.learning_curve`) in one figure.

    ``curves`` maps a label (e.g. ``"set 1"``) to its list of ``LearningPoint``. Left: test ρ
    of the ensemble (solid) and training ρ (dashed) against the training size; right: the
    test residual of log10(prediction / target) in decades, log-log, where a straight falling
    line means more data keeps helping.
    """
    from matplotlib.ticker import FormatStrFormatter, NullFormatter

    fig = new_figure((10.0, 4.0))
    a1, a2 = fig.subplots(1, 2)
    for label, pts in curves.items():
        n = [p.n_train for p in pts]
        line, = a1.semilogx(n, [p.r_test_ensemble for p in pts], "o-", label=f"{label} test")
        a1.semilogx(n, [p.r_train_ensemble for p in pts], "s--", color=line.get_color(),
                    mfc="none", label=f"{label} training")
        a2.loglog(n, [p.log_residual_test for p in pts], "o-", color=line.get_color(),
                  label=label)
    a1.axhline(0.99, color="k", lw=0.8, ls=":", label="ρ = 0.99")
    # one or two decades: label the training sizes themselves, not overlapping minor ticks
    sizes = sorted({p.n_train for pts in curves.values() for p in pts})
    for ax in (a1, a2):
        ax.set_xticks(sizes, [str(v) for v in sizes])
        ax.xaxis.set_minor_formatter(NullFormatter())
    a2.yaxis.set_major_formatter(FormatStrFormatter("%.3g"))
    a2.yaxis.set_minor_formatter(FormatStrFormatter("%.3g"))
    a1.set_xlabel("training tests")
    a1.set_ylabel("ρ (eq. 15), ensemble")
    a1.legend(fontsize="small")
    a1.grid(alpha=0.3, which="both")
    a2.set_xlabel("training tests")
    a2.set_ylabel("test residual of log10(pred / target) (decades)")
    a2.legend(fontsize="small")
    a2.grid(alpha=0.3, which="both")
    return save_figure(fig, path, title=title)
