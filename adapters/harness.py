"""The budgeted objective and `run()`: the one place where evaluations are counted.

A plugin sees only `objective(X) -> f` (a batch of points in, one value per point out).
The harness counts every row as one FE evaluation, stops the run by raising
`BudgetExhausted` when the budget is spent (evaluating exactly the rows that fit), keeps the
best point seen with its best-so-far trace, and times the run: wall, CPU and the time spent
inside the FE evaluations. A plugin may therefore simply loop until it is stopped.
"""

from __future__ import annotations

import math
import platform
import time
import traceback
from dataclasses import asdict, dataclass, field
from typing import Any

import numpy as np

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
    Times in seconds: wall_s, cpu_s (this process), fe_s (inside FE evaluations).
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
    status: str = "ok"
    error: str | None = None
    variant: str = "paper"
    host: str = ""
    format: str = RECORD_FORMAT

    @property
    def overhead_s(self) -> float:
        """Time spent outside the FE evaluations (the optimizer's own cost)."""
        return self.wall_s - self.fe_s

    def to_dict(self) -> dict:
        d = asdict(self)
        d["best_f"] = None if not math.isfinite(self.best_f) else self.best_f
        return d

    @classmethod
    def from_dict(cls, d: dict) -> "RunResult":
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
    that need it: `residuals_and_jacobian(x)` is charged `problem.jacobian_cost_evals`.
    """

    def __init__(self, problem, budget: int, time_limit_s: float | None = None):
        if int(budget) < 1:
            raise ValueError(f"budget must be a positive number of evaluations, got {budget}")
        self.problem = problem
        self.budget = int(budget)
        self.time_limit_s = time_limit_s
        self.n_evals = 0
        self.best_f = math.inf
        self.best_x: np.ndarray | None = None
        self.trace: list[list[float]] = []
        self.fe_s = 0.0
        self._t0 = time.perf_counter()
        self.n_var = problem.n_var
        self.bounds = (np.asarray(problem.xl, float).copy(), np.asarray(problem.xu, float).copy())

    @property
    def remaining(self) -> int:
        return self.budget - self.n_evals

    def _check_time(self) -> None:
        if self.time_limit_s is not None and time.perf_counter() - self._t0 > self.time_limit_s:
            raise TimeLimitExceeded(f"time limit of {self.time_limit_s} s exceeded")

    def _record(self, X: np.ndarray, f: np.ndarray) -> None:
        start = self.n_evals
        self.n_evals += len(f)
        if np.isnan(f).any():
            raise FloatingPointError("the objective returned NaN")
        k = int(np.argmin(f)) if len(f) else 0
        if len(f) and f[k] < self.best_f:
            self.best_f, self.best_x = float(f[k]), X[k].copy()
            self.trace.append([start + k + 1, self.best_f])

    def __call__(self, X) -> np.ndarray:
        self._check_time()
        X = np.atleast_2d(np.asarray(X, dtype=float))
        if self.remaining <= 0:
            raise BudgetExhausted()
        take = X[: self.remaining]
        t = time.perf_counter()
        f = np.asarray(self.problem.evaluate(take), dtype=float)
        self.fe_s += time.perf_counter() - t
        self._record(take, f)
        if len(take) < len(X) or self.remaining <= 0:
            raise BudgetExhausted()
        return f

    def least_squares(self, x):
        """Objective, frequency residuals and their Jacobian at one point (the problem's
        `least_squares`), charged `problem.jacobian_cost_evals` evaluations."""
        self._check_time()
        cost = int(getattr(self.problem, "jacobian_cost_evals", 1))
        if self.remaining < cost:
            raise BudgetExhausted()
        X = np.atleast_2d(np.asarray(x, dtype=float))
        t = time.perf_counter()
        out = self.problem.least_squares(X[0])
        self.fe_s += time.perf_counter() - t
        self._record(X, np.array([out.f]))
        self.n_evals += cost - 1
        if self.remaining <= 0:
            raise BudgetExhausted()
        return out

    def finish_trace(self) -> list:
        """The trace with a final entry at the last evaluation."""
        out = [list(t) for t in self.trace]
        if out and out[-1][0] != self.n_evals:
            out.append([self.n_evals, self.best_f])
        return out


def run(name: str, problem, budget: int, seed: int, time_limit_s: float | None = None,
        variant: str = "paper", **options: Any) -> RunResult:
    """Run optimizer `name` on `problem` with exactly `budget` FE evaluations and `seed`.

    Never raises for a failing optimizer: its record has status ``failed`` and the error.
    Unknown names and bad budgets or seeds raise ValueError before anything runs.
    """
    from .registry import get

    cls = get(name)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    optimizer = cls()
    min_budget = int(getattr(optimizer, "min_budget", 1))
    if int(budget) < min_budget:
        raise ValueError(f"optimizer {name!r} needs a budget of at least {min_budget} evaluations, got {budget}")
    objective = BudgetedObjective(problem, budget, time_limit_s)
    rng = np.random.default_rng(int(seed))
    status, error = "stopped", None
    wall0, cpu0 = time.perf_counter(), time.process_time()
    try:
        optimizer.minimize(objective, objective.bounds, objective.budget, rng, **options)
    except BudgetExhausted:
        status = "ok"
    except TimeLimitExceeded as exc:
        status, error = "timeout", str(exc)
    except Exception as exc:  # a failing plugin must not end a study
        status, error = "failed", f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=6)}"
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    if status == "stopped" and objective.n_evals >= objective.budget:
        status = "ok"
    return RunResult(
        optimizer=name, problem=getattr(problem, "name", type(problem).__name__), seed=int(seed),
        budget=int(budget), options=dict(options), n_evals=objective.n_evals, best_f=objective.best_f,
        best_x=[] if objective.best_x is None else objective.best_x.tolist(), trace=objective.finish_trace(),
        wall_s=wall, cpu_s=cpu, fe_s=objective.fe_s, status=status, error=error, variant=variant,
        host=platform.node())
