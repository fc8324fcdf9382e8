"""The evaluating side of a sandboxed run: the problem stays here, the optimizer runs elsewhere.

`run_isolated` runs one optimizer in a worker process (adapters.sandbox_worker) forked for
this run from a worker server that never imported the FE package. The worker gets the bounds,
the budget, the seed, x0 when asked for and the options; its objective is a proxy that sends
points here. This process evaluates them through `harness.BudgetedObjective` (the one place
that counts, refuses what exceeds the budget, keeps the best point and times the run) and
decides the run's status from what it saw:

- ``ok``: it stopped the run because the budget was spent (the worker is ended at once);
- ``timeout``: it stopped the run at its time limit, at the next request after the limit or,
  when none comes, at the hard deadline `worker_deadline_s` (the worker is killed; the
  evaluations done so far are kept);
- ``stopped``: the optimizer's minimize returned before the budget was spent;
- ``failed``: it raised (the error is the worker's text), or its process ended without a word,
  or it broke the protocol.

What comes from the worker is read as data only: points as raw float64 bytes, everything else
as JSON, never a pickle (unpickling runs code, and it would run here, beside the problem and its
counts), and no message longer than the budget's points (`MESSAGE_BYTES` for the others) is
read at all. What an optimizer raises, prints or patches stays in its worker, which is ended with every
process it started when its run ends (`_Worker.end`: all stopped first, then killed, so none is
started after the listing); its stdout and stderr are the record's ``output``.

The server: one per process that runs optimizers (started on first use, ended with that
process); a study's run processes use their study's (`use_server`).

A run's worker is forked before the run: after each run this process has the server fork the
next run's worker (`fork_spare`), which settles its output file, path and directory and then
waits; a study's run process (one run each) has its worker forked when it starts, while it
builds its problem. A spare has run no optimizer code, serves exactly one run and is ended with
it, so nothing of one run reaches another. What a run's times include: `wall_s` and `cpu_s`
start once its optimizer is loaded and ready (the evaluating process's CPU and the worker's
from then on, with its reaped children's and, at the end, those of its descendants still alive
then) and end with the run; the worker's fork and settling are in no run's times, nor
in an `adapters.run` call's but for a process's first run (a call spends ~0.3 ms asking for
the next run's spare; the server forks it meanwhile); its optimizer's loading and its end are
in the call's only.
"""

from __future__ import annotations

import atexit
import fcntl
import json
import os
import pickle
import re
import shutil
import signal
import stat
import subprocess
import sys
import tempfile
import threading
import time
from contextlib import contextmanager
from multiprocessing.connection import Client

import numpy as np
import psutil

from .budget import check_budget, check_seed, check_x0_mode, jacobian_cost
from .capabilities import CAPABILITIES
from .budgeted import RunResult, BudgetedObjective, BudgetExhausted, TimeLimitExceeded, _problem_count, record
from .processes import freeze, kill_frozen
from .registry import check_name
from .sandbox_worker import DONE, ERROR, EVAL, LSQ, STOP, VALUES

#: Seconds a worker server may take to start (a loaded machine, numpy and the optimizers' imports).
SERVER_START_S = 120.0
#: Seconds a worker may take to load its optimizer and say it is ready (its library's import).
READY_S = 120.0
#: Characters of a run's captured stdout and stderr kept in its record (the end is kept).
OUTPUT_CHARS = 20_000
#: Characters of the core claims file read (a line per run under way: far more than enough).
CLAIMS_CHARS = 65_536
#: Seconds a run waits for the core claims file's lock before it runs unpinned.
CLAIMS_LOCK_S = 1.0
#: The longest message read from a worker that is not a batch of points (its pid, a description,
#: an end of run with its traceback): a longer one is a protocol fault, refused before it is read.
MESSAGE_BYTES = 1 << 20


#: The deepest nesting of arrays and objects read in a worker's JSON message (its descriptions
#: are 3 deep): a deeper one is a protocol fault, refused before it is parsed (Python's parser
#: recurses, and a deep enough message raised RecursionError here).
MESSAGE_DEPTH = 32

# a JSON string (escapes included), matched without backtracking: its brackets are not nesting
_JSON_STRING = re.compile(rb'"[^"\\]*(?:\\.[^"\\]*)*"', re.S)


def json_depth(raw: bytes) -> int:
    """The deepest nesting of arrays and objects in the JSON text `raw` (its strings' brackets
    not counted), in linear time and memory, without parsing it."""
    bare = np.frombuffer(_JSON_STRING.sub(b'""', raw), dtype=np.uint8)
    step = (np.isin(bare, (ord("["), ord("{"))).astype(np.int64) - np.isin(bare, (ord("]"), ord("}"))))
    return int(np.cumsum(step).max(initial=0))


def loads_bounded(raw: bytes, depth: int = MESSAGE_DEPTH):
    """`raw` read as JSON if it nests at most `depth` deep, else ValueError ("protocol: ..."),
    as for a message that is not JSON: what a worker sends is never allowed to raise anything
    else here (no RecursionError, whatever its shape)."""
    if json_depth(raw) > depth:
        raise ValueError(f"protocol: the optimizer's process sent a message nested more than {depth} deep")
    try:
        return json.loads(raw)
    except (ValueError, RecursionError):  # not UTF-8 JSON (json's own error is a ValueError too)
        raise ValueError("protocol: the optimizer's process sent a message that is not JSON") from None


