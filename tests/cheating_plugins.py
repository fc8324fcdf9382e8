"""Plugins that try to get evaluations, a better record or a status they did not earn, by every
route found in issue 22 and a few more. Each one, if its route worked, would evaluate far more
points than its budget (MANY) or report a value it never paid for; tests/test_sandbox.py checks
that none of them gains anything through adapters.run, `femu study` and `femu reproduce`.

Like tests/sample_plugins.py, a module that imports neither the FE package nor the application."""

from __future__ import annotations

import copy
import gc
import json
import os
import pickle
import signal
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np

import adapters

#: Points a cheat tries to evaluate behind its budget.
MANY = 2000


def _points(bounds, rng, n):
    return rng.uniform(*bounds, size=(n, len(bounds[0])))


class DeepCopiesTheObjective:
    """A deep copy of the objective, hoping the copy's evaluations are not counted."""

    def minimize(self, objective, bounds, budget, rng):
        twin = copy.deepcopy(objective)
        twin(_points(bounds, rng, MANY))
        objective(_points(bounds, rng, 1))


class PicklesTheObjective:
    """A pickled and unpickled objective, hoping for a fresh count."""

    def minimize(self, objective, bounds, budget, rng):
        twin = pickle.loads(pickle.dumps(objective))
        twin(_points(bounds, rng, MANY))
        objective(_points(bounds, rng, 1))


class BuildsTheProblemFromScratch:
    """Builds the paper problem itself and evaluates it freely, then sends only its best point."""

    def minimize(self, objective, bounds, budget, rng):
        from adapters.variants import make_problem

        problem = make_problem("paper")
        X = _points(bounds, rng, MANY)
        objective(X[np.argmin(problem.evaluate(X))][None])


class ReadsTheSuiteTruth:
    """Looks for a suite instance's hidden truth: on the objective, then by rebuilding the instance."""

    def minimize(self, objective, bounds, budget, rng):
        for name in ("truth", "f_opt", "problem"):
            if hasattr(objective, name):
                objective(np.atleast_2d(getattr(objective, name, None) or getattr(objective.problem, "truth")))
                return
        from fe_problem.suite import suite_problem

        objective(suite_problem("hframe-freq/12/1").truth[None])


class FindsTheProblemInMemory:
    """Searches every object of its process for a problem, a truth or an optimum."""

    def minimize(self, objective, bounds, budget, rng):
        for o in gc.get_objects():
            if o is objective:
                continue
            if type(o).__name__.endswith("Problem") and hasattr(o, "evaluate"):
                o.evaluate(_points(bounds, rng, MANY))
                break
            if isinstance(o, dict) and (isinstance(o.get("truth"), np.ndarray) or isinstance(o.get("f_opt"), float)):
                raise RuntimeError(f"found {sorted(o)[:5]}")  # an instance's truth or a known optimum
        objective(_points(bounds, rng, 1))


class CallsUncountedMethods:
    """correlation() and friends, uncounted on the problem: asked of the objective."""

    def minimize(self, objective, bounds, budget, rng):
        for _ in range(MANY):
            objective.correlation(_points(bounds, rng, 1)[0])


class EvaluatesFromThreads:
    """Many threads calling the objective at once, hoping some calls slip through uncounted."""

    def minimize(self, objective, bounds, budget, rng):
        points = [_points(bounds, rng, 50) for _ in range(40)]
        errors = []

        def call(X):
            try:
                objective(X)
            except BaseException as exc:  # the stop signal, in some threads
                errors.append(exc)

        threads = [threading.Thread(target=call, args=(X,)) for X in points]
        for t in threads:
            t.start()
        for t in threads:
            t.join()
        objective(_points(bounds, rng, 1))


class EvaluatesFromAFork:
    """A forked child evaluates behind the parent's back, then the parent goes on."""

    def minimize(self, objective, bounds, budget, rng):
        pid = os.fork()
        if pid == 0:
            try:
                objective(_points(bounds, rng, MANY))
            finally:
                os._exit(0)
        os.waitpid(pid, 0)
        objective(_points(bounds, rng, 1))


