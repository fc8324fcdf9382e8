"""Comparative studies: the grid optimizers x problem variants x seeds, run in parallel into a
resumable result store (adapters/store.py), and the `femu study` / `femu results` commands.

Each run is a task, a pure function of (optimizer, variant, budget, seed, options): the
worker builds the problem itself (`variants.make_problem`) and calls `harness.run`, so a seed
gives the same record (apart from times and host) in this process, in a worker process and on
a Dask cluster. Workers return records; only this (the parent) process writes the store, one
file per finished run, atomically, as soon as it arrives.

Executors
- in-process (``workers=0``): one run after another in this process; no hard time limit.
- local pool (default, ``workers=None`` = every core): at most `workers` runs at once, each in
  its own process forked from a forkserver that has already imported numpy, scipy, the FE
  core and the study's optimizers (a few ms per run, once ~0.5 s to start the server). A run
  that hangs or crashes takes only its own process with it. As with any multiprocessing
  code, a script that calls `run_study` needs the ``if __name__ == "__main__":`` guard.
- Dask (``scheduler="tcp://host:port"``): one Dask task per run through
  ``dask.distributed.Client(address)``; the workers need femu-bench installed. Runs in one
  worker process go one at a time (some libraries draw from the process-global random
  generators, see `harness.seeded_global_rngs`): give workers one thread and more processes.

Time limits: the harness stops a run cooperatively at its next objective call once
`time_limit_s` has passed (status ``timeout``, with the evaluations done so far). A plugin
that stops calling the objective is caught by a hard deadline of ``time_limit_s + 1 s + 10 %``
after the run started (its problem built; a process that does not get there within
STARTUP_LIMIT_S is given up as failed): its process is terminated (local pool) or its child
interpreter killed (on Dask each run with a time limit runs in a child interpreter, because
Dask worker processes may not fork) and the record has status ``timeout``, no evaluations
(they died with the process) and an error saying so. Without a time limit there is no hard
deadline.

Optimizers are registry names or import paths ``package.module:Class`` (registry.get), so a
class that is not registered reaches every worker process.

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
import multiprocessing
import multiprocessing.connection
import os
import platform
import re
import signal
import subprocess
import sys
import tempfile
import threading
import time
import traceback
from collections import deque
from dataclasses import asdict, dataclass, field
from datetime import datetime, timezone
from functools import lru_cache
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Callable, Iterable, Iterator

from adapters.harness import RunResult, run
from adapters.registry import BUILTINS, ENTRY_POINT_GROUP, get
from .store import Store, run_key
from adapters.variants import VARIANTS, make_problem

STUDY_FORMAT = "femu.study/1"

#: Statuses that --retry-failed runs again.
RETRY_STATUSES = ("failed", "timeout")

#: Packages whose versions study.json records.
_VERSIONED = ("femu-bench", "numpy", "scipy", "pymoo", "deap", "pyswarms", "cma", "dask", "distributed", "rich")


# -- the task: one run ---------------------------------------------------------------------
@dataclass(frozen=True)
class Task:
    """One run of the grid. time_limit_s in seconds (None: no limit)."""

    optimizer: str
    variant: str
    budget: int
    seed: int
    options: dict = field(default_factory=dict)
    time_limit_s: float | None = None

    @property
    def key(self) -> str:
        """The run's key in the store."""
        return run_key(self.variant, self.optimizer, self.budget, self.seed)


def run_task(task: Task, on_start: Callable[[], None] | None = None) -> dict:
    """Run one task and return its record as a dict (RunResult.to_dict()).

    Pure: builds the problem from the variant name and runs the optimizer with the task's
    seed. A failing optimizer gives a ``failed`` record (harness.run); so does a failure while
    building the problem, so that a worker always returns a record. `on_start` is called once
    the problem is built, when the run (and its time limit) starts.
    """
    t0 = time.perf_counter()
    try:
        problem = make_problem(task.variant)
        if on_start is not None:
            on_start()
        return run(task.optimizer, problem, task.budget, task.seed, time_limit_s=task.time_limit_s,
                   variant=task.variant, **task.options).to_dict()
    except Exception as exc:
        return _lost_record(task, "failed", f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=6)}",
                            time.perf_counter() - t0)


