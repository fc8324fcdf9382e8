"""Reports of a study: summary records computed from the runs, then Markdown and PNG figures.

Two stages, kept apart on purpose (a report renders records and computes nothing new):

1. `summarize(runs)` turns the RunResults of a store into `GroupSummary` records, one per
   (problem variant, budget), each holding a `SolverSummary` per optimizer: median and
   quartiles over seeds of best_f, of the updated frequencies (from the problem's
   `correlation(best_x)`, which is a post-processing solve, not a counted FE evaluation), of
   the signed and absolute frequency errors (%), MAC and COMAC where the data have shapes,
   evaluations, wall/CPU/FE seconds, the solver overhead, failures, the best-so-far curves and
   the fixed-target ECDF; for the 'paper' variant also the paper's own Table 1 numbers.
2. `write_report(store_or_runs, out_dir)` renders those records as DIR/report.md,
   DIR/summary.json and PNG figures (convergence, ECDF, overhead, mean error vs the paper).
"""

from __future__ import annotations

import json
import math
from collections import Counter
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from adapters.harness import RunResult
from adapters.registry import BUILTINS
from femu.studies.store import Store

from .render import figure, markdown_table, save_figure

#: Statuses that count as a failed run (no usable result or cut short by an error).
FAILED = ("failed", "timeout")
#: The paper's method names and the optimizers here that play their part.
PAPER_COUNTERPART = {"PSO": "mlp-surrogate", "SA": "scipy-sa", "GA": "pymoo-ga, deap-ga"}
#: How many fixed targets the ECDF uses (log-spaced).
N_TARGETS = 51


# == records ==================================================================================
@dataclass(frozen=True)
class Spread:
    """Median and quartiles of one quantity over the runs that have it (n of them)."""

    median: float
    q1: float
    q3: float
    n: int

    @classmethod
    def of(cls, values) -> "Spread":
        v = np.asarray(list(values), dtype=float)
        v = v[np.isfinite(v)]
        if not v.size:
            return cls(math.nan, math.nan, math.nan, 0)
        q1, med, q3 = np.quantile(v, [0.25, 0.5, 0.75])
        return cls(float(med), float(q1), float(q3), int(v.size))

    @property
    def iqr(self) -> float:
        return self.q3 - self.q1

    def to_dict(self) -> dict:
        return {"median": _num(self.median), "q1": _num(self.q1), "q3": _num(self.q3), "n": self.n}


@dataclass(frozen=True, eq=False)
class ArraySpread:
    """Per-component median and quartiles over runs: arrays of shape (m,)."""

    median: np.ndarray
    q1: np.ndarray
    q3: np.ndarray
    n: int

    @classmethod
    def of(cls, rows: np.ndarray) -> "ArraySpread":
        rows = np.asarray(rows, dtype=float)
        q1, med, q3 = np.nanquantile(rows, [0.25, 0.5, 0.75], axis=0)
        return cls(med, q1, q3, rows.shape[0])

    def to_dict(self) -> dict:
        return {"median": _arr(self.median), "q1": _arr(self.q1), "q3": _arr(self.q3), "n": self.n}


@dataclass(frozen=True, eq=False)
class Curve:
    """Best-so-far objective against evaluations: median and quartiles over runs (grid,)."""

    evals: np.ndarray
    median: np.ndarray
    q1: np.ndarray
    q3: np.ndarray


