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
                  per_decade: int = PER_DECADE, scale: float | None = None) -> Targets:
    """Targets on Delta = J - f_opt, `per_decade` per decade over `decades` decades.

    With `scale` (the problem family's fixed normalisation, fe_problem.suite.target_scale):
    COCO's absolute targets 10^(2 - k/per_decade), k = 0 .. decades*per_decade, on
    Delta / scale: 1e2 ... 1e-8 times the scale, the same on every instance of the family.
    Without: 10^(top - k/per_decade) with 10^top the power of ten at or above the initial
    precision f_start - f_opt (a problem that is its own family). ValueError unless
    f_start > f_opt."""
    gap = float(f_start) - float(f_opt)
    if not (math.isfinite(gap) and gap > 0):
        raise ValueError(f"problem {problem!r}: the initial J ({f_start!r}) must be above f_opt ({f_opt!r})")
    k = np.arange(decades * per_decade + 1)
    if scale is not None:
        return Targets(problem, float(f_opt), float(f_start),
                       tuple(float(v) for v in float(scale) * 10.0 ** (2 - k / per_decade)))
    top = math.ceil(math.log10(gap) - 1e-12)
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
    """ERT (evaluations) per solver, group and target level; inf where no run hit. `lower`,
    `upper`: the 10 and 90 % points of COCO's bootstrapped run lengths with restarts
    (`ert_interval`); `beyond_budget`: the ERT exceeds the largest budget any of those runs had
    (an extrapolation from restarts that no run made; never for an infinite ERT)."""

    levels: tuple[float, ...]
    ert: dict          # {solver: {group: [ERT per level]}}
    successes: dict    # {solver: {group: [runs that hit, per level]}}
    runs: dict         # {solver: {group: number of runs}}
    lower: dict = field(default_factory=dict)          # {solver: {group: [10 % point per level]}}
    upper: dict = field(default_factory=dict)          # {solver: {group: [90 % point per level]}}
    beyond_budget: dict = field(default_factory=dict)  # {solver: {group: [bool per level]}}

    def to_dict(self) -> dict:
        return _dict(self)


