"""The budgeted objective and the run record: what in-process runs (adapters.harness) and
sandboxed runs (adapters.sandbox, adapters.sandbox_worker) share.

`BudgetedObjective` is the one place where evaluations are counted: every row of a batch is one
FE evaluation, the run is stopped by raising `BudgetExhausted` when the budget is spent
(evaluating exactly the rows that fit) or `TimeLimitExceeded`, the best point and its
best-so-far trace are kept and the run is timed. `record` makes a run's `RunResult` from it
on the evaluating side. Helpers for adapters: `unit_scaled` and `seeded_global_rngs`.

This module imports neither adapters.harness nor adapters.sandbox: both import it, so that
the two never import each other (tests/test_adapters_imports.py checks the package's graph).
"""

from __future__ import annotations

import inspect
import math
import platform
import random
import time
from contextlib import contextmanager
from dataclasses import asdict, dataclass, field

import numpy as np

from .budget import check_budget, jacobian_cost
from .provenance import library_versions

RECORD_FORMAT = "femu.run/1"


class BudgetExhausted(Exception):
    """Raised by the objective when the evaluation budget is spent: the normal end of a run."""


class TimeLimitExceeded(Exception):
    """Raised by the objective when the run's time limit has passed."""


@dataclass(frozen=True)
class RunResult:
    """One run of one optimizer on one problem: everything needed to reproduce and report it.

    trace: best-so-far as [[n_evals, best_f], ...], one entry per improvement (and the last
    evaluation), so `best_f` after k evaluations is the last entry with n_evals <= k.
    status: ``ok`` (budget spent), ``stopped`` (the method ended by itself before the budget),
    ``failed`` (it raised, or produced NaN), ``timeout`` (time limit).
    Times in seconds: wall_s (wall clock of the run), cpu_s (CPU of this process during the
    run, time.process_time), fe_s (wall clock inside FE evaluations); the fair costs:
    fe_cpu_s (process CPU inside FE evaluations) and opt_cpu_s = cpu_s - fe_cpu_s (the
    optimizer's own CPU), which do not grow with the machine's load as wall times do.
    n_jacobians: derivative requests, each charged n_var + 1 evaluations (in n_evals).
    x0: ``all`` when the solver was given the problem's initial point, ``none`` otherwise.
    versions: Python's and every run library's version (adapters.provenance.library_versions).
    f_opt: the problem's known optimum J (suite problems, set by studies), None if unknown.
    verified: True when the optimizer ran in a worker process without the problem and this
    record was made by the evaluating side (adapters.sandbox); False for a run in the problem's
    own process (``run(..., isolated=False)``, for debugging; and records made before the
    sandbox), whose counts a plugin could have bypassed.
    output: what the optimizer printed (stdout and stderr of its worker, the end kept).
    distribution, distribution_version: the installed package that provides the optimizer
    (``femu-bench`` for the built-ins, the plugin's own for a plugin; None for a class no
    installed package provides); effective_options: minimize's keyword defaults overridden by
    `options` (what the run ran with); capabilities: the optimizer's declared flags
    (adapters.capabilities: anytime, uses_gradients, batch, supports_x0). Records written before
    these fields have them empty. problem_source: for a user's problem (variant ``user:PATH``)
    the paths and SHA-256 of its model, data and parameter files (fe_problem.user_problem),
    set by studies; None otherwise.
    suite_version: the benchmark suite's version (fe_problem.suite.SUITE_VERSION) the problem
    was defined by; None in records written before it was recorded.
    sandbox: which of the kernel's confinements held for its worker (adapters.sandbox.CONFINEMENT:
    filesystem, signals, own_uid, limits, session, undumpable, peer_checked -> true or false, and
    landlock_abi); empty for in-process runs and records made before it.
    blind: True for a run on a blind suite instance (its truth and data drawn from its store's
    secret, femu.studies.blind; set by studies), False otherwise and in records made before it.
    f_opt_kind, f_opt_precision, f_start: how f_opt is known, its precision and J(x0), for a
    blind instance (the report cannot rebuild it from its id); None otherwise.
    """

    optimizer: str
    problem: str
    seed: int
    budget: int
    options: dict = field(default_factory=dict)
    n_evals: int = 0
    best_f: float = math.inf
    best_x: list = field(default_factory=list)
    trace: list = field(default_factory=list)
    wall_s: float = 0.0
    cpu_s: float = 0.0
    fe_s: float = 0.0
    fe_cpu_s: float = 0.0
    opt_cpu_s: float = 0.0
    n_jacobians: int = 0
    x0: str = "none"
    status: str = "ok"
    error: str | None = None
    variant: str = "paper"
    host: str = ""
    versions: dict = field(default_factory=dict)
    format: str = RECORD_FORMAT
    f_opt: float | None = None
    verified: bool = False
    output: str = ""
    distribution: str | None = None
    distribution_version: str | None = None
    effective_options: dict = field(default_factory=dict)
    capabilities: dict = field(default_factory=dict)
    problem_source: dict | None = None
    suite_version: str | None = None
    sandbox: dict = field(default_factory=dict)
    blind: bool = False
    f_opt_kind: str | None = None
    f_opt_precision: float | None = None
    f_start: float | None = None

    @property
    def overhead_s(self) -> float:
        """Time spent outside the FE evaluations (the optimizer's own cost)."""
        return self.wall_s - self.fe_s

    def to_dict(self) -> dict:
        """The record as a JSON-ready dict (a best_f that is not finite becomes None)."""
        d = asdict(self)
        d["best_f"] = None if not math.isfinite(self.best_f) else self.best_f
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "RunResult":
        """The record from `to_dict`'s output; unknown keys are ignored."""
        d = dict(d)
        d["best_f"] = math.inf if d.get("best_f") is None else d["best_f"]
        known = set(cls.__dataclass_fields__)
        return cls(**{k: v for k, v in d.items() if k in known})

    def best_at(self, n_evals: int) -> float:
        """Best-so-far objective after `n_evals` evaluations (inf before the first)."""
        best = math.inf
        for n, f in self.trace:
            if n > n_evals:
                break
            best = f
        return best


