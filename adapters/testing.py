"""A pytest helper for optimizer plugins: `check_optimizer` runs a plugin under the harness and
asserts the contract every optimizer of femu-bench keeps.

    from adapters.testing import check_optimizer

    def test_my_method_keeps_the_contract():
        check_optimizer("my-method")            # or the class, or "my_package.module:MyMethod"

What it checks (each failure is an AssertionError that says which rule and by how much):

- budget: at the minimum budget and at a larger one the run is ``ok`` and spent exactly the
  budget (the harness stops it; a method that ends early is ``stopped`` and fails the check
  unless ``may_stop=True``), every point inside the bounds, no point evaluated behind the
  objective's back;
- seeding: two runs with one seed evaluate the same points (a seed fixes a run); two seeds
  evaluate different ones (the seed is used); numpy's and Python's global generators are left
  as they were;
- silence: nothing written to stdout or stderr (also by C code, at the file-descriptor
  level), no warning raised, the root logger's handlers and level unchanged, the current
  directory unchanged;
- capabilities: the declared flags are booleans; a plugin declaring ``anytime = True``
  evaluates, in a run of the minimum budget, exactly the first points of a longer run with the
  same seed; one declaring ``supports_x0`` finishes ``ok`` when given x0, and uses it (its points
  differ from those of the run without x0 with the same seed).

The problem is a cheap separable quadratic with a known minimum in a box of moduli-like scale
(`QuadraticProblem`, 6 parameters by default, with residuals and a Jacobian for methods that use
gradients), so the check takes seconds; pass ``problem=`` to use another (any object with
n_var, xl, xu, x0 and a vectorised evaluate).
"""

from __future__ import annotations

import contextlib
import io
import logging
import os
import random
import sys
import tempfile
import warnings
from dataclasses import dataclass, field

import numpy as np

from .budget import min_budget
from .capabilities import capabilities
from .harness import run
from .registry import get


@dataclass(frozen=True, eq=False)
class _LeastSquares:
    f: float
    residuals: np.ndarray
    jacobian: np.ndarray | None


