"""`run()`: one optimizer on one problem with an exact budget, in a worker process without the
problem (adapters.sandbox, the default) or, for debugging, in this process.

The budgeted objective it runs against (adapters.budgeted, re-exported here) is the one place
where evaluations are counted. A plugin sees only `objective(X) -> f` (a batch of points in, one value per point out).
The harness counts every row as one FE evaluation, stops the run by raising
`BudgetExhausted` when the budget is spent (evaluating exactly the rows that fit), keeps the
best point seen with its best-so-far trace, and times the run: wall, CPU and the time spent
inside the FE evaluations. A plugin may therefore simply loop until it is stopped. Derivatives
(`BudgetedObjective.least_squares`) are charged `adapters.budget.jacobian_cost(n_var)` = n_var + 1
evaluations, whoever asks.

Helpers for adapters: `unit_scaled` (work in the unit cube) and `seeded_global_rngs` (for
libraries that draw from numpy's or Python's global generator).
"""

from __future__ import annotations

import signal
import threading
import time
import traceback
from contextlib import contextmanager
from typing import Any

import numpy as np

from .capabilities import check_options, run_description
from .budget import check_budget, check_min_budget, check_seed, check_x0_mode
# the shared pieces, defined once (adapters.budgeted, which the sandbox imports too: harness and
# sandbox never import each other's module back) and importable from here as before
from .budgeted import (RECORD_FORMAT, BudgetExhausted, BudgetedObjective, RunResult, TimeLimitExceeded,
                       _problem_count, check_takes_x0, record, seeded_global_rngs, unit_scaled)

__all__ = ["RECORD_FORMAT", "BudgetExhausted", "BudgetedObjective", "RunResult", "TimeLimitExceeded",
           "check_takes_x0", "record", "run", "seeded_global_rngs", "unit_scaled"]


def _start(optimizer, name: str, problem, x0: str) -> dict:
    """The start keyword for `minimize`: ``{"x0": problem.x0}`` when x0 is ``all`` (ValueError
    if the plugin's minimize takes no x0), nothing when it is ``none`` (the plugin's x0 stays
    None and it draws its first points from rng)."""
    if check_x0_mode(x0) == "none":
        return {}
    check_takes_x0(name, optimizer)
    return {"x0": np.asarray(problem.x0, dtype=float).copy()}


def run(name: str, problem, budget: int, seed: int, time_limit_s: float | None = None,
        variant: str = "paper", x0: str = "none", isolated: bool = True, **options: Any) -> RunResult:
    """Run optimizer `name` on `problem` with exactly `budget` FE evaluations and `seed`.

    isolated (default): the optimizer runs in a worker process that never holds the problem
    (adapters.sandbox); this process evaluates, counts, times and judges the run, and the
    record is ``verified``. isolated=False runs it in this process, for debugging: a plugin can
    then reach the problem, so the record has verified False and reports say so.

    x0: ``none`` (default: the solver is told nothing about the start) or ``all`` (it gets
    the problem's initial point as ``minimize(..., x0=array)``); see adapters.budget.X0_MODES.
    Never raises for a failing optimizer: its record has status ``failed`` and the error.
    Unknown names, options the optimizer does not take (capabilities.check_options) and bad
    budgets, seeds or x0 modes raise ValueError before anything runs.
    """
    if isolated:
        from .sandbox import run_isolated

        return run_isolated(name, problem, budget, seed, time_limit_s=time_limit_s, variant=variant, x0=x0,
                            **options)
    from .registry import get

    cls = get(name)
    check_options(name, cls, options)  # a misspelt option: ValueError before the run, as the CLI does
    described = run_description(cls, options)  # a plugin's bad capability flag: ValueError before the run
    seed, budget = check_seed(seed), check_budget(budget)
    optimizer = cls()
    check_min_budget(name, optimizer, budget, problem.n_var, **options)
    start = _start(optimizer, name, problem, x0)
    objective = BudgetedObjective(problem, budget, time_limit_s)
    rng = np.random.default_rng(int(seed))
    status, error = "stopped", None
    counted0 = _problem_count(problem)
    wall0, cpu0 = time.perf_counter(), time.process_time()
    sigint = [signal.SIGINT]  # until the watch is in place, an interrupt counts as a Ctrl-C
    try:
        with _sigint_watch() as sigint:
            optimizer.minimize(objective, objective.bounds, objective.budget, rng, **start, **options)
    except SystemExit as exc:  # a plugin's sys.exit() ends its run, not the study
        status, error = "failed", f"SystemExit: the optimizer called sys.exit({exc.code!r})"
    except KeyboardInterrupt:  # a Ctrl-C stops the study; one the plugin raised ends its run
        if sigint:
            raise
        status, error = "failed", "KeyboardInterrupt: raised by the optimizer (no Ctrl-C was pressed)"
    except BaseException as exc:  # a failing plugin must not end a study (nor its own BaseException)
        # a library may re-raise our stop signal wrapped in its own exception: look at the chain
        stop = _stop_signal(exc)
        if isinstance(stop, BudgetExhausted):
            status = "ok"
        elif isinstance(stop, TimeLimitExceeded):
            status, error = "timeout", str(stop)
        else:
            status, error = "failed", f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=6)}"
    wall, cpu = time.perf_counter() - wall0, time.process_time() - cpu0
    if status == "stopped" and objective.n_evals >= objective.budget:
        status = "ok"
    return record(name, problem, counted0, objective, seed, budget, options, x0, status, error, variant, wall, cpu,
                  **described)



@contextmanager
def _sigint_watch():
    """Notes whether a real SIGINT (Ctrl-C) arrives during the block: yields a list that is
    non-empty once one has. A KeyboardInterrupt without a SIGINT was raised by the plugin. In
    the main thread only (elsewhere signals cannot be handled), and only while SIGINT has
    Python's default handler; otherwise it cannot tell, and counts any interrupt as real
    unless SIGINT is ignored (then no Ctrl-C can have caused it)."""
    seen: list[int] = []
    if threading.current_thread() is not threading.main_thread():
        seen.append(signal.SIGINT)
        yield seen
        return
    previous = signal.getsignal(signal.SIGINT)
    if previous is not signal.default_int_handler:
        if previous is not signal.SIG_IGN:
            seen.append(signal.SIGINT)
        yield seen
        return

    def handler(signum, frame):
        seen.append(signum)
        signal.default_int_handler(signum, frame)

    signal.signal(signal.SIGINT, handler)
    try:
        yield seen
    finally:
        signal.signal(signal.SIGINT, previous)


def _stop_signal(exc: BaseException) -> BaseException | None:
    """The BudgetExhausted or TimeLimitExceeded in `exc`'s cause/context chain, if any."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, (BudgetExhausted, TimeLimitExceeded)):
            return exc
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return None


