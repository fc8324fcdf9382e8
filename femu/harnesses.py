"""The suite's problems for other benchmark harnesses: IOHexperimenter (ioh), pymoo,
Nevergrad and optuna, each in its library's own idiom (docs/suite.md, "In other harnesses").

Each takes a problem: a suite id (``hframe-freq/12/1``), a variant name (``paper``) or an
`UpdatingProblem`, and evaluates that problem, so its evaluation counter counts what the
harness asks. Bounds are the problem's (Pa) except for ioh, whose problems live on [0, 1]^n:

- `ioh_problem(pid)`: an ioh RealSingleObjective (minimisation) made by ioh.wrap_problem,
  named and numbered as the IOH export (`femu.reports.ioh`): function id, instance, dimension
  n_var, x in [0, 1]^n mapped to xl + x (xu - xl), value raw_y = (J - f_opt) / scale, optimum
  (truth, 0) where the truth is known. Its loggers (ioh.logger.Analyzer, ...) work as on any
  ioh problem, and write what `femu report --ioh` writes. Problems of several ids live side by
  side (for one id, the latest made answers).
- `pymoo_problem(pid)`: a pymoo Problem(n_var, xl, xu) whose `_evaluate` evaluates a whole
  population in one vectorised call.
- `nevergrad_function(pid)`: a nevergrad ExperimentFunction on ng.p.Array(init=x0, lower=xl,
  upper=xu) (nevergrad spreads its sigma over the bounds).
- `optuna_objective(pid)`: objective(trial) suggesting each parameter by its name within its
  bounds.

The libraries are imported when a function is called; a missing one is one line naming the
extra that installs it.
"""

from __future__ import annotations

import numpy as np

#: The extra that installs each harness's library.
EXTRA = {"ioh": "optimizers", "pymoo": "optimizers", "nevergrad": "optimizers", "optuna": "optimizers"}


def _need(module: str):
    import importlib

    try:
        return importlib.import_module(module)
    except ImportError:
        raise ValueError(f"the {module.split('.')[0]} harness needs the '{EXTRA[module.split('.')[0]]}' extra: "
                         f"pip install 'femu-bench[{EXTRA[module.split('.')[0]]}]'") from None


def _problem(problem):
    """A problem object for a suite id, a variant name or a problem (returned as it is)."""
    if isinstance(problem, str):
        from femu.studies.tasks import problem_of

        return problem_of(problem)
    return problem


def _names(p) -> list[str]:
    """A name per parameter: the problem's, else x0, x1, ..."""
    names = [getattr(q, "name", None) for q in getattr(p, "parameters", ())]
    return names if len(names) == p.n_var and all(names) and len(set(names)) == p.n_var \
        else [f"x{i}" for i in range(p.n_var)]


def ioh_problem(problem_id: str):
    """The suite problem (or variant) `problem_id` as an ioh problem (see the module doc)."""
    _need("ioh")
    from femu.reports.ioh import ioh_problem as make, ioh_terms

    terms = ioh_terms(problem_id)
    p = _problem(problem_id)

    def feed(x):
        return float(terms.raw(p.evaluate(np.atleast_2d(terms.xl + np.asarray(x, float) * (terms.xu - terms.xl))))[0])

    return make(terms, feed)  # the feed holds the problem (its evaluation counter)


def pymoo_problem(problem):
    """The problem as a pymoo Problem (bounds in Pa, vectorised `_evaluate`)."""
    core = _need("pymoo.core.problem")
    p = _problem(problem)

    class UpdatingProblem(core.Problem):
        """A femu-bench updating problem: J(x) over the moduli x (Pa)."""

        def __init__(self):
            super().__init__(n_var=int(p.n_var), n_obj=1, xl=np.asarray(p.xl, float), xu=np.asarray(p.xu, float))
            self.problem = p

        def _evaluate(self, X, out, *args, **kwargs):
            out["F"] = self.problem.evaluate(np.atleast_2d(X))[:, None]

    return UpdatingProblem()


def nevergrad_function(problem):
    """The problem as a nevergrad ExperimentFunction over ng.p.Array(init=x0, lower=xl, upper=xu)."""
    ng = _need("nevergrad")
    from nevergrad.functions import ExperimentFunction

    p = _problem(problem)
    param = ng.p.Array(init=np.asarray(p.x0, float), lower=np.asarray(p.xl, float), upper=np.asarray(p.xu, float))
    param.set_name(problem if isinstance(problem, str) else str(getattr(p, "name", "femu")))  # ExperimentFunction asks

    def objective(x):
        return float(p.evaluate(np.atleast_2d(np.asarray(x, float)))[0])

    f = ExperimentFunction(objective, param)
    f.femu_problem = p
    return f


def optuna_objective(problem):
    """The problem as an optuna objective: objective(trial) -> J, each parameter suggested as a
    float within its bounds (Pa) under its name (`objective.names`)."""
    _need("optuna")
    p = _problem(problem)
    names, xl, xu = _names(p), np.asarray(p.xl, float), np.asarray(p.xu, float)

    def objective(trial) -> float:
        x = np.array([trial.suggest_float(n, lo, hi) for n, lo, hi in zip(names, xl, xu)])
        return float(p.evaluate(x[None, :])[0])

    objective.names, objective.problem = names, p
    return objective
