"""Optimizer plugins for the tests: honest, failing, hanging, and ones that try to cheat.

They live in a module of their own that imports neither the FE package nor the application,
because an optimizer runs in a worker process where those cannot be imported
(adapters.sandbox_worker); tests name them "sample_plugins:Class" (this directory is on the
path of pytest and of the `femu` programs the tests start)."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import adapters


def _points(bounds, rng, n):
    return rng.uniform(*bounds, size=(n, len(bounds[0])))


class TinyES:
    """A cheap second optimizer class: (1+4)-ES with step-size adaptation."""

    name = "tiny-es"
    anytime = True  # nothing in it depends on the budget: its ECDFs below the budget are honest

    def minimize(self, objective, bounds, budget, rng, sigma=0.2):
        xl, xu = bounds
        x = rng.uniform(xl, xu)
        fx = objective(x[None])[0]
        while True:
            y = np.clip(x + sigma * (xu - xl) * rng.standard_normal((4, len(x))), xl, xu)
            fy = objective(y)
            k = int(np.argmin(fy))
            if fy[k] < fx:
                x, fx, sigma = y[k], fy[k], sigma * 1.5
            else:
                sigma *= 0.8


class Broken:
    """Fails after its first batch: the report must list it as failed."""

    name = "broken"
    anytime = True  # its one batch does not depend on the budget

    def minimize(self, objective, bounds, budget, rng):
        objective(rng.uniform(*bounds, size=(20, len(bounds[0]))))
        raise RuntimeError("boom after 20 evaluations")


class Raises:
    """Evaluates one batch, then raises."""

    def minimize(self, objective, bounds, budget, rng):
        objective(rng.uniform(*bounds, size=(5, len(bounds[0]))))
        raise RuntimeError("plugin bug")


class _NaNProblem:
    """A problem whose evaluations come back NaN (a broken model)."""

    n_var, xl, xu, name = 3, np.zeros(3), np.ones(3), "nan-problem"

    def evaluate(self, X):
        return np.full(len(X), np.nan)


class ReturnsNaN:
    """Tries to swap in a problem that returns NaN (as a broken model would): the objective
    does not let it (the problem is not the plugin's to touch), and the run fails."""

    def minimize(self, objective, bounds, budget, rng):
        objective.problem = _NaNProblem()
        objective(rng.uniform(*bounds, size=(3, len(bounds[0]))))


class Hangs:
    """Never calls the objective again after its first batch: only a hard kill stops it."""

    def minimize(self, objective, bounds, budget, rng):
        objective(rng.uniform(*bounds, size=(2, len(bounds[0]))))
        time.sleep(3600)


class HangsTellingPid:
    """As Hangs, after writing its process's pid to `pid_file`: a test can then check that the
    process that would have slept for an hour was ended."""

    def minimize(self, objective, bounds, budget, rng, pid_file=None):
        Path(pid_file).write_text(str(os.getpid()))
        objective(rng.uniform(*bounds, size=(2, len(bounds[0]))))
        time.sleep(3600)


def hang_was_ended(pid_file: Path) -> bool:
    """Whether the process whose pid HangsTellingPid wrote (it would sleep an hour) is gone: no
    such pid, a zombie, or the pid taken since by a process started after the file was written."""
    import psutil

    try:
        p = psutil.Process(int(pid_file.read_text()))
        return p.status() == psutil.STATUS_ZOMBIE or p.create_time() > pid_file.stat().st_mtime
    except psutil.NoSuchProcess:
        return True


class Slow:
    """Calls the objective slowly: the harness stops it cooperatively at the time limit."""

    def minimize(self, objective, bounds, budget, rng):
        while True:
            objective(rng.uniform(*bounds, size=(1, len(bounds[0]))))
            time.sleep(0.05)


class NeedsFifty:
    min_budget = 50

    def minimize(self, objective, bounds, budget, rng):
        objective(rng.uniform(*bounds, size=(budget, len(bounds[0]))))


class SleepsLong:
    """Evaluates once, then sleeps (a Ctrl-C lands in its sleep)."""

    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 2))
        time.sleep(600)


class SpawnsAndReturns:
    """Starts a process of its own, writes its pid, and returns without ending it."""

    def minimize(self, objective, bounds, budget, rng, pid_file):
        child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"])
        Path(pid_file).write_text(str(child.pid))
        objective(_points(bounds, rng, 2))


class UsesTheProblemBehind:
    def minimize(self, objective, bounds, budget, rng):
        objective.problem.evaluate(_points(bounds, rng, 5000))


class ReachesTheProblemThroughAClosure:
    def minimize(self, objective, bounds, budget, rng):
        cells = [c.cell_contents for c in objective._evaluate.__closure__]
        evaluate = next(c for c in cells if callable(c))
        evaluate(_points(bounds, rng, 500))
        objective(_points(bounds, rng, 1))