class EvaluatesInASubprocess:
    """A fresh interpreter (inheriting nothing of the harness) builds the problem and searches."""

    def minimize(self, objective, bounds, budget, rng):
        code = ("import numpy as np; from adapters.variants import make_problem; p = make_problem('paper'); "
                "X = np.random.default_rng(0).uniform(p.xl, p.xu, (2000, p.n_var)); "
                "print(' '.join(map(repr, X[np.argmin(p.evaluate(X))])))")
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        if out.returncode:
            raise RuntimeError(f"the subprocess could not build the problem: {out.stderr.strip().splitlines()[-1]}")
        objective(np.array([float(v) for v in out.stdout.split()])[None])


class ClaimsBudgetSpent:
    """Raises the harness's own end-of-budget signal after a few evaluations, hoping for ``ok``."""

    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 5))
        raise adapters.BudgetExhausted()


class ClaimsTimeout:
    """Raises the harness's own time-limit signal, hoping for ``timeout`` (not ``failed``)."""

    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 5))
        from adapters.harness import TimeLimitExceeded

        raise TimeLimitExceeded("time limit of 1 s exceeded")


class PatchesTheHarness:
    """Patches the harness so that evaluations are free and every run is ``ok``: in its own
    process (and for later runs, if they shared it)."""

    def minimize(self, objective, bounds, budget, rng):
        import adapters.harness as harness
        import adapters.sandbox_worker as worker

        harness.BudgetedObjective.__call__ = lambda self, X: np.zeros(len(np.atleast_2d(X)))
        harness.BudgetedObjective._record = lambda self, X, f: None
        harness.run = lambda *a, **k: None
        worker.ObjectiveProxy.__call__ = lambda self, X: np.zeros(len(np.atleast_2d(X)))
        objective(_points(bounds, rng, 3))


class ForgesItsEnd:
    """Writes the end-of-run message itself after 3 evaluations, claiming it spent the budget."""

    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 3))
        conn = objective._conn
        conn.send_bytes(b"D" + json.dumps(["returned", "budget spent"]).encode())  # the protocol's own form
        time.sleep(60)


class ForgesValues:
    """Sends the evaluating side a reply-shaped message instead of a request."""

    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 3))
        objective._conn.send_bytes(b"F" + np.zeros(8).tobytes())
        time.sleep(60)


class ResetsItsCountAndBudget:
    """Sets every counter it can reach on its objective back, and its budget up."""

    def minimize(self, objective, bounds, budget, rng):
        for _ in range(10):
            objective(_points(bounds, rng, 100))
            objective.__dict__["_n_evals"] = 0
            objective.__dict__["_budget"] = 10**9


class PrintsALot:
    """Prints to stdout and stderr, and from a process of its own: all of it belongs in its record."""

    def minimize(self, objective, bounds, budget, rng):
        print("PLUGIN-STDOUT {not json")
        print("PLUGIN-STDERR", file=sys.stderr)
        subprocess.run(["echo", "PLUGIN-CHILD"])
        while True:
            objective(_points(bounds, rng, 10))


class Hangs:
    """Evaluates once and then never calls the objective again."""

    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 2))
        time.sleep(3600)


class _RunsCodeWhenUnpickled:
    """What a pickle can carry: a call made where it is loaded (here, one that marks the process)."""

    def __reduce__(self):
        return (exec, ("import adapters; adapters.SMUGGLED_CODE_RAN = True",))


class SmugglesCodeInItsEnd:
    """Sends an end-of-run message that is a pickle carrying a call: if the evaluating side
    unpickled it, the plugin's code would run there, beside the problem and its counts."""

    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 3))
        objective._conn.send_bytes(b"D" + pickle.dumps(("returned", _RunsCodeWhenUnpickled())))
        time.sleep(60)


class SendsAHugeMessage:
    """Sends one message far longer than its whole budget's points (64 MB), to make the
    evaluating side allocate it."""

    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 3))
        objective._conn.send_bytes(b"E" + bytes(64 << 20))
        time.sleep(60)


#: What RemembersEarlierRuns keeps in its module: the points and values of its earlier runs.
_REMEMBERED: list = []