@dataclass(frozen=True, eq=False)
class SolverSummary:
    """One optimizer on one (variant, budget), over its seeds.

    Frequencies in Hz, errors in % of the measured frequency (signed: model - measured),
    times in seconds, overhead_ms_per_eval = 1000 (wall_s - fe_s) / n_evals. Quantities from
    the updated model (frequencies_hz .. mean_comac) cover the runs that produced a point.
    """

    optimizer: str
    variant: str
    budget: int
    seeds: tuple[int, ...]
    statuses: dict
    failures: tuple[tuple[int, str, str], ...]  # (seed, status, first line of the error)
    best_f: Spread
    frequencies_hz: ArraySpread | None
    error_pct: ArraySpread | None
    abs_error_pct: ArraySpread | None
    mean_abs_error_pct: Spread
    mac: ArraySpread | None
    mean_comac: Spread | None
    n_evals: Spread
    wall_s: Spread
    cpu_s: Spread
    fe_s: Spread
    overhead_s: Spread
    overhead_ms_per_eval: Spread
    curve: Curve | None
    ecdf: np.ndarray | None = None  # fraction of (run, target) pairs reached on the group's grid

    @property
    def n_runs(self) -> int:
        return len(self.seeds)

    @property
    def n_failed(self) -> int:
        return sum(self.statuses.get(s, 0) for s in FAILED)

    @property
    def status(self) -> str:
        """The common status of every run, or ``mixed``."""
        return next(iter(self.statuses)) if len(self.statuses) == 1 else "mixed"

    def to_dict(self) -> dict:
        opt = lambda s: None if s is None else s.to_dict()  # noqa: E731
        return {"optimizer": self.optimizer, "variant": self.variant, "budget": self.budget,
                "seeds": list(self.seeds), "status": self.status, "statuses": dict(self.statuses),
                "failures": [{"seed": s, "status": st, "error": e} for s, st, e in self.failures],
                "best_f": self.best_f.to_dict(), "frequencies_hz": opt(self.frequencies_hz),
                "error_pct": opt(self.error_pct), "abs_error_pct": opt(self.abs_error_pct),
                "mean_abs_error_pct": self.mean_abs_error_pct.to_dict(), "mac": opt(self.mac),
                "mean_comac": opt(self.mean_comac), "n_evals": self.n_evals.to_dict(),
                "wall_s": self.wall_s.to_dict(), "cpu_s": self.cpu_s.to_dict(), "fe_s": self.fe_s.to_dict(),
                "overhead_s": self.overhead_s.to_dict(),
                "overhead_ms_per_eval": self.overhead_ms_per_eval.to_dict()}


@dataclass(frozen=True, eq=False)
class PaperComparison:
    """The paper's Table 1 and text figures, with its mean absolute errors recomputed (%)
    from the table's frequencies; `disagreements` name the methods whose text percentage
    differs from what the table implies by more than 0.05 percentage points."""

    measured_hz: np.ndarray
    initial_hz: np.ndarray
    updated_hz: dict
    abs_error_pct: dict  # method (and "initial") -> (m,) from the table
    mean_abs_error_pct: dict  # method -> float, from the table
    mean_error_pct_text: dict
    mean_comac_text: dict
    cpu_minutes_text: dict
    disagreements: tuple[str, ...]


@dataclass(frozen=True, eq=False)
class GroupSummary:
    """Every optimizer on one problem variant under one budget, with the initial model,
    the ECDF targets and grid, and (variant 'paper') the paper's own numbers."""

    variant: str
    budget: int
    measured_hz: np.ndarray
    initial_hz: np.ndarray
    initial_error_pct: np.ndarray
    initial_mac: np.ndarray | None
    initial_mean_comac: float | None
    has_shapes: bool
    solvers: tuple[SolverSummary, ...]
    grid: np.ndarray  # evaluations at which curves and ECDFs are sampled
    targets: np.ndarray  # ECDF objective targets, descending
    paper: PaperComparison | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)

    @property
    def initial_mean_abs_error_pct(self) -> float:
        return float(np.mean(np.abs(self.initial_error_pct)))

    def solver(self, name: str) -> SolverSummary:
        for s in self.solvers:
            if s.optimizer == name:
                return s
        raise KeyError(f"no optimizer {name!r} in {self.variant} b{self.budget}")

    def to_dict(self) -> dict:
        d = {"variant": self.variant, "budget": self.budget, "measured_hz": _arr(self.measured_hz),
             "initial_hz": _arr(self.initial_hz), "initial_error_pct": _arr(self.initial_error_pct),
             "initial_mean_abs_error_pct": self.initial_mean_abs_error_pct,
             "initial_mean_comac": self.initial_mean_comac, "has_shapes": self.has_shapes,
             "targets": _arr(self.targets), "solvers": {s.optimizer: s.to_dict() for s in self.solvers}}
        if self.paper is not None:
            p = self.paper
            d["paper"] = {"measured_hz": _arr(p.measured_hz), "initial_hz": _arr(p.initial_hz),
                          "updated_hz": {k: _arr(v) for k, v in p.updated_hz.items()},
                          "mean_abs_error_pct_from_table": p.mean_abs_error_pct,
                          "mean_error_pct_text": p.mean_error_pct_text, "mean_comac_text": p.mean_comac_text,
                          "cpu_minutes_text": p.cpu_minutes_text, "text_disagrees_with_table": list(p.disagreements)}
        return d


def _num(x):
    return None if x is None or not math.isfinite(x) else float(x)


