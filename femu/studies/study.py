"""Comparative studies: the grid optimizers x problem variants x seeds, run in parallel into a
resumable result store (femu.studies.store), by `femu study` and `femu reproduce`.

The parts: tasks (one run, a pure function of its parameters), executors (in-process, local
pool; child: Dask and the child-process entry), seeds (parsing the lists), manifest
(study.json), progress (the bar), store. This module checks the inputs, picks the executor and
writes each record as it arrives: only this (the parent) process writes the store, one file
per finished run, atomically.

Optimizers are registry names or import paths ``package.module:Class`` (registry.get), so a
class that is not registered reaches every worker process. Time limits and executors: see
femu.studies.executors.

Resume: a study started again with the same grid keeps every stored run as it is (the file is
not rewritten) and runs only the missing ones. Failed and timed-out runs are stored like the
others, so a resumed study does not loop on a broken method; ``retry_failed=True``
(``--retry-failed``) runs them again and replaces their records. Options are not part of a
run's key: a study that asks for other options than a stored run has is refused. study.json
records what each invocation asked (the latest at the top, earlier ones in ``history``), the
executor, the start time (UTC) and the package versions.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time
from dataclasses import dataclass, replace
from pathlib import Path

from adapters.budget import check_budget, check_budget_covers, check_x0_mode
from adapters.capabilities import check_options
from adapters.harness import RunResult
from adapters.registry import BUILTINS, check_name, get
from adapters.sandbox import PluginFault, confinement_missing, hide_from_workers, optimizer_facts, preloads, server_address
from adapters.variants import USER_PREFIX, VARIANTS
from fe_problem.suite import select_suite
from fe_problem.jsonutil import dumps

from .blind import blind_keys, certificates
from .child import DaskCluster, check_scheduler_address
from .executors import InProcess, LocalPool
from .manifest import read_manifest, write_manifest
from .progress import Progress
from .seeds import parse_names, parse_seeds
from .store import Store, safe_name
from .tasks import Task, n_var_of, run_task
from . import DEFAULT_TIME_LIMIT_S  # noqa: F401  (femu.studies.study.DEFAULT_TIME_LIMIT_S, as before)


#: Statuses that --retry-failed runs again.
RETRY_STATUSES = ("failed", "timeout")

__all__ = ["RETRY_STATUSES", "StudyResult", "Task", "parse_seeds", "run_study", "run_task"]


def _check_options(options, optimizers: list[str]) -> dict[str, dict]:
    """Per-optimizer options as plain JSON; ValueError for a shape, name or value that is not."""
    if options is None:
        return {}
    if not isinstance(options, dict) or not all(isinstance(v, dict) for v in options.values()):
        raise ValueError("options: expected {optimizer name: {keyword: value}}")
    extra = sorted(set(options) - set(optimizers))
    if extra:
        raise ValueError(f"options given for {extra[0]!r}, which is not among the study's optimizers "
                         f"({', '.join(optimizers)})")
    for name, opts in options.items():  # a plugin's options are checked in its worker (optimizer_facts)
        if name in BUILTINS:
            check_options(name, get(name), opts)
    try:  # records are JSON: the options must survive the round trip unchanged
        return json.loads(dumps(options, indent=None))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"options: not JSON serialisable ({exc})") from None


@dataclass(frozen=True)
class StudyResult:
    """What a study left in its store.

    runs: every run of the grid (kept and new), in grid order (variant, optimizer, seed), but
    for the `n_elsewhere` runs another process on the same store was running (claimed);
    n_new: runs done by this call; n_kept: runs found in the store; wall_s: seconds."""

    store: Path
    runs: tuple[RunResult, ...]
    n_new: int
    n_kept: int
    wall_s: float
    executor: str
    n_elsewhere: int = 0

    def counts(self) -> dict[str, int]:
        """Number of runs per status."""
        out: dict[str, int] = {}
        for r in self.runs:
            out[r.status] = out.get(r.status, 0) + 1
        return out

    def summary(self) -> str:
        """One line: how many runs, new and kept, per status, how long, where."""
        c = self.counts()
        statuses = ", ".join(f"{c.get(s, 0)} {s}" for s in ("ok", "failed", "timeout"))
        if c.get("stopped"):
            statuses += f", {c['stopped']} stopped"
        line = (f"femu study: {len(self.runs)} runs in {self.store} ({self.n_new} new, {self.n_kept} kept): "
                f"{statuses}; {self.wall_s:.1f} s ({self.executor})")
        unverified = sum(1 for r in self.runs if not r.verified)
        if unverified:
            line += (f"; {unverified} unverified (their optimizer ran in the problem's own process: --in-process, "
                     f"or recorded before the sandbox)")
        if self.n_elsewhere:
            line += (f"; {self.n_elsewhere} runs left to another process running them on this store "
                     f"(the same command gathers them once it has finished)")
        return line


def _n_cores() -> int:
    """The cores this process may use."""
    if hasattr(os, "sched_getaffinity"):  # the cores this process may use, not the machine's
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def check_budget_for(optimizers: list[str], budget, variants: list[str], options: dict) -> int:
    """`budget` as an int if every optimizer can run with it on every variant (with its
    options); ValueError naming ``--budget`` otherwise (and for an unknown optimizer)."""
    budget = check_budget(budget, "--budget")
    n_vars = sorted({n_var_of(v) for v in variants})
    for name in optimizers:
        try:
            facts = optimizer_facts(name, n_vars, options.get(name, {}))  # a plugin is asked in a worker
        except PluginFault:  # its process broke the protocol or died: its own runs fail, named; the study goes on
            continue
        for n_var in n_vars:
            try:
                check_budget_covers(name, facts["min_budget"][n_var], budget, n_var, **options.get(name, {}))
            except ValueError as exc:
                raise ValueError(f"--budget {budget}: {exc}") from None
    return budget


#: Local worker processes allowed per core this process may use (each is a Python process with
#: numpy, scipy and the FE model in memory: far more than the cores only exhausts memory).
WORKERS_PER_CORE = 4


def max_workers() -> int:
    """The most local worker processes a study may start: `WORKERS_PER_CORE` per core, at least 8."""
    return max(8, WORKERS_PER_CORE * _n_cores())


def check_workers(workers) -> None:
    """ValueError unless `workers` is None (every core) or an integer from 0 (this process) to
    `max_workers()`."""
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 0):
        raise ValueError(f"--workers: must be an integer >= 0 (0: run in this process), got {workers!r}")
    if workers is not None and workers > max_workers():
        raise ValueError(f"--workers: at most {max_workers()} ({WORKERS_PER_CORE} per core of the {_n_cores()} this "
                         f"process may use), got {workers}")


def user_source(store: Store, model, data, parameters=None) -> str:
    """The variant ``user:PATH`` of a user's problem: its source (the files' paths and SHA-256,
    fe_problem.user_problem.ProblemSource) written to STORE/problems/NAME.json, the problem built
    once here so that a bad file is refused before anything runs."""
    from fe_problem.safe_files import write_text
    from fe_problem.user_problem import ProblemSource, problem_from_source

    src = ProblemSource.of(model, data, parameters)
    problem_from_source(src)  # every file checked (one line naming the file and field otherwise)
    folder = store.path / "problems"
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"--store {store.path}: cannot create {folder} ({exc.strerror or exc})") from None
    path = folder / f"{safe_name(src.name.replace(':', '_'))}.json"
    if not path.exists():
        write_text(path, dumps(src.relative_to(folder).to_dict()) + "\n")  # the files relative to it
    return USER_PREFIX + str(path.resolve())


def _problems(variants, suite, user: str | None = None) -> list[str]:
    """The study's problems: the variants named, then the suite ids selected (`select_suite`:
    ids, families or family/dimension prefixes), then a user's problem; ``paper`` when none is
    given."""
    if user is not None and variants is None and suite is None:
        return [user]
    names = [] if variants is None and suite is not None else parse_names(variants or "paper", "variants")
    for v in names:
        if v not in VARIANTS:
            raise ValueError(f"--variants: unknown problem variant {v!r}; available: {', '.join(VARIANTS)}")
    if suite is not None:
        try:
            names += [i for i in select_suite(suite) if i not in names]
        except ValueError as exc:
            raise ValueError(f"--suite: {exc}") from None
    if user is not None:
        names.append(user)
    return names


def _check_inputs(optimizers, seeds, budget, variants, workers, scheduler, time_limit_s, options, suite=None,
                  user: str | None = None):
    """The study's arguments checked and normalised; ValueError naming the flag otherwise."""
    optimizers = parse_names(optimizers, "optimizers")
    variants = _problems(variants, suite, user)
    seeds = parse_seeds(seeds)
    for name in optimizers:
        check_name(name)  # ValueError naming the known ones, before the options are looked at (no import)
    # the sandbox's server, its workers finding the study's optimizers imported: for the checks
    # below (a plugin is asked in a worker) and the runs
    server_address(preloads(optimizers))
    options = _check_options(options, optimizers)
    budget = check_budget_for(optimizers, budget, variants, options)
    if time_limit_s is not None and not (isinstance(time_limit_s, (int, float)) and math.isfinite(time_limit_s)
                                         and time_limit_s > 0):
        raise ValueError(f"--time-limit: must be a positive number of seconds, got {time_limit_s!r}")
    if scheduler is not None and workers is not None:
        raise ValueError("--workers and --scheduler exclude each other (the Dask cluster has its own workers)")
    if scheduler is not None:
        check_scheduler_address(scheduler)
    check_workers(workers)
    return optimizers, seeds, budget, variants, options