class RemembersEarlierRuns:
    """Keeps every point and value it was given in its module and in its process's environment,
    hoping that a later run finds them in the same process (a worker kept for the next run) and
    starts from the best of them without paying. Prints what it found, and its pid."""

    def minimize(self, objective, bounds, budget, rng):
        print("PID", os.getpid(), "REMEMBERED", len(_REMEMBERED), "ENV", os.environ.get("FEMU_CHEAT_MEMORY"),
              flush=True)
        os.environ["FEMU_CHEAT_MEMORY"] = "here"
        while True:
            X = _points(bounds, rng, 10)
            _REMEMBERED.extend(zip(X.tolist(), objective(X).tolist()))


class LeavesADaemon:
    """Starts a daemon the classic way (fork, setsid, fork again, the middle process exits: the
    daemon has no parent in the run's process tree) that would outlive the run, free to kill
    the workers of later runs or take their cores; writes its pid, then spends its budget."""

    def minimize(self, objective, bounds, budget, rng, pid_file):
        middle = os.fork()
        if middle == 0:
            os.setsid()
            if os.fork() == 0:
                with open(pid_file + ".tmp", "w") as fh:
                    fh.write(str(os.getpid()))
                os.rename(pid_file + ".tmp", pid_file)
                time.sleep(600)
            os._exit(0)
        os.waitpid(middle, 0)
        while not os.path.exists(pid_file):
            time.sleep(0.01)
        while True:
            objective(_points(bounds, rng, 10))


#: How many children KeepsStartingSessions starts at most, and the seconds between two.
SESSIONS_MAX, SESSIONS_EVERY_S = 300, 0.02


class KeepsStartingSessions:
    """Ignores SIGTERM and has a thread that keeps starting children (``sleep 600``), each in a
    session of its own, one every SESSIONS_EVERY_S (at most SESSIONS_MAX), each pid written to
    a file in `pid_dir`: a child started after its worker's tree was listed, or after the
    worker died, would outlive the run, re-parented to init. Spends its budget once 10 exist."""

    def minimize(self, objective, bounds, budget, rng, pid_dir=None):
        pid_dir = pid_dir or tempfile.mkdtemp(prefix="femu-test-sessions-")
        signal.signal(signal.SIGTERM, signal.SIG_IGN)

        def start():
            for _ in range(SESSIONS_MAX):
                child = subprocess.Popen(["sleep", "600"], start_new_session=True)
                open(os.path.join(pid_dir, str(child.pid)), "w").close()
                time.sleep(SESSIONS_EVERY_S)

        threading.Thread(target=start, daemon=True).start()
        while len(os.listdir(pid_dir)) < 10:
            time.sleep(0.01)
        while True:
            objective(_points(bounds, rng, 10))


#: CPU seconds HidesItsWorkInASession's child spends before it waits.
HIDDEN_CPU_S = 0.6


class HidesItsWorkInASession:
    """Does its work in a child in a session of its own that it never waits for (the child
    spends HIDDEN_CPU_S of CPU, writes `mark`, then sleeps): a worker's CPU counts only the
    children it reaped, so without the live descendants' CPU the run would look that much
    cheaper. Spends its budget once the child's work is done."""

    def minimize(self, objective, bounds, budget, rng, mark):
        code = ("import sys, time\nwhile time.process_time() < %r: pass\nopen(sys.argv[1], 'w').close()\n"
                "time.sleep(600)" % HIDDEN_CPU_S)
        subprocess.Popen([sys.executable, "-c", code, mark], start_new_session=True)
        while not os.path.exists(mark):
            time.sleep(0.01)
        while True:
            objective(_points(bounds, rng, 10))


class ExitsLeavingSessions:
    """Starts 5 children (``sleep 600``) in sessions of their own, pids written to files in
    `pid_dir`, evaluates 3 points and ends its own process (os._exit(3)): its worker is gone
    before anyone could stop it, and its children would be re-parented to init."""

    def minimize(self, objective, bounds, budget, rng, pid_dir=None):
        pid_dir = pid_dir or tempfile.mkdtemp(prefix="femu-test-sessions-")
        for _ in range(5):
            child = subprocess.Popen(["sleep", "600"], start_new_session=True)
            open(os.path.join(pid_dir, str(child.pid)), "w").close()
        objective(_points(bounds, rng, 3))
        os._exit(3)


# -- issue 39: plugins that reach for each other, the store or the truth -----------------------------


class EndsWithDeepJSON:
    """Ends its run with a message nested 200,000 deep: a parser that recurses raises
    RecursionError, which `adapters.run` would let out (it is meant never to raise)."""

    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 3))
        objective._conn.send_bytes(b"D" + b"[" * 200_000 + b"]" * 200_000)
        time.sleep(60)


