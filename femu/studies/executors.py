"""Executors of a study's tasks: each yields (task, record dict) as runs finish and reports
through `running(n)` how many runs are under way.


Executors
- in-process (``workers=0``): one run after another in this process.
- local pool (default, ``workers=None`` = every core): at most `workers` runs at once, each in
  its own process forked from a forkserver that has already imported numpy, scipy, the FE
  core and the study's optimizers (a few ms per run, once ~0.5 s to start the server). A run
  process that hangs or crashes takes only its own run with it. As with any multiprocessing
  code, a script that calls `run_study` needs the ``if __name__ == "__main__":`` guard.
- Dask (``scheduler="tcp://host:port"``): one Dask task per run through
  ``dask.distributed.Client(address)``; the workers need femu-bench installed. Runs in one
  worker process go one at a time (some libraries draw from the process-global random
  generators, see `harness.seeded_global_rngs`): give workers one thread and more processes.

Under every executor the optimizer itself runs in a worker process of the sandbox
(adapters.sandbox) that never holds the problem: the run's process evaluates, counts, times and
judges. This process's sandbox server (started on first use, preloaded with the study's
optimizers) serves the local pool's run processes too (they are given its address); each Dask
worker process starts one of its own on first use.
What a plugin does to its process (os._exit, a segfault, sys.exit, a patched harness, processes
of its own) ends with its worker.

Time limits: the sandbox stops a run at its next objective call once `time_limit_s` has passed,
or, when the optimizer stops calling the objective, kills its worker at
``time_limit_s + 0.5 s + 5 %`` (adapters.sandbox.worker_deadline_s); either way the record has
status ``timeout`` and the evaluations done until then. The local pool keeps a backstop for a
run process that itself hangs: it is terminated at ``time_limit_s + 5 s + 10 %`` after the run
started (its problem built; a process that does not get there within STARTUP_LIMIT_S is given
up as failed), with status ``timeout`` and no evaluations. Without a time limit there is no
deadline (`femu study` and `femu reproduce` always give one).

"""

from __future__ import annotations

import math
import multiprocessing
import multiprocessing.connection
import signal
import sys
import time
from collections import deque
from typing import Callable, Iterable, Iterator

from adapters.sandbox import drop_spare, hide_from_workers, server_address, use_server

from .kill import kill_descendants, kill_tree
from .tasks import STARTUP_LIMIT_S, Task, hard_deadline_s, hard_timeout_error, lost_record, run_task, startup_error

class InProcess:
    """Runs the tasks one after another in this process (no hard time limit)."""

    def __init__(self, name: str = "in-process"):
        self.name = name

    def run(self, tasks: list[Task], running: Callable[[int], None]) -> Iterator[tuple[Task, dict]]:
        for task in tasks:
            running(1)
            yield task, run_task(task)
        running(0)


def _child(conn, task: Task, server: str, hidden: list) -> None:
    """Body of a local-pool process: says when the run starts, then sends its record. The run's
    optimizer runs in a worker of the study's worker server at `server` (adapters.sandbox),
    which may not read the paths `hidden` (the study's store)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's: it stops the children
    hide_from_workers(hidden)
    use_server(server)  # its worker forked now, while it builds its problem
    try:
        record = run_task(task, on_start=lambda: conn.send(None))
    finally:
        drop_spare()  # the worker its run did not take (a run that failed before it started): no exit handlers here
    kill_descendants()  # processes the plugin started do not outlive its run
    conn.send(record)
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
                return lost_record(self.task, "failed", startup_error(self.task), 0.0)
        elif now - self.started > limit:
            return lost_record(self.task, "timeout", hard_timeout_error(self.task, now - self.started),
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

    def __init__(self, workers: int, preload: Iterable[str] = (), hidden: Iterable[str] = ()):
        self.workers = int(workers)
        self.name = f"local pool, {self.workers} worker{'s' if self.workers != 1 else ''}"
        self.ctx = multiprocessing.get_context("forkserver")
        # Import once in the server what every run needs, not once per run (each child runs the
        # main module again unless the server has it: `python -m pkg` mains are named by their
        # spec). Only effective before the server starts (the first pool of this process).
        spec = getattr(sys.modules.get("__main__"), "__spec__", None)
        main = [spec.name] if spec is not None and spec.name else []
        self.ctx.set_forkserver_preload(["__main__", *main, "femu.studies.study"])
        self.preload = list(preload)  # the optimizers' modules: imported by the workers' server
        self.hidden = list(hidden)  # what their workers may not read (the store)

    def run(self, tasks: list[Task], running: Callable[[int], None]) -> Iterator[tuple[Task, dict]]:
        queue = deque(tasks)
        live: dict = {}  # receiving end -> _Live
        server = server_address(self.preload)  # the optimizers run in its workers, never in a run's process
        try:
            while queue or live:
                while queue and len(live) < self.workers:
                    task = queue.popleft()
                    recv, send = self.ctx.Pipe(duplex=False)
                    proc = self.ctx.Process(target=_child, args=(send, task, server, self.hidden), name=f"femu {task.key}",
                                            daemon=True)
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
            return lost_record(r.task, "failed", f"the run's process exited with code {r.proc.exitcode} "
                                f"without returning a record", time.perf_counter() - r.launched)
        return msg


def _stop(proc) -> None:
    """End a run's process and every process it started."""
    kill_tree(proc.pid)
    proc.join()

