"""The optimizer's side of a sandboxed run: the worker server and the objective proxy.

``python -m adapters.sandbox_worker SOCKET [MODULE ...]`` (started by `adapters.sandbox`) makes
imports of the FE package and the application (``fe_problem``, ``femu``) fail, imports numpy,
the plugin layer and the MODULEs named (the optimizers a study will run), then listens on the
Unix socket SOCKET. Every connection is one run: the server forks a worker for it, which

1. sends its pid, receives the run's spec (optimizer name, bounds, budget, seed, x0, options,
   the file that takes its stdout and stderr),
2. loads the optimizer, checks its minimum budget and x0 (its own code runs only here), says
   ``ready`` or why not,
3. calls ``minimize`` with an `ObjectiveProxy`: each call sends the points to the evaluating
   process and waits for their values; the evaluating process alone counts them, holds the
   budget, the best point, the clock and decides the run's status,
4. says how minimize ended, and waits to be ended (with every process it started) by the
   evaluating process.

The worker never holds the problem, its data, the FE model or a suite instance's truth: they
are not in this process (the server never imported them) and importing their packages fails.
The server ends when its owner closes its stdin. Nothing a worker starts outlives it: the
worker is the child subreaper of its descendants and the evaluating process stops and kills the
whole tree (adapters.sandbox); a worker whose evaluating process is gone, or whose run raised
out of it, ends its tree itself (`_end_this_worker`); what a worker that died on its own left
running is adopted by the server and ended when the worker is reaped (`_end_adopted`).
"""

from __future__ import annotations

import os

import importlib
import importlib.abc
import importlib.metadata
import json
import math
import pickle
import shutil
import signal
import socket
import struct
import sys
import threading
import time
import traceback
from collections import namedtuple

from . import _threads  # noqa: F401  (one BLAS thread per worker: before numpy loads)
from .processes import freeze

#: Packages an optimizer's process may not import: the FE model, its data, the suite (with its
#: hidden truths) and the application.
BLOCKED_PACKAGES = ("fe_problem", "femu")

#: Message tags (first byte) from the worker: points to evaluate, a least-squares request, the end.
EVAL, LSQ, DONE = b"E", b"L", b"D"
#: Tags of the evaluating side's answers: values, a stop (budget or time), an error to raise.
VALUES, STOP, ERROR = b"F", b"S", b"X"


def send_json(conn, obj, tag: bytes = b"") -> None:
    """Send `obj` to the evaluating process as JSON: what this process sends there is data only,
    never a pickle (unpickling runs code, and this process is the plugin's)."""
    conn.send_bytes(tag + json.dumps(obj).encode())

#: What `ObjectiveProxy.least_squares` returns (as the problem's LeastSquares).
LeastSquares = namedtuple("LeastSquares", "f residuals jacobian")


class _Refused(importlib.abc.MetaPathFinder):
    """Import hook of the optimizer's process: the FE package and the application are refused."""

    def find_spec(self, name, path=None, target=None):
        if name.partition(".")[0] in BLOCKED_PACKAGES:
            raise ImportError(f"{name}: not available in the optimizer's process (the FE model, its data and the "
                              f"suite stay with the evaluating process; an optimizer sees only its objective)",
                              name=name)
        return None