def _receive(conn, limit: int = MESSAGE_BYTES):
    """A worker's message, read as JSON: the worker is the plugin's process, so what comes from
    it is data only, never a pickle (unpickling runs code, here, beside the problem). ValueError
    ("protocol: ...") when it is not JSON, longer than `limit` bytes or nested deeper than
    `MESSAGE_DEPTH`; EOFError/OSError when the process is gone."""
    return loads_bounded(_receive_bytes(conn, limit))


def _receive_bytes(conn, limit: int) -> bytes:
    """A worker's message of at most `limit` bytes; ValueError ("protocol: ...") when it is
    longer (refused before it is read), EOFError/OSError when the process is gone."""
    try:
        return conn.recv_bytes(limit)
    except OSError as exc:
        if str(exc) == "bad message length":  # multiprocessing's words for a message over the limit
            raise ValueError(f"protocol: the optimizer's process sent a message longer than {limit} bytes") from None
        raise


def _pair(message) -> tuple[str, object]:
    """A worker's ``[kind, payload]`` message, or ValueError."""
    if not (isinstance(message, list) and len(message) == 2 and isinstance(message[0], str)):
        raise ValueError("protocol: the optimizer's process sent a message of the wrong shape")
    return message[0], message[1]



def worker_deadline_s(time_limit_s: float | None) -> float | None:
    """Seconds after a run's start at which a worker that has not asked for anything since the
    limit passed is killed (status ``timeout``): the limit plus 0.5 s + 5 %."""
    return None if time_limit_s is None else time_limit_s + 0.5 + 0.05 * time_limit_s


class WorkerServer:
    """A worker server process (adapters.sandbox_worker) with its Unix socket in a private
    temporary directory; `preload`: modules its workers find imported (the optimizers)."""

    def __init__(self, preload=()):
        self._dir = tempfile.mkdtemp(prefix="femu-sandbox-")
        # others may pass through to their own temporary directory (`sandbox_worker._confine`),
        # never list it nor connect to the socket (and the server takes this user's connections only)
        os.chmod(self._dir, 0o711)
        _undumpable()
        self.address = os.path.join(self._dir, "server")
        self.owner = os.getpid()
        # the mark fe_problem refuses to import under, inherited by every process a plugin starts
        env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path if p), FEMU_OPTIMIZER_PROCESS="1")
        self._log = open(os.path.join(self._dir, "server.log"), "w+")
        # its own session: a Ctrl-C in the terminal reaches the evaluating process, which ends the run
        self._proc = subprocess.Popen([sys.executable, "-m", "adapters.sandbox_worker", self.address, *preload],
                                      stdin=subprocess.PIPE, stdout=self._log, stderr=self._log, env=env,
                                      start_new_session=True)
        t0 = time.perf_counter()
        while not os.path.exists(self.address):
            if self._proc.poll() is not None or time.perf_counter() - t0 > SERVER_START_S:
                self._log.seek(0)
                why = self._log.read()[-2000:]
                self.close()
                raise RuntimeError(f"the optimizers' worker server did not start: {why}")
            time.sleep(0.005)

    def close(self) -> None:
        """End the server (its workers are ended by their runs)."""
        if self._proc.poll() is None:
            self._proc.stdin.close()
            try:
                self._proc.wait(5)
            except subprocess.TimeoutExpired:
                self._proc.kill()
                self._proc.wait()
        self._log.close()
        shutil.rmtree(self._dir, ignore_errors=True)


_server: WorkerServer | None = None
_address: str | None = None


#: Whether a run forks the worker of this process's next run when it ends (`fork_spare`): a
#: process that runs one run only (a study's run process, `use_server`) does not.
_spares_after_runs = True


def use_server(address: str | None) -> None:
    """Run this process's optimizers in workers of the server at `address` (a study's run
    processes use their study's server); None: a server of this process's own. A study's run
    process runs one run: its worker is forked now (`fork_spare`), while it builds its problem,
    and none after its run."""
    global _address, _spares_after_runs
    _address = address
    if address is not None:
        _spares_after_runs = False
        fork_spare()


def server_address(preload=()) -> str:
    """The address of the worker server this process uses, started on first use."""
    global _server
    if _address is not None:
        return _address
    if _server is None or _server.owner != os.getpid() or _server._proc.poll() is not None:
        _server = WorkerServer(preload)
        atexit.register(_server.close)
    return _server.address