def ert_table(runs: list[RunTrace], targets: dict[str, Targets], samples: int = 1000) -> ErtTable:
    """ERT of every solver on every group (family/dimension), runs pooled over instances, with
    COCO's bootstrapped 10-90 % range (`samples` simulated restarts, a fixed seed) and the
    beyond-budget flag."""
    _check(runs, targets)
    out, succ, count, lo, hi, beyond = {}, {}, {}, {}, {}, {}
    for (solver, group), rs in by_key(runs, lambda r: (r.solver, group_of(r.problem))).items():
        times = np.array([hitting_times(r, targets[r.problem]) for r in rs])
        n_evals = np.array([r.n_evals for r in rs])
        e = ert(times, n_evals)
        out.setdefault(solver, {})[group] = e.tolist()
        succ.setdefault(solver, {})[group] = np.isfinite(times).sum(axis=0).tolist()
        count.setdefault(solver, {})[group] = len(rs)
        ranges = [ert_interval(times[:, k], n_evals, samples=samples, seed=k) for k in range(times.shape[1])]
        lo.setdefault(solver, {})[group] = [a for a, _ in ranges]
        hi.setdefault(solver, {})[group] = [b for _, b in ranges]
        beyond.setdefault(solver, {})[group] = [bool(math.isfinite(v) and v > n_evals.max()) for v in e]
    n = len(next(iter(targets.values())).deltas) if targets else 0
    return ErtTable(target_levels(n // PER_DECADE if n else DECADES), out, succ, count, lo, hi, beyond)


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
    """Holm's step-down adjusted p-values (same order as given), capped at 1 (as statsmodels'
    multipletests, method "holm", gives them)."""
    return _holm(pvalues)


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


# -- problems as blocks (Demsar 2006) ------------------------------------------------------------
#: One value per (solver, problem) for the block comparison: ``median_final`` (median over the
#: solver's runs of the final J - f_opt, raised to the problem's last target) or ``ert`` (the
#: ERT at one target level, inf where no run hit).
BLOCK_VALUES = ("median_final", "ert")


def _holm(pvalues) -> np.ndarray:
    """Holm (1979): the i-th smallest of m p-values times (m - i), the running maximum of these
    in that order, capped at 1 (statsmodels' multipletests "holm" computes the same; it is the
    tests' reference, tests/test_stats_power.py)."""
    p = np.asarray(pvalues, dtype=float)
    if not len(p):
        return p
    order = np.argsort(p, kind="stable")
    adjusted = np.minimum(np.maximum.accumulate(p[order] * (len(p) - np.arange(len(p)))), 1.0)
    out = np.empty_like(p)
    out[order] = adjusted
    return out


def _paired_t_power(dz: float, n: float, level: float) -> float:
    """The two-sided one-sample (paired) t-test's power at standardized effect `dz` with `n`
    observations at level `level`: the noncentral t (df n - 1, noncentrality dz sqrt(n)) beyond
    the central t's two critical values (statsmodels' TTestPower, the tests' reference)."""
    df = n - 1.0
    crit = sps.t.isf(level / 2.0, df)
    nc = dz * math.sqrt(n)
    # the lower tail P(T < -crit) as P(T' > crit), T' with noncentrality -nc: scipy's nct.cdf gives
    # nan there for a real df and a large nc (1.17: df 29.5, nc 8.3), its sf does not
    return float(sps.nct.sf(crit, df, nc) + sps.nct.sf(crit, df, -nc))


def _solve_dz(n: float, level: float, power: float) -> float:
    """The effect dz the paired t-test detects with probability `power` (brentq on dz > 0)."""
    from scipy.optimize import brentq

    hi = 1.0
    while _paired_t_power(hi, n, level) < power:
        hi *= 2.0
    return float(brentq(lambda d: _paired_t_power(d, n, level) - power, 1e-12, hi, xtol=1e-12, rtol=1e-12))


def _solve_n(dz: float, level: float, power: float) -> float:
    """The (real) number of observations with which the paired t-test detects `dz` with
    probability `power` (brentq on n > 2)."""
    from scipy.optimize import brentq

    lo, hi = 2.0 + 1e-9, 4.0
    if _paired_t_power(dz, lo, level) >= power:
        return lo
    while _paired_t_power(dz, hi, level) < power:
        hi *= 2.0
    return float(brentq(lambda n: _paired_t_power(dz, n, level) - power, lo, hi, xtol=1e-12, rtol=1e-12))


def smallest_p(test: str, *sizes: int, n_tests: int = 1) -> float:
    """The smallest p-value a design can reach, after Holm over `n_tests` tests (times n_tests):
    ``mannwhitneyu`` (sizes n_a, n_b): 2 / C(n_a + n_b, n_a), the exact two-sided test with no
    ties; ``wilcoxon`` (n blocks): 2 / 2^n, the exact signed-rank test; ``friedman`` (n blocks,
    k solvers): the chi-square tail at the largest statistic n (k - 1) (every block ranked alike)."""
    if test == "mannwhitneyu":
        n_a, n_b = sizes
        p = 2.0 / math.comb(n_a + n_b, n_a)
    elif test == "wilcoxon":
        (n,) = sizes
        p = 2.0 / 2.0 ** n
    elif test == "friedman":
        n, k = sizes
        p = float(sps.chi2.sf(n * (k - 1), k - 1))
    else:
        raise ValueError(f"test must be mannwhitneyu, wilcoxon or friedman, got {test!r}")
    return float(min(1.0, p * n_tests))


#: Asymptotic relative efficiency of Wilcoxon's signed-rank test to the paired t-test when the
#: differences are normal (3 / pi, Hodges and Lehmann 1956): n problems under Wilcoxon weigh as
#: n * 3 / pi under the t-test.
WILCOXON_ARE = 3.0 / math.pi
#: Standardized per-problem differences the report says the problems needed for (Cohen's dz:
#: mean / standard deviation of a pair's differences over problems; 0.5 medium, 0.8 large).
EFFECTS = (0.5, 0.8, 1.2)


def min_blocks(test: str, alpha: float = 0.05, n_tests: int = 1, k: int = 2) -> int:
    """The fewest blocks (problems) with which `test` can reach p <= alpha at all (after Holm
    over `n_tests`): ``wilcoxon`` 2 / 2^n <= alpha / n_tests; ``friedman`` (k solvers) the
    chi-square tail at n (k - 1) <= alpha (`smallest_p`)."""
    n = 1
    while smallest_p(test, *((n,) if test == "wilcoxon" else (n, k)), n_tests=n_tests) > alpha:
        n += 1
    return n


def wilcoxon_power(n_problems: int, n_pairs: int, alpha: float = 0.05, power: float = 0.8,
                   effects=EFFECTS) -> dict:
    """What a Wilcoxon-Holm comparison on `n_problems` blocks can detect, for normal per-problem
    differences: `min_problems` (the fewest with which a pair can be separated at all),
    `detectable_dz` (the smallest standardized difference dz found with probability `power` at
    Holm's first step, alpha / n_pairs; None below min_problems) and `problems_needed` {dz: the
    problems that power needs}. The paired t-test's power (noncentral t, `_paired_t_power`) on the
    problems' Wilcoxon-equivalent number n * `WILCOXON_ARE`; tests/test_stats_power.py checks it
    against simulated Wilcoxon tests."""
    level = alpha / max(n_pairs, 1)
    floor = min_blocks("wilcoxon", alpha, n_tests=max(n_pairs, 1))
    dz = None
    if n_problems >= floor and n_problems * WILCOXON_ARE > 2:
        dz = _solve_dz(n_problems * WILCOXON_ARE, level, power)
    needed = {float(d): max(floor, math.ceil(_solve_n(d, level, power) / WILCOXON_ARE)) for d in effects}
    return {"alpha": alpha, "level": level, "power": power, "problems": n_problems, "pairs": n_pairs,
            "min_problems": floor, "detectable_dz": dz, "problems_needed": needed}


def block_table(runs: list[RunTrace], targets: dict[str, Targets], value: str = "median_final",
                level: int = 0):
    """(solvers, problems, table (n_problems, n_solvers), dropped problems): one value per
    (solver, problem) (`BLOCK_VALUES`; `level` indexes the target of ``ert``), lower is better;
    a problem some solver did not run is dropped."""
    if value not in BLOCK_VALUES:
        raise ValueError(f"value must be one of {BLOCK_VALUES}, got {value!r}")
    _check(runs, targets)
    solvers = tuple(sorted({r.solver for r in runs}))
    cells = by_key(runs, lambda r: (r.problem, r.solver))
    all_problems = sorted({r.problem for r in runs})
    problems = [p for p in all_problems if all((p, s) in cells for s in solvers)]

    def cell(rs):
        t = targets[rs[0].problem]
        if value == "median_final":
            return float(np.median([max(r.best_at([r.n_evals])[0] - t.f_opt, t.floor) for r in rs]))
        times = np.array([hitting_times(r, t)[level] for r in rs])[:, None]
        return float(ert(times, np.array([r.n_evals for r in rs]))[0])

    table = np.array([[cell(cells[(p, s)]) for s in solvers] for p in problems]).reshape(len(problems), len(solvers))
    return solvers, tuple(problems), table, len(all_problems) - len(problems)


def value_name(value: str, targets: dict[str, Targets] | None = None, level: int = 0) -> str:
    """What a block value means, as the report and the JSON name it."""
    if value == "median_final":
        return "median over the solver's runs of the final J - f_opt (raised to the problem's last target)"
    return f"ERT (FE evaluations) to target level {level} (J - f_opt <= the problem's target {level}; inf: never)"


@dataclass(frozen=True)
class BlockComparison:
    """Solvers compared on problems as blocks (Demsar 2006): one value per (solver, problem)
    (`value`, named), mean ranks (1 = best, ties averaged), Friedman's test (None for fewer than
    3 solvers), pairwise Wilcoxon signed-rank tests on the problems with Holm's correction,
    Nemenyi's critical difference and its cliques (solvers whose mean ranks differ by less than
    the CD: the bars and the scale of the CD diagram come from this one test), and the smallest
    p-values the design can reach."""

    value: str
    value_name: str
    alpha: float
    solvers: tuple[str, ...]
    problems: tuple[str, ...]
    n_dropped_problems: int
    table: dict
    mean_ranks: dict
    friedman_statistic: float | None
    friedman_p: float | None
    pairwise: tuple[Pairwise, ...]
    critical_difference: float
    cd_test: str
    cliques: tuple[tuple[str, ...], ...]
    smallest_p: dict

    @property
    def n_blocks(self) -> int:
        """The number of blocks (problems)."""
        return len(self.problems)

    def to_dict(self) -> dict:
        return dict(_dict(self), n_blocks=self.n_blocks)


def wilcoxon_values(table: np.ndarray) -> np.ndarray:
    """The block values the signed-rank test sees: an infinite ERT (no run hit) counts as 10 x
    the largest finite value of the table, worse than every ERT and tied with other infinities
    (the ranks of Friedman and Nemenyi are the same either way)."""
    finite = table[np.isfinite(table)]
    return np.where(np.isfinite(table), table, 10.0 * (finite.max() if finite.size else 1.0))


def compare_problems(runs: list[RunTrace], targets: dict[str, Targets], value: str = "median_final",
                     level: int = 0, alpha: float = 0.05) -> BlockComparison:
    """Friedman, Wilcoxon-Holm on problems, mean ranks, Nemenyi CD and its cliques on one value
    per (solver, problem); seeds are never paired across solvers. ValueError for fewer than 2
    solvers or 2 common problems."""
    solvers, problems, table, dropped = block_table(runs, targets, value, level)
    if len(solvers) < 2 or len(problems) < 2:
        raise ValueError(f"a comparison on problems as blocks needs at least 2 solvers on at least 2 common problems, "
                         f"got {len(solvers)} solver(s) on {len(problems)} problem(s)")
    n, k = table.shape
    ranks = sps.rankdata(table, axis=1).mean(axis=0)
    mean_ranks = dict(zip(solvers, ranks.tolist()))
    fs = fp = None
    if k >= 3:
        if np.all(table == table[:, :1]):
            fs, fp = 0.0, 1.0
        else:
            res = sps.friedmanchisquare(*table.T)
            fs, fp = float(res.statistic), float(res.pvalue)
    pairs = list(combinations(range(k), 2))
    tested = wilcoxon_values(table)
    raw = [_wilcoxon(tested[:, i], tested[:, j]) for i, j in pairs]
    adj = _holm([p for _, p in raw])
    pairwise = tuple(Pairwise(solvers[i], solvers[j], st, p, float(pa),
                              (solvers[i] if ranks[i] < ranks[j] else solvers[j]) if pa <= alpha else None)
                     for (i, j), (st, p), pa in zip(pairs, raw, adj))
    cd = nemenyi_cd(k, n, alpha)
    # Demsar: two solvers differ when their mean ranks differ by at least the CD
    separated = {frozenset((solvers[i], solvers[j])) for i, j in pairs if abs(ranks[i] - ranks[j]) >= cd}
    order = sorted(solvers, key=lambda s: (mean_ranks[s], s))
    limits = {"wilcoxon": smallest_p("wilcoxon", n), "wilcoxon_holm": smallest_p("wilcoxon", n, n_tests=len(pairs))}
    if k >= 3:
        limits["friedman"] = smallest_p("friedman", n, k)
    return BlockComparison(value, value_name(value, targets, level), alpha, solvers, problems, dropped,
                           {s: table[:, j].tolist() for j, s in enumerate(solvers)}, mean_ranks, fs, fp, pairwise,
                           cd, "nemenyi", _cliques(order, separated), limits)


# -- per-problem tests on unpaired runs ------------------------------------------------------

@dataclass(frozen=True)
class ProblemPair:
    """Mann-Whitney U test of solvers a and b on one problem's runs (unpaired): U of a, raw p,
    p after Holm over every pair and problem, and the better solver when p_holm <= alpha."""

    problem: str
    a: str
    b: str
    n_a: int
    n_b: int
    statistic: float
    p: float
    p_holm: float
    better: str | None

    def to_dict(self) -> dict:
        return _dict(self)


@dataclass(frozen=True)
class ProblemTests:
    """Every per-problem pairwise test (`ProblemPair`) of one run score (`metric`), Holm over
    all of them, and the smallest p-value each and all together can reach."""

    metric: str
    alpha: float
    pairs: tuple[ProblemPair, ...]
    smallest_p: float
    smallest_p_holm: float

    def to_dict(self) -> dict:
        return _dict(self)


def _mannwhitney(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    if np.all(x == x[0]) and np.all(y == x[0]):  # every value tied: no evidence either way
        return len(x) * len(y) / 2.0, 1.0
    res = sps.mannwhitneyu(x, y, alternative="two-sided")
    return float(res.statistic), float(res.pvalue)


def per_problem_tests(runs: list[RunTrace], targets: dict[str, Targets], metric: str = "final",
                      alpha: float = 0.05) -> ProblemTests:
    """Mann-Whitney U tests of every pair of solvers on every problem both ran, on the runs'
    scores (`run_scores`: ties below the last target), Holm over all pairs and problems."""
    scores = run_scores(runs, targets, metric)
    cells: dict = {}
    for r, s in zip(runs, scores):
        cells.setdefault((r.problem, r.solver), []).append(s)
    found = []
    for problem in sorted({r.problem for r in runs}):
        solvers = sorted(s for p, s in cells if p == problem)
        for a, b in combinations(solvers, 2):
            x, y = np.array(cells[(problem, a)]), np.array(cells[(problem, b)])
            u, p = _mannwhitney(x, y)
            found.append((problem, a, b, len(x), len(y), u, p))
    adj = _holm([f[-1] for f in found])
    pairs = tuple(ProblemPair(pr, a, b, na, nb, u, p, float(pa),
                              (a if u < na * nb / 2.0 else b) if pa <= alpha and u != na * nb / 2.0 else None)
                  for (pr, a, b, na, nb, u, p), pa in zip(found, adj))
    least = min((smallest_p("mannwhitneyu", f[3], f[4]) for f in found), default=1.0)
    return ProblemTests(metric, alpha, pairs, least, min(1.0, least * len(found)))


def seeds_can_separate(n_seeds: int, n_solvers: int, n_problems: int, alpha: float = 0.05) -> bool:
    """Whether a study of n_solvers x n_problems with n_seeds runs each can separate any pair
    on a problem: the smallest Mann-Whitney p after Holm over every pair and problem <= alpha."""
    m = math.comb(n_solvers, 2) * n_problems
    return m == 0 or smallest_p("mannwhitneyu", n_seeds, n_seeds, n_tests=m) <= alpha


# -- ERT intervals (COCO) --------------------------------------------------------------------

def simulated_runlengths(times, n_evals, samples: int = 1000, seed: int = 0) -> np.ndarray:
    """COCO's bootstrap of run lengths with simulated restarts (cocopp.toolsstats.drawSP) for one
    target: each sample adds the lengths of runs drawn uniformly with replacement (a failed run
    counts its evaluations) up to and including the first run that hit. Their mean estimates the
    ERT. Sorted, (samples,); all inf when no run hit."""
    times = np.asarray(times, dtype=float)
    success = np.isfinite(times)
    if not success.any():
        return np.full(samples, np.inf)
    lengths = np.where(success, times, np.asarray(n_evals, dtype=float))
    rng = np.random.default_rng(seed)
    total, open_ = np.zeros(samples), np.ones(samples, dtype=bool)
    while open_.any():  # one draw per still-restarting sample, vectorised over samples
        idx = rng.integers(0, len(times), size=int(open_.sum()))
        total[open_] += lengths[idx]
        done = success[idx]
        open_[np.flatnonzero(open_)[done]] = False
    return np.sort(total)


def ert_interval(times, n_evals, percentiles=(10, 90), samples: int = 1000, seed: int = 0) -> tuple[float, float]:
    """The `percentiles` of COCO's simulated run lengths (`simulated_runlengths`): the 10-90 %
    range COCO prints beside an ERT; (inf, inf) when no run hit."""
    if not np.isfinite(np.asarray(times, dtype=float)).any():
        return math.inf, math.inf
    lo, hi = np.percentile(simulated_runlengths(times, n_evals, samples, seed), percentiles)
    return float(lo), float(hi)


# -- aggregates over problems (COCO, IOHanalyzer) ----------------------------------------------

@dataclass(frozen=True)
class AggregateEcdf:
    """Per solver, the ECDF over every (problem, target) pair (problems weighted equally, runs
    averaged within a problem) against FE evaluations / dimension, and its area: the mean of the
    ECDF over log10(evaluations / dimension) from `lower` to `upper` (0: nothing hit, 1: every
    target at the first point)."""

    budgets_per_dim: tuple[float, ...]
    fraction: dict
    area: dict
    lower: float
    upper: float

    def to_dict(self) -> dict:
        return _dict(self)


def aggregate_ecdf(runs: list[RunTrace], targets: dict[str, Targets], n_var: dict[str, int],
                   points: int = 60) -> AggregateEcdf:
    """The aggregated ECDF and its area for every solver (`AggregateEcdf`); the range is fixed
    by the problems and budgets: from 1 / the largest dimension to the largest n_evals / the
    smallest dimension."""
    _check(runs, targets)
    lower = 1.0 / max(n_var[r.problem] for r in runs)
    upper = max(r.n_evals / n_var[r.problem] for r in runs)
    grid = np.logspace(math.log10(lower), math.log10(upper), points)
    span = math.log10(upper) - math.log10(lower)
    frac, area = {}, {}
    for solver, rs in by_key(runs, lambda r: r.solver).items():
        f_p, a_p = [], []
        for problem, prs in by_key(rs, lambda r: r.problem).items():
            t = np.concatenate([hitting_times(r, targets[problem]) for r in prs]) / n_var[problem]
            f_p.append((t[None, :] <= grid[:, None]).mean(axis=1))
            with np.errstate(divide="ignore"):
                left = np.log10(np.clip(t, lower, None))
            a_p.append(np.where(np.isfinite(t), np.clip(math.log10(upper) - left, 0.0, None) / span, 0.0).mean())
        frac[solver] = np.mean(f_p, axis=0).tolist()
        area[solver] = float(np.mean(a_p))
    return AggregateEcdf(tuple(grid.tolist()), frac, area, lower, upper)


#: Moré and Wild's (2009) convergence tolerances tau: solved when J <= f_opt + tau (J(x0) - f_opt).
TOLERANCES = (1e-1, 1e-3, 1e-5, 1e-7)


@dataclass(frozen=True)
class Profiles:
    """Data profiles (Moré-Wild 2009: the fraction of problems solved within alpha (n_var + 1)
    evaluations) and performance profiles (Dolan-Moré 2002: the fraction of problems on which
    a solver's cost is within a ratio of the best solver's) at one tolerance tau; the cost of a
    solver on a problem is its ERT to J <= f_opt + tau (J(x0) - f_opt) over its runs."""

    tolerance: float
    cost: dict           # {solver: [ERT per problem]} (inf: never solved)
    problems: tuple[str, ...]
    alpha: tuple[float, ...]
    data: dict           # {solver: [fraction per alpha]}
    ratio: tuple[float, ...]
    performance: dict    # {solver: [fraction per ratio]}

    def to_dict(self) -> dict:
        return _dict(self)


def profiles(runs: list[RunTrace], targets: dict[str, Targets], n_var: dict[str, int],
             tolerances=TOLERANCES, points: int = 60) -> list[Profiles]:
    """Data and performance profiles at each tolerance, on the problems every solver ran."""
    _check(runs, targets)
    solvers = sorted({r.solver for r in runs})
    cells = by_key(runs, lambda r: (r.problem, r.solver))
    problems = tuple(p for p in sorted({r.problem for r in runs}) if all((p, s) in cells for s in solvers))
    out = []
    alpha_hi = max(r.n_evals / (n_var[r.problem] + 1) for r in runs)
    for tau in tolerances:
        cost = np.full((len(problems), len(solvers)), np.inf)
        for i, p in enumerate(problems):
            t = targets[p]
            goal = Targets(p, t.f_opt, t.f_start, (tau * (t.f_start - t.f_opt),))
            for j, s in enumerate(solvers):
                rs = cells[(p, s)]
                times = np.array([hitting_times(r, goal) for r in rs])
                cost[i, j] = ert(times, np.array([r.n_evals for r in rs]))[0]
        per_simplex = cost / np.array([n_var[p] + 1 for p in problems])[:, None]
        alpha = np.logspace(-1, math.log10(max(alpha_hi, 1.0)), points)
        data = {s: (per_simplex[:, j][None, :] <= alpha[:, None]).mean(axis=1).tolist() for j, s in enumerate(solvers)}
        best = cost.min(axis=1, keepdims=True)
        with np.errstate(invalid="ignore", divide="ignore"):
            r = np.where(np.isfinite(cost), cost / best, np.inf)
        finite = r[np.isfinite(r)]
        ratio = np.logspace(0, math.log10(max(2.0, finite.max() * 1.1 if finite.size else 2.0)), points)
        perf = {s: (r[:, j][None, :] <= ratio[:, None]).mean(axis=1).tolist() for j, s in enumerate(solvers)}
        out.append(Profiles(float(tau), {s: cost[:, j].tolist() for j, s in enumerate(solvers)}, problems,
                            tuple(alpha.tolist()), data, tuple(ratio.tolist()), perf))
    return out
