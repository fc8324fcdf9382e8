"""The Dask executor and the child-process entry of a run.

On Dask each run goes through `dask_task` in a worker, its optimizer in a worker of the sandbox
server of that Dask worker process (adapters.sandbox), which stops it at its time limit.
`run_task_in_child` (``python -m femu.studies.child --run-task TASK_FILE OUT STARTED``) runs a
task in a fresh interpreter killed at its hard deadline, for callers that need that. The task
goes in a file of a private directory, never on the command line (which any process may read
in /proc: a blind instance's key is in it).
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import asdict
from pathlib import Path
from typing import Callable, Iterator

from fe_problem.jsonutil import dumps

from .kill import kill_descendants, kill_tree
from .tasks import STARTUP_LIMIT_S, Task, hard_deadline_s, hard_timeout_error, lost_record, run_task, startup_error

#: Seconds to wait for a Dask scheduler to answer before the study is refused.
CONNECT_TIMEOUT_S = 5

#: Runs in one Dask worker process go one at a time (process-global random generators).
_DASK_RUN_LOCK = threading.Lock()


def dask_task(task: Task, hidden: tuple = ()) -> dict:
    """What a Dask worker runs for one task: the run, its optimizer in a worker of the sandbox
    server this Dask worker process starts once (adapters.sandbox, a subprocess: Dask worker
    processes may not fork multiprocessing children, but may start programs), confined as a
    local run's: it may never read the paths `hidden` (the study's store, on a shared
    filesystem), nor write outside its own directory. The sandbox stops an optimizer at its
    time limit, so no child interpreter is needed for one."""
    from adapters.sandbox import hide_from_workers

    with _DASK_RUN_LOCK:
        hide_from_workers(hidden)
        return run_task(task)


def confinement_missing_here() -> str | None:
    """What this (Dask worker's) machine cannot confine (adapters.sandbox.confinement_missing)."""
    from adapters.sandbox import confinement_missing

    return confinement_missing()


def run_task_in_child(task: Task) -> dict:
    """Run a task in a fresh interpreter (``python -m femu.studies.child --run-task``), killed at
    the hard deadline: a ``timeout`` record then, a ``failed`` one if it dies."""
    # one process per run: the run's parallelism is the cluster's, not the sparse solver's
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p), FEMU_SOLVER_WORKERS="1")
    with tempfile.TemporaryDirectory(prefix="femu-run-") as tmp:
        out, started, log = Path(tmp) / "record.json", Path(tmp) / "started", Path(tmp) / "stderr.txt"
        spec = Path(tmp) / "task.json"  # the directory is this user's only (mode 0700)
        spec.write_text(dumps(asdict(task), indent=None))
        with open(log, "w") as err:
            proc = subprocess.Popen([sys.executable, "-m", "femu.studies.child", "--run-task",
                                     str(spec), str(out), str(started)],
                                    env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=err)
        launched, t_start, record = time.perf_counter(), None, None
        try:
            while proc.poll() is None:
                time.sleep(0.02)
                now = time.perf_counter()
                if t_start is None and started.exists():
                    t_start = now
                if t_start is None and now - launched > STARTUP_LIMIT_S:
                    record = lost_record(task, "failed", startup_error(task), 0.0)
                elif t_start is not None and task.time_limit_s is not None and \
                        now - t_start > hard_deadline_s(task.time_limit_s):
                    record = lost_record(task, "timeout", hard_timeout_error(task, now - t_start), now - t_start)
                if record is not None:
                    return record
        finally:
            if proc.poll() is None:
                kill_tree(proc.pid)
                proc.wait()
        if proc.returncode != 0 or not out.exists():
            return lost_record(task, "failed", f"the run's process exited with code {proc.returncode}: "
                                f"{log.read_text()[-2000:]}", time.perf_counter() - launched)
        return json.loads(out.read_text())


def check_scheduler_address(address: str) -> None:
    """ValueError unless `address` is a Dask scheduler address (tcp://host:port and the like)
    of a scheme distributed knows; nothing is contacted. Without dask: the line naming the
    'cluster' extra (adapters.extras)."""
    from adapters.extras import require

    require("--scheduler (a Dask cluster)", "dask", "distributed")
    from distributed.comm import parse_address
    from distributed.comm.registry import get_backend

    scheme, location = parse_address(address)
    if not location or (scheme in ("tcp", "tls", "ws", "wss") and not re.fullmatch(r".+:\d{1,5}", location)):
        raise ValueError(f"--scheduler {address!r}: not a scheduler address (tcp://host:port)")
    try:  # a bad scheme, checked before a Client exists (a failed Client lingers on exit)
        get_backend(scheme)
    except ValueError as exc:
        raise ValueError(f"--scheduler {address}: {exc}") from None