def _arr(a):
    return None if a is None else [_num(float(v)) for v in np.asarray(a, dtype=float)]


# == computation ==============================================================================
def paper_comparison() -> PaperComparison:
    """The paper's Table 1 (fe_problem.paper_table()) with its errors recomputed."""
    from fe_problem import frequency_errors_pct, paper_table

    t = paper_table()
    meas = np.asarray(t["measured_hz"], float)
    rows = {"initial": np.asarray(t["initial_hz"], float)}
    rows.update({k: np.asarray(v, float) for k, v in t["updated_hz"].items()})
    abs_err = {k: np.abs(frequency_errors_pct(meas, v)) for k, v in rows.items()}
    mean = {k: float(np.mean(v)) for k, v in abs_err.items()}
    text = dict(t["mean_error_pct_text"])
    bad = tuple(k for k in mean if k in text and abs(mean[k] - text[k]) > 0.05)
    return PaperComparison(meas, rows["initial"], {k: rows[k] for k in t["updated_hz"]}, abs_err, mean, text,
                           dict(t["mean_comac_text"]), dict(t["cpu_minutes_text"]), bad)


def _optimizer_order(name: str):
    known = list(BUILTINS)
    return (known.index(name), "") if name in known else (len(known), name)


def _grid(budget: int) -> np.ndarray:
    """Evaluation counts to sample curves at: dense at the start (log) and along the run (linear)."""
    pts = np.concatenate([np.geomspace(1, budget, 120), np.linspace(1, budget, 200)])
    return np.unique(np.round(pts).astype(int))


def best_so_far(run: RunResult, grid: np.ndarray) -> np.ndarray:
    """The run's best objective after each grid count of evaluations (inf before the first)."""
    if not run.trace:
        return np.full(len(grid), np.inf)
    tr = np.asarray(run.trace, dtype=float)
    idx = np.searchsorted(tr[:, 0], grid, side="right") - 1
    return np.where(idx >= 0, tr[np.clip(idx, 0, None), 1], np.inf)


def _first_error_line(error: str | None) -> str:
    return (error or "").strip().splitlines()[0] if error else ""


def _solver_summary(name, variant, budget, runs, problem, grid) -> SolverSummary:
    corr = [problem.correlation(r.best_x) for r in runs
            if len(r.best_x) == problem.n_var and math.isfinite(r.best_f)]
    has_shapes = bool(problem.has_shape.any())
    freq = err = aerr = mac = comac = None
    if corr:
        freq = ArraySpread.of([c.model_hz for c in corr])
        err = ArraySpread.of([c.error_pct for c in corr])
        aerr = ArraySpread.of([np.abs(c.error_pct) for c in corr])
        if has_shapes:
            mac = ArraySpread.of([c.mac for c in corr])
            comac = Spread.of([np.mean(c.comac) for c in corr])
    elif has_shapes:
        comac = Spread.of([])
    traced = [r for r in runs if r.trace]
    curve = None
    if traced:
        b = np.array([best_so_far(r, grid) for r in traced])
        with np.errstate(invalid="ignore"):
            q1, med, q3 = np.quantile(b, [0.25, 0.5, 0.75], axis=0)
        curve = Curve(grid, med, q1, q3)
    n = np.array([r.n_evals for r in runs], float)
    over = np.array([r.wall_s - r.fe_s for r in runs], float)
    with np.errstate(invalid="ignore", divide="ignore"):
        per_eval = np.where(n > 0, 1000.0 * over / n, np.nan)
    return SolverSummary(
        optimizer=name, variant=variant, budget=budget, seeds=tuple(r.seed for r in runs),
        statuses=dict(Counter(r.status for r in runs)),
        failures=tuple((r.seed, r.status, _first_error_line(r.error)) for r in runs if r.status in FAILED),
        best_f=Spread.of(r.best_f for r in runs), frequencies_hz=freq, error_pct=err, abs_error_pct=aerr,
        mean_abs_error_pct=Spread.of(np.mean(np.abs(c.error_pct)) for c in corr), mac=mac, mean_comac=comac,
        n_evals=Spread.of(n), wall_s=Spread.of(r.wall_s for r in runs), cpu_s=Spread.of(r.cpu_s for r in runs),
        fe_s=Spread.of(r.fe_s for r in runs), overhead_s=Spread.of(over), overhead_ms_per_eval=Spread.of(per_eval),
        curve=curve)