class BudgetedObjective:
    """Wraps a problem's `evaluate` with an exact budget, a best-so-far trace and timing.

    Parameters: problem (anything with n_var, xl, xu and a vectorised evaluate), budget
    (FE evaluations), time_limit_s (None: no limit). Extra least-squares access for methods
    that need derivatives: `least_squares(x)`, charged `jacobian_cost` = n_var + 1 evaluations.
    fe_s / fe_cpu_s: wall / process CPU seconds inside the problem's evaluations.

    What a plugin sees is this object only: the problem behind it is not an attribute (its
    evaluate and least_squares are kept in closures), and the counters (`n_evals`, `budget`,
    `remaining`, `best_f`, `best_x`, `trace`, `fe_s`, `fe_cpu_s`, `n_jacobians`,
    `time_limit_s`, `jacobian_cost`) are read-only properties. `run` also cross-checks the
    problem's own evaluation count, so a plugin that reaches the problem some other way has its
    run marked failed.
    """

    #: The names a plugin may read but never assign.
    READ_ONLY = ("problem", "n_evals", "budget", "remaining", "best_f", "best_x", "trace", "fe_s", "fe_cpu_s",
                 "n_jacobians", "jacobian_cost", "time_limit_s", "n_var", "bounds")

    def __init__(self, problem, budget: int, time_limit_s: float | None = None):
        budget = check_budget(budget)
        evaluate = problem.evaluate
        least_squares = getattr(problem, "least_squares", None)
        self._evaluate = lambda X: evaluate(X)
        self._least_squares = _charged_least_squares(least_squares) if least_squares is not None else None
        self._budget = int(budget)
        self._time_limit_s = time_limit_s
        self._n_evals = 0
        self._best_f = math.inf
        self._best_x: np.ndarray | None = None
        self._trace: list[list[float]] = []
        self._fe_s = 0.0
        self._fe_cpu_s = 0.0
        self._n_jacobians = 0
        self._residuals_at: bytes | None = None  # the point of the last least_squares(jacobian=False)
        self._t0 = time.perf_counter()
        self._n_var = int(problem.n_var)
        self._jacobian_cost = jacobian_cost(self._n_var)
        self._bounds = (np.asarray(problem.xl, float).copy(), np.asarray(problem.xu, float).copy())

    def __setattr__(self, name: str, value) -> None:
        if name in self.READ_ONLY:
            raise AttributeError(f"the objective's {name!r} is read-only: the harness owns the budget and its counts")
        super().__setattr__(name, value)

    n_evals = property(lambda self: self._n_evals, doc="Evaluations charged so far.")
    budget = property(lambda self: self._budget, doc="The run's budget (FE evaluations).")
    best_f = property(lambda self: self._best_f, doc="Best objective value seen (inf before the first).")
    best_x = property(lambda self: None if self._best_x is None else self._best_x.copy(),
                      doc="The point of `best_f` (a copy), or None.")
    trace = property(lambda self: [list(t) for t in self._trace], doc="Best-so-far [[n_evals, f], ...] (a copy).")
    fe_s = property(lambda self: self._fe_s, doc="Wall seconds spent inside FE evaluations.")
    fe_cpu_s = property(lambda self: self._fe_cpu_s, doc="Process CPU seconds spent inside FE evaluations.")
    n_jacobians = property(lambda self: self._n_jacobians, doc="Jacobians requested (each charged jacobian_cost).")
    jacobian_cost = property(lambda self: self._jacobian_cost,
                             doc="FE evaluations charged for the residuals and Jacobian at a point (n_var + 1).")
    time_limit_s = property(lambda self: self._time_limit_s, doc="The run's time limit in seconds, or None.")
    n_var = property(lambda self: self._n_var, doc="The number of parameters.")
    bounds = property(lambda self: (self._bounds[0].copy(), self._bounds[1].copy()),
                      doc="(xl, xu), copies: the box the points must lie in.")

    @property
    def remaining(self) -> int:
        """Evaluations left in the budget."""
        return self._budget - self._n_evals

    def _check_time(self) -> None:
        if self._time_limit_s is not None and time.perf_counter() - self._t0 > self._time_limit_s:
            raise TimeLimitExceeded(f"time limit of {self._time_limit_s} s exceeded")

    def _record(self, X: np.ndarray, f: np.ndarray) -> None:
        start = self._n_evals
        self._n_evals += len(f)
        # every row that beats all before it, also inside a batch, so that best-so-far after
        # any evaluation count is exact; NaN rows never improve (fmin skips them)
        running = np.fmin.accumulate(np.concatenate(([self._best_f], f)))
        new = np.flatnonzero(running[1:] < running[:-1])
        self._trace.extend([start + int(i) + 1, float(f[i])] for i in new)
        if len(new):
            self._best_f, self._best_x = float(f[new[-1]]), X[new[-1]].copy()
        if np.isnan(f).any():
            raise FloatingPointError(f"the objective returned NaN at evaluation "
                                     f"{start + int(np.argmax(np.isnan(f))) + 1}")

    def __call__(self, X) -> np.ndarray:
        self._check_time()
        X = np.atleast_2d(np.asarray(X, dtype=float))
        if self.remaining <= 0:
            raise BudgetExhausted()
        take = X[: self.remaining]
        f = np.asarray(self._timed(self._evaluate, take), dtype=float)
        if f.shape != (len(take),):
            raise ValueError(f"the problem returned values of shape {f.shape} for {len(take)} points")
        self._record(take, f)
        if len(take) < len(X) or self.remaining <= 0:
            raise BudgetExhausted()
        return f

    def _timed(self, fn, arg):
        """fn(arg), its wall and process CPU seconds added to fe_s and fe_cpu_s."""
        t, c = time.perf_counter(), time.process_time()
        out = fn(arg)
        self._fe_cpu_s += time.process_time() - c
        self._fe_s += time.perf_counter() - t
        return out

    def least_squares(self, x, jacobian: bool = True):
        """Objective, frequency residuals and their Jacobian at one point (the problem's
        `least_squares`).

        Charged like finite differences: n_var + 1 evaluations (`jacobian_cost`) with the
        Jacobian; 1 evaluation with jacobian=False (then ``.jacobian`` is None), and n_var for
        the Jacobian at the point of the previous jacobian=False call (its value is paid).
        BudgetExhausted, with nothing evaluated, when the remaining budget cannot pay."""
        self._check_time()
        if self._least_squares is None:
            raise TypeError("this problem has no least_squares (residuals and Jacobian)")
        X = np.atleast_2d(np.asarray(x, dtype=float))
        key = X[0].tobytes()
        cost = 1 if not jacobian else self._jacobian_cost - (key == self._residuals_at)
        if self.remaining < cost:
            raise BudgetExhausted()
        out = self._timed(lambda x: self._least_squares(x, cost, bool(jacobian)), X[0])
        self._residuals_at = None if jacobian else key
        self._n_jacobians += bool(jacobian)
        # charge the extra cost first, so the trace dates the point at the evaluation count
        # after which it is known
        self._n_evals += cost - 1
        self._record(X, np.array([out.f]))
        if not jacobian:
            out = type(out)(out.f, out.residuals, None)
        if self.remaining <= 0:
            raise BudgetExhausted()
        return out

    def finish_trace(self) -> list:
        """The trace with a final entry at the last evaluation."""
        out = [list(t) for t in self._trace]
        if out and out[-1][0] != self.n_evals:
            out.append([self.n_evals, self.best_f])
        return out


