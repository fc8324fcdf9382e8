"""The figures of a study report, drawn from its summary records (femu.reports.records) and
saved through femu.reports.render: convergence (with the best J known), fixed-target ECDF, solver
overhead, mean frequency error against the paper, the updated parameters of each optimizer's best
run beside the initial ones, the frame in its first modes (initial and updated model) and the MAC
matrices of the updated modes."""

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
    if g.best_known_f is not None and g.best_known_f > 0:
        known = "lowest J found" if g.best_known_how.startswith("the lowest J of the runs") else "best known J"
        ax.axhline(g.best_known_f, color="k", ls="--", lw=1.2, label=f"{known} = {g.best_known_f:.5g}")
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_xlabel("FE evaluations")
    ax.set_ylabel("best objective so far, J")
    ax.set_title(f"Convergence: {g.variant}, budget {g.budget} (median, band = quartiles over seeds)", fontsize=10)
    ax.grid(True, which="both", alpha=0.25)
    ax.legend(fontsize=7.5, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)  # off the curves
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



#: A parameter kind's unit on the figures and the factor from SI.
UNITS = {"modulus": ("GPa", 1e-9), "density": ("kg/m^3", 1.0), "mass": ("kg", 1.0), "spring": ("N/m", 1.0),
         "release": ("N m/rad", 1.0)}


def parameter_unit(g: GroupSummary) -> tuple[str, float]:
    """The unit the group's parameters are shown in, and the factor from SI (one kind: its unit)."""
    kinds = set(g.parameters.kinds)
    return UNITS.get(kinds.pop(), ("", 1.0)) if len(kinds) == 1 else ("SI", 1.0)