@lru_cache(maxsize=None)
def _problem_name(variant: str) -> str:
    return make_problem(variant).name


def _lost_record(task: Task, status: str, error: str, wall_s: float) -> dict:
    """The record of a run whose process returned nothing (hard timeout, crash)."""
    return RunResult(optimizer=task.optimizer, problem=_problem_name(task.variant), seed=task.seed,
                     budget=task.budget, options=dict(task.options), wall_s=wall_s, status=status,
                     error=error, variant=task.variant, host=platform.node()).to_dict()


def hard_deadline_s(time_limit_s: float | None) -> float | None:
    """Seconds after a run's start (problem built) at which its process is killed: the limit
    plus a grace of 1 s + 10 % for the cooperative stop to land."""
    return None if time_limit_s is None else time_limit_s + 1.0 + 0.1 * time_limit_s


#: Seconds a run with a time limit may take to start (process, imports, problem build) before
#: it is given up as failed: generous, a loaded machine can be slow to start a Python process.
STARTUP_LIMIT_S = 300.0


def _hard_timeout_error(task: Task, elapsed_s: float) -> str:
    return (f"terminated after {elapsed_s:.1f} s: the run passed its time limit of {task.time_limit_s} s "
            f"without returning (the optimizer stopped calling the objective); its evaluations are lost")


def _startup_error(task: Task) -> str:
    return f"the run's process did not start within {STARTUP_LIMIT_S:.0f} s; it was terminated"


# -- executors: each yields (task, record dict) as runs finish and reports how many run ----
class InProcess:
    """Runs the tasks one after another in this process (no hard time limit)."""

    def __init__(self, name: str = "in-process"):
        self.name = name

    def run(self, tasks: list[Task], running: Callable[[int], None]) -> Iterator[tuple[Task, dict]]:
        for task in tasks:
            running(1)
            yield task, run_task(task)
        running(0)


def _child(conn, task: Task) -> None:
    """Body of a local-pool process: says when the run starts, then sends its record."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's: it stops the children
    conn.send(run_task(task, on_start=lambda: conn.send(None)))
    conn.close()


class _Live:
    """A run in a local-pool process: its clock starts when the child says the run started."""

    def __init__(self, task: Task, proc, conn):
        self.task, self.proc, self.conn = task, proc, conn
        self.launched, self.started = time.perf_counter(), None

    def overdue(self, now: float) -> dict | None:
        """The record to store if the run is past its deadline, else None."""
        limit = hard_deadline_s(self.task.time_limit_s)
        if limit is None:
            return None
        if self.started is None:
            if now - self.launched > STARTUP_LIMIT_S:
                return _lost_record(self.task, "failed", _startup_error(self.task), 0.0)
        elif now - self.started > limit:
            return _lost_record(self.task, "timeout", _hard_timeout_error(self.task, now - self.started),
                                now - self.started)
        return None

    def wait_s(self, now: float) -> float:
        limit = hard_deadline_s(self.task.time_limit_s)
        if limit is None:
            return math.inf
        due = self.launched + STARTUP_LIMIT_S if self.started is None else self.started + limit
        return max(0.0, due - now)


class LocalPool:
    """At most `workers` runs at once, each in its own forkserver process; a run past its hard
    deadline is terminated and recorded as ``timeout``, one whose process dies as ``failed``."""

    def __init__(self, workers: int, preload: Iterable[str] = ()):
        self.workers = int(workers)
        self.name = f"local pool, {self.workers} worker{'s' if self.workers != 1 else ''}"
        self.ctx = multiprocessing.get_context("forkserver")
        # Import once in the server what every run needs, not once per run (each child runs the
        # main module again unless the server has it: `python -m pkg` mains are named by their
        # spec). Only effective before the server starts (the first pool of this process).
        spec = getattr(sys.modules.get("__main__"), "__spec__", None)
        main = [spec.name] if spec is not None and spec.name else []
        self.ctx.set_forkserver_preload(["__main__", *main, "femu.studies.study", *preload])

    def run(self, tasks: list[Task], running: Callable[[int], None]) -> Iterator[tuple[Task, dict]]:
        queue = deque(tasks)
        live: dict = {}  # receiving end -> _Live
        try:
            while queue or live:
                while queue and len(live) < self.workers:
                    task = queue.popleft()
                    recv, send = self.ctx.Pipe(duplex=False)
                    proc = self.ctx.Process(target=_child, args=(send, task), name=f"femu {task.key}", daemon=True)
                    proc.start()
                    send.close()  # so that recv sees EOF if the child dies
                    live[recv] = _Live(task, proc, recv)
                running(len(live))
                now = time.perf_counter()
                wait = min([1.0] + [r.wait_s(now) + 0.01 for r in live.values()])
                for conn in multiprocessing.connection.wait(list(live), timeout=wait):
                    record = self._receive(live[conn])
                    if record is not None:
                        yield live.pop(conn).task, record
                now = time.perf_counter()
                for conn, r in list(live.items()):
                    record = r.overdue(now)
                    if record is not None:
                        del live[conn]
                        _stop(r.proc)
                        conn.close()
                        yield r.task, record
            running(0)
        finally:  # interrupted (Ctrl-C, an error in the consumer): leave no process behind
            for r in live.values():
                _stop(r.proc)
                r.conn.close()

    @staticmethod
    def _receive(r: _Live) -> dict | None:
        """The run's record once it is done (None: it has only started)."""
        try:
            msg = r.conn.recv()
        except (EOFError, OSError):
            msg = False  # the process died without a record
        if msg is None:
            r.started = time.perf_counter()
            return None
        r.conn.close()
        r.proc.join(10)
        if r.proc.is_alive():
            _stop(r.proc)
        if msg is False:
            return _lost_record(r.task, "failed", f"the run's process exited with code {r.proc.exitcode} "
                                f"without returning a record", time.perf_counter() - r.launched)
        return msg