def _charged_least_squares(least_squares):
    """`least_squares` as f(x, cost, jacobian): the cost charged for the call is passed on as
    ``charged=`` when the problem's method takes it (a logging wrapper records that many
    evaluations), and whether a Jacobian is wanted as ``jacobian=`` when it takes that (a cost
    of 1 does not tell: with one parameter the Jacobian at a point already paid costs 1 too);
    each dropped otherwise."""
    try:
        params = inspect.signature(least_squares).parameters
    except (TypeError, ValueError):
        params = {}

    def call(x, cost, jacobian):
        kw = {}
        if "charged" in params:
            kw["charged"] = cost
        if "jacobian" in params:
            kw["jacobian"] = jacobian
        return least_squares(x, **kw)
    return call


def check_takes_x0(name: str, optimizer=None) -> None:
    """ValueError unless optimizer `name` (or the given class or instance) can be given the
    initial point: its minimize takes an ``x0`` keyword (or **kwargs)."""
    from .registry import get

    optimizer = get(name) if optimizer is None else optimizer
    params = inspect.signature(optimizer.minimize).parameters
    if "x0" not in params and not any(p.kind is p.VAR_KEYWORD for p in params.values()):
        raise ValueError(f"optimizer {name!r}: its minimize takes no x0 keyword, so it cannot be given the "
                         f"initial point (x0='all'); run it with x0='none'")