def _ecdf(runs_by_opt, grid) -> tuple[np.ndarray, dict]:
    """Targets log-spaced from the worst first value to the best value found in the group,
    and per optimizer the fraction of (run, target) pairs reached on the grid."""
    firsts = [r.trace[0][1] for rs in runs_by_opt.values() for r in rs if r.trace]
    bests = [r.best_f for rs in runs_by_opt.values() for r in rs if r.trace and r.best_f > 0]
    if not firsts or not bests or max(firsts) <= min(bests):
        return np.array([]), {}
    targets = np.geomspace(max(firsts), min(bests), N_TARGETS)
    out = {}
    for name, rs in runs_by_opt.items():
        traced = [r for r in rs if r.trace]
        if not traced:
            continue
        b = np.array([best_so_far(r, grid) for r in traced])  # (runs, grid)
        # failed runs without a trace count as pairs never reached
        out[name] = (b[:, :, None] <= targets[None, None, :]).sum(axis=(0, 2)) / (len(rs) * len(targets))
    return targets, out


def summarize(runs: list[RunResult]) -> list[GroupSummary]:
    """Summary records of the runs, one GroupSummary per (variant, budget), sorted."""
    from adapters.variants import make_problem

    groups: dict[tuple[str, int], list[RunResult]] = {}
    for r in runs:
        groups.setdefault((r.variant, int(r.budget)), []).append(r)
    out = []
    paper = paper_comparison()
    for (variant, budget) in sorted(groups):
        problem = make_problem(variant)
        grid = _grid(max([budget] + [r.n_evals for r in groups[(variant, budget)]]))
        by_opt: dict[str, list[RunResult]] = {}
        for r in sorted(groups[(variant, budget)], key=lambda r: r.seed):
            by_opt.setdefault(r.optimizer, []).append(r)
        by_opt = dict(sorted(by_opt.items(), key=lambda kv: _optimizer_order(kv[0])))
        targets, ecdf = _ecdf(by_opt, grid)
        solvers = []
        for name, rs in by_opt.items():
            s = _solver_summary(name, variant, budget, rs, problem, grid)
            solvers.append(replace(s, ecdf=ecdf.get(name)))
        init = problem.correlation()
        has_shapes = bool(problem.has_shape.any())
        out.append(GroupSummary(
            variant=variant, budget=budget, measured_hz=init.measured_hz, initial_hz=init.model_hz,
            initial_error_pct=init.error_pct, initial_mac=init.mac if has_shapes else None,
            initial_mean_comac=float(np.mean(init.comac)) if has_shapes else None, has_shapes=has_shapes,
            solvers=tuple(solvers), grid=grid, targets=targets, paper=paper if variant == "paper" else None))
    return out


# == rendering: figures =======================================================================
def _colors(names) -> dict:
    """One colour per optimizer, the same in every figure of a group; never grey, which
    marks the initial model and the paper's numbers."""
    from matplotlib import colormaps

    tab10, tab20 = colormaps["tab10"], colormaps["tab20"]
    palette = [tab10(i) for i in range(10) if i != 7] + [tab20(i) for i in range(1, 20, 2) if i not in (15,)]
    return {n: palette[i % len(palette)] for i, n in enumerate(names)}


def _figure():
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


# == rendering: Markdown ======================================================================
def _f(x, fmt=".2f") -> str:
    return "n/a" if x is None or not math.isfinite(x) else format(x, fmt)


def _cell(median, q1, q3, fmt=".2f") -> str:
    """'median (IQR)'."""
    if not math.isfinite(median):
        return "n/a"
    return f"{format(median, fmt)} ({format(q3 - q1, fmt)})"