def _executor(todo: list[Task], optimizers: list[str], workers, cluster, store: Store | None = None):
    """The executor for the runs to do: none needed, the Dask `cluster` (already reached), this
    process or a local pool."""
    if not todo:  # every run is stored: no pool to start
        if cluster is not None:
            cluster.client.close()
        return InProcess(name="nothing to run")
    if cluster is not None:
        return cluster
    if workers == 0:
        return InProcess()
    n = workers if workers is not None else _n_cores()
    return LocalPool(max(1, min(n, len(todo))), preload=preloads(optimizers),
                     hidden=[str(store.path)] if store is not None else [])


def _stored_runs(store: Store, grid: list[Task]) -> dict[str, RunResult]:
    """Every stored record (read first: a corrupt file stops the study before anything is
    written); ValueError if a run of the grid is stored with other options."""
    stored = {k: store.read(k) for k in sorted(store.keys())} if store.path.is_dir() else {}
    read_manifest(store)  # a damaged study.json is reported, not overwritten
    for t in grid:
        old = stored.get(t.key)
        if old is not None and old.options != t.options:
            raise ValueError(f"{store.record_path(t.key)}: stored with options {old.options}, "
                             f"asked for {t.options}; use another store")
        if old is not None and old.blind != (t.blind is not None):
            raise ValueError(f"{store.record_path(t.key)}: stored on the {'blind' if old.blind else 'public'} "
                             f"instance, asked for the {'blind' if t.blind is not None else 'public'} one "
                             f"(--{'no-' if t.blind is None else ''}blind); use another store")
        if old is not None and old.x0 != t.x0:
            raise ValueError(f"{store.record_path(t.key)}: stored with x0 {old.x0}, asked for --x0 {t.x0}; "
                             "use another store")
    return stored


