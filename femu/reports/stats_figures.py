"""Figures of the benchmark statistics (femu.reports.stats): fixed-target ECDFs, ERT against the
target precision, fixed-budget box plots, convergence per problem and the critical-difference
diagram.

Each function draws records that `stats` computed (nothing is computed here but positions) on
a `render.figure` and writes it with `render.save_figure`; one panel per group
(family/dimension) where there are several. Solver colours are the same in every figure.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .render import figure, save_figure, solver_colors
from .stats import AggregateEcdf, BlockComparison, Comparison, Ecdf, ErtTable, FixedBudget, Profiles

#: Panels per row of a multi-group figure.
COLUMNS = 3


def _panels(groups: list[str], height: float = 3.4):
    cols = min(COLUMNS, len(groups))
    rows = math.ceil(len(groups) / cols)
    fig, axes = figure(width=4.2 * cols + 1.6, height=height * rows + 0.4, nrows=rows, ncols=cols)
    flat = list(axes.ravel())
    for ax in flat[len(groups):]:
        ax.set_visible(False)
    return fig, dict(zip(groups, flat))


def _legend(fig, colors: dict) -> None:
    from matplotlib.lines import Line2D

    handles = [Line2D([], [], color=c, lw=2.2) for c in colors.values()]
    fig.legend(handles, list(colors), loc="outside right upper", fontsize=9, frameon=False)


def plot_ecdf(ecdfs: list[Ecdf], path) -> Path:
    """Fraction of (run, target) pairs reached against FE evaluations, per group and solver."""
    groups = sorted({e.group for e in ecdfs})
    colors = solver_colors(sorted({e.solver for e in ecdfs}))
    fig, axes = _panels(groups)
    for e in ecdfs:
        ax = axes[e.group]
        ax.step(e.budgets, e.fraction, where="post", color=colors[e.solver], lw=1.8)
    for g, ax in axes.items():
        n = max(e.n_runs for e in ecdfs if e.group == g)
        ax.set(xscale="log", ylim=(-0.02, 1.02), title=f"{g} ({n} runs per solver)",
               xlabel="FE evaluations", ylabel="fraction of (run, target) pairs")
        ax.grid(True, which="both", alpha=0.25)
    fig.suptitle("Fixed-target ECDF, 51 targets on J - f_opt over 10 decades, instances pooled", fontsize=11)
    _legend(fig, colors)
    return save_figure(fig, path)


def plot_ert(table: ErtTable, path) -> Path:
    """ERT (evaluations, log) against the target precision level; a marker where a target
    is not reached by any run sits on the top edge."""
    groups = sorted({g for per in table.ert.values() for g in per})
    colors = solver_colors(sorted(table.ert))
    fig, axes = _panels(groups)
    x = -np.log10(np.asarray(table.levels))
    for solver, per in table.ert.items():
        for g, values in per.items():
            v = np.asarray(values, dtype=float)
            ok = np.isfinite(v)
            axes[g].plot(x[ok], v[ok], color=colors[solver], lw=1.8, marker="o", ms=2.5)
            if table.lower:  # COCO's bootstrapped 10-90 % range of the run lengths
                lo = np.asarray(table.lower[solver][g], dtype=float)
                hi = np.asarray(table.upper[solver][g], dtype=float)
                axes[g].fill_between(x[ok], lo[ok], hi[ok], color=colors[solver], alpha=0.15, lw=0)
            if table.beyond_budget:  # an ERT past every run's budget: an open marker
                far = np.asarray(table.beyond_budget[solver][g], dtype=bool) & ok
                axes[g].plot(x[far], v[far], ls="none", marker="o", ms=6, mfc="white", color=colors[solver])
            if not ok.all():  # the first target level none of the runs reached
                axes[g].plot(x[np.argmin(ok)], 1.0, marker="x", color=colors[solver], ms=7, mew=2,
                             transform=axes[g].get_xaxis_transform(), clip_on=False)
    for g, ax in axes.items():
        ax.set(yscale="log", title=g, xlabel="target: decades below the top (log10 of Delta_top / Delta)",
               ylabel="ERT (FE evaluations)")
        ax.grid(True, which="both", alpha=0.25)
    fig.suptitle("Expected running time (COCO ERT) per target\nband: bootstrapped 10-90 %; open marker: beyond the "
                 "budget; x on the top edge: first target never reached", fontsize=10)
    _legend(fig, colors)
    return save_figure(fig, path)


def plot_fixed_budget(results: list[FixedBudget], group: str, path) -> Path:
    """Box plots of Delta = best J - f_opt per solver at each budget of one group; values below
    the precision floor are drawn at the floor (dashed line)."""
    rows = [r for r in results if r.group == group]
    if not rows:
        raise ValueError(f"no fixed-budget results for group {group!r}")
    budgets = sorted({r.budget for r in rows})
    solvers = sorted({r.solver for r in rows})
    colors = solver_colors(solvers)
    fig, axes = _panels([str(b) for b in budgets], height=3.6)
    floor = min(r.floor for r in rows)
    for r in rows:
        ax = axes[str(r.budget)]
        i = solvers.index(r.solver)
        v = np.log10(np.maximum(np.asarray(r.deltas, dtype=float), floor))
        bp = ax.boxplot([v], positions=[i], widths=0.6, patch_artist=True, showfliers=True)
        for patch in bp["boxes"]:
            patch.set(facecolor=colors[r.solver], alpha=0.55)
        for med in bp["medians"]:
            med.set(color="black", lw=1.6)
    for b, ax in axes.items():
        ax.axhline(math.log10(floor), color="grey", ls="--", lw=1)
        ax.set_xticks(range(len(solvers)), solvers, rotation=35, ha="right", fontsize=8)
        ax.set(title=f"after {b} evaluations", ylabel="log10(J - f_opt)")
        ax.grid(True, axis="y", alpha=0.25)
    fig.suptitle(f"Fixed-budget precision on {group} (dashed: precision floor, ties below)", fontsize=11)
    return save_figure(fig, path)


def plot_cd(c: BlockComparison | Comparison, path) -> Path:
    """Critical-difference diagram: mean ranks on an axis (1 = best, on the left), the Nemenyi
    CD as a scale bar, and a thick bar joining the solvers of each clique. For a
    `BlockComparison` the cliques are Nemenyi's (mean ranks closer than the CD): bars and scale
    from one test, said in the title; for the older `Comparison`, Wilcoxon-Holm's."""
    order = sorted(c.solvers, key=lambda s: (c.mean_ranks[s], s))
    k, half, n_bars = len(order), math.ceil(len(order) / 2), len(c.cliques)
    top = 0.35 + 0.3 * n_bars                      # the clique bars sit between the axis and the labels
    fig, axes = figure(width=8.0, height=1.4 + 0.3 * (half + n_bars))
    ax = axes[0, 0]
    ax.set_xlim(-1.2, k + 2.2)                    # room for the solver names on both sides
    ax.set_ylim(-(top + 0.6 * half + 0.4), 1.7)
    ax.axis("off")
    ax.hlines(0, 1, k, color="black", lw=1.2)
    for r in range(1, k + 1):
        ax.vlines(r, 0, 0.15, color="black", lw=1)
        ax.text(r, 0.25, str(r), ha="center", va="bottom", fontsize=9)
    ax.hlines(1.25, 1, 1 + c.critical_difference, color="black", lw=1.6)
    ax.text(1 + c.critical_difference / 2, 1.35, f"Nemenyi CD = {c.critical_difference:.2f}", ha="center",
            va="bottom", fontsize=8)
    for i, s in enumerate(order):
        rank, left = c.mean_ranks[s], i < half
        y = -(top + 0.6 * (i if left else k - 1 - i))
        edge = 0.9 if left else k + 0.1
        ax.plot([rank, rank, edge], [0, y, y], color="black", lw=1)
        ax.text(edge + (-0.05 if left else 0.05), y, f"{s} ({rank:.2f})", ha="right" if left else "left",
                va="center", fontsize=9)
    for j, clique in enumerate(c.cliques):
        lo, hi = c.mean_ranks[clique[0]], c.mean_ranks[clique[-1]]
        ax.hlines(-0.25 - 0.3 * j, lo - 0.05, hi + 0.05, color="tab:red", lw=4, alpha=0.8)
    if isinstance(c, BlockComparison):
        title = (f"Mean ranks on {c.n_blocks} problems as blocks, value '{c.value}'"
                 + (f", Friedman p = {c.friedman_p:.2g}" if c.friedman_p is not None else "")
                 + f"\nred: cliques of the Nemenyi test (mean ranks closer than the CD, alpha {c.alpha})")
    else:
        title = (f"Mean ranks on {c.n_blocks} (problem, seed) blocks, metric '{c.metric}'"
                 + (f", Friedman p = {c.friedman_p:.2g}" if c.friedman_p is not None else "")
                 + f"\nred: not separated (Wilcoxon-Holm, alpha {c.alpha})")
    ax.set_title(title, fontsize=9)
    return save_figure(fig, path)