class ObjectiveProxy:
    """The objective an optimizer gets in its worker: ``objective(X) -> f`` for a batch (n,
    n_var) or one point, ``least_squares(x, jacobian=True)``, and read-only copies of what the
    evaluating side has charged (`n_evals`, `remaining`). Nothing it holds can change the count:
    the count, the budget, the best point and the clock are the evaluating process's.

    `best_f`, `best_x` and `trace` are the worker's own view of the values it received (a
    convenience for an optimizer; the run record is the evaluating side's)."""

    def __init__(self, conn, spec: dict):
        import numpy as np

        self._np = np
        self._conn = conn
        self._lock = threading.Lock()  # one request at a time, also from a plugin's threads
        self._n_var = int(spec["n_var"])
        self._budget = int(spec["budget"])
        self._jacobian_cost = int(spec["jacobian_cost"])
        self._time_limit_s = spec["time_limit_s"]
        self._xl = np.array(spec["xl"], dtype=float)
        self._xu = np.array(spec["xu"], dtype=float)
        self._n_evals = 0
        self._best_f, self._best_x, self._trace = float("inf"), None, []
        self._stopped: BaseException | None = None

    n_var = property(lambda self: self._n_var, doc="The number of parameters.")
    budget = property(lambda self: self._budget, doc="The run's budget (FE evaluations).")
    n_evals = property(lambda self: self._n_evals, doc="Evaluations the evaluating side has charged so far.")
    remaining = property(lambda self: self._budget - self._n_evals, doc="Evaluations left in the budget.")
    jacobian_cost = property(lambda self: self._jacobian_cost,
                             doc="FE evaluations charged for a least_squares call with the Jacobian (n_var + 1).")
    time_limit_s = property(lambda self: self._time_limit_s, doc="The run's time limit in seconds, or None.")
    bounds = property(lambda self: (self._xl.copy(), self._xu.copy()), doc="(xl, xu), copies.")
    best_f = property(lambda self: self._best_f, doc="Best value received (inf before the first).")
    best_x = property(lambda self: None if self._best_x is None else self._best_x.copy(),
                      doc="The point of best_f (a copy), or None.")
    trace = property(lambda self: [list(t) for t in self._trace], doc="Best-so-far [[n_evals, f], ...] received.")

    #: Names a plugin may read but not assign (as on harness.BudgetedObjective): a plugin that
    #: tries is told at once instead of changing only its own copy.
    READ_ONLY = ("problem", "n_evals", "budget", "remaining", "best_f", "best_x", "trace", "fe_s", "fe_cpu_s",
                 "n_jacobians", "jacobian_cost", "time_limit_s", "n_var", "bounds")

    def __setattr__(self, name, value):
        if name in self.READ_ONLY:
            raise AttributeError(f"the objective's {name!r} is read-only: the evaluating process owns the budget "
                                 "and its counts")
        super().__setattr__(name, value)

    def _request(self, message: bytes) -> bytes:
        """The evaluating side's answer to `message`: its VALUES answer (tag included)."""
        sys.stdout.flush()  # what it printed so far is in its record, even if ended now
        sys.stderr.flush()
        with self._lock:
            if self._stopped is not None:  # the run is over: nothing more is evaluated
                raise self._stopped
            self._conn.send_bytes(message)
            answer = self._conn.recv_bytes()
        tag = answer[:1]
        if tag == VALUES:
            return answer
        body = answer[1:]
        if tag == STOP:
            from .budgeted import BudgetExhausted, TimeLimitExceeded

            kind, text = pickle.loads(body)
            exc = BudgetExhausted() if kind == "budget" else TimeLimitExceeded(text)
            self._stopped = exc
            raise exc
        if tag == ERROR:
            kind, text = pickle.loads(body)
            raise {"ValueError": ValueError, "FloatingPointError": FloatingPointError}.get(kind, TypeError)(text)
        return answer

    def _received(self, X, f) -> None:
        start = self._n_evals
        if len(f) == 1:  # one point per call (most calls of such optimizers): no array work
            v = float(f[0])
            if v < self._best_f:  # False for NaN, as fmin.accumulate below
                self._trace.append([start + 1, v])
                self._best_f, self._best_x = v, X[0].copy()
            return
        np = self._np
        running = np.fmin.accumulate(np.concatenate(([self._best_f], f)))
        new = np.flatnonzero(running[1:] < running[:-1])
        self._trace.extend([start + int(i) + 1, float(f[i])] for i in new)
        if len(new):
            self._best_f, self._best_x = float(f[new[-1]]), X[new[-1]].copy()

    def __call__(self, X):
        np = self._np
        X = np.asarray(X, dtype=float)
        if X.ndim != 2:
            X = np.atleast_2d(X)
        if X.ndim != 2 or X.shape[1] != self._n_var:
            raise ValueError(f"the points must have shape (n, {self._n_var}), got {X.shape}")
        answer = self._request(EVAL + X.tobytes())  # tobytes: C order whatever X's layout
        n_evals = int.from_bytes(answer[1:9], "little")
        f = np.frombuffer(answer, dtype=float, offset=9).copy()
        self._received(X[: len(f)], f)
        self._n_evals = n_evals
        return f

    def least_squares(self, x, jacobian: bool = True):
        """Objective, weighted frequency residuals and (with `jacobian`) their Jacobian at one
        point, charged by the evaluating side as `adapters.harness.BudgetedObjective.least_squares`."""
        np = self._np
        X = np.atleast_2d(np.asarray(x, dtype=float))
        if X.shape != (1, self._n_var):
            raise ValueError(f"least_squares takes one point of {self._n_var} parameters, got shape {X.shape}")
        answer = self._request(LSQ + bytes([bool(jacobian)]) + X.tobytes())
        n_evals, f, residuals, jac = pickle.loads(answer[1:])
        self._received(X, np.array([f]))
        self._n_evals = n_evals
        return LeastSquares(f, residuals, jac)