def run_study(optimizers, seeds, budget: int, store, variants=None, workers: int | None = None,
              scheduler: str | None = None, time_limit_s: float | None = None, progress: bool = True,
              options: dict | None = None, retry_failed: bool = False, suite=None, x0: str = "none",
              isolated: bool = True, model=None, data=None, parameters=None, unconfined: bool = False,
              blind: bool | None = None) -> StudyResult:
    """Run the grid optimizers x variants x seeds with `budget` FE evaluations per run into
    `store` (a directory), skipping the runs already stored.

    optimizers, variants: lists or comma-separated strings; seeds: a list or "0-29" / "0,3,7".
    suite: suite ids or prefixes (``hframe-freq/12``, ``paper``), a list or comma-separated,
    run as further variants (records carry the id as variant and problem, and f_opt);
    variants None: ``paper`` unless a suite is given.
    workers: local processes (None: every core; 0: in this process); scheduler: a Dask
    scheduler address (excludes workers). time_limit_s: seconds per run (None: none).
    progress: a progress bar when stdout is a terminal. options: {optimizer: {keyword: value}}
    passed to that optimizer's minimize. retry_failed: run again stored failed/timeout runs.
    x0: ``none`` (every solver starts from its own seeded draws) or ``all`` (every solver is
    given the problem's initial point; a plugin whose minimize takes no x0 is refused).
    isolated: each optimizer in a worker process without the problem (adapters.sandbox); False
    runs it in its run's own process, for debugging (`femu study --in-process`): its records
    are unverified, and reports say so.
    model, data, parameters: a user's own problem (`femu study --model FILE --data FILE
    [--parameters FILE]`, the balanced objective of `femu update`) run as a further variant
    ``user:PATH``: PATH the problem source file written into the store (`user_source`); only it
    when no variants or suite are given.
    unconfined: run even where this machine cannot confine the workers (adapters.confine:
    no Landlock, or neither root nor Landlock's signal scope); without it such a study is refused
    (ValueError naming --unconfined). Each record says what held; reports mark unconfined runs.
    blind: run the blind instances of the suite problems (femu.studies.blind: truths drawn from
    the store's secret, which no optimizer's worker can read); None (default): blind when a
    suite is given; False: the public instances (`femu study --no-blind`). The paper problem
    and named variants are public either way. Each record says whether its instance was blind;
    a run stored blind is not run again public (nor the other way): use another store.
    Raises ValueError (StoreError for the store) before running anything on bad input.
    """
    if isolated and not unconfined:
        missing = confinement_missing()
        if missing:
            raise ValueError(f"--unconfined: this machine cannot confine the optimizers' workers ({missing}); "
                             f"pass --unconfined to run and rank them anyway (their records and reports say so)")
    # no worker of this process reads or writes the store, from the first (a plugin's description)
    hide_from_workers([store.path if isinstance(store, Store) else store])
    store = store if isinstance(store, Store) else Store(store)
    user = None
    if model is not None or data is not None or parameters is not None:
        if model is None or data is None:
            raise ValueError("--model and --data go together (a user's problem needs both; --parameters is optional)")
        user = user_source(store, model, data, parameters)
    optimizers, seeds, budget, variants, options = _check_inputs(
        optimizers, seeds, budget, variants, workers, scheduler, time_limit_s, options, suite, user)
    x0 = check_x0_mode(x0, "--x0")
    if x0 == "all":
        n_vars = sorted({n_var_of(v) for v in variants})
        for name in optimizers:
            try:
                refused = optimizer_facts(name, n_vars, options.get(name, {}))["x0_refused"]
            except PluginFault:  # as in check_budget_for: its runs fail, named
                continue
            if refused:
                raise ValueError(refused)
    blind = suite is not None if blind is None else bool(blind)
    keys = blind_keys(store, variants) if blind else {}
    grid = [Task(o, v, budget, s, options.get(o, {}), time_limit_s, x0, bool(isolated), keys.get(v))
            for v in variants for o in optimizers for s in seeds]
    stored = _stored_runs(store, grid)
    store.remove_stale_claims()  # left by studies that were killed, whatever runs they were for
    wanted = [t for t in grid if t.key not in stored or (retry_failed and stored[t.key].status in RETRY_STATUSES)]
    # a noisy blind instance's f_opt: certified here, on the evaluating side, once per store
    certified = certificates(store, {t.variant: t.blind for t in wanted if t.blind is not None})
    wanted = [replace(t, certificate=certified.get(t.variant)) for t in wanted]
    # the cluster is reached before any claim: an unreachable one leaves nothing in the store
    cluster = DaskCluster(scheduler) if scheduler is not None and wanted else None
    if cluster is not None:
        cluster.hidden = (str(store.path.resolve()),)  # its workers' optimizers never read the store either
        if isolated and not unconfined:
            cluster.refuse_unconfined()  # as a local study is refused (above), naming the worker
    try:
        todo, n_elsewhere = _claim(store, wanted, stored)
    except BaseException:
        if cluster is not None:
            cluster.client.close()
        raise
    try:
        executor = _executor(todo, optimizers, workers, cluster, store)
        t0 = time.perf_counter()
        write_manifest(store, {"optimizers": optimizers, "seeds": seeds, "budget": budget, "variants": variants,
                               "suite": suite if suite is None or isinstance(suite, str) else list(suite),
                               "time_limit_s": time_limit_s, "options": options,
                               "retry_failed": bool(retry_failed), "x0": x0, "in_process": not isolated,
                               "blind": blind},
                       executor.name)
        records = {t.key: stored[t.key] for t in grid if t.key in stored}
        todo_keys = {t.key for t in todo}
        kept_failed = sum(1 for k, r in records.items() if k not in todo_keys and r.status in RETRY_STATUSES)
        with Progress(len(grid), len(grid) - len(todo), kept_failed,
                      enabled=progress and sys.stdout.isatty()) as bar:
            for task, record in executor.run(todo, bar.running):
                result = RunResult.from_dict(record)
                store.write(result)
                store.release(task.key)  # the run has ended: its claim goes now, not with the study
                records[task.key] = result
                bar.done(result.status in RETRY_STATUSES)
    finally:
        for t in todo:
            store.release(t.key)
    return StudyResult(store=store.path, runs=tuple(records[t.key] for t in grid if t.key in records),
                       n_new=len(todo), n_kept=len(grid) - len(todo) - n_elsewhere, wall_s=time.perf_counter() - t0,
                       executor=executor.name, n_elsewhere=n_elsewhere)


def _claim(store: Store, wanted: list[Task], stored: dict) -> tuple[list[Task], int]:
    """The wanted runs to do now, each claimed in the store, and how many are left to another
    process that holds their claim. A run another process finished between reading the store
    and claiming is read into `stored` instead of being run again."""
    todo, elsewhere = [], 0
    try:
        for t in wanted:
            if not store.claim(t.key):
                elsewhere += 1
            elif t.key not in stored and store.record_path(t.key).exists():
                stored[t.key] = store.read(t.key)
                store.release(t.key)
            else:
                todo.append(t)
    except BaseException:  # a store that cannot be written, Ctrl-C: leave no claim of ours behind
        for t in wanted:
            store.release(t.key)  # only this process's claims are removed
        raise
    return todo, elsewhere