class _Worker:
    """One worker of the server: connected, its pid known; ended with everything it started.

    `prepare`: a spare for this process's next run (`_fresh_worker`): the server forks it now
    and it settles the output file, path and directory at once, while this process goes on;
    its pid is read when the run takes it."""

    def __init__(self, preload=(), prepare: bool = False):
        self.address = server_address(preload)
        self.owner = os.getpid()
        self.conn = Client(self.address, family="AF_UNIX")
        try:  # the built-ins' modules its server imports before forking it (and keeps for later workers)
            self.conn.send_bytes(json.dumps({"preload": list(preloads_of(preload))}).encode())
        except OSError:  # a server that hung up: it sends no pid either (`pid`), said there
            pass
        self._pid: int | None = None
        self._pidfd: int | None = None  # opened as soon as the pid is read (`pid`)
        self._frozen: list | None = None  # the stopped descendants once `freeze` has run
        self.output_path = None
        self.place: dict | None = None  # what it was confined to at its prepare (`confinement_place`)
        self.confinement: dict | None = None  # what held, once read (`confinement_of`)
        try:
            fd, self.output_path = tempfile.mkstemp(prefix="femu-run-", suffix=".out")
            os.close(fd)
            if prepare:
                self.place = confinement_place()
                self.conn.send({"prepare": True, "output_path": self.output_path, "sys_path": list(sys.path),
                                "cwd": os.getcwd(), "confine": self.place})
            else:
                self.pid  # noqa: B018  (waits for the fork)
        except BaseException:  # nothing left behind: the connection, the output file, the pidfd
            self._release()
            raise

    @property
    def pid(self) -> int:
        """The worker's process id (sent by the worker once forked); RuntimeError when it sends
        none. Its pidfd is opened at once, so that the worker is signalled through it only,
        never a process that took its pid over after it died and was reaped."""
        if self._pid is None:
            if not self.conn.poll(SERVER_START_S):
                raise RuntimeError("the optimizers' worker server did not answer")
            try:
                pid = _receive(self.conn)
            except (EOFError, OSError, ValueError):
                raise RuntimeError("the optimizers' worker server sent no process id") from None
            if type(pid) is not int:
                raise RuntimeError("the optimizers' worker server sent no process id")
            try:
                self._pidfd = os.pidfd_open(pid)
            except AttributeError:  # no pidfd (not Linux): signalled by pid
                self._pidfd = None
            except OSError:  # gone already: `end` signals nothing
                self._pidfd = -1
            self._pid = pid
        return self._pid

    def cpu_s(self) -> float:
        """CPU seconds of the worker so far (its own and its reaped children's) and, once
        `freeze` has run, those of every descendant still alive then (a process in a session
        of its own that the worker never reaped)."""
        try:
            t = psutil.Process(self.pid).cpu_times()
            total = t.user + t.system + t.children_user + t.children_system
        except (psutil.Error, RuntimeError):
            return 0.0
        for p in self._frozen or ():
            try:
                t = p.cpu_times()
                total += t.user + t.system + t.children_user + t.children_system
            except psutil.Error:
                pass
        return total

    def freeze(self) -> None:
        """Stop the worker and every process it started (`processes.freeze`): the run is over,
        nothing of it may start another process; `cpu_s` then counts them all."""
        if self._frozen is None:
            try:
                pid = self.pid
            except (RuntimeError, ValueError, EOFError, OSError):
                self._frozen = []
                return
            self._frozen = [] if self._pidfd == -1 else freeze(pid, self._pidfd)

    def output(self) -> str:
        try:
            with open(self.output_path, errors="replace") as fh:
                text = fh.read()
        except OSError:
            return ""
        return text if len(text) <= OUTPUT_CHARS else "[...]\n" + text[-OUTPUT_CHARS:]

    def exit_code(self, wait_s: float = 2.0) -> int | None:
        """The worker's exit code once it has ended (its server records it), None if unknown."""
        path = f"{self.address}.exit.{self.pid}"
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < wait_s:
            try:
                with open(path) as fh:
                    return int(fh.read())
            except (OSError, ValueError):
                time.sleep(0.01)
        return None

    def end(self) -> None:
        """End the worker with every process it started, and return once they have exited (at
        most `processes.KILL_WAIT_S`): all are stopped first (`freeze`: the worker through its
        pidfd, then its descendants, listed until no new one appears), then sent SIGKILL; the
        worker's exit is awaited on its pidfd (no polling of the process table). Its server is
        told first that this end is no news (no exit code kept)."""
        try:
            pid = self.pid
        except (RuntimeError, ValueError, EOFError, OSError):  # never forked (its server is gone)
            pid = None
        if pid is not None:
            ended, exited = f"{self.address}.ended.{pid}", f"{self.address}.exit.{pid}"
            try:
                os.close(os.open(ended, os.O_WRONLY | os.O_CREAT | os.O_NOFOLLOW, 0o600))
            except OSError:
                pass
            if self._pidfd != -1:
                try:
                    self.freeze()
                finally:  # a Ctrl-C inside the stop (a spare dropped by the next run too) still kills it
                    kill_frozen(pid, self._pidfd, self._frozen or [])
            if os.path.exists(exited):  # it had ended before (its server kept the code): both go
                for path in (exited, ended):
                    try:
                        os.unlink(path)
                    except OSError:
                        pass
        self._release()

    def _release(self) -> None:
        """Close the connection and the pidfd, remove the output file."""
        self.conn.close()
        if self._pidfd is not None and self._pidfd >= 0:
            os.close(self._pidfd)
        self._pidfd = -1
        if self.output_path is not None:
            try:
                os.unlink(self.output_path)
            except OSError:
                pass


_spare: _Worker | None = None
_spare_lock = threading.Lock()


