"""One run of a study as a task: a pure function of (optimizer, variant, budget, seed, options).

The variant is a problem variant name (``paper``, ``synthetic``) or a suite id
(``hframe-freq/12/1``, `fe_problem.suite_ids`). The worker builds the problem itself
(`problem_of`) and calls
`adapters.harness.run`, so a seed gives the same record (apart from times, host) in this
process, in a worker process and on a Dask cluster. Also here: the record of a run whose process
returned nothing, and the hard deadline after which such a process is killed.
"""

from __future__ import annotations

import platform
import time
import traceback
from dataclasses import dataclass, field
from functools import lru_cache
from typing import Callable

from adapters.harness import RunResult, run
from adapters.variants import USER_PREFIX, make_problem
from fe_problem.suite import suite_entry, suite_problem

from .store import run_key

@dataclass(frozen=True)
class Task:
    """One run of the grid. time_limit_s in seconds (None: no limit); x0: what the solver is told
    of the start (``none`` or ``all``, adapters.budget.X0_MODES); isolated: the optimizer in a
    worker process without the problem (adapters.sandbox), False for the in-process debugging
    mode (`femu study --in-process`: the record is unverified). blind: the key of the variant's
    blind instance (femu.studies.blind; None: the public instance), for the evaluating side
    only; certificate: a noisy blind instance's [f_opt, precision] certified by the study."""

    optimizer: str
    variant: str
    budget: int
    seed: int
    options: dict = field(default_factory=dict)
    time_limit_s: float | None = None
    x0: str = "none"
    isolated: bool = True
    blind: str | None = None
    certificate: list | None = None

    def __repr__(self) -> str:  # a blind key is never shown (logs, a Dask dashboard)
        return (f"Task({self.optimizer!r}, {self.variant!r}, budget={self.budget}, seed={self.seed}, "
                f"blind={self.blind is not None})")

    @property
    def key(self) -> str:
        """The run's key in the store."""
        return run_key(self.variant, self.optimizer, self.budget, self.seed)


def is_suite_id(variant: str) -> bool:
    """Whether a study's variant is a suite id (``family/dimension/instance``; a user's problem,
    ``user:PATH``, is not)."""
    return "/" in variant and not variant.startswith(USER_PREFIX)


def variant_stem(variant: str) -> str:
    """A variant as a piece of a file name: a suite id's ``/`` as ``_``; a user's problem
    ``user:PATH`` as ``user_`` and the stem of its source file."""
    if variant.startswith(USER_PREFIX):
        from pathlib import Path
        return "user_" + Path(variant[len(USER_PREFIX):]).stem
    return variant.replace("/", "_")


def problem_of(variant: str, blind: str | None = None, certificate=None):
    """A fresh problem for a variant name or a suite id (then a SuiteProblem with f_opt; with
    `blind`, the blind instance of that key, `certificate` its certified [f_opt, precision])."""
    if is_suite_id(variant):
        return suite_problem(variant, blind=blind, certificate=None if certificate is None else tuple(certificate))
    return make_problem(variant)


def n_var_of(variant: str) -> int:
    """The number of parameters of a variant or suite id (a suite id's without building it)."""
    return suite_entry(variant).n_var if is_suite_id(variant) else make_problem(variant).n_var


def run_task(task: Task, on_start: Callable[[], None] | None = None) -> dict:
    """Run one task and return its record as a dict (RunResult.to_dict()).

    Pure: builds the problem from the variant name and runs the optimizer with the task's
    seed. A failing optimizer gives a ``failed`` record (harness.run); so does a failure while
    building the problem, so that a worker always returns a record. `on_start` is called once
    the problem is built, when the run (and its time limit) starts.
    """
    t0 = time.perf_counter()
    try:
        problem = problem_of(task.variant, task.blind, task.certificate)
        facts = blind_facts(problem) if task.blind is not None else {}
        if on_start is not None:
            on_start()
        record = run(task.optimizer, problem, task.budget, task.seed, time_limit_s=task.time_limit_s,
                     variant=task.variant, x0=task.x0, isolated=task.isolated, **task.options).to_dict()
        source = getattr(problem, "source", None)  # a user's problem: its files and their SHA-256
        return dict(record, f_opt=getattr(problem, "f_opt", None),
                    problem_source=None if source is None else source.to_dict(), **facts)
    except Exception as exc:
        return lost_record(task, "failed", f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=6)}",
                            time.perf_counter() - t0)


def blind_facts(problem) -> dict:
    """The record fields of a run on a blind instance: what a report needs of the instance and
    cannot rebuild from its id (how f_opt is known, its precision, J(x0), this evaluation not
    counted: it is made before the run)."""
    f_start = float(problem.evaluate(problem.x0)[0])
    problem.n_evals = 0
    return {"blind": True, "f_opt_kind": problem.f_opt_kind, "f_opt_precision": problem.f_opt_precision,
            "f_start": f_start}


@lru_cache(maxsize=None)
def _problem_name(variant: str) -> str:
    """The problem name of a variant (for records of runs that returned nothing)."""
    return problem_of(variant).name


def lost_record(task: Task, status: str, error: str, wall_s: float) -> dict:
    """The record of a run whose process returned nothing (hard timeout, crash)."""
    return RunResult(optimizer=task.optimizer, problem=_problem_name(task.variant), seed=task.seed,
                     budget=task.budget, options=dict(task.options), wall_s=wall_s, status=status, x0=task.x0,
                     error=error, variant=task.variant, host=platform.node(), verified=task.isolated,
                     blind=task.blind is not None).to_dict()


def hard_deadline_s(time_limit_s: float | None) -> float | None:
    """Seconds after a run's start (problem built) at which its process is killed: the limit
    plus a grace of 5 s + 10 %. A backstop: the run's process itself stops its optimizer's
    worker at the limit (adapters.sandbox.worker_deadline_s) and records the evaluations done;
    this deadline catches only a run process that hangs itself."""
    return None if time_limit_s is None else time_limit_s + 5.0 + 0.1 * time_limit_s


#: Seconds a run with a time limit may take to start (process, imports, problem build) before
#: it is given up as failed: generous, a loaded machine can be slow to start a Python process.
STARTUP_LIMIT_S = 300.0


def hard_timeout_error(task: Task, elapsed_s: float) -> str:
    """The error of a run killed at its hard deadline."""
    return (f"terminated after {elapsed_s:.1f} s: the run passed its time limit of {task.time_limit_s} s "
            f"without returning (the optimizer stopped calling the objective); its evaluations are lost")


def startup_error(task: Task) -> str:
    """The error of a run whose process did not start in time."""
    return f"the run's process did not start within {STARTUP_LIMIT_S:.0f} s; it was terminated"