class FindsTheProblemAndResetsItsCount:
    """Finds the problem among all live objects, evaluates behind the harness and sets the
    problem's own public counter back."""

    def minimize(self, objective, bounds, budget, rng):
        import gc

        problem = next(o for o in gc.get_objects() if type(o).__name__ == "UpdatingProblem")
        problem.evaluate(_points(bounds, rng, 500))
        problem.n_evals = 0
        objective(_points(bounds, rng, 1))


class ResetsTheCounter:
    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 100))
        objective.n_evals = 0


class ResetsTheHiddenCounter:
    def minimize(self, objective, bounds, budget, rng):
        for _ in range(5):
            objective._n_evals = 0
            objective(_points(bounds, rng, 100))


class RaisesItsBudget:
    def minimize(self, objective, bounds, budget, rng):
        objective._budget = 10**6
        objective(_points(bounds, rng, 500))


class WritesTheBudget:
    def minimize(self, objective, bounds, budget, rng):
        objective.budget = 10**6


class AsksForTooMuch:
    """One batch far larger than its budget: the rows that fit are evaluated, no more."""

    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 10 * budget))


class ReturnsGarbage:
    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 7))
        return "garbage"


class SendsBadPoints:
    def minimize(self, objective, bounds, budget, rng):
        objective(np.ones((3, 5)))


class CallsSysExit:
    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 4))
        sys.exit(3)


class ReplacesTheRecorder:
    """Shadows the objective's bookkeeping method, so that its evaluations are not charged."""

    def minimize(self, objective, bounds, budget, rng):
        objective._record = lambda X, f: None
        for _ in range(5):
            objective(_points(bounds, rng, 100))


class SwallowsTheStopSignal:
    """Catches the end of the budget and keeps asking: each further call is refused unevaluated."""

    def minimize(self, objective, bounds, budget, rng):
        for _ in range(10):
            try:
                objective(_points(bounds, rng, 200))
            except adapters.BudgetExhausted:
                pass


class SendsNaN:
    def minimize(self, objective, bounds, budget, rng):
        X = _points(bounds, rng, 4)
        X[2, 3] = np.nan
        objective(X)


class SendsPointsOutOfBounds:
    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 2) * 1e3)


class RaisesInItsOwnCode:
    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 6))
        return 1 / 0


class Cancelled(BaseException):
    """An exception outside Exception, as some async and test libraries raise."""


class RaisesABaseException:
    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 2))
        raise Cancelled("cancelled by its own library")


class ExitsHard:
    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 3))
        os._exit(7)


class Segfaults:
    def minimize(self, objective, bounds, budget, rng):
        os.kill(os.getpid(), signal.SIGSEGV)


class Interrupted:
    def minimize(self, objective, bounds, budget, rng):
        raise KeyboardInterrupt


class SpawnsAndHangs:
    """Starts a process of its own (as a solver binary would), writes its pid, and hangs."""

    def minimize(self, objective, bounds, budget, rng, pid_file):
        child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"])
        Path(pid_file).write_text(str(child.pid))
        time.sleep(600)


# -- plugins whose checks fail (tests/test_bad_command_lines.py) ------------------------------
class MinBudgetRaises:
    def min_budget(self, n_var, **options):
        raise RuntimeError("no budget for you")

    def minimize(self, objective, bounds, budget, rng):
        pass


class MinBudgetNotANumber(MinBudgetRaises):
    def min_budget(self, n_var, **options):
        return "many"


class NeedsArguments(MinBudgetRaises):
    def __init__(self, required):
        self.required = required


AN_INSTANCE = MinBudgetRaises()


class BadFlag:
    """A capability flag that is not a bool (tests/test_capabilities.py)."""

    name = "bad-flag"
    anytime = "yes"

    def minimize(self, objective, bounds, budget, rng, x0=None):
        while True:
            objective(rng.uniform(bounds[0], bounds[1], (10, len(bounds[0]))))



#: The environment variable that names PrintsItsCores' barrier directory, and how many runs meet there.
BARRIER_ENV, BARRIER_RUNS = "FEMU_TEST_BARRIER", 2
#: Seconds PrintsItsCores waits at its barrier for the other runs before it fails its run.
BARRIER_S = 300.0


class PrintsItsCores:
    """Honest: prints the cores its process may run on once its run is under way, then, when
    the environment variable FEMU_TEST_BARRIER names a directory, waits there until
    BARRIER_RUNS runs are under way at once (each leaves a file), so that the runs of a
    parallel study certainly overlap (RuntimeError after BARRIER_S: a test then fails loudly);
    then spends its budget."""

    name = "prints-its-cores"
    min_budget = 1

    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 1))
        print("CORES", sorted(os.sched_getaffinity(0)), flush=True)
        barrier = os.environ.get(BARRIER_ENV)
        if barrier:
            Path(barrier, str(os.getpid())).touch()
            t0 = time.monotonic()
            while len(os.listdir(barrier)) < BARRIER_RUNS:
                if time.monotonic() - t0 > BARRIER_S:
                    raise RuntimeError(f"barrier: {len(os.listdir(barrier))} of {BARRIER_RUNS} runs under way "
                                       f"at once after {BARRIER_S:.0f} s")
                time.sleep(0.01)
        while True:
            objective(_points(bounds, rng, 1))