def fork_spare(preload=()) -> None:
    """Have the server fork the worker of this process's next run now, before that run's clock
    starts (`_fresh_worker`); one spare at a time, a previous one ended. When the server
    cannot be reached, nothing (the run forks its worker itself, and says why it cannot)."""
    global _spare
    try:
        worker = _Worker(preload, prepare=True)
    except (OSError, RuntimeError):
        return
    with _spare_lock:
        old, _spare = _spare, worker
    with _interrupt_after():  # as drop_spare
        _discard(old)


def drop_spare() -> None:
    """End this process's spare worker if it has one (`fork_spare`): for a process that ends
    without running its exit handlers (a study's run process) and whose run did not take it.
    A Ctrl-C that lands while it is ended is raised once it is (`_interrupt_after`), as at a
    run's end: never a spare left stopped, its connection open or its output file behind."""
    global _spare
    with _spare_lock:
        spare, _spare = _spare, None
    with _interrupt_after():
        _discard(spare)


def _discard(worker: _Worker | None) -> None:
    """End an unused spare of this process (one inherited through a fork is its parent's: left)."""
    if worker is not None and worker.owner == os.getpid():
        worker.end()


def _fresh_worker(preload=()) -> _Worker:
    """A worker for one run: the spare forked before the run (`fork_spare`) when it is this
    process's and of the server in use, else one forked now. Either is a fresh fork of the
    server that has run no optimizer code and serves this one run only."""
    global _spare
    address = server_address(preload)
    with _spare_lock:
        spare, _spare = _spare, None
    if spare is not None and spare.owner == os.getpid() and spare.address == address and \
            spare.place == confinement_place():  # confined as a run now would be
        try:
            spare.pid  # noqa: B018  (forked, and said so)
            if not spare.conn.poll(0):  # and quiet since: not ended by anyone (its end would read as EOF)
                return spare
        except (RuntimeError, ValueError, EOFError, OSError):
            pass
    _discard(spare)
    return _Worker(preload)


atexit.register(drop_spare)


def describe(name: str, n_vars, options: dict | None = None) -> dict:
    """Ask optimizer `name` in a worker (its code never runs in this process): ``{"min_budget":
    {n_var: evaluations}, "x0_refused": None or why it cannot be given x0}``; ValueError when
    it cannot be loaded."""
    check_name(name)
    worker = _Worker(_preload(name))
    try:
        worker.conn.send({"describe": True, "name": name, "n_vars": [int(n) for n in n_vars],
                          "options": dict(options or {}), "output_path": worker.output_path,
                          "sys_path": list(sys.path), "cwd": os.getcwd(), "confine": confinement_place()})
        confinement_of(worker, name)
        if not worker.conn.poll(READY_S):
            raise PluginFault(f"optimizer {name!r}: loading it took more than {READY_S:.0f} s")
        kind, answer = _pair(_receive(worker.conn))
    except (EOFError, OSError):
        raise PluginFault(f"optimizer {name!r}: its process ended while it was loaded") from None
    except PluginFault:
        raise
    except ValueError as exc:  # a protocol fault
        raise PluginFault(f"optimizer {name!r}: {exc}") from None
    finally:
        worker.end()
    if kind == "refused" and isinstance(answer, str):
        raise ValueError(answer)
    if kind != "described":
        raise PluginFault(f"optimizer {name!r}: protocol: its process sent a message of the wrong shape")
    return _facts(name, n_vars, answer)


def _facts(name: str, n_vars, answer) -> dict:
    """A worker's description in `optimizer_facts`' shape (JSON keys are text: the n_var keys
    become ints again), or ValueError when it is not that shape."""
    try:
        need = {int(n): answer["min_budget"][str(int(n))] for n in n_vars}
        refused = answer["x0_refused"]
        if not all(type(v) is int for v in need.values()) or not (refused is None or isinstance(refused, str)):
            raise TypeError
    except (KeyError, TypeError, ValueError):
        raise PluginFault(f"optimizer {name!r}: protocol: its process sent a description of the wrong shape") from None
    return {"min_budget": need, "x0_refused": refused}


def optimizer_facts(name: str, n_vars, options: dict | None = None) -> dict:
    """What a study checks before it runs optimizer `name`: ``{"min_budget": {n_var: need},
    "x0_refused": None or why it cannot be given x0}``. A built-in is asked here (the project's
    own code); any other optimizer in a worker (`describe`), so that no plugin code ever runs in
    a process that holds problems or writes the store. ValueError when it cannot be loaded."""
    from .registry import BUILTINS, get

    if name not in BUILTINS:
        return describe(name, n_vars, options)
    from .budget import min_budget
    from .budgeted import check_takes_x0

    cls = get(name)
    try:
        check_takes_x0(name, cls)
        refused = None
    except ValueError as exc:
        refused = str(exc)
    return {"min_budget": {int(n): min_budget(cls, int(n), **(options or {})) for n in n_vars}, "x0_refused": refused}


def preloads(names) -> list[str]:
    """The modules a worker server may import before it forks its workers, for optimizers
    `names`: those of the built-ins only. A plugin's module is never imported there: its
    import-time code would run in the server and so in every worker forked after it (it could
    patch what later runs of other optimizers see); it is imported in its own run's worker."""
    from .registry import BUILTINS, module_of

    return list(dict.fromkeys(module_of(n) for n in names if n in BUILTINS))