def record(name: str, problem, counted0: int, objective: BudgetedObjective, seed: int, budget: int, options: dict,
           x0: str, status: str, error: str | None, variant: str, wall: float, cpu: float, **fields) -> RunResult:
    """The run's record, made by the evaluating side alone (in-process runs and the sandbox's):
    counts, best point, trace and FE times from `objective`, the status failed when the problem
    counted more points than the objective was charged (`_overrun`); `fields`: the rest
    (verified, output, the optimizer's description)."""
    # here, on the evaluating side: an optimizer's process cannot import fe_problem
    from fe_problem.suite import SUITE_VERSION

    overrun = _overrun(problem, counted0, objective, budget)
    if overrun:
        status, error = "failed", overrun
    return RunResult(
        optimizer=name, problem=getattr(problem, "name", type(problem).__name__), seed=int(seed),
        budget=int(budget), options=dict(options), n_evals=objective.n_evals, best_f=objective.best_f,
        best_x=[] if objective.best_x is None else objective.best_x.tolist(), trace=objective.finish_trace(),
        wall_s=wall, cpu_s=cpu, fe_s=objective.fe_s, fe_cpu_s=objective.fe_cpu_s,
        opt_cpu_s=max(cpu - objective.fe_cpu_s, 0.0), n_jacobians=objective.n_jacobians, x0=x0, status=status,
        error=error, variant=variant, host=platform.node(), versions=library_versions(), suite_version=SUITE_VERSION,
        **fields)


def _problem_count(problem) -> int | None:
    """The problem's own count of evaluated points, if it keeps one: UpdatingProblem's
    `points_evaluated` (which a plugin that reaches the problem cannot reset by a public name), or
    another problem's `n_evals`."""
    n = getattr(problem, "points_evaluated", getattr(problem, "n_evals", None))
    return int(n) if isinstance(n, (int, np.integer)) and not isinstance(n, bool) else None


def _overrun(problem, counted0: int | None, objective: BudgetedObjective, budget: int) -> str | None:
    """Why the run spent more than it was charged (None if it did not): the harness's count
    above the budget, or the problem's own count above what the harness charged."""
    if objective.n_evals > budget:
        return f"budget overrun: {objective.n_evals} evaluations charged against a budget of {budget}"
    counted1 = _problem_count(problem)
    if counted0 is not None and counted1 is not None and counted1 - counted0 > objective.n_evals:
        return (f"budget bypassed: the problem evaluated {counted1 - counted0} points but the run was charged "
                f"{objective.n_evals}; a plugin must evaluate through the objective it is given")
    return None



@contextmanager
def seeded_global_rngs(rng: np.random.Generator):
    """Seed numpy's and Python's global generators from `rng` for the duration of a block,
    then put back their previous states.

    For libraries that draw from the global generators (PySwarms, pycma, DEAP): a run is then
    fixed by its seed, and runs one after another in a process do not disturb each other or
    the host's own random streams. Not thread-safe: the global state is the process's.
    """
    np_state, py_state = np.random.get_state(), random.getstate()
    seed = int(rng.integers(2**32))
    np.random.seed(seed)
    random.seed(seed)
    try:
        yield seed
    finally:
        np.random.set_state(np_state)
        random.setstate(py_state)


def unit_scaled(objective, bounds):
    """`objective` in coordinates scaled to the unit cube, and the map back to x.

    u in [0, 1]^n_var stands for x = xl + u (xu - xl). For libraries whose steps, tolerances or
    initial spreads are absolute: the moduli are ~1e10 Pa. u is clipped into the cube first,
    so a library's round-off at a bound never reaches the problem as an out-of-bounds point.
    Returns (f, to_x): f(U) takes a point (n_var,) or a batch (n, n_var) and returns (n,).
    """
    xl, xu = (np.asarray(b, dtype=float) for b in bounds)
    span = xu - xl

    def to_x(U) -> np.ndarray:
        return xl + np.clip(np.atleast_2d(U), 0.0, 1.0) * span

    def f(U) -> np.ndarray:
        return objective(to_x(U))

    return f, to_x