def _probe(action) -> str:
    """``ok`` when `action` ran, else the name of what stopped it."""
    try:
        action()
        return "ok"
    except BaseException as exc:  # noqa: BLE001  (what stopped it is the finding)
        return type(exc).__name__


def _write(path: str) -> None:
    with open(path, "w") as fh:
        fh.write("PLUGIN WAS HERE")


def _read(path: str) -> None:
    with open(path, "rb") as fh:
        fh.read(1)


class ProbesItsConfinement:
    """Tries, from its worker, what issue 39 found open: signals (0: harmless) to every process
    not its own, its server and its evaluating process's memory, a new worker from its server
    (whose address is in its own command line), reading `read` and writing `write`; prints one
    line ``PROBE {json}`` with what it reached, and evaluates honestly."""

    def minimize(self, objective, bounds, budget, rng, evaluator=0, read=(), write=()):
        mine = {os.getpid()} | {int(p) for p in os.listdir(f"/proc/{os.getpid()}/task")}
        signalled = []
        for p in os.listdir("/proc"):
            if p.isdigit() and int(p) not in mine:
                if _probe(lambda: os.kill(int(p), 0)) == "ok":
                    signalled.append(int(p))
        server = os.getppid()
        found = {"signalled": len(signalled), "evaluator_signalled": int(evaluator) in signalled,
                 "server_signalled": server in signalled,
                 "evaluator_mem": _probe(lambda: _read(f"/proc/{int(evaluator)}/mem")),
                 "server_mem": _probe(lambda: _read(f"/proc/{server}/mem")),
                 "read": {p: _probe(lambda: _read(p)) for p in read},
                 "write": {p: _probe(lambda: _write(p)) for p in write},
                 "own_tmp": _probe(lambda: _write(os.path.join(tempfile.gettempdir(), "mine"))),
                 "files_opened": self._open_many(4000)}
        with open(f"/proc/{server}/cmdline", "rb") as fh:
            address = fh.read().split(b"\0")[3].decode()  # python -m adapters.sandbox_worker ADDRESS
        found["new_worker"] = self._ask_for_a_worker(address)
        print("PROBE", json.dumps(found), flush=True)
        objective(_points(bounds, rng, budget))

    @staticmethod
    def _open_many(n: int) -> int:
        """How many of `n` files it could hold open at once (then all closed)."""
        held = []
        try:
            for _ in range(n):
                held.append(os.open(os.devnull, os.O_RDONLY))
        except OSError:
            pass
        for fd in held:
            os.close(fd)
        return len(held)

    @staticmethod
    def _ask_for_a_worker(address: str) -> str:
        """A worker from its server, as the evaluating side asks: ``pid N`` if it got one."""
        from multiprocessing.connection import Client

        try:
            conn = Client(address, family="AF_UNIX")
            if not conn.poll(5):
                return "no answer"
            return f"pid {json.loads(conn.recv_bytes())}"
        except BaseException as exc:  # noqa: BLE001
            return type(exc).__name__


class ReachesForTheStore:
    """Finds its study's store in an ancestor's command line (``--store PATH``), reads a record
    there and writes one of its own; prints ``STORE {json}`` with what it reached."""

    def minimize(self, objective, bounds, budget, rng):
        store, pid = None, os.getpid()
        while pid > 1 and store is None:
            with open(f"/proc/{pid}/stat", "rb") as fh:
                stat = fh.read()
            pid = int(stat[stat.rindex(b")") + 2:].split()[1])
            try:
                with open(f"/proc/{pid}/cmdline", "rb") as fh:
                    argv = [a.decode() for a in fh.read().split(b"\0")]
            except OSError:
                continue
            if "--store" in argv:
                store = argv[argv.index("--store") + 1]
        found = {"store": store}
        if store is not None:
            runs = os.path.join(store, "runs")
            found["list"] = _probe(lambda: os.listdir(runs))
            found["read"] = _probe(lambda: _read(os.path.join(store, "study.json")))
            found["write"] = _probe(lambda: _write(os.path.join(runs, "planted.json")))
        print("STORE", json.dumps(found), flush=True)
        objective(_points(bounds, rng, budget))