def _stop(proc) -> None:
    proc.terminate()
    proc.join(2)
    if proc.is_alive():
        proc.kill()
        proc.join()


#: Runs in one Dask worker process go one at a time (process-global random generators).
_DASK_RUN_LOCK = threading.Lock()


def dask_task(task: Task) -> dict:
    """What a Dask worker runs for one task: in the worker when there is no time limit, else in
    a child interpreter killed at the hard deadline."""
    with _DASK_RUN_LOCK:
        if task.time_limit_s is None:
            return run_task(task)
        return run_task_in_child(task)


def run_task_in_child(task: Task) -> dict:
    """Run a task in a fresh interpreter (``python -m femu.studies.study --run-task``), killed at
    the hard deadline: a ``timeout`` record then, a ``failed`` one if it dies."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p))
    with tempfile.TemporaryDirectory(prefix="femu-run-") as tmp:
        out, started, log = Path(tmp) / "record.json", Path(tmp) / "started", Path(tmp) / "stderr.txt"
        with open(log, "w") as err:
            proc = subprocess.Popen([sys.executable, "-m", "femu.studies.study", "--run-task",
                                     json.dumps(asdict(task)), str(out), str(started)],
                                    env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=err)
        launched, t_start, record = time.perf_counter(), None, None
        try:
            while proc.poll() is None:
                time.sleep(0.02)
                now = time.perf_counter()
                if t_start is None and started.exists():
                    t_start = now
                if t_start is None and now - launched > STARTUP_LIMIT_S:
                    record = _lost_record(task, "failed", _startup_error(task), 0.0)
                elif t_start is not None and now - t_start > hard_deadline_s(task.time_limit_s):
                    record = _lost_record(task, "timeout", _hard_timeout_error(task, now - t_start), now - t_start)
                if record is not None:
                    return record
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait()
        if proc.returncode != 0 or not out.exists():
            return _lost_record(task, "failed", f"the run's process exited with code {proc.returncode}: "
                                f"{log.read_text()[-2000:]}", time.perf_counter() - launched)
        return json.loads(out.read_text())


class DaskCluster:
    """Submits every task to the Dask scheduler at `address` and yields them as they finish.

    `running` is an estimate: the unfinished runs, at most the cluster's thread count."""

    def __init__(self, address: str):
        from dask.distributed import Client
        from distributed.comm import parse_address
        from distributed.comm.registry import get_backend

        scheme, location = parse_address(address)
        if not location:
            raise ValueError(f"--scheduler {address!r}: not a scheduler address (tcp://host:port)")
        try:  # a bad scheme, checked before a Client exists (a failed Client lingers on exit)
            get_backend(scheme)
        except ValueError as exc:
            raise ValueError(f"--scheduler {address}: {exc}") from None
        try:
            self.client = Client(address, timeout=10, set_as_default=False)
        except Exception as exc:  # OSError, TimeoutError, ValueError for a malformed address
            raise ValueError(f"--scheduler {address}: cannot connect to a Dask scheduler "
                             f"({type(exc).__name__}: {exc})") from None
        self.name = f"Dask scheduler {address}"

    def run(self, tasks: list[Task], running: Callable[[int], None]) -> Iterator[tuple[Task, dict]]:
        from dask.distributed import as_completed

        futures = {}
        try:
            futures = {self.client.submit(dask_task, t, pure=False): t for t in tasks}
            slots = max(1, sum(self.client.nthreads().values()))
            left = len(futures)
            running(min(left, slots))
            for fut in as_completed(futures, loop=self.client.loop):  # our client is not the default
                task = futures[fut]
                try:
                    record = fut.result()
                except Exception as exc:  # the worker died (KilledWorker) or lost the task
                    record = _lost_record(task, "failed", f"the Dask task failed: {type(exc).__name__}: {exc}", 0.0)
                left -= 1
                running(min(left, slots))
                yield task, record
        finally:
            self.client.cancel([f for f in futures if not f.done()])
            self.client.close()