def _table1(g: GroupSummary) -> list[str]:
    p = g.paper
    head = ["mode", "measured"]
    if p is not None:
        head += ["initial (paper)"]
    head += ["initial (ours)"]
    if p is not None:
        head += [f"{k} (paper)" for k in p.updated_hz]
    head += [s.optimizer for s in g.solvers]
    rows = []
    for i in range(len(g.measured_hz)):
        r = [str(i + 1), _f(g.measured_hz[i], ".1f" if p is not None else ".2f")]  # the paper gives 1 decimal
        if p is not None:
            r.append(_f(p.initial_hz[i], ".1f"))
        r.append(_f(g.initial_hz[i]))
        if p is not None:
            r += [_f(v[i], ".1f") for v in p.updated_hz.values()]
        for s in g.solvers:
            fr = s.frequencies_hz
            r.append("n/a" if fr is None else _cell(fr.median[i], fr.q1[i], fr.q3[i]))
        rows.append(r)
    # per-mode absolute errors, then the mean
    for i in range(len(g.measured_hz)):
        r = [f"abs err % {i + 1}", ""]
        if p is not None:
            r.append(_f(p.abs_error_pct["initial"][i]))
        r.append(_f(abs(g.initial_error_pct[i])))
        if p is not None:
            r += [_f(p.abs_error_pct[k][i]) for k in p.updated_hz]
        for s in g.solvers:
            a = s.abs_error_pct
            r.append("n/a" if a is None else _cell(a.median[i], a.q1[i], a.q3[i]))
        rows.append(r)
    r = ["**mean abs err %**", ""]
    if p is not None:
        r.append(f"**{_f(p.mean_abs_error_pct['initial'])}**")
    r.append(f"**{_f(g.initial_mean_abs_error_pct)}**")
    if p is not None:
        r += [f"**{_f(p.mean_abs_error_pct[k])}**" for k in p.updated_hz]
    r += [f"**{_cell(s.mean_abs_error_pct.median, s.mean_abs_error_pct.q1, s.mean_abs_error_pct.q3)}**"
          for s in g.solvers]
    rows.append(r)
    if g.has_shapes:
        for i in range(len(g.measured_hz)):
            r = [f"MAC {i + 1}", ""] + [_f(g.initial_mac[i], ".3f")]
            r += ["n/a" if s.mac is None else _cell(s.mac.median[i], s.mac.q1[i], s.mac.q3[i], ".3f")
                  for s in g.solvers]
            rows.append(r)
        r = ["mean COMAC", "", _f(g.initial_mean_comac, ".3f")]
        r += [_cell(s.mean_comac.median, s.mean_comac.q1, s.mean_comac.q3, ".3f") for s in g.solvers]
        rows.append(r)
    elif p is not None:
        r = ["mean COMAC", "", _f(p.mean_comac_text.get("initial"), ".3g"), "n/a"]
        r += [_f(p.mean_comac_text.get(k), ".4g") for k in p.updated_hz]
        r += ["n/a"] * len(g.solvers)
        rows.append(r)
    return markdown_table(head, rows)


def _solver_table(g: GroupSummary) -> list[str]:
    head = ["optimizer", "runs", "failed", "best_f median (IQR)", "mean abs err % median (IQR)",
            "n_evals", "wall s", "CPU s", "FE s", "overhead s", "overhead ms/eval"]
    rows = []
    for s in g.solvers:
        rows.append([s.optimizer, str(s.n_runs), str(s.n_failed),
                     _cell(s.best_f.median, s.best_f.q1, s.best_f.q3, ".4g"),
                     _cell(s.mean_abs_error_pct.median, s.mean_abs_error_pct.q1, s.mean_abs_error_pct.q3),
                     _f(s.n_evals.median, ".0f"), _f(s.wall_s.median, ".3g"), _f(s.cpu_s.median, ".3g"),
                     _f(s.fe_s.median, ".3g"), _f(s.overhead_s.median, ".3g"),
                     _f(s.overhead_ms_per_eval.median, ".3g")])
    return markdown_table(head, rows)


def _paper_section(p: PaperComparison) -> list[str]:
    rows = [["initial", _f(p.mean_abs_error_pct["initial"]), _f(p.mean_error_pct_text.get("initial")),
             _f(p.mean_comac_text.get("initial"), ".4g"), "", ""]]
    for k in p.updated_hz:
        rows.append([k, _f(p.mean_abs_error_pct[k]), _f(p.mean_error_pct_text.get(k)),
                     _f(p.mean_comac_text.get(k), ".4g"), _f(p.cpu_minutes_text.get(k), ".0f"),
                     PAPER_COUNTERPART.get(k, "")])
    lines = ["### The paper's own numbers", "",
             "Mean absolute frequency error recomputed from the frequencies of the paper's Table 1, "
             "beside the percentages its text states:", ""]
    lines += markdown_table(["method", "mean abs err % (from Table 1)", "mean err % (paper's text)", "mean COMAC (text)",
                     "CPU minutes (text)", "counterpart here"], rows)
    bad = ", ".join(p.disagreements) or "none"
    lines += ["", f"The paper's text percentages do not all agree with its own table: they differ from what "
              f"the table's frequencies imply for {bad}. We compare against the table. The paper's "
              "\"PSO\" method is in fact a response surface (an MLP trained on FE runs, minimised by a GA); "
              "its counterpart here is mlp-surrogate, and pyswarms-pso runs the standard PSO the paper "
              "describes. The measured mode shapes are not published, so MAC/COMAC cannot be recomputed "
              "for the paper's data (the paper's COMAC values are quoted from its text).", ""]
    return lines