def _start(conn, spec: dict):
    """The optimizer instance and minimize's keywords, or a ValueError saying why it cannot run."""
    import numpy as np

    from .budget import check_min_budget
    from .capabilities import check_options
    from .budgeted import check_takes_x0
    from .registry import get

    cls = get(spec["name"])
    check_options(spec["name"], cls, spec["options"])  # a misspelt option: refused before the run, as the CLI does
    optimizer = cls()
    check_min_budget(spec["name"], optimizer, spec["budget"], spec["n_var"], **spec["options"])
    start = {}
    if spec["x0"] is not None:
        check_takes_x0(spec["name"], optimizer)
        start = {"x0": np.array(spec["x0"], dtype=float)}
    return optimizer, start


def _describe(spec: dict) -> dict:
    """What the evaluating side asks before any run: the minimum budget of optimizer `name` on
    each n_var with its options, and whether it takes x0."""
    from .budget import min_budget
    from .capabilities import check_options
    from .budgeted import check_takes_x0
    from .registry import get

    cls = get(spec["name"])
    check_options(spec["name"], cls, spec["options"])  # a misspelt option: refused before any run
    need = {n: min_budget(cls, n, **spec["options"]) for n in spec["n_vars"]}
    try:
        check_takes_x0(spec["name"], cls)
        takes_x0 = None
    except ValueError as exc:
        takes_x0 = str(exc)
    return {"min_budget": need, "x0_refused": takes_x0}


def _capture_output(path: str) -> None:
    """Send this process's stdout and stderr (and those of every process it starts) to `path`."""
    fd = os.open(path, os.O_WRONLY | os.O_APPEND)
    os.dup2(fd, 1)
    os.dup2(fd, 2)
    os.close(fd)
    for stream in (sys.stdout, sys.stderr):
        stream.reconfigure(line_buffering=True)


def _settle(spec: dict) -> None:
    """Take the evaluating process's output file, import path and directory from `spec` (the
    server's are those of its start), and look up one distribution, so that the run's own
    lookups (capabilities.distribution_of) find importlib.metadata's caches filled."""
    _capture_output(spec["output_path"])
    sys.path[:] = [p for p in spec.get("sys_path", sys.path)]
    importlib.invalidate_caches()
    try:
        os.chdir(spec.get("cwd", os.getcwd()))
    except OSError:
        pass
    try:
        importlib.metadata.version("femu-bench")
    except Exception:  # not installed (run from a checkout): the caches are filled all the same
        pass


def _confine(conn, spec: dict) -> None:
    """Confine this worker (adapters.confine) as the evaluating side asks in `spec`, before any
    optimizer code is imported, tell it what held (``["confined", {...}]``), then watch that
    process (`_watch_evaluator`): every thread of this process is started after the
    confinement, which holds for the thread that makes it and those it starts only."""
    from .confine import confine

    place = spec.get("confine") or {}
    tmp_dir = f"{_address}.run.{os.getpid()}"
    try:
        os.mkdir(tmp_dir, 0o700)
    except OSError:
        tmp_dir = None
    try:
        held = confine(list(place.get("readable", [])), list(place.get("writable", [])),
                       list(place.get("hidden", [])), tmp_dir)
    except OSError as exc:  # a mechanism that failed half-way: none is claimed
        held = {"error": f"{type(exc).__name__}: {exc}"}
    send_json(conn, ["confined", held])
    threading.Thread(target=_watch_evaluator, args=(_evaluator_pidfd,), daemon=True).start()