def preloads_of(modules) -> list[str]:
    """The built-ins' modules among `modules` (what a worker server may import)."""
    from .registry import BUILTINS

    builtin = {target.split(":")[0] for target in BUILTINS.values()}
    return [m for m in modules if m in builtin]


def _preload(name: str) -> list[str]:
    return preloads([name])


def run_isolated(name: str, problem, budget: int, seed: int, time_limit_s: float | None = None,
                 variant: str = "paper", x0: str = "none", **options) -> RunResult:
    """`harness.run` with the optimizer in a worker process (see the module doc); the record
    has ``verified`` True and the worker's stdout and stderr in ``output``. ValueError (before
    anything is evaluated) for an unknown name, a bad budget, seed or x0, a budget below the
    optimizer's minimum, or x0 given to an optimizer that takes none."""
    check_name(name)
    seed, budget, x0 = check_seed(seed), check_budget(budget), check_x0_mode(x0)
    n_var = int(problem.n_var)
    xl, xu = np.asarray(problem.xl, dtype=float), np.asarray(problem.xu, dtype=float)
    worker = _fresh_worker(_preload(name))
    counted0 = _problem_count(problem)
    status, error = None, None

    def spec(w: _Worker) -> dict:
        return {"name": name, "n_var": n_var, "xl": xl.tolist(), "xu": xu.tolist(), "budget": budget, "seed": seed,
                "options": dict(options), "time_limit_s": time_limit_s, "jacobian_cost": jacobian_cost(n_var),
                "output_path": w.output_path, "sys_path": list(sys.path), "cwd": os.getcwd(),
                "confine": w.place or confinement_place(),
                "x0": None if x0 == "none" else np.asarray(problem.x0, dtype=float).tolist()}

    try:
        # on one core from the start: the worker loads its optimizer while this thread waits,
        # instead of waiting for a wake-up on another core of a loaded machine
        with _one_core(worker.pid, claims_path()) as core:
            objective = _Lazy(lambda: BudgetedObjective(problem, budget, time_limit_s))
            try:
                try:
                    described = _load(worker, name, spec(worker))
                except _NeverGotItsRun:
                    # it died before it answered its run's spec (a process a plugin left running killed
                    # the spare between `_fresh_worker`'s look and the spec): nothing was evaluated; the
                    # run takes a worker forked now, once (an optimizer that ends its process as it is
                    # loaded does so again, and that is the run's error)
                    worker.end()
                    worker = _Worker(_preload(name))
                    _pin(worker.pid, core)
                    described = _load(worker, name, spec(worker))
            except PluginFault as exc:  # its own fault as it was loaded: its run fails, nothing evaluated
                described, fault = {}, str(exc)
            else:
                fault = None
            cpu0, worker_cpu0 = time.process_time(), worker.cpu_s()
            wall0 = time.perf_counter()
            # the cooperative clock (BudgetedObjective's) starts at the optimizer's first request, so
            # that the wake-ups of a loaded machine between two processes do not eat its time; the
            # hard deadline counts from now, its optimizer loaded
            if fault is None:
                status, error = _serve(worker, objective, problem, time_limit_s, budget)
            else:
                status, error = "failed", fault
            wall = time.perf_counter() - wall0
            worker.freeze()  # nothing of the run goes on; its live descendants' CPU is counted
            cpu = time.process_time() - cpu0 + max(worker.cpu_s() - worker_cpu0, 0.0)
        objective = objective.get()
    except KeyboardInterrupt:  # a real Ctrl-C (the worker ignores SIGINT): the study stops
        raise
    finally:
        with _interrupt_after():  # a Ctrl-C now would leave the worker stopped, never killed
            output = worker.output()
            worker.end()
    if _spares_after_runs:
        fork_spare(_preload(name))  # the next run's worker, forked while this process makes the record
    return record(name, problem, counted0, objective, seed, budget, options, x0, status, error, variant, wall, cpu,
                  verified=True, output=output, sandbox=worker.confinement or {}, **described)


@contextmanager
def _interrupt_after():
    """A Ctrl-C (SIGINT) that arrives in the block is raised as KeyboardInterrupt once the block
    is over, not inside it: for the end of a run's worker (`_Worker.end`: stopped, then killed),
    which an interrupt between the two would leave stopped for good. Outside the main thread,
    or where SIGINT is not Python's to handle, the block runs as it is."""
    if threading.current_thread() is not threading.main_thread() or \
            signal.getsignal(signal.SIGINT) is not signal.default_int_handler:
        yield
        return
    pressed = []
    signal.signal(signal.SIGINT, lambda signum, frame: pressed.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, signal.default_int_handler)
        if pressed:  # raised even when the block raised: a Ctrl-C is never lost
            raise KeyboardInterrupt


_hidden: list[str] = []


def hide_from_workers(paths) -> None:
    """Paths this process's workers may never read, whatever directory they are in (a study's
    store: femu.studies.study), from now on, instead of those set before (one study at a time
    in a process); added to `confine.HIDDEN_ENV`'s. An empty path is no path."""
    _hidden[:] = list(dict.fromkeys(os.path.realpath(p) for p in map(str, paths) if p.strip()))