# -- input checks --------------------------------------------------------------------------
def parse_seeds(spec) -> list[int]:
    """Seeds from ``"0-29"``, ``"0,3,7"`` or a mix (``"0-4,10"``), or from a list of ints.

    ValueError for anything else: negative or non-integer seeds, a descending range, an empty
    spec, a seed given twice."""
    hint = "seeds are integers >= 0, e.g. 0-29 or 0,3,7"
    if isinstance(spec, str):
        items = [s.strip() for s in spec.split(",")]
        if not spec.strip() or any(not s for s in items):
            raise ValueError(f"--seeds {spec!r}: empty seed in the list ({hint})")
        seeds: list[int] = []
        for item in items:
            m = re.fullmatch(r"(\d+)(?:-(\d+))?", item, flags=re.ASCII)
            if m is None:
                raise ValueError(f"--seeds {spec!r}: {item!r} is not a seed or a range a-b ({hint})")
            a = int(m[1])
            b = int(m[2]) if m[2] is not None else a
            if b < a:
                raise ValueError(f"--seeds {spec!r}: range {item!r} runs backwards (write {b}-{a})")
            seeds.extend(range(a, b + 1))
    else:
        seeds = []
        for s in spec:
            if isinstance(s, bool) or not hasattr(s, "__index__") or s.__index__() < 0:
                raise ValueError(f"seeds: {s!r} is not a seed ({hint})")
            seeds.append(s.__index__())
        if not seeds:
            raise ValueError(f"seeds: no seed given ({hint})")
    dup = sorted({s for s in seeds if seeds.count(s) > 1})
    if dup:
        raise ValueError(f"--seeds {spec!r}: seed {dup[0]} is given twice")
    return seeds


def _names(spec, what: str) -> list[str]:
    names = [s.strip() for s in spec.split(",")] if isinstance(spec, str) else [str(s) for s in spec]
    if not names or any(not n for n in names):
        raise ValueError(f"--{what} {spec!r}: empty name in the list")
    dup = sorted({n for n in names if names.count(n) > 1})
    if dup:
        raise ValueError(f"--{what}: {dup[0]!r} is given twice")
    return names


def _optimizer_module(name: str) -> str | None:
    """The module that defines an optimizer, for the forkserver to preload."""
    if name in BUILTINS:
        return BUILTINS[name].split(":")[0]
    if ":" in name:
        return name.split(":")[0]
    from importlib.metadata import entry_points
    eps = {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}
    return eps[name].module if name in eps else None