def _same_place(a: dict, b: dict) -> bool:
    return all(a.get(k) == b.get(k) for k in ("output_path", "sys_path", "cwd", "confine"))


def worker(conn) -> None:
    """One run (see the module doc), on the connection `conn` to the evaluating process.

    A spare worker (forked before its run, adapters.sandbox) first gets a ``prepare`` message
    with the output file, path and directory, settles them, then waits for its one run's spec;
    a spec with the same three is not settled again, but for the import system's directory
    listings, renewed so that a module written since is found. Either way the process serves
    one run and is ended with it: nothing of a run outlives it."""
    send_json(conn, os.getpid())
    spec = conn.recv()
    prepared = None
    if spec.get("prepare"):
        _settle(spec)
        _confine(conn, spec)
        prepared, spec = spec, conn.recv()
    if prepared is not None and _same_place(prepared, spec):
        for finder in list(sys.path_importer_cache.values()):  # a file written since the prepare
            if finder is not None and hasattr(finder, "invalidate_caches"):
                finder.invalidate_caches()
    else:
        _settle(spec)
        if prepared is None:
            _confine(conn, spec)
    if spec.get("time_limit_s") is not None:  # its CPU bounded too, once its limit is known
        from .confine import limit_cpu

        limit_cpu(math.ceil(2 * float(spec["time_limit_s"]) + 60))
    if spec.get("describe"):
        try:
            send_json(conn, ["described", _describe(spec)])
        except BaseException as exc:
            send_json(conn, ["refused", str(exc) if isinstance(exc, ValueError) else f"{type(exc).__name__}: {exc}"])
        conn.recv()  # ended by the evaluating process
        return
    try:
        optimizer, start = _start(conn, spec)
        from .capabilities import run_description

        described = run_description(type(optimizer), spec["options"])  # a bad capability flag: refused
    except BaseException as exc:
        message = str(exc) if isinstance(exc, ValueError) else f"{type(exc).__name__}: {exc}"
        send_json(conn, ["refused", message])
        conn.recv()
        return
    import numpy as np

    proxy = ObjectiveProxy(conn, spec)
    send_json(conn, ["ready", described])
    try:
        optimizer.minimize(proxy, proxy.bounds, proxy.budget, np.random.default_rng(spec["seed"]), **start,
                           **spec["options"])
        outcome = ("returned", None)
    except SystemExit as exc:
        outcome = ("raised", f"SystemExit: the optimizer called sys.exit({exc.code!r})")
    except KeyboardInterrupt:  # Ctrl-C goes to the evaluating process only: this one is the plugin's
        outcome = ("raised", "KeyboardInterrupt: raised by the optimizer (no Ctrl-C was pressed)")
    except BaseException as exc:
        outcome = ("raised", f"{type(exc).__name__}: {exc}\n{traceback.format_exc(limit=6)}")
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except Exception:
            pass
    send_json(conn, list(outcome), DONE)
    conn.recv()  # the evaluating process ends this process and every one it started


#: The evaluating process of this worker, as a pidfd opened when the worker is forked (None: no
#: pidfd on this system; then its pid, `_evaluator_pid`).
_evaluator_pidfd: int | None = None
_evaluator_pid: int | None = None
#: The worker server's socket address (its workers' temporary directories are beside it).
_address = ""


def _watch_evaluator(pidfd: int | None) -> None:
    """End this worker and every process it started once its evaluating process is gone
    (killed at a hard deadline, or its study stopped): a worker without its evaluating side has
    nothing left to do (`_end_this_worker`). Watched on its pidfd (readable once it has exited,
    whichever uid this worker has now), else by its pid."""
    if pidfd is not None:
        import select

        select.select([pidfd], [], [])
        _end_this_worker()
    while True:
        time.sleep(0.25)
        try:
            os.kill(_evaluator_pid, 0)
        except ProcessLookupError:
            _end_this_worker()
        except PermissionError:  # the pid was taken by another user's process: ours is gone
            if os.getuid() < 1_000_000_000:  # (a worker of its own uid may signal no one: alive)
                _end_this_worker()