def confinement_place() -> dict:
    """What a worker may read, write and never read (adapters.confine), as real paths: it reads
    the import path and this directory (where registry._import_here finds a plugin module), Python's installation and the system's
    directories; it writes its own temporary directory and those named in `confine.WRITABLE_ENV`;
    it never reads those in `confine.HIDDEN_ENV` (a study's store) nor the FE package (its data,
    the suite)."""
    from importlib.util import find_spec

    from .confine import HIDDEN_ENV, SYSTEM_DIRS, WRITABLE_ENV

    def real(paths):
        return list(dict.fromkeys(os.path.realpath(p or os.getcwd()) for p in paths))

    fe = find_spec("fe_problem")
    hidden = [p for p in os.environ.get(HIDDEN_ENV, "").split(os.pathsep) if p] + _hidden
    hidden += list(fe.submodule_search_locations or []) if fe is not None else []
    return {"readable": real([*sys.path, os.getcwd(), sys.prefix, sys.base_prefix, sys.exec_prefix, os.path.dirname(sys.executable),
                              *SYSTEM_DIRS]),
            "writable": real(p for p in os.environ.get(WRITABLE_ENV, "").split(os.pathsep) if p),
            "hidden": real(hidden)}


#: What `RunResult.sandbox` says of a run, each True when it held: ``filesystem`` (Landlock:
#: reads and writes as `confinement_place` says), ``signals`` (no signal to another run's worker,
#: its server or this process: its own uid, or Landlock's signal scope), ``own_uid`` (checked here),
#: ``limits`` (resource limits), ``session`` (its own session and process group, checked here),
#: ``undumpable`` (this process: no ptrace, no /proc/PID/mem), ``peer_checked`` (the server took
#: its connection from this process only, SO_PEERCRED), ``network`` (no TCP connect or bind:
#: Landlock ABI 4; not required); ``landlock_abi`` the kernel's (0: none).
CONFINEMENT = ("filesystem", "signals", "own_uid", "limits", "session", "undumpable", "peer_checked", "network")
#: What a run must have held to count as confined (`is_confined`); ``own_uid`` is one way to
#: ``signals``, not required where Landlock scopes signals.
REQUIRED = ("filesystem", "signals", "limits", "session", "undumpable", "peer_checked")


def confinement_missing() -> str | None:
    """What this machine cannot give a worker of `REQUIRED` (adapters.confine), in words, or None
    when it can give all: Landlock for the filesystem, and for signals a uid of its own (root)
    or Landlock's signal scope (ABI 6)."""
    from .confine import LANDLOCK_ENV, landlock_abi

    abi = landlock_abi()
    missing = []
    if abi == 0:
        missing.append(f"no Landlock (kernel without it, or {LANDLOCK_ENV}=off): no filesystem confinement")
    if not (os.geteuid() == 0 or abi >= 6):
        missing.append("not root and no Landlock signal scope (ABI 6): a worker may signal other runs' workers")
    return "; ".join(missing) or None


def is_confined(confinement: dict) -> bool:
    """Whether a record's `sandbox` (its `confinement`) says every `REQUIRED` mechanism held."""
    return all(confinement.get(k) is True for k in REQUIRED)


def confinement_of(worker: _Worker, name: str) -> dict:
    """Read the worker's word on its confinement (sent before any optimizer code ran in it) and
    check here what can be checked from outside (its uid, its session, this process not
    dumpable); kept on `worker.confinement`. EOFError/OSError when its process is gone."""
    if worker.confinement is not None:
        return worker.confinement
    pid = worker.pid
    if not worker.conn.poll(SERVER_START_S):
        raise PluginFault(f"optimizer {name!r}: its process did not say how it was confined")
    try:
        kind, held = _pair(_receive(worker.conn))
    except ValueError as exc:
        raise PluginFault(f"optimizer {name!r}: {exc}") from None
    if kind != "confined" or not isinstance(held, dict):
        raise PluginFault(f"optimizer {name!r}: protocol: its process did not say how it was confined")
    try:
        proc = psutil.Process(pid)
        own_uid = held.get("own_uid") is True and proc.uids().real != os.getuid() and proc.uids().effective != 0
        session = os.getsid(pid) == pid
    except (psutil.Error, OSError):
        own_uid = session = False
    abi = held.get("landlock_abi")
    worker.confinement = {
        "filesystem": held.get("filesystem") is True, "own_uid": own_uid,
        "signals": own_uid or held.get("signal_scope") is True, "limits": held.get("limits") is True,
        "session": session, "undumpable": _undumpable(), "peer_checked": True, "network": held.get("network") is True,
        "landlock_abi": abi if type(abi) is int else 0}
    return worker.confinement


_undumpable_held: bool | None = None


def _undumpable() -> bool:
    """Make this process (the evaluating side) not dumpable, once (adapters.confine)."""
    global _undumpable_held
    if _undumpable_held is None:
        from .confine import make_undumpable

        _undumpable_held = make_undumpable()
    return _undumpable_held


class PluginFault(ValueError):
    """An optimizer's process that broke the protocol, or ended or hung while it was loaded or
    described: the plugin's own fault, never its caller's. Its runs fail with this error, named
    (`run_isolated` returns a failed record, nothing evaluated), and a study goes on with the
    others (femu.studies.study.check_budget_for)."""