def _check_options(options, optimizers: list[str]) -> dict[str, dict]:
    if options is None:
        return {}
    if not isinstance(options, dict) or not all(isinstance(v, dict) for v in options.values()):
        raise ValueError("options: expected {optimizer name: {keyword: value}}")
    extra = sorted(set(options) - set(optimizers))
    if extra:
        raise ValueError(f"options given for {extra[0]!r}, which is not among the study's optimizers "
                         f"({', '.join(optimizers)})")
    try:  # records are JSON: the options must survive the round trip unchanged
        return json.loads(json.dumps(options))
    except (TypeError, ValueError) as exc:
        raise ValueError(f"options: not JSON serialisable ({exc})") from None


# -- the study -----------------------------------------------------------------------------
@dataclass(frozen=True)
class StudyResult:
    """What a study left in its store.

    runs: every run of the grid (kept and new), in grid order (variant, optimizer, seed);
    n_new: runs done by this call; n_kept: runs found in the store; wall_s: seconds."""

    store: Path
    runs: tuple[RunResult, ...]
    n_new: int
    n_kept: int
    wall_s: float
    executor: str

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
        return (f"femu study: {len(self.runs)} runs in {self.store} ({self.n_new} new, {self.n_kept} kept): "
                f"{statuses}; {self.wall_s:.1f} s ({self.executor})")


def _n_cores() -> int:
    if hasattr(os, "sched_getaffinity"):  # the cores this process may use, not the machine's
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1


def _versions() -> dict:
    out = {"python": platform.python_version()}
    for pkg in _VERSIONED:
        try:
            out[pkg] = version(pkg)
        except PackageNotFoundError:
            out[pkg] = None
    return out


def _write_manifest(store: Store, request: dict) -> None:
    """study.json: the latest request at the top, earlier ones (resumed or extended) in history."""
    old = store.manifest()
    history = []
    if old is not None:
        history = list(old.get("history", [])) + [{k: v for k, v in old.items() if k not in ("history", "format")}]
    store.write_manifest({"format": STUDY_FORMAT, **request, "history": history})