def _end_this_worker() -> None:
    """Stop this worker and its descendants, then SIGKILL them all (processes.freeze), from a
    forked helper (a process cannot stop itself and go on listing): a child in a session of
    its own is ended too, which killing the process group would miss; then, whatever happened
    to the helper, this worker's process group."""
    me = os.getpid()
    try:
        helper = os.fork()
    except OSError:
        helper = None
    if helper == 0:
        try:
            procs = freeze(me, exclude={os.getpid()})
            for p in procs:
                try:
                    p.kill()
                except Exception:
                    pass
        finally:
            os.kill(me, signal.SIGKILL)
            os._exit(0)
    if helper is not None:
        try:
            os.waitpid(helper, 0)
        except ChildProcessError:
            pass
    os.killpg(0, signal.SIGKILL)


#: The server's workers not yet reaped (their pids), and the lock a fork and a reap take.
_workers: set[int] = set()
_workers_lock = threading.Lock()


def _reap(address: str) -> None:
    """Reap the server's workers, leaving each one's exit code in ADDRESS.exit.PID for its
    evaluating process (a worker that dies says nothing itself), unless that process ended it
    (it leaves ADDRESS.ended.PID first: the code is no news, and no file is left behind). The
    server is the child subreaper of its workers' descendants: what a worker that died left
    running is adopted here and ended (`_end_adopted`) as the worker is reaped."""
    while True:
        try:
            pid, status = os.waitpid(-1, 0)
        except ChildProcessError:
            time.sleep(0.05)
            continue
        with _workers_lock:
            if pid not in _workers:  # an adopted process, ended: nobody waits for its code
                continue
            _workers.discard(pid)
            _end_adopted()
        shutil.rmtree(f"{address}.run.{pid}", ignore_errors=True)  # its temporary directory (`_confine`)
        try:
            os.unlink(f"{address}.ended.{pid}")
            continue
        except OSError:
            pass
        try:
            with open(f"{address}.exit.{pid}", "w") as fh:
                fh.write(str(os.waitstatus_to_exitcode(status)))
        except OSError:
            pass


def _end_adopted() -> None:
    """SIGKILL every child of the server that is not one of its workers, with its descendants
    (stopped first, processes.freeze): processes a worker left running when it died (its own
    os._exit, a crash, a SIGKILL from elsewhere), re-parented here, not to init."""
    children = set()
    try:
        for tid in os.listdir("/proc/self/task"):
            with open(f"/proc/self/task/{tid}/children") as fh:
                children.update(int(c) for c in fh.read().split())
    except OSError:  # not Linux, or no children file: nothing to find
        return
    for pid in children - _workers:
        for p in freeze(pid):
            try:
                p.kill()
            except Exception:
                pass
        try:
            os.kill(pid, signal.SIGKILL)  # its child, not yet reaped: the pid is still its
        except OSError:
            pass


def _watch_owner() -> None:
    """End the server when its owner closes our stdin (or dies)."""
    try:
        while os.read(0, 4096):
            pass
    finally:
        os._exit(0)


#: prctl's option that makes a process the "child subreaper" of its descendants (linux/prctl.h).
PR_SET_CHILD_SUBREAPER = 36
_prctl = None  # libc's prctl, looked up by the server (once, before it forks any worker)


def _find_prctl():
    """libc's prctl, or None (not Linux)."""
    try:
        import ctypes

        return ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return None


def adopt_orphans() -> None:
    """Make this process the child subreaper of what it starts: a descendant whose parent ends
    (a daemon forked twice, in a session of its own) is re-parented to it instead of to init,
    so it stays in the worker's tree, which the evaluating process ends with the run (without
    it, such a daemon outlived the run, free to kill later runs' workers). Not Linux: nothing."""
    if _prctl is not None:
        _prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)