def plot_aggregate(a: AggregateEcdf, path) -> Path:
    """The ECDF over every (problem, target) pair against evaluations / dimension, one line per
    solver, its area in the legend."""
    colors = solver_colors(sorted(a.fraction))
    fig, axes = figure(width=7.5, height=4.2)
    ax = axes[0, 0]
    for solver, frac in a.fraction.items():
        ax.step(a.budgets_per_dim, frac, where="post", color=colors[solver], lw=1.8,
                label=f"{solver} (area {a.area[solver]:.3f})")
    ax.set(xscale="log", ylim=(-0.02, 1.02), xlim=(a.lower, a.upper), xlabel="FE evaluations / dimension",
           ylabel="fraction of (problem, target) pairs")
    ax.grid(True, which="both", alpha=0.25)
    ax.legend(fontsize=8, frameon=False, loc="upper left")
    ax.set_title("ECDF aggregated over all problems and targets (problems weighted equally)", fontsize=10)
    return save_figure(fig, path)


def plot_profiles(profiles: list[Profiles], path) -> Path:
    """Data profiles (top row) and performance profiles (bottom row), one column per tolerance."""
    solvers = sorted({s for p in profiles for s in p.data})
    colors = solver_colors(solvers)
    n = len(profiles)
    fig, axes = figure(width=3.4 * n + 1.6, height=6.6, nrows=2, ncols=n)
    for j, p in enumerate(profiles):
        top, bottom = axes[0, j], axes[1, j]
        for s in solvers:
            top.step(p.alpha, p.data[s], where="post", color=colors[s], lw=1.8)
            bottom.step(p.ratio, p.performance[s], where="post", color=colors[s], lw=1.8)
        top.set(xscale="log", ylim=(-0.02, 1.02), title=f"data profile, tau = {p.tolerance:g}",
                xlabel="alpha: evaluations / (n_var + 1)", ylabel="fraction of problems")
        bottom.set(xscale="log", ylim=(-0.02, 1.02), title=f"performance profile, tau = {p.tolerance:g}",
                   xlabel="ratio to the best solver's ERT", ylabel="fraction of problems")
        for ax in (top, bottom):
            ax.grid(True, which="both", alpha=0.25)
    fig.suptitle(f"Moré-Wild data and Dolan-Moré performance profiles on {len(profiles[0].problems)} problems",
                 fontsize=11)
    _legend(fig, colors)
    return save_figure(fig, path)


def plot_convergence(curves: list[dict], path) -> Path:
    """Median (line) and quartiles (band) of J - f_opt against FE evaluations, one panel per
    problem, one colour per solver; `curves` as femu.reports.benchmark.convergence gives them."""
    problems = sorted({c["problem"] for c in curves})
    colors = solver_colors(sorted({c["solver"] for c in curves}))
    fig, axes = _panels(problems, height=3.2)
    for c in curves:
        ax = axes[c["problem"]]
        ax.plot(c["evals"], c["median"], color=colors[c["solver"]], lw=1.8)
        ax.fill_between(c["evals"], c["q1"], c["q3"], color=colors[c["solver"]], alpha=0.18, lw=0)
    for p, ax in axes.items():
        ax.set(xscale="log", yscale="log", title=p, xlabel="FE evaluations", ylabel="J - f_opt (floored)")
        ax.grid(True, which="both", alpha=0.25)
    fig.suptitle("Convergence per problem: median and quartiles over seeds", fontsize=11)
    _legend(fig, colors)
    return save_figure(fig, path)