def _reach(address: str) -> None:
    """ValueError unless a Dask comm (connection and handshake) can be opened to `address`
    within CONNECT_TIMEOUT_S seconds; the connection is closed again."""
    import asyncio

    from distributed.comm import connect

    async def probe():
        comm = await connect(address, timeout=CONNECT_TIMEOUT_S)
        await comm.close()

    try:
        asyncio.run(probe())
    except OSError as exc:  # nothing listening, an unknown host, a timeout
        raise ValueError(f"--scheduler {address}: cannot connect to a Dask scheduler within "
                         f"{CONNECT_TIMEOUT_S} s ({exc})") from None
    except Exception as exc:  # something answered, but does not speak Dask's protocol
        raise ValueError(f"--scheduler {address}: what answered there is not a Dask scheduler "
                         f"({type(exc).__name__}: {str(exc)[:200]})") from None


class DaskCluster:
    """Submits every task to the Dask scheduler at `address` and yields them as they finish.

    `running` is an estimate: the unfinished runs, at most the cluster's thread count."""

    def __init__(self, address: str):
        from dask.distributed import Client

        check_scheduler_address(address)
        _reach(address)  # before a Client exists: a Client that failed to connect lingers and complains on exit
        try:
            self.client = Client(address, timeout=CONNECT_TIMEOUT_S, set_as_default=False)
        except Exception as exc:  # it went away between the two
            raise ValueError(f"--scheduler {address}: cannot connect to a Dask scheduler "
                             f"({type(exc).__name__}: {str(exc)[:200]})") from None
        self.name = f"Dask scheduler {address}"
        self.address = address
        self.hidden: tuple = ()  # what the runs' optimizers may never read (the store: run_study sets it)

    def refuse_unconfined(self) -> None:
        """ValueError naming ``--unconfined`` when a worker of the cluster runs on a machine that
        cannot confine optimizers as a local study would (adapters.sandbox.confinement_missing),
        naming the worker and what it lacks; the client is closed then."""
        try:
            missing = self.client.run(confinement_missing_here)
        except Exception as exc:  # a worker that cannot even answer: its runs could not be trusted either
            self.client.close()
            raise ValueError(f"--scheduler {self.address}: cannot ask its workers how they confine optimizers "
                             f"({type(exc).__name__}: {str(exc)[:200]})") from None
        bad = {w: why for w, why in sorted(missing.items()) if why}
        if bad:
            self.client.close()
            worker, why = next(iter(bad.items()))
            raise ValueError(f"--unconfined: {len(bad)} worker(s) of the Dask cluster cannot confine the optimizers' "
                             f"workers ({worker}: {why}); pass --unconfined to run and rank them anyway (their records "
                             "and reports say so)")

    def run(self, tasks: list[Task], running: Callable[[int], None]) -> Iterator[tuple[Task, dict]]:
        from dask.distributed import as_completed

        futures = {}
        try:
            futures = {self.client.submit(dask_task, t, self.hidden, pure=False): t for t in tasks}
            slots = max(1, sum(self.client.nthreads().values()))
            left = len(futures)
            running(min(left, slots))
            for fut in as_completed(futures, loop=self.client.loop):  # our client is not the default
                task = futures[fut]
                try:
                    record = fut.result()
                except Exception as exc:  # the worker died (KilledWorker) or lost the task
                    record = lost_record(task, "failed", f"the Dask task failed: {type(exc).__name__}: {exc}", 0.0)
                left -= 1
                running(min(left, slots))
                yield task, record
        finally:
            self.client.cancel([f for f in futures if not f.done()])
            self.client.close()



def _run_task_main(argv: list[str]) -> int:
    """``python -m femu.studies.child --run-task TASK_FILE OUT STARTED``: one run (the task as
    JSON in the file TASK_FILE), its record to the file OUT; the file STARTED is created when
    the run starts."""
    task = Task(**json.loads(Path(argv[1]).read_text()))
    record = run_task(task, on_start=Path(argv[3]).touch)
    kill_descendants()  # processes the plugin started do not outlive its run
    Path(argv[2]).write_text(dumps(record, indent=None))
    return 0


if __name__ == "__main__":
    if len(sys.argv) == 5 and sys.argv[1] == "--run-task":
        sys.exit(_run_task_main(sys.argv[1:]))
    sys.exit("usage: python -m femu.studies.child --run-task TASK_FILE OUT STARTED (used on Dask workers)")