def plot_parameters(g: GroupSummary, path: Path) -> Path:
    """The updated parameters (moduli) of each optimizer's best run, one group of bars per element
    (parameter), each bar drawn from the initial value (black line) to the updated one, between
    the bounds (dashed): a bar that reaches a dashed line is pinned at that bound."""
    q = g.parameters
    unit, f = parameter_unit(g)
    shown = [s for s in g.solvers if s.best_x is not None]
    colors = _colors(s.optimizer for s in g.solvers)
    from .render import figure

    fig, axes = figure(width=max(7.5, 0.9 * len(q.labels) + 2.5), height=4.8)
    ax = axes[0, 0]
    n = max(len(shown), 1)
    width = 0.84 / n
    x = np.arange(len(q.labels))
    lo = float(np.min(q.lower)) * f
    for k, s in enumerate(shown):
        ax.bar(x - 0.42 + (k + 0.5) * width, (s.best_x - q.x0) * f, width, bottom=q.x0 * f,
               color=colors[s.optimizer], label=f"{s.optimizer} (seed {s.best_seed})")
    ax.hlines(q.x0 * f, x - 0.45, x + 0.45, colors="k", lw=1.6, label="initial")
    ax.hlines(q.lower * f, x - 0.45, x + 0.45, colors="0.3", linestyles="--", lw=1)
    ax.hlines(q.upper * f, x - 0.45, x + 0.45, colors="0.3", linestyles="--", lw=1, label="bounds")
    for b in x[:-1] + 0.5:  # where one element's group ends
        ax.axvline(b, color="0.85", lw=0.8, zorder=0)
    span = float(np.max(q.upper) - np.min(q.lower)) * f
    ax.set_ylim(lo - 0.02 * span, float(np.max(q.upper)) * f + 0.04 * span)
    ax.set_xticks(x, q.labels)
    ax.set_xlabel("parameter (E<n>: the modulus of element n)")
    ax.set_ylabel(f"value ({unit})")
    ax.set_title(f"Updated parameters of each optimizer's best run: {g.variant}, budget {g.budget}", fontsize=10)
    ax.grid(True, axis="y", alpha=0.25)
    ax.legend(fontsize=7, ncols=1, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    save_figure(fig, path)
    return path


def plot_mode_shapes(g: GroupSummary, path: Path, n_modes: int = 4) -> Path:
    """The frame in its first modes: the initial model's shape (grey) and the updated model's
    (the group's best run, coloured) on the undeformed frame, one panel per mode."""
    # the drawing plane of the diagnosis figures: a planar model as it is, a space model projected
    from .diagnosis import deformed_frame, projected
    from .render import figure

    m = g.modes
    model = m.model
    k = min(n_modes, m.shapes_initial.shape[1])
    fig, axes = figure(width=2.7 * k + 0.4, height=3.9, ncols=k)
    xy = projected(model, model.coordinates)
    size = float(np.max(np.ptp(xy, axis=0)))
    index = {n.id: i for i, n in enumerate(model.nodes)}
    segs = np.array([[xy[index[e.node_i]], xy[index[e.node_j]]] for e in model.elements])
    trans = [i for i, (node, d) in enumerate(model.dofs) if d in model.layout.translations]
    for p in range(k):
        ax = axes[0, p]
        for s in segs:
            ax.plot(s[:, 0], s[:, 1], color="0.8", lw=1.0, zorder=1)
        u0, u1 = m.shapes_initial[:, p], m.shapes_updated[:, p]
        scale = 0.12 * size / max(float(np.max(np.abs(u0[trans]))), 1e-300)
        # the initial shape wide and light under the updated one: where they differ both show
        for curve in deformed_frame(model, u0, scale):
            ax.plot(curve[:, 0], curve[:, 1], color="tab:orange", lw=4.0, alpha=0.55, zorder=2)
        for curve in deformed_frame(model, u1, scale):
            ax.plot(curve[:, 0], curve[:, 1], color="tab:blue", lw=1.5, zorder=3)
        meas = g.measured_hz[p] if p < len(g.measured_hz) else math.nan
        ax.set_title(f"mode {p + 1}: initial {m.frequencies_initial_hz[p]:.1f} Hz\nupdated "
                     f"{m.frequencies_updated_hz[p]:.1f} Hz, measured {meas:.1f} Hz", fontsize=8.5)
        ax.set_aspect("equal")
        ax.margins(0.1)
        ax.tick_params(labelsize=7)
        ax.set_xlabel("x (m)", fontsize=8)
    axes[0, 0].plot([], [], color="tab:orange", lw=4.0, alpha=0.55, label="initial model")
    axes[0, 0].plot([], [], color="tab:blue", lw=1.5, label=f"updated model ({m.optimizer}, seed {m.seed})")
    axes[0, 0].plot([], [], color="0.8", lw=1.0, label="undeformed frame")
    fig.legend(*axes[0, 0].get_legend_handles_labels(), loc="outside lower center", ncols=3, fontsize=8)
    fig.suptitle(f"The frame in its first modes, initial and updated model: {g.variant}, budget {g.budget}",
                 fontsize=10)
    save_figure(fig, path)
    return path


def _mac_panel(ax, values: np.ndarray, rows: str, cols: str, title: str) -> None:
    im = ax.imshow(values, vmin=0.0, vmax=1.0, cmap="Blues")
    n, k = values.shape
    for i in range(n):
        for j in range(k):
            v = values[i, j]
            if math.isfinite(v):
                ax.text(j, i, f"{v:.2f}", ha="center", va="center", fontsize=7,
                        color="white" if v > 0.6 else "black")
    ax.set_xticks(range(k), [str(j + 1) for j in range(k)])
    ax.set_yticks(range(n), [str(i + 1) for i in range(n)])
    ax.set_xlabel(cols, fontsize=8.5)
    ax.set_ylabel(rows, fontsize=8.5)
    ax.set_title(title, fontsize=9)
    return im


def plot_mac(g: GroupSummary, path: Path) -> Path:
    """MAC matrices of the updated model's modes (the group's best run): against the measured
    modes when the data have shapes, and against the initial model's modes."""
    from .render import figure

    m = g.modes
    panels = [(m.mac_initial_updated, "initial model mode", "updated model mode",
               "initial vs updated model\n(translations of every node)")]
    if m.mac_measured_updated is not None:
        panels.insert(0, (m.mac_measured_updated, "measured mode", "updated model mode",
                          "measured vs updated model\n(the measured coordinates)"))
    fig, axes = figure(width=max(6.0, 4.2 * len(panels) + 0.8), height=4.2, ncols=len(panels))
    for ax, (values, rows, cols, title) in zip(axes[0], panels):
        im = _mac_panel(ax, values, rows, cols, title)
    fig.colorbar(im, ax=list(axes[0]), shrink=0.8, label="MAC")
    fig.suptitle(f"MAC of the updated modes ({m.optimizer}, seed {m.seed}): {g.variant}, budget {g.budget}"
                 + ("" if m.mac_measured_updated is not None else "\n(no measured shapes in these data)"),
                 fontsize=10)
    save_figure(fig, path)
    return path