@dataclass(eq=False)
class QuadraticProblem:
    """J(x) = sum(((x - centre) / (xu - xl))^2) in [6e10, 8e10]^n_var (moduli in Pa), centre
    off the middle of the box; every evaluated point is kept in `points` (rows, in order), so a
    test can compare what two runs evaluated. least_squares(x) gives J, the residuals and their
    Jacobian (as the FE problem's), evaluated points also kept."""

    n_var: int = 6
    name: str = "quadratic"
    points: list = field(default_factory=list)

    def __post_init__(self):
        self.xl = np.full(self.n_var, 6e10)
        self.xu = np.full(self.n_var, 8e10)
        self.x0 = np.full(self.n_var, 7e10)
        self.centre = self.xl + (self.xu - self.xl) * np.linspace(0.3, 0.8, self.n_var)
        self.points_evaluated = 0

    def _residuals(self, X) -> np.ndarray:
        return (X - self.centre) / (self.xu - self.xl)

    def evaluate(self, X) -> np.ndarray:
        """J at each row of X (n, n_var) or at one point (n_var,)."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        if np.any(X < self.xl) or np.any(X > self.xu):
            raise AssertionError("budget contract: a point outside the bounds reached the problem")
        self.points.extend(X.copy())
        self.points_evaluated += len(X)
        return np.sum(self._residuals(X) ** 2, axis=1)

    def least_squares(self, x, charged: int = 1):
        """J, residuals (n_var,) and Jacobian (n_var, n_var) at one point."""
        X = np.atleast_2d(np.asarray(x, dtype=float))
        self.points.append(X[0].copy())
        self.points_evaluated += int(charged)
        r = self._residuals(X)[0]
        return _LeastSquares(float(r @ r), r, np.diag(1.0 / (self.xu - self.xl)))


@contextlib.contextmanager
def _fd_output():
    """Captures what is written to file descriptors 1 and 2 (Python and C code) during the
    block; yields a list that holds the text once the block ends."""
    out: list[str] = []
    sys.stdout.flush()
    sys.stderr.flush()
    saved = [os.dup(1), os.dup(2)]
    text = io.StringIO()  # Python-level writes, whatever sys.stdout is (pytest replaces it)
    with tempfile.TemporaryFile(mode="w+b") as tmp:
        os.dup2(tmp.fileno(), 1)
        os.dup2(tmp.fileno(), 2)
        try:
            with contextlib.redirect_stdout(text), contextlib.redirect_stderr(text):
                yield out
        finally:
            sys.stdout.flush()
            sys.stderr.flush()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)
            tmp.seek(0)
            out.append(text.getvalue() + tmp.read().decode(errors="replace"))


def check_optimizer(optimizer, problem_factory=None, budget: int | None = None, seeds=(0, 1),
                    may_stop: bool = False, **options) -> dict:
    """Run `optimizer` (a registry name, a ``package.module:Class`` path or a class) under the
    harness and assert the contract (module doc). problem_factory: a function returning a fresh
    problem (default `QuadraticProblem`); budget: the longer run's budget (default: 4 x the
    minimum budget, at least 40); seeds: two different seeds; may_stop: allow a method to end
    before its budget (status ``stopped``); options: passed to minimize. Returns what it
    measured ({"min_budget", "budget", "capabilities", "best_f"})."""
    name = optimizer if isinstance(optimizer, str) else f"{optimizer.__module__}:{optimizer.__qualname__}"
    cls = get(name)
    problem_factory = problem_factory or QuadraticProblem
    n_var = problem_factory().n_var
    caps = capabilities(cls)  # ValueError for a flag that is not a bool
    need = min_budget(cls, n_var, **options)
    budget = max(4 * need, 40) if budget is None else int(budget)
    s0, s1 = seeds

    def one(b, seed, x0="none"):
        # in this process (the sandbox's debugging mode): the contract is about what the plugin
        # does to its own process (prints, warnings, global generators, logging, the directory),
        # which a worker process would hide
        problem = problem_factory()
        return run(name, problem, b, seed, x0=x0, isolated=False, **options), problem

    # silence, global generators, logging, cwd: around one full run
    np_state, py_state = np.random.get_state(), random.getstate()
    root = logging.getLogger()
    handlers, level, cwd = list(root.handlers), root.level, os.getcwd()
    with warnings.catch_warnings(record=True) as caught, _fd_output() as printed:
        warnings.simplefilter("always")
        long_a, pa = one(budget, s0)
    assert printed[0] == "", f"silence contract: the run wrote to stdout/stderr: {printed[0][:300]!r}"
    assert not caught, f"silence contract: the run raised warnings: {[str(w.message)[:200] for w in caught]}"
    assert root.handlers == handlers and root.level == level, \
        "silence contract: the run changed the root logger's handlers or level"
    assert os.getcwd() == cwd, "silence contract: the run changed the current directory"
    assert _same_state(np.random.get_state(), np_state) and random.getstate() == py_state, \
        "seeding contract: numpy's or Python's global generator was left changed (use adapters.harness.seeded_global_rngs)"

    # budget
    for record, b in ((long_a, budget), (one(need, s0)[0], need)):
        ok = ("ok", "stopped") if may_stop else ("ok",)
        assert record.status in ok, (f"budget contract: a run of budget {b} ended {record.status!r} "
                                     f"({(record.error or '').splitlines()[0] if record.error else 'before its budget'})")
        assert record.n_evals == b or (may_stop and record.status == "stopped"), \
            f"budget contract: a run of budget {b} was charged {record.n_evals} evaluations"

    # seeding
    long_b, pb = one(budget, s0)
    assert _same_points(pa.points, pb.points), "seeding contract: two runs with one seed evaluated different points"
    assert long_a.best_f == long_b.best_f and long_a.trace == long_b.trace, \
        "seeding contract: two runs with one seed have different results"
    _, pc = one(budget, s1)
    assert not _same_points(pa.points, pc.points), \
        f"seeding contract: seeds {s0} and {s1} evaluated the same points (the seed is not used)"

    # capabilities
    if caps["anytime"]:
        for b in sorted({need, need + 1, (need + budget) // 2}):
            _, short = one(b, s0)
            a, c = _visited(short.points), _visited(pa.points)
            assert _same_points(a, c[:len(a)]), (
                f"anytime contract: the run of budget {b} did not visit the first {len(a)} points of the run of "
                f"budget {budget} with the same seed (declare anytime = False if the schedule follows the budget)")
    if caps["supports_x0"]:
        record, px = one(budget, s0, x0="all")
        assert record.status in (("ok", "stopped") if may_stop else ("ok",)), \
            f"x0 contract: a run given x0 ended {record.status!r}: {(record.error or '')[:300]}"
        assert not _same_points(px.points, pa.points), (
            "x0 contract: a run given x0 evaluated exactly the points of the run without it with the same seed "
            "(x0 is ignored: use it, or declare supports_x0 = False)")
    return {"min_budget": need, "budget": budget, "capabilities": caps, "best_f": long_a.best_f}


def _visited(points) -> list:
    """The points in order, a point repeated at once counted once (a Jacobian at the point just
    evaluated, or a method spending its last evaluations on its current point)."""
    out = []
    for p in points:
        if not out or not np.array_equal(out[-1], p):
            out.append(p)
    return out


def _same_points(a, b) -> bool:
    return len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b))


def _same_state(a, b) -> bool:
    return a[0] == b[0] and np.array_equal(a[1], b[1]) and tuple(a[2:]) == tuple(b[2:])