def render_markdown(groups: list[GroupSummary], figures: dict, source: str) -> str:
    """The report text from the summary records; `figures` maps (variant, budget) to
    {kind: file name}."""
    n_runs = sum(s.n_runs for g in groups for s in g.solvers)
    lines = ["# femu-bench report", "", f"Source: {source}; {n_runs} runs in {len(groups)} group(s) "
             "(problem variant x budget).", "",
             "Every number is a median over seeds with the interquartile range (Q3 - Q1) in parentheses. "
             "Updated frequencies are those of the model at each run's best point; errors are "
             "100 (f_model - f_measured) / f_measured.", "",
             "**The H-frame geometry is a reconstruction**: the paper (T. Marwala, \"Dynamic model updating "
             "using particle swarm optimization method\") gives no dimensions; ours reproduces its "
             "initial-model frequencies to about 0.15 %.", ""]
    for g in groups:
        lines += [f"## Variant `{g.variant}`, budget {g.budget} FE evaluations per run", ""]
        title = "Table 1 rebuilt" if g.paper is not None else "Frequencies"
        lines += [f"### {title}: natural frequencies (Hz) and absolute errors (%)", ""]
        lines += _table1(g)
        lines += ["", "### Solvers", ""] + _solver_table(g) + [""]
        if g.paper is not None:
            lines += _paper_section(g.paper)
        fig = figures.get((g.variant, g.budget), {})
        captions = {"convergence": "Convergence (best-so-far vs evaluations)",
                    "ecdf": "Fixed-target ECDF (targets log-spaced from the worst first value to the best found)",
                    "errors": "Mean absolute frequency error", "overhead": "Solver overhead per evaluation"}
        for kind, cap in captions.items():
            if kind in fig:
                lines += [f"![{cap}]({fig[kind]})", "", f"*{cap}.*", ""]
        failures = [(s.optimizer, *f) for s in g.solvers for f in s.failures]
        if failures:
            lines += ["### Failed runs", ""]
            lines += markdown_table(["optimizer", "seed", "status", "error"],
                            [[o, str(seed), st, e.replace("|", "\\|")] for o, seed, st, e in failures])
            lines.append("")
    return "\n".join(lines) + "\n"


def write_report(store_or_runs, out_dir, ioh: bool = False, source: str | None = None) -> Path:
    """Write OUT/report.md, OUT/summary.json and PNG figures for a Store, a store path or a
    list of RunResults; with `ioh`, also OUT/ioh (IOHprofiler files). `source` says in the
    report where the runs come from (default: the store's path). Returns report.md's path."""
    if isinstance(store_or_runs, (str, Path)):
        store_or_runs = Store(store_or_runs)
    if isinstance(store_or_runs, Store):
        default, runs = f"store `{store_or_runs.path}`", store_or_runs.runs()
    else:
        default, runs = "a list of runs", list(store_or_runs)
    source = source or default
    if not runs:
        raise ValueError(f"{source}: no finished runs to report on")
    path = render_files(summarize(runs), out_dir, source)
    if ioh:
        from .ioh import export_runs
        export_runs(runs, Path(out_dir) / "ioh")
    return path


def render_files(groups: list[GroupSummary], out_dir, source: str) -> Path:
    """Render summary records as OUT/report.md, OUT/summary.json and the PNG figures."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    figures = {}
    for g in groups:
        stem = f"{g.variant}_b{g.budget}"
        made = {"convergence": plot_convergence(g, out / f"convergence_{stem}.png"),
                "errors": plot_errors(g, out / f"errors_{stem}.png"),
                "overhead": plot_overhead(g, out / f"overhead_{stem}.png")}
        if len(g.targets):
            made["ecdf"] = plot_ecdf(g, out / f"ecdf_{stem}.png")
        figures[(g.variant, g.budget)] = {k: p.name for k, p in made.items()}
    (out / "summary.json").write_text(json.dumps([g.to_dict() for g in groups], indent=1))
    path = out / "report.md"
    path.write_text(render_markdown(groups, figures, source))
    return path