class _NeverGotItsRun(PluginFault):
    """A worker that ended before it answered its run's spec (`_load`): nothing was evaluated.
    (A worker killed as it waits may still take the spec: its process shows as ended while a
    thread of it has not yet closed its connection.)"""


def _load(worker: _Worker, name: str, spec: dict) -> dict:
    """Send the run's `spec` to `worker` and wait until its optimizer is loaded and ready; the
    run-record fields it describes (`_description`), or ValueError saying why it cannot run."""
    try:
        worker.conn.send(spec)
    except OSError:
        raise _NeverGotItsRun(f"optimizer {name!r}: its process ended before it was loaded") from None
    try:
        confinement_of(worker, name)
    except (EOFError, OSError):
        raise _NeverGotItsRun(f"optimizer {name!r}: its process ended before it was loaded") from None
    if not worker.conn.poll(READY_S):
        raise PluginFault(f"optimizer {name!r}: loading it took more than {READY_S:.0f} s")
    try:
        kind, why = _pair(_receive(worker.conn))
    except (EOFError, OSError):
        raise _NeverGotItsRun(f"optimizer {name!r}: its process ended while it was loaded: "
                              f"{worker.output()[-500:]}") from None
    except ValueError as exc:  # a protocol fault (not JSON, too long, too deep, wrong shape)
        raise PluginFault(f"optimizer {name!r}: {exc}") from None
    if kind == "ready":
        return _description(why)
    if kind != "refused" or not isinstance(why, str):
        raise PluginFault(f"optimizer {name!r}: protocol: its process sent a message of the wrong shape")
    raise ValueError(why[:MESSAGE_BYTES])


def _description(answer) -> dict:
    """The run-record fields the worker reports on what ran (capabilities.run_description),
    kept only in their documented shape: the worker is the plugin's process, and its word is
    information for the report, never a count or a status."""
    if not isinstance(answer, dict):
        return {}
    text = lambda v: v if isinstance(v, str) and len(v) <= 200 else None  # noqa: E731
    flags = answer.get("capabilities")
    options = answer.get("effective_options")
    return {"distribution": text(answer.get("distribution")),
            "distribution_version": text(answer.get("distribution_version")),
            "effective_options": options if isinstance(options, dict) else {},
            "capabilities": {k: v for k, v in flags.items() if k in CAPABILITIES and isinstance(v, bool)}
            if isinstance(flags, dict) else {}}


class _Lazy:
    """The run's BudgetedObjective, made on first use."""

    def __init__(self, make):
        self._make, self._value = make, None

    def get(self) -> BudgetedObjective:
        if self._value is None:
            self._value = self._make()
        return self._value


#: The environment variable that names the core claims file instead of `claims_path`'s default.
CLAIMS_ENV = "FEMU_CORE_CLAIMS"


def claims_path() -> str:
    """The file in which sandboxed runs claim their cores (`claim_core`): one per user and
    machine (in the temporary directory), shared by every process that runs optimizers,
    whichever worker server it uses (a study's run processes, each Dask worker process's own
    server, two studies at once), so that all of them spread over the cores; the environment
    variable FEMU_CORE_CLAIMS names another (a test's own)."""
    return os.environ.get(CLAIMS_ENV) or os.path.join(tempfile.gettempdir(), f"femu-cores-{os.getuid()}")


@contextmanager
def _one_core(worker_pid: int, claims: str | None = None):
    """This thread and the worker on one core for the run, this thread's cores put back after.

    The two take turns (a request, its values, the next request): on one core each hands the
    core straight to the other, while on two cores every turn is a wake-up across cores (a
    ping-pong of two processes on this 2-core machine: 51-79 against 98-425 microseconds a
    round trip at load 9). The core is the least claimed one in the file `claims` (the runs of
    this user on this machine, `claims_path`), so that the runs of a parallel study are spread
    over the cores instead of all pinned to the one they started on; without `claims`, the
    core this thread is on. (Affinity is a thread's: claims are by thread id.) Yields the core,
    or None when the run is not pinned (then this thread's cores are left as they were)."""
    before = None
    try:
        before = os.sched_getaffinity(0)
        core = claim_core(before, claims)
        os.sched_setaffinity(0, {core})
        os.sched_setaffinity(worker_pid, {core})
    except (AttributeError, OSError, psutil.Error):  # not Linux, or the worker is gone: run as it is
        if before is not None:
            try:
                os.sched_setaffinity(0, before)  # never left on one core by a run that is not pinned
            except OSError:
                pass
        _release_core(claims)
        yield None
        return
    try:
        yield core
    finally:
        os.sched_setaffinity(0, before)
        _release_core(claims)


def _pin(pid: int, core: int | None) -> None:
    """Put process `pid` on `core` (`_one_core`'s; None: not pinned, nothing); a process gone: nothing."""
    if core is not None:
        try:
            os.sched_setaffinity(pid, {core})
        except OSError:
            pass


