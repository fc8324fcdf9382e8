"""Summaries of a study's runs: `summarize(runs)` turns RunResults into `GroupSummary` records,
one per (problem variant, budget), each holding a `SolverSummary` per optimizer: median and
quartiles over seeds of best_f, of the updated frequencies (from the problem's
`correlation(best_x)`, a post-processing solve, not a counted FE evaluation), of the signed and
absolute frequency errors (%), MAC and COMAC where the data have shapes, evaluations,
wall/CPU/FE seconds, the solver overhead, failures, the best-so-far curves and the
fixed-target ECDF, and each optimizer's best run (its seed and updated parameters); per group the
parameters' initial values and bounds, the best J known (a line on the convergence plots), the
first modes of the initial and the updated model (the group's best run) with their MAC matrices;
for the 'paper' variant also the paper's own Table 1 numbers.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import replace

import numpy as np

from adapters.harness import RunResult
from adapters.registry import BUILTINS

from .records import (FAILED, ArraySpread, Curve, GroupSummary, ModeComparison, PaperComparison,  # noqa: F401
                      Parameters, SolverSummary, Spread)

#: How many fixed targets the ECDF uses (log-spaced).
N_TARGETS = 51


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
    """Sort key: built-ins in registry order, then plugins by name."""
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
    """The first line of a run's error ("" for none)."""
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
    usable = [r for r in runs if len(r.best_x) == problem.n_var and math.isfinite(r.best_f)]
    best = min(usable, key=lambda r: (r.best_f, r.seed)) if usable else None
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
        curve=curve, best_seed=None if best is None else best.seed,
        best_run_f=math.nan if best is None else float(best.best_f),
        best_x=None if best is None else np.asarray(best.best_x, dtype=float))


def _parameters(problem) -> Parameters:
    return Parameters(tuple(p.label for p in problem.parameters), tuple(p.kind for p in problem.parameters),
                      np.asarray(problem.x0, float), np.asarray(problem.xl, float), np.asarray(problem.xu, float))


def _best_known(variant: str, solvers) -> tuple[float | None, str]:
    """The lowest J known for the group's problem and where it comes from."""
    lowest = min((float(s.best_run_f) for s in solvers if math.isfinite(s.best_run_f)), default=None)
    if variant == "paper":
        from fe_problem.suite import PAPER_F_OPT

        if lowest is not None and lowest < PAPER_F_OPT:
            return lowest, "the lowest J of the runs here, below the best known before (fe_problem.suite.PAPER_F_OPT)"
        return PAPER_F_OPT, "the best J known for the paper's problem (fe_problem.suite.PAPER_F_OPT)"
    return lowest, "the lowest J of the runs here"


#: How many modes the frame drawing shows at most.
N_DRAWN_MODES = 4


def _modes(problem, solvers) -> ModeComparison | None:
    """The first modes of the initial model and of the model at the group's best point."""
    from fe_problem import mac

    best = [s for s in solvers if s.best_x is not None]
    if not best:
        return None
    s = min(best, key=lambda s: (s.best_run_f, s.optimizer))
    k = len(problem.data.frequencies_hz)
    init, upd = problem.modal(None, k), problem.modal(s.best_x, k)
    sign = np.where(np.sum(init.shapes * upd.shapes, axis=0) < 0, -1.0, 1.0)
    model = problem.model
    # a frame: the translations of every node; a matrix model (no nodes): every DOF
    moving = ([(n.id, d) for n in model.nodes for d in model.layout.translations] if hasattr(model, "nodes")
              else list(model.dofs))
    mac_iu = mac(init.at(moving), upd.at(moving))
    data = problem.data
    mac_mu = None
    if data.has_shape.any():
        rows = np.flatnonzero(data.has_shape)
        mac_mu = np.full((k, k), np.nan)
        mac_mu[rows] = mac(data.shapes[:, rows], upd.at(data.dofs))
    return ModeComparison(model, s.optimizer, int(s.best_seed), float(s.best_run_f), init.frequencies_hz,
                          upd.frequencies_hz, init.shapes, upd.shapes * sign, mac_iu, mac_mu)


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
        best_f, how = _best_known(variant, solvers)
        out.append(GroupSummary(
            variant=variant, budget=budget, measured_hz=init.measured_hz, initial_hz=init.model_hz,
            initial_error_pct=init.error_pct, initial_mac=init.mac if has_shapes else None,
            initial_mean_comac=float(np.mean(init.comac)) if has_shapes else None, has_shapes=has_shapes,
            solvers=tuple(solvers), grid=grid, targets=targets, paper=paper if variant == "paper" else None,
            parameters=_parameters(problem), best_known_f=best_f, best_known_how=how,
            modes=_modes(problem, solvers)))
    return out

