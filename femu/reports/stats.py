"""Benchmark statistics in the manner of COCO and IOHprofiler: pure computation, no plotting.

Inputs are run traces (`RunTrace`: solver, problem id, seed, evaluations used, best-so-far
trace ``[[n_evals, best_f], ...]`` as `adapters.harness.RunResult.trace` stores it) and, per
problem, its fixed `Targets`:

- targets on the precision Delta = J - f_opt, log-spaced (5 per decade over 10 decades, as
  COCO) from the decade above the initial model's Delta; they depend on the problem only, never
  on the solvers run. Target *level* k is the k-th target of every problem, so runs on the
  instances of a family/dimension pool by level. The last target is the precision floor:
  below it, values count as equal (ties);
- first-hitting times per run and target; ERT (expected running time, COCO: the evaluations of
  all runs until they hit or stop, divided by the number of runs that hit); fixed-target
  ECDFs (fraction of (run, target) pairs hit within a budget) aggregated over instances;
  fixed-budget distributions of Delta;
- a comparison of solvers on blocks (problem, seed): Friedman's omnibus test, pairwise
  Wilcoxon signed-rank tests with Holm's correction, mean ranks, Nemenyi's critical difference
  and the cliques of solvers no Holm-corrected test separates (critical-difference diagram).

Statistics come from scipy.stats (friedmanchisquare, wilcoxon, rankdata, studentized_range);
scikit-posthocs would add pandas, seaborn and statsmodels for the same few lines.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from itertools import combinations

import numpy as np
from scipy import stats as sps

from fe_problem.jsonutil import jsonable

DECADES, PER_DECADE = 10, 5
METRICS = ("final", "auc")


def _dict(obj) -> dict:
    return jsonable({k: getattr(obj, k) for k in obj.__dataclass_fields__})


@dataclass(frozen=True)
class Targets:
    """Fixed targets of one problem: deltas (descending, > 0) on Delta = J - f_opt.

    f_opt: the problem's optimum value; f_start: J of its initial model x0 (what fixes the top).
    """

    problem: str
    f_opt: float
    f_start: float
    deltas: tuple[float, ...]

    @property
    def floor(self) -> float:
        """The last (hardest) target: the precision below which values are ties."""
        return self.deltas[-1]

    def to_dict(self) -> dict:
        return _dict(self)


def fixed_targets(problem: str, f_opt: float, f_start: float, decades: int = DECADES,
                  per_decade: int = PER_DECADE) -> Targets:
    """Targets 10^(top - k/per_decade), k = 0 .. decades*per_decade, with 10^top the power of ten
    at or above the initial precision f_start - f_opt (> 0, else ValueError)."""
    gap = float(f_start) - float(f_opt)
    if not (math.isfinite(gap) and gap > 0):
        raise ValueError(f"problem {problem!r}: the initial J ({f_start!r}) must be above f_opt ({f_opt!r})")
    top = math.ceil(math.log10(gap) - 1e-12)
    k = np.arange(decades * per_decade + 1)
    return Targets(problem, float(f_opt), float(f_start), tuple(float(v) for v in 10.0 ** (top - k / per_decade)))


def target_levels(decades: int = DECADES, per_decade: int = PER_DECADE) -> tuple[float, ...]:
    """Target levels relative to the top target (1, 10^-0.2, ..., 10^-decades)."""
    return tuple(float(v) for v in 10.0 ** (-np.arange(decades * per_decade + 1) / per_decade))


@dataclass(frozen=True)
class RunTrace:
    """What the statistics need of one run: solver, problem id, seed, n_evals (evaluations
    used) and the best-so-far trace [[n_evals, best_f], ...]."""

    solver: str
    problem: str
    seed: int
    n_evals: int
    trace: tuple = field(default=(), repr=False)

    @classmethod
    def of(cls, record) -> "RunTrace":
        """From a RunResult or its dict (``optimizer``, ``problem``, ``seed``, ``n_evals``, ``trace``)."""
        get = record.get if isinstance(record, dict) else (lambda k: getattr(record, k))
        return cls(get("optimizer"), get("problem"), int(get("seed")), int(get("n_evals")),
                   tuple(tuple(t) for t in get("trace")))

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """(evaluation counts, best-so-far J), J made non-increasing."""
        t = np.asarray(self.trace, dtype=float).reshape(-1, 2)
        return t[:, 0], np.minimum.accumulate(t[:, 1]) if len(t) else t[:, 1]

    def best_at(self, budgets) -> np.ndarray:
        """Best J after each budget (evaluations); inf before the first evaluation."""
        n, f = self.arrays()
        i = np.searchsorted(n, np.asarray(budgets, dtype=float), side="right")
        return np.where(i > 0, np.concatenate(([np.inf], f))[i], np.inf)

    def to_dict(self) -> dict:
        return _dict(self)


def group_of(problem: str) -> str:
    """The aggregation group of a suite id: ``family/dimension`` (instances pooled)."""
    parts = problem.split("/")
    return "/".join(parts[:2]) if len(parts) == 3 else problem


def hitting_times(run: RunTrace, targets: Targets) -> np.ndarray:
    """First evaluation count at which J - f_opt <= each target delta (inf: never), (n_targets,)."""
    n, f = run.arrays()
    err = f - targets.f_opt
    i = np.searchsorted(-err, -np.asarray(targets.deltas), side="left")  # err non-increasing
    return np.where(i < len(n), np.concatenate((n, [np.inf]))[i], np.inf)


def ert(times: np.ndarray, n_evals: np.ndarray) -> np.ndarray:
    """COCO's expected running time per target from hitting times (runs, targets) and each
    run's evaluations (runs,): sum of min(time, n_evals) over runs / successes (inf: none)."""
    times = np.atleast_2d(np.asarray(times, dtype=float))
    spent = np.minimum(times, np.asarray(n_evals, dtype=float)[:, None]).sum(axis=0)
    hits = np.isfinite(times).sum(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(hits > 0, spent / np.maximum(hits, 1), np.inf)


def _check(runs, targets) -> None:
    missing = sorted({r.problem for r in runs} - set(targets))
    if missing:
        raise ValueError(f"no targets for problem(s) {missing}: pass Targets for every problem run")


def by_key(runs, key) -> dict:
    """The runs grouped by key(run), the groups in key order."""
    out: dict = {}
    for r in runs:
        out.setdefault(key(r), []).append(r)
    return dict(sorted(out.items()))


@dataclass(frozen=True)
class ErtTable:
    """ERT (evaluations) per solver, group and target level; inf where no run hit."""

    levels: tuple[float, ...]
    ert: dict          # {solver: {group: [ERT per level]}}
    successes: dict    # {solver: {group: [runs that hit, per level]}}
    runs: dict         # {solver: {group: number of runs}}

    def to_dict(self) -> dict:
        return _dict(self)


def ert_table(runs: list[RunTrace], targets: dict[str, Targets]) -> ErtTable:
    """ERT of every solver on every group (family/dimension), runs pooled over instances."""
    _check(runs, targets)
    out, succ, count = {}, {}, {}
    for (solver, group), rs in by_key(runs, lambda r: (r.solver, group_of(r.problem))).items():
        times = np.array([hitting_times(r, targets[r.problem]) for r in rs])
        out.setdefault(solver, {})[group] = ert(times, np.array([r.n_evals for r in rs])).tolist()
        succ.setdefault(solver, {})[group] = np.isfinite(times).sum(axis=0).tolist()
        count.setdefault(solver, {})[group] = len(rs)
    n = len(next(iter(targets.values())).deltas) if targets else 0
    return ErtTable(target_levels(n // PER_DECADE if n else DECADES), out, succ, count)


@dataclass(frozen=True)
class Ecdf:
    """Fixed-target ECDF of one solver on one group: fraction of (run, target) pairs hit
    within each budget (evaluations)."""

    solver: str
    group: str
    budgets: tuple[float, ...]
    fraction: tuple[float, ...]
    n_runs: int

    def to_dict(self) -> dict:
        return _dict(self)


def budget_grid(max_budget: int, per_decade: int = 20) -> np.ndarray:
    """Log-spaced evaluation counts from 1 to max_budget (inclusive), unique integers."""
    g = np.unique(np.round(np.logspace(0, math.log10(max(max_budget, 1)),
                                       int(per_decade * math.log10(max(max_budget, 10))) + 1)))
    return np.union1d(g, [max_budget])


def ecdfs(runs: list[RunTrace], targets: dict[str, Targets], grid=None) -> list[Ecdf]:
    """The fixed-target ECDF of every solver on every group, on a common budget grid."""
    _check(runs, targets)
    grid = budget_grid(max(r.n_evals for r in runs)) if grid is None else np.asarray(grid, dtype=float)
    out = []
    for (solver, group), rs in by_key(runs, lambda r: (r.solver, group_of(r.problem))).items():
        times = np.concatenate([hitting_times(r, targets[r.problem]) for r in rs])
        frac = (times[None, :] <= grid[:, None]).mean(axis=1)
        out.append(Ecdf(solver, group, tuple(grid.tolist()), tuple(frac.tolist()), len(rs)))
    return out


@dataclass(frozen=True)
class FixedBudget:
    """Delta = best J - f_opt of each run of a solver on a group after `budget` evaluations
    (runs pooled over instances); `floor`: the smallest precision target of those problems."""

    solver: str
    group: str
    budget: int
    deltas: tuple[float, ...]
    floor: float

    @property
    def quartiles(self) -> tuple[float, float, float]:
        """(q1, median, q3) of Delta."""
        return tuple(float(v) for v in np.percentile(self.deltas, [25, 50, 75]))

    def to_dict(self) -> dict:
        return dict(_dict(self), quartiles=list(self.quartiles))


def fixed_budget(runs: list[RunTrace], targets: dict[str, Targets], budgets) -> list[FixedBudget]:
    """Fixed-budget distributions of Delta for every solver, group and budget."""
    _check(runs, targets)
    out = []
    for (solver, group), rs in by_key(runs, lambda r: (r.solver, group_of(r.problem))).items():
        vals = np.array([r.best_at(budgets) - targets[r.problem].f_opt for r in rs])
        floor = min(targets[r.problem].floor for r in rs)
        out += [FixedBudget(solver, group, int(b), tuple(vals[:, j].tolist()), floor) for j, b in enumerate(budgets)]
    return out


# -- comparing solvers -----------------------------------------------------------------------

def run_scores(runs: list[RunTrace], targets: dict[str, Targets], metric: str = "final", grid=None) -> np.ndarray:
    """One score per run, lower is better.

    ``final``: the final Delta = best J - f_opt, raised to the problem's precision floor (so two
    runs below the last target tie); ``auc``: 1 - the area under the run's fixed-target ECDF on
    the log budget grid (the fraction of (target, budget) pairs *not* reached: earlier hits and
    more targets score lower; targets below the floor do not exist, so those runs tie too).
    """
    if metric not in METRICS:
        raise ValueError(f"metric must be one of {METRICS}, got {metric!r}")
    _check(runs, targets)
    if metric == "final":
        return np.array([max(r.best_at([r.n_evals])[0] - targets[r.problem].f_opt, targets[r.problem].floor)
                         for r in runs])
    grid = budget_grid(max(r.n_evals for r in runs)) if grid is None else np.asarray(grid, dtype=float)
    return np.array([1.0 - (hitting_times(r, targets[r.problem])[None, :] <= grid[:, None]).mean() for r in runs])


def holm(pvalues) -> np.ndarray:
    """Holm's step-down adjusted p-values (same order as given), capped at 1."""
    p = np.asarray(pvalues, dtype=float)
    order = np.argsort(p, kind="stable")
    m = len(p)
    adj = np.minimum(1.0, np.maximum.accumulate((m - np.arange(m)) * p[order]))
    out = np.empty(m)
    out[order] = adj
    return out


def nemenyi_cd(k: int, n_blocks: int, alpha: float = 0.05) -> float:
    """Nemenyi's critical difference of mean ranks for k solvers on n_blocks blocks (Demsar 2006):
    q_alpha sqrt(k (k + 1) / (6 N)), q_alpha the studentized range quantile / sqrt(2)."""
    q = sps.studentized_range.ppf(1.0 - alpha, k, np.inf) / math.sqrt(2.0)
    return float(q * math.sqrt(k * (k + 1) / (6.0 * n_blocks)))


@dataclass(frozen=True)
class Pairwise:
    """Wilcoxon signed-rank test of solvers a and b on the common blocks: statistic, raw p,
    Holm-adjusted p, and the winner (lower mean rank) when significant at alpha, else None."""

    a: str
    b: str
    statistic: float
    p: float
    p_holm: float
    better: str | None

    def to_dict(self) -> dict:
        return _dict(self)


@dataclass(frozen=True)
class Comparison:
    """Solvers compared on blocks (problem, seed): one score per block and solver (`metric`),
    mean ranks (1 = best, ties averaged), Friedman's test (None for fewer than 3 solvers), the
    pairwise tests, Nemenyi's critical difference and the Holm cliques (solvers no test
    separates, each a run of consecutive mean ranks: the bars of a CD diagram)."""

    metric: str
    alpha: float
    solvers: tuple[str, ...]
    n_blocks: int
    n_dropped_blocks: int
    mean_ranks: dict
    friedman_statistic: float | None
    friedman_p: float | None
    pairwise: tuple[Pairwise, ...]
    critical_difference: float
    cliques: tuple[tuple[str, ...], ...]

    def to_dict(self) -> dict:
        return _dict(self)


def score_table(runs: list[RunTrace], targets: dict[str, Targets], metric: str = "final"):
    """(solvers, blocks, scores (n_blocks, n_solvers), dropped): blocks (problem, seed) that
    every solver ran; a block some solver lacks is dropped (its count is returned)."""
    scores = run_scores(runs, targets, metric)
    solvers = tuple(sorted({r.solver for r in runs}))
    cell = {(r.problem, r.seed, r.solver): s for r, s in zip(runs, scores)}
    all_blocks = sorted({(r.problem, r.seed) for r in runs})
    blocks = [b for b in all_blocks if all((*b, s) in cell for s in solvers)]
    table = np.array([[cell[(*b, s)] for s in solvers] for b in blocks]).reshape(len(blocks), len(solvers))
    return solvers, blocks, table, len(all_blocks) - len(blocks)


def _wilcoxon(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    if np.all(x == y):  # no difference at all (e.g. both below the precision floor everywhere)
        return 0.0, 1.0
    res = sps.wilcoxon(x, y, zero_method="zsplit")
    return float(res.statistic), float(res.pvalue)


def _cliques(order: list[str], separated: set) -> tuple[tuple[str, ...], ...]:
    spans = []
    for i in range(len(order)):
        j = i
        while j + 1 < len(order) and not any(frozenset((order[a], order[j + 1])) in separated
                                             for a in range(i, j + 1)):
            j += 1
        if j > i and not any(s <= i and j <= e for s, e in spans):
            spans.append((i, j))
    return tuple(tuple(order[s:e + 1]) for s, e in spans)


def compare(runs: list[RunTrace], targets: dict[str, Targets], metric: str = "final",
            alpha: float = 0.05) -> Comparison:
    """Friedman, pairwise Wilcoxon (Holm), mean ranks, CD and cliques; needs >= 2 solvers and
    >= 2 common blocks (ValueError otherwise)."""
    solvers, blocks, table, dropped = score_table(runs, targets, metric)
    if len(solvers) < 2 or len(blocks) < 2:
        raise ValueError(f"a comparison needs at least 2 solvers on at least 2 common (problem, seed) blocks, "
                         f"got {len(solvers)} solver(s) on {len(blocks)} block(s)")
    ranks = sps.rankdata(table, axis=1).mean(axis=0)
    mean_ranks = dict(zip(solvers, ranks.tolist()))
    fs = fp = None
    if len(solvers) >= 3:
        if np.all(table == table[:, :1]):
            fs, fp = 0.0, 1.0
        else:
            res = sps.friedmanchisquare(*table.T)
            fs, fp = float(res.statistic), float(res.pvalue)
    pairs = list(combinations(range(len(solvers)), 2))
    raw = [_wilcoxon(table[:, i], table[:, j]) for i, j in pairs]
    adj = holm([p for _, p in raw])
    pairwise = tuple(Pairwise(solvers[i], solvers[j], st, p, float(pa),
                              (solvers[i] if ranks[i] < ranks[j] else solvers[j]) if pa <= alpha else None)
                     for (i, j), (st, p), pa in zip(pairs, raw, adj))
    separated = {frozenset((pw.a, pw.b)) for pw in pairwise if pw.better is not None}
    order = sorted(solvers, key=lambda s: (mean_ranks[s], s))
    return Comparison(metric, alpha, solvers, len(blocks), dropped, mean_ranks, fs, fp, pairwise,
                      nemenyi_cd(len(solvers), len(blocks), alpha), _cliques(order, separated))