def _preload_asked(sock, builtin: set) -> None:
    """Import here, before forking the connection's worker, the built-in optimizers' modules its
    evaluating process names first (``{"preload": [module, ...]}``, adapters.sandbox._Worker),
    so that its run and every later one find them imported (a plugin's module: never here)."""
    try:
        sock.settimeout(5.0)
        header = sock.recv(4, socket.MSG_PEEK | socket.MSG_WAITALL)
        size = struct.unpack("!i", header)[0] if len(header) == 4 else -1
        if not 0 < size <= 65536:
            return
        raw = sock.recv(4 + size, socket.MSG_PEEK | socket.MSG_WAITALL)[4:]
        asked = json.loads(raw)
        if not (isinstance(asked, dict) and isinstance(asked.get("preload"), list)):
            return  # not this message: left for the worker
        sock.recv(4 + size, socket.MSG_WAITALL)  # taken off the connection
    except (OSError, ValueError, struct.error):
        return
    finally:
        sock.settimeout(None)
    for module in asked["preload"]:
        if module in builtin and module not in sys.modules:
            try:
                __import__(module)
            except BaseException:  # a broken library fails the runs that need it, in their workers
                pass


def _from_a_worker(pid: int) -> bool:
    """Whether process `pid` is one of this server's workers or descends from one (its parents
    read from /proc up to init or this server): a worker may not have the server start a process
    for it, which would be no descendant of its own and outlive its run."""
    seen = 0
    while pid > 1 and pid != os.getpid() and seen < 4096:
        with _workers_lock:
            if pid in _workers:
                return True
        try:
            with open(f"/proc/{pid}/stat", "rb") as fh:
                stat = fh.read()
            pid = int(stat[stat.rindex(b")") + 2:].split()[1])
        except (OSError, ValueError, IndexError):
            return False
        seen += 1
    return False


def serve(address: str, preload: list[str]) -> None:
    """The worker server: import hook, preloads, then one forked worker per connection."""
    global _prctl, _address, _evaluator_pid, _evaluator_pidfd
    _address = address
    sys.meta_path.insert(0, _Refused())
    _prctl = _find_prctl()
    import numpy  # noqa: F401

    import adapters.budgeted  # noqa: F401  (the objective's stop signals; harness imports it too)
    import adapters.registry  # noqa: F401

    from adapters.registry import BUILTINS

    builtin = {target.split(":")[0] for target in BUILTINS.values()}
    for module in preload:
        if module not in builtin:  # a plugin's import-time code never runs here (sandbox.preloads)
            continue
        try:
            __import__(module)
        except BaseException:  # a broken plugin module fails its own runs, with its own error
            pass
    from multiprocessing.connection import Connection

    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(address + ".tmp")
    listener.listen(64)
    os.rename(address + ".tmp", address)  # the address appears only once it accepts
    threading.Thread(target=_reap, args=(address,), daemon=True).start()
    threading.Thread(target=_watch_owner, daemon=True).start()
    adopt_orphans()  # what a dead worker left running comes here (`_end_adopted`), not to init
    while True:
        sock, _ = listener.accept()
        peer, uid, _ = struct.unpack("3i", sock.getsockopt(socket.SOL_SOCKET, socket.SO_PEERCRED, struct.calcsize("3i")))
        if uid != os.getuid() or _from_a_worker(peer):  # only the evaluating side starts a worker
            sock.close()
            continue
        _preload_asked(sock, builtin)
        with _workers_lock:  # a worker is in `_workers` before the reaper can see it
            pid = os.fork()
            if pid:
                _workers.add(pid)
        if pid == 0:
            listener.close()
            signal.signal(signal.SIGINT, signal.SIG_IGN)  # a Ctrl-C is the evaluating process's
            os.setsid()  # its own process group: ended as one when the evaluating side is gone
            adopt_orphans()
            _evaluator_pid = peer
            try:
                _evaluator_pidfd = os.pidfd_open(peer)
            except (AttributeError, OSError):
                _evaluator_pidfd = None
            null = os.open(os.devnull, os.O_RDONLY)
            os.dup2(null, 0)
            os.close(null)
            try:
                worker(Connection(sock.detach()))
            except BaseException:  # its evaluating process gone (the usual end is a SIGKILL from it)
                pass
            # nothing it started may outlive it, re-parented to init: ended with it (its exit
            # code is then that of a SIGKILL; a plugin's own os._exit or crash keeps its own)
            _end_this_worker()
            os._exit(1)
        sock.close()


if __name__ == "__main__":
    serve(sys.argv[1], sys.argv[2:])