def run_study(optimizers, seeds, budget: int, store, variants=("paper",), workers: int | None = None,
              scheduler: str | None = None, time_limit_s: float | None = None, progress: bool = True,
              options: dict | None = None, retry_failed: bool = False) -> StudyResult:
    """Run the grid optimizers x variants x seeds with `budget` FE evaluations per run into
    `store` (a directory), skipping the runs already stored.

    optimizers, variants: lists or comma-separated strings; seeds: a list or "0-29" / "0,3,7".
    workers: local processes (None: every core; 0: in this process); scheduler: a Dask
    scheduler address (excludes workers). time_limit_s: seconds per run (None: none).
    progress: a progress bar when stdout is a terminal. options: {optimizer: {keyword: value}}
    passed to that optimizer's minimize. retry_failed: run again stored failed/timeout runs.
    Raises ValueError (StoreError for the store) before running anything on bad input.
    """
    optimizers = _names(optimizers, "optimizers")
    variants = _names(variants, "variants")
    seeds = parse_seeds(seeds)
    for v in variants:
        if v not in VARIANTS:
            raise ValueError(f"--variants: unknown problem variant {v!r}; available: {', '.join(VARIANTS)}")
    if isinstance(budget, bool) or not hasattr(budget, "__index__") or budget.__index__() < 1:
        raise ValueError(f"--budget: must be an integer >= 1 (FE evaluations per run), got {budget!r}")
    budget = budget.__index__()
    for name in optimizers:
        min_budget = int(getattr(get(name), "min_budget", 1))  # get(): ValueError naming the known ones
        if budget < min_budget:
            raise ValueError(f"--budget {budget}: optimizer {name!r} needs at least {min_budget} evaluations")
    if time_limit_s is not None and not (isinstance(time_limit_s, (int, float)) and math.isfinite(time_limit_s)
                                         and time_limit_s > 0):
        raise ValueError(f"--time-limit: must be a positive number of seconds, got {time_limit_s!r}")
    if scheduler is not None and workers is not None:
        raise ValueError("--workers and --scheduler exclude each other (the Dask cluster has its own workers)")
    if workers is not None and (isinstance(workers, bool) or not isinstance(workers, int) or workers < 0):
        raise ValueError(f"--workers: must be an integer >= 0 (0: run in this process), got {workers!r}")
    options = _check_options(options, optimizers)

    store = store if isinstance(store, Store) else Store(store)
    # read every stored record first: a corrupt file stops the study before anything is written
    stored = {k: store.read(k) for k in sorted(store.keys())} if store.path.is_dir() else {}
    store.manifest()  # a corrupt study.json is reported, not overwritten
    grid = [Task(o, v, budget, s, options.get(o, {}), time_limit_s)
            for v in variants for o in optimizers for s in seeds]
    for t in grid:
        old = stored.get(t.key)
        if old is not None and old.options != t.options:
            raise ValueError(f"{store.runs_dir / (t.key + '.json')}: stored with options {old.options}, "
                             f"asked for {t.options}; use another store")
    todo = [t for t in grid if t.key not in stored or (retry_failed and stored[t.key].status in RETRY_STATUSES)]

    if not todo:  # every run is stored: no pool to start, no cluster to reach
        executor = InProcess(name="nothing to run")
    elif scheduler is not None:
        executor = DaskCluster(scheduler)
    elif workers == 0:
        executor = InProcess()
    else:
        n = workers if workers is not None else _n_cores()
        executor = LocalPool(max(1, min(n, len(todo))),
                             preload=[m for m in map(_optimizer_module, optimizers) if m])

    t0 = time.perf_counter()
    store.path.mkdir(parents=True, exist_ok=True)
    _write_manifest(store, {
        "optimizers": optimizers, "seeds": seeds, "budget": budget, "variants": variants,
        "time_limit_s": time_limit_s, "options": options, "retry_failed": bool(retry_failed),
        "executor": executor.name, "started": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "host": platform.node(), "versions": _versions()})

    records = {t.key: stored[t.key] for t in grid if t.key in stored}
    todo_keys = {t.key for t in todo}
    kept_failed = sum(1 for k, r in records.items() if k not in todo_keys and r.status in RETRY_STATUSES)
    bar = _Progress(len(grid), len(grid) - len(todo), kept_failed, enabled=progress and sys.stdout.isatty())
    with bar:
        for task, record in executor.run(todo, bar.running):
            result = RunResult.from_dict(record)
            store.write(result)
            records[task.key] = result
            bar.done(result.status in RETRY_STATUSES)
    return StudyResult(store=store.path, runs=tuple(records[t.key] for t in grid), n_new=len(todo),
                       n_kept=len(grid) - len(todo), wall_s=time.perf_counter() - t0, executor=executor.name)


class _Progress:
    """A rich progress bar of runs done, running and failed (does nothing when disabled)."""

    def __init__(self, total: int, done: int, failed: int, enabled: bool):
        self.enabled, self.failed, self._running = enabled, failed, 0
        if enabled:
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

            self.bar = Progress(TextColumn("runs"), BarColumn(), MofNCompleteColumn(),
                                TextColumn("done · {task.fields[running]} running · {task.fields[failed]} failed"),
                                TimeElapsedColumn())
            self.task = self.bar.add_task("study", total=total, completed=done, running=0, failed=failed)

    def __enter__(self):
        if self.enabled:
            self.bar.start()
        return self

    def __exit__(self, *exc):
        if self.enabled:
            self.bar.stop()

    def running(self, n: int) -> None:
        if self.enabled and n != self._running:
            self._running = n
            self.bar.update(self.task, running=n)

    def done(self, failed: bool) -> None:
        if self.enabled:
            self.failed += failed
            self.bar.update(self.task, advance=1, failed=self.failed)


def _run_task_main(argv: list[str]) -> int:
    """``python -m femu.studies.study --run-task TASK_JSON OUT STARTED``: one run, its record to
    the file OUT; the file STARTED is created when the run starts."""
    task = Task(**json.loads(argv[1]))
    record = run_task(task, on_start=Path(argv[3]).touch)
    Path(argv[2]).write_text(json.dumps(record))
    return 0


if __name__ == "__main__":
    if len(sys.argv) == 5 and sys.argv[1] == "--run-task":
        sys.exit(_run_task_main(sys.argv[1:]))
    sys.exit("usage: python -m femu.studies.study --run-task TASK_JSON OUT STARTED (used on Dask workers)")
