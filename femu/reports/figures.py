"""The figures of a study report, drawn from its summary records (femu.reports.records) and
saved through femu.reports.render: convergence, fixed-target ECDF, solver overhead and mean
frequency error against the paper."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .records import GroupSummary
from .render import figure, save_figure


def _colors(names) -> dict:
    """One colour per optimizer, the same in every figure of a group; never grey, which
    marks the initial model and the paper's numbers."""
    from matplotlib import colormaps

    tab10, tab20 = colormaps["tab10"], colormaps["tab20"]
    palette = [tab10(i) for i in range(10) if i != 7] + [tab20(i) for i in range(1, 20, 2) if i not in (15,)]
    return {n: palette[i % len(palette)] for i, n in enumerate(names)}


def _figure():
    """One figure of the default size and its single axes."""
    fig, axes = figure()
    return fig, axes[0, 0]


def plot_convergence(g: GroupSummary, path: Path) -> Path:
    """Best-so-far objective vs evaluations: median line and quartile band per optimizer."""
    fig, ax = _figure()
    colors = _colors(s.optimizer for s in g.solvers)
    for s in g.solvers:
        if s.curve is None:
            continue
        c = s.curve
        ok = np.isfinite(c.median)
        ax.plot(c.evals[ok], c.median[ok], color=colors[s.optimizer], lw=1.8, label=s.optimizer)
        band = np.isfinite(c.q1) & np.isfinite(c.q3)
        ax.fill_between(c.evals[band], c.q1[band], c.q3[band], color=colors[s.optimizer], alpha=0.18, lw=0)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("FE evaluations")
    ax.set_ylabel("best objective so far, J")
    ax.set_title(f"Convergence: {g.variant}, budget {g.budget} (median, band = quartiles over seeds)", fontsize=10)
    ax.grid(True, which="both", alpha=0.25)
    ax.legend(fontsize=8, ncols=2)
    save_figure(fig, path)
    return path


def plot_ecdf(g: GroupSummary, path: Path) -> Path:
    """Fraction of (run, target) pairs reached vs evaluations, one line per optimizer."""
    fig, ax = _figure()
    colors = _colors(s.optimizer for s in g.solvers)
    for s in g.solvers:
        if s.ecdf is not None:
            ax.step(g.grid, s.ecdf, where="post", color=colors[s.optimizer], lw=1.8, label=s.optimizer)
    ax.set_xscale("log")
    ax.set_ylim(-0.02, 1.02)
    ax.set_xlabel("FE evaluations")
    ax.set_ylabel("fraction of (run, target) pairs reached")
    if len(g.targets):
        ax.set_title(f"Fixed-target ECDF: {g.variant}, budget {g.budget}, {len(g.targets)} targets "
                     f"{g.targets[0]:.3g} .. {g.targets[-1]:.3g}", fontsize=10)
    ax.grid(True, which="both", alpha=0.25)
    ax.legend(fontsize=8, ncols=2, loc="upper left")
    save_figure(fig, path)
    return path


def plot_overhead(g: GroupSummary, path: Path) -> Path:
    """Bar chart of the solver's own time per evaluation, (wall - FE) / n_evals in ms."""
    fig, ax = _figure()
    colors = _colors(s.optimizer for s in g.solvers)
    names = [s.optimizer for s in g.solvers]
    med = np.array([s.overhead_ms_per_eval.median for s in g.solvers])
    lo = np.array([s.overhead_ms_per_eval.q1 for s in g.solvers])
    hi = np.array([s.overhead_ms_per_eval.q3 for s in g.solvers])
    fe = np.array([1000 * s.fe_s.median / s.n_evals.median if s.n_evals.median else np.nan for s in g.solvers])
    x = np.arange(len(names))
    pos = np.where(med > 0, med, np.nan)
    ax.bar(x, pos, color=[colors[n] for n in names],
           yerr=np.nan_to_num(np.vstack([pos - np.minimum(lo, pos), np.maximum(hi, pos) - pos])), capsize=3)
    ax.plot(x, fe, "k_", ms=22, mew=2, label="FE time per evaluation (median)")
    ax.set_yscale("log")
    ax.set_xticks(x, names, rotation=25, ha="right", fontsize=9)
    ax.set_ylabel("ms per evaluation")
    ax.set_title(f"Solver overhead (wall - FE) / evaluations: {g.variant}, budget {g.budget}", fontsize=10)
    ax.grid(True, axis="y", which="both", alpha=0.25)
    ax.legend(fontsize=8)
    save_figure(fig, path)
    return path


def plot_errors(g: GroupSummary, path: Path) -> Path:
    """Mean absolute frequency error per solver (median, quartile whiskers), with the
    initial model and, for the paper's data, the paper's methods recomputed from its table."""
    fig, ax = _figure()
    colors = _colors(s.optimizer for s in g.solvers)
    labels, vals, err, cols, hatch = ["initial (ours)"], [g.initial_mean_abs_error_pct], [(0, 0)], ["0.55"], ["//"]
    for s in g.solvers:
        m = s.mean_abs_error_pct
        labels.append(s.optimizer)
        vals.append(m.median)
        err.append((m.median - m.q1, m.q3 - m.median) if m.n else (0, 0))
        cols.append(colors[s.optimizer])
        hatch.append("")
    if g.paper is not None:
        for k in ("initial", *g.paper.updated_hz):
            labels.append(f"paper {k}")
            vals.append(g.paper.mean_abs_error_pct[k])
            err.append((0, 0))
            cols.append("0.8")
            hatch.append("//" if k == "initial" else "")
    x = np.arange(len(labels))
    err = np.nan_to_num(np.array(err, dtype=float).T)
    bars = ax.bar(x, vals, color=cols, edgecolor="0.2", linewidth=0.6)
    spread = err.sum(axis=0) > 0
    ax.errorbar(x[spread], np.asarray(vals)[spread], yerr=err[:, spread], fmt="none", ecolor="k", capsize=3)
    for b, h in zip(bars, hatch):
        b.set_hatch(h)
    for i, v in enumerate(vals):
        if math.isfinite(v):  # above the upper whisker, so the number stays readable
            ax.text(i, v + err[1, i], f"{v:.2f}", ha="center", va="bottom", fontsize=7.5)
    ax.set_xticks(x, labels, rotation=30, ha="right", fontsize=9)
    ax.set_ylabel("mean |frequency error| (%)")
    ax.set_title(f"Mean absolute frequency error: {g.variant}, budget {g.budget}, median and quartiles"
                 + ("\n(light grey: the paper's Table 1, recomputed; hatched: initial models)"
                    if g.paper is not None else ""), fontsize=10)
    ax.grid(True, axis="y", alpha=0.25)
    save_figure(fig, path)
    return path