def claim_core(allowed, claims: str | None = None, tid: int | None = None) -> int:
    """The core for the sandboxed run of thread `tid` (default: this thread) among `allowed`:
    the one the fewest live threads have claimed in the file `claims` (a line "tid core" each;
    lines of threads that have ended are dropped), ties to the core it is on now; the claim is
    added to the file under an exclusive lock. Without `claims`, the core it is on now."""
    allowed = sorted(allowed)
    pid = threading.get_native_id() if tid is None else int(tid)
    here = psutil.Process(threading.get_native_id()).cpu_num()  # the calling thread's
    here = here if here in allowed else allowed[0]
    if claims is None or len(allowed) == 1:
        return here
    with _claims(claims) as taken:
        count = {c: 0 for c in allowed}
        for c in taken.values():
            if c in count:
                count[c] += 1
        core = min(allowed, key=lambda c: (count[c], c != here))
        taken[pid] = core
    return core


def _release_core(claims: str | None, tid: int | None = None) -> None:
    """Drop the claim of thread `tid` (default: this thread) from the file `claims`."""
    if claims is None:
        return
    try:
        with _claims(claims) as taken:
            taken.pop(threading.get_native_id() if tid is None else int(tid), None)
    except OSError:
        pass


def _alive(tid: int) -> bool:
    """Whether thread (or process) id `tid` is in use (psutil.pid_exists says False for threads)."""
    try:
        os.kill(tid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, ValueError):
        return tid > 0
    return True


@contextmanager
def _claims(path: str):
    """The claims in the file `path` as {tid: core} of live threads, locked; written back after."""
    # in the temporary directory, which a plugin's process (and another user) could also write:
    # a symlink, a FIFO, another user's file, a huge file or a lock held there costs the run its
    # pinning (OSError), never a wait
    fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_NOFOLLOW | os.O_NONBLOCK, 0o600)
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode) or st.st_uid != os.getuid():
        os.close(fd)
        raise OSError(f"{path}: not a regular file of this user")
    with os.fdopen(fd, "r+") as fh:
        t0 = time.perf_counter()
        while True:
            try:
                fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
                break
            except BlockingIOError:
                if time.perf_counter() - t0 > CLAIMS_LOCK_S:
                    raise
                time.sleep(0.002)
        taken = {}
        for line in fh.read(CLAIMS_CHARS).split("\n"):
            try:
                pid, core = (int(v) for v in line.split())
            except ValueError:
                continue
            if _alive(pid):
                taken[pid] = core
        yield taken
        fh.seek(0)
        # written, then cut at its end: a file cut to nothing and written again is flushed to
        # disk when closed (ext4's auto_da_alloc), 0.5-3 ms of every run's end
        fh.write("".join(f"{pid} {core}\n" for pid, core in taken.items()))
        fh.truncate()


def _serve(worker: _Worker, lazy: _Lazy, problem, time_limit_s, budget: int) -> tuple[str, str | None]:
    """Answer the worker's requests until the run ends; the run's (status, error)."""
    conn, n_var = worker.conn, int(problem.n_var)
    # no request is longer than the whole budget's points (a longer one is refused unread, so a
    # plugin cannot make this process allocate what it likes)
    limit = MESSAGE_BYTES + 8 * n_var * int(budget)
    deadline = worker_deadline_s(time_limit_s)
    t0 = time.perf_counter()
    while True:
        if deadline is not None and not conn.poll(max(0.0, t0 + deadline - time.perf_counter())):
            return "timeout", (f"stopped after {time.perf_counter() - t0:.1f} s: the optimizer passed its time limit "
                               f"of {time_limit_s} s without asking for an evaluation; the evaluations done until "
                               f"then are kept")
        try:
            message = _receive_bytes(conn, limit)
        except ValueError as exc:
            return "failed", str(exc)
        except (EOFError, OSError):
            code = worker.exit_code()
            how = "exited" if code is None else f"exited with code {code}"
            return "failed", (f"the optimizer's process {how} without finishing its run; the evaluations done "
                              f"until then are kept")
        tag, body = message[:1], message[1:]
        objective = lazy.get()
        try:
            if tag == EVAL:
                if len(body) % (8 * n_var):
                    return "failed", "protocol: the optimizer's process sent points of a wrong size"
                X = np.frombuffer(body, dtype=float).reshape(-1, n_var)
                f = objective(X)
                conn.send_bytes(VALUES + objective.n_evals.to_bytes(8, "little") + np.asarray(f, float).tobytes())
            elif tag == LSQ and len(body) == 1 + 8 * n_var:
                x = np.frombuffer(body[1:], dtype=float)
                out = objective.least_squares(x, jacobian=bool(body[0]))
                conn.send_bytes(VALUES + pickle.dumps((objective.n_evals, out.f, out.residuals, out.jacobian)))
            elif tag == DONE:
                try:  # JSON, never a pickle: unpickling would run the plugin's code here
                    kind, text = _pair(loads_bounded(body))
                except ValueError as exc:
                    return "failed", f"{exc} (its end of run)"
                if kind == "returned":
                    return ("ok" if objective.n_evals >= objective.budget else "stopped"), None
                return "failed", str(text)
            else:
                return "failed", "protocol: the optimizer's process sent an unknown request"
        except BudgetExhausted:  # the budget is spent: nothing the optimizer does after this counts
            return "ok", None
        except TimeLimitExceeded as exc:
            return "timeout", str(exc)
        except (ValueError, FloatingPointError, TypeError) as exc:  # bad points, NaN values: the plugin's to handle
            try:
                conn.send_bytes(ERROR + pickle.dumps((type(exc).__name__, str(exc))))
            except OSError:
                pass
