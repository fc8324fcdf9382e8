"""The sandbox (issue 22): every optimizer runs in a worker process that never holds the problem,
so no route a plugin takes gets it an evaluation it was not charged, a status it did not earn,
a hidden truth, or a say in later runs. Checked through adapters.run, `femu study` and `femu
reproduce` with the plugins of tests/cheating_plugins.py, each of which would evaluate far more
than its budget (or report a value it never paid for) if its route worked.

The invariant every run is held to: the problem evaluated exactly the points the record charges
(`points_evaluated == n_evals <= budget`), and the record is ``verified``."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import adapters
import cheating_plugins as cp
from adapters.variants import make_problem
from femu.reports.study import write_report
from femu.studies.store import Store, run_key, safe_name
from fe_problem.suite import suite_problem

HERE = Path(__file__).parent
BUDGET = 300


def plugin(cls) -> str:
    return f"{cls.__module__}:{cls.__name__}"


# route -> (status, n_evals, words of the error or None)
ROUTES = [
    (cp.DeepCopiesTheObjective, "failed", 0, "TypeError"),  # the proxy holds a connection: no copy
    (cp.PicklesTheObjective, "failed", 0, "TypeError"),
    (cp.BuildsTheProblemFromScratch, "failed", 0, "not available in the optimizer's process"),
    (cp.ReadsTheSuiteTruth, "failed", 0, "not available in the optimizer's process"),
    (cp.FindsTheProblemInMemory, "stopped", 1, None),  # found nothing: its one honest point
    (cp.CallsUncountedMethods, "failed", 0, "has no attribute 'correlation'"),
    (cp.EvaluatesFromThreads, "ok", BUDGET, None),  # every thread's points charged: the budget ends it
    (cp.EvaluatesFromAFork, "ok", BUDGET, None),  # the child's points charged the same
    (cp.EvaluatesInASubprocess, "failed", 0, "could not build the problem"),
    (cp.ClaimsBudgetSpent, "failed", 5, "BudgetExhausted"),  # its own stop signal is not the harness's
    (cp.ClaimsTimeout, "failed", 5, "TimeLimitExceeded"),
    (cp.PatchesTheHarness, "stopped", 3, None),  # it patched its own copies only: its 3 points charged
    (cp.ForgesItsEnd, "stopped", 3, None),  # an end it sends itself is a return, never "ok"
    (cp.ForgesValues, "failed", 3, "protocol"),
    (cp.SmugglesCodeInItsEnd, "failed", 3, "protocol"),  # read as JSON: its pickle never runs here
    (cp.SendsAHugeMessage, "failed", 3, "protocol"),  # refused by its length, never read
    (cp.ResetsItsCountAndBudget, "ok", BUDGET, None),
    (cp.PrintsALot, "ok", BUDGET, None),
    (cp.RemembersEarlierRuns, "ok", BUDGET, None),
    (cp.KeepsStartingSessions, "ok", BUDGET, None),  # its children end with its run (a test below)
    (cp.ExitsLeavingSessions, "failed", 3, "exited with code 3"),  # and these with its worker
]


@pytest.mark.parametrize("cls,status,n_evals,says", ROUTES, ids=[r[0].__name__ for r in ROUTES])
def test_no_route_gains_anything_through_adapters_run(cls, status, n_evals, says):
    problem = make_problem("paper")
    r = adapters.run(plugin(cls), problem, BUDGET, 0)
    assert (r.status, r.n_evals) == (status, n_evals), r.error
    assert says is None and r.error is None or says in r.error, r.error
    assert problem.points_evaluated == r.n_evals <= BUDGET  # not one point uncharged
    assert r.verified
    assert not hasattr(adapters, "SMUGGLED_CODE_RAN")  # no plugin code ran in this process


def test_a_suite_problems_truth_and_optimum_never_reach_the_optimizer():
    problem = suite_problem("hframe-freq/12/1")
    assert problem.truth is not None and problem.f_opt == 0.0
    before = problem.points_evaluated  # J(truth), checked when the instance is built
    r = adapters.run(plugin(cp.ReadsTheSuiteTruth), problem, BUDGET, 0)
    assert r.status == "failed" and r.n_evals == 0 and r.best_f == float("inf"), r.error
    assert "not available in the optimizer's process" in r.error
    assert problem.points_evaluated == before


def test_a_plugin_that_patches_the_harness_changes_no_later_run():
    honest_before = adapters.run("random-search", make_problem("paper"), BUDGET, 3)
    patched = adapters.run(plugin(cp.PatchesTheHarness), make_problem("paper"), BUDGET, 0)
    assert patched.status == "stopped" and patched.n_evals == 3
    problem = make_problem("paper")
    honest_after = adapters.run("random-search", problem, BUDGET, 3)
    assert honest_after.status == "ok" and problem.points_evaluated == honest_after.n_evals == BUDGET
    assert honest_after.best_f == honest_before.best_f and honest_after.best_x == honest_before.best_x
    assert honest_after.best_f > 0


def _ended(pid: int, wait_s: float = 0.0) -> bool:
    """Whether process `pid` is gone (or a zombie), now or within `wait_s` (a process this test
    killed itself may take a moment to exit on a loaded machine; a run returns only once its
    worker has exited)."""
    import psutil

    deadline = time.time() + wait_s
    while True:
        try:
            if psutil.Process(pid).status() == psutil.STATUS_ZOMBIE:
                return True
        except psutil.NoSuchProcess:
            return True
        if time.time() > deadline:
            return False
        time.sleep(0.05)


def test_every_run_has_a_fresh_worker_that_keeps_nothing_for_the_next():
    """The worker of a run is forked before it (a spare, after the previous run), serves that
    run only and is ended with it: a plugin that keeps what it saw in its module and its
    environment finds nothing in its next run, which is another process."""
    pids = []
    for seed in range(3):
        problem = make_problem("paper")
        r = adapters.run(plugin(cp.RemembersEarlierRuns), problem, BUDGET, seed)
        assert r.status == "ok" and r.n_evals == problem.points_evaluated == BUDGET and r.verified, r.error
        words = r.output.split()
        assert words[2:] == ["REMEMBERED", "0", "ENV", "None"], r.output
        pids.append(int(words[1]))
        assert _ended(pids[-1])
    assert len(set(pids)) == 3 and os.getpid() not in pids


def test_a_worker_forked_before_its_run_finds_the_callers_directory_and_modules_written_since(tmp_path,
                                                                                               monkeypatch):
    """A spare is settled in the directory and path of the run before it: a run from another
    directory, or of a module written since, is found all the same (`module:Class` of a file in
    the current directory)."""
    source = ("class Plugin{n}:\n    def minimize(self, objective, bounds, budget, rng):\n"
              "        import os\n        print('CWD', os.getcwd())\n"
              "        while True:\n            objective(rng.uniform(*bounds, size=(10, len(bounds[0]))))\n")
    for n, where in enumerate([tmp_path / "a", tmp_path / "a", tmp_path / "b"]):
        where.mkdir(exist_ok=True)
        monkeypatch.chdir(where)
        (where / f"written_since_{n}.py").write_text(source.format(n=n))
        r = adapters.run(f"written_since_{n}:Plugin{n}", make_problem("paper"), 50, 0)
        assert r.status == "ok" and r.n_evals == 50, r.error
        assert f"CWD {where}" in r.output, r.output


def test_a_daemon_a_plugin_leaves_ends_with_its_run(tmp_path):
    """Its worker adopts the processes whose parents end (a child subreaper), so a daemon
    (forked twice, its own session) is still in the worker's tree when the run ends."""
    pid_file = tmp_path / "daemon.pid"
    problem = make_problem("paper")
    r = adapters.run(plugin(cp.LeavesADaemon), problem, BUDGET, 0, pid_file=str(pid_file))
    assert r.status == "ok" and r.n_evals == problem.points_evaluated == BUDGET, r.error
    assert _ended(int(pid_file.read_text()))


def test_children_started_in_sessions_of_their_own_until_the_end_do_not_outlive_the_run(tmp_path):
    """A plugin that ignores SIGTERM and keeps starting children, each in a session of its own,
    while its run ends: its tree is stopped before it is killed, so no child is started after
    it was listed, and none is left running when adapters.run returns."""
    problem = make_problem("paper")
    r = adapters.run(plugin(cp.KeepsStartingSessions), problem, BUDGET, 0, pid_dir=str(tmp_path))
    assert r.status == "ok" and r.n_evals == problem.points_evaluated == BUDGET, r.error
    started = {int(p) for p in os.listdir(tmp_path)}
    assert 10 <= len(started) < cp.SESSIONS_MAX  # still starting them when the run ended
    alive = [pid for pid in started if not _ended(pid)]
    assert alive == [], f"{len(alive)} of {len(started)} children alive after the run"
    time.sleep(1.0)
    assert {int(p) for p in os.listdir(tmp_path)} == started  # and none started since


def test_children_in_sessions_of_their_own_end_when_the_evaluating_process_dies(tmp_path):
    """The evaluating process killed (SIGKILL) mid-run: its worker ends itself and every process
    it started, those in sessions of their own too, not its process group only."""
    code = ("import sys, adapters; from adapters.variants import make_problem; "
            "adapters.run('cheating_plugins:KeepsStartingSessions', make_problem('paper'), 10**7, 0, "
            "pid_dir=sys.argv[1])")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE), os.environ.get("PYTHONPATH", "")]))
    proc = subprocess.Popen([sys.executable, "-c", code, str(tmp_path)], env=env)
    try:
        deadline = time.time() + 300
        while len(os.listdir(tmp_path)) < 10:
            assert proc.poll() is None and time.time() < deadline, "the plugin did not start its children"
            time.sleep(0.05)
    finally:
        proc.kill()
        proc.wait()
    deadline = time.time() + 20
    while True:
        started = {int(p) for p in os.listdir(tmp_path)}
        alive = [pid for pid in started if not _ended(pid)]
        if not alive or time.time() > deadline:
            break
        time.sleep(0.2)
    assert alive == [], f"{len(alive)} of {len(started)} children alive 20 s after the evaluating process died"
    assert len(started) < cp.SESSIONS_MAX  # ended while it was still starting them


def test_children_in_sessions_of_their_own_end_when_their_worker_ends_itself(tmp_path):
    """A plugin that starts children in sessions of their own and ends its process (os._exit):
    the worker server, their subreaper, ends them once it reaps the worker."""
    problem = make_problem("paper")
    r = adapters.run(plugin(cp.ExitsLeavingSessions), problem, BUDGET, 0, pid_dir=str(tmp_path))
    assert r.status == "failed" and r.n_evals == problem.points_evaluated == 3, r.error
    assert "exited with code 3" in r.error, r.error
    started = [int(p) for p in os.listdir(tmp_path)]
    assert len(started) == 5
    alive = [pid for pid in started if not _ended(pid, wait_s=10.0)]
    assert alive == [], f"{len(alive)} of 5 children alive 10 s after their worker ended"


def test_a_runs_cpu_includes_its_live_descendants_in_sessions_of_their_own(tmp_path):
    """cpu_s counts the CPU of a plugin's child that it never reaped (its own session, alive
    at the run's end): the run is charged its HIDDEN_CPU_S."""
    problem = make_problem("paper")
    r = adapters.run(plugin(cp.HidesItsWorkInASession), problem, BUDGET, 0, mark=str(tmp_path / "done"))
    assert r.status == "ok" and r.n_evals == BUDGET, r.error
    assert r.cpu_s >= cp.HIDDEN_CPU_S, r.cpu_s


def test_a_worker_that_never_says_its_pid_leaves_no_file_nor_connection(tmp_path, monkeypatch):
    """A server that accepts and hangs up at once: the worker is refused (RuntimeError, which a
    spare's fork swallows) and its output file and connection are not left behind."""
    import socket
    import tempfile

    from adapters import sandbox

    address = str(tmp_path / "server")
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(address)
    listener.listen(4)

    def hang_up():
        for _ in range(2):
            conn, _ = listener.accept()
            conn.close()

    import threading

    threading.Thread(target=hang_up, daemon=True).start()
    out = tmp_path / "tmp"
    out.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(out))
    sandbox.drop_spare()  # a spare of an earlier test's run: its connection is not this test's
    monkeypatch.setattr(sandbox, "_address", address)
    before = len(os.listdir("/proc/self/fd"))
    with pytest.raises(RuntimeError, match="sent no process id"):
        sandbox._Worker()
    sandbox.fork_spare()  # swallowed; its spare (connected, its prepare sent) is kept
    sandbox.drop_spare()
    listener.close()
    assert os.listdir(out) == []
    assert len(os.listdir("/proc/self/fd")) == before - 1  # the listener's fd only is gone


def test_a_spare_worker_killed_before_its_run_is_replaced_and_the_run_loses_nothing():
    """A process a plugin left running could kill the worker forked for the next run: that run
    forks another and gets the record it earns."""
    import signal

    from adapters import sandbox

    assert adapters.run("random-search", make_problem("paper"), 20, 0).status == "ok"
    spare = sandbox._spare
    assert spare is not None and spare.owner == os.getpid()
    os.kill(spare.pid, signal.SIGKILL)
    assert _ended(spare.pid, wait_s=10.0)
    problem = make_problem("paper")
    r = adapters.run("random-search", problem, 20, 1)
    assert r.status == "ok" and r.n_evals == problem.points_evaluated == 20 and r.verified, r.error


def test_a_spare_worker_killed_after_it_was_taken_is_replaced_and_the_run_loses_nothing(monkeypatch):
    """The same kill a moment later: after the run took its spare (`_fresh_worker` saw it alive)
    and before the run's spec reached it. No optimizer code ran in it, so the run forks another
    worker and gets the record it earns; this thread's cores are as they were after the run
    (the dead worker could not be pinned)."""
    import signal

    from adapters import sandbox

    assert adapters.run("random-search", make_problem("paper"), 20, 0).status == "ok"
    spare = sandbox._spare
    assert spare is not None and spare.owner == os.getpid()
    os.kill(spare.pid, signal.SIGKILL)
    assert _ended(spare.pid, wait_s=10.0)
    taken = []

    def the_spare_as_seen_alive(preload=()):
        sandbox._spare = None
        taken.append(spare)
        return spare

    monkeypatch.setattr(sandbox, "_fresh_worker", the_spare_as_seen_alive)
    cores = os.sched_getaffinity(0)
    problem = make_problem("paper")
    r = adapters.run("random-search", problem, 20, 1)
    assert taken == [spare]
    assert r.status == "ok" and r.n_evals == problem.points_evaluated == 20 and r.verified, r.error
    assert os.sched_getaffinity(0) == cores


def test_a_ctrl_c_while_a_run_ends_its_worker_stops_the_caller_and_leaves_no_worker_stopped(monkeypatch, ctrl_c_is_pythons):
    """A Ctrl-C that lands between the worker's stop and its kill (`_Worker.end`) is raised once
    the worker is killed: the caller gets its KeyboardInterrupt, and no worker is left stopped
    for good (it used to be, with the SIGKILL never sent). The patched stop presses Ctrl-C each
    time: first in the run's own stop after its last request (an interrupt there reaches
    `_Worker.end` as before), then in the stop inside `_Worker.end`, the one this checks."""
    import signal

    from adapters import sandbox
    from adapters.processes import freeze as real_freeze

    stopped = []

    def freeze_then_ctrl_c(pid, pidfd=None, exclude=()):
        procs = real_freeze(pid, pidfd, exclude)
        stopped.append(pid)
        os.kill(os.getpid(), signal.SIGINT)  # delivered to this (main) thread at once
        return procs

    monkeypatch.setattr(sandbox, "freeze", freeze_then_ctrl_c)
    with pytest.raises(KeyboardInterrupt):
        adapters.run("random-search", make_problem("paper"), 20, 0)
    assert stopped and all(_ended(pid, wait_s=10.0) for pid in stopped), stopped
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_the_worker_server_keeps_no_file_for_the_workers_its_runs_ended():
    from adapters.sandbox import server_address

    for seed in range(3):
        assert adapters.run("random-search", make_problem("paper"), 20, seed).status == "ok"
    folder = Path(server_address()).parent
    deadline = time.time() + 10
    while time.time() < deadline and [p for p in os.listdir(folder) if ".exit." in p or ".ended." in p]:
        time.sleep(0.05)
    assert not [p for p in os.listdir(folder) if ".exit." in p or ".ended." in p], os.listdir(folder)


def test_what_a_plugin_prints_is_in_its_record_not_on_the_callers_output(capfd):
    r = adapters.run(plugin(cp.PrintsALot), make_problem("paper"), BUDGET, 0)
    out, err = capfd.readouterr()
    for words in ("PLUGIN-STDOUT {not json", "PLUGIN-STDERR", "PLUGIN-CHILD"):
        assert words in r.output and words not in out + err


def test_a_plugin_that_hangs_is_stopped_at_its_time_limit_with_its_evaluations_kept(tmp_path):
    """Checked by behaviour, not by a wall-clock bound (a loaded machine delays any wake-up):
    stopped by the sandbox's deadline (the error only that path writes), not before the limit
    + 0.5 s + 5 % as the evaluating side measured it, its process (asleep for an hour) ended."""
    from adapters.sandbox import worker_deadline_s
    from sample_plugins import HangsTellingPid, hang_was_ended

    pid_file = tmp_path / "hangs.pid"
    for name in (plugin(cp.Hangs), plugin(HangsTellingPid)):
        options = {"pid_file": str(pid_file)} if name.endswith("Pid") else {}
        r = adapters.run(name, problem := make_problem("paper"), BUDGET, 0, time_limit_s=1.0, **options)
        assert r.status == "timeout" and r.n_evals == 2 == problem.points_evaluated, r.error
        assert "time limit of 1.0 s without asking for an evaluation" in r.error, r.error
        assert r.wall_s >= worker_deadline_s(1.0)
    assert hang_was_ended(pid_file)


def test_the_debugging_mode_runs_in_this_process_and_is_marked_unverified(tmp_path):
    verified = adapters.run("random-search", make_problem("paper"), 50, 0)
    debug = adapters.run("random-search", make_problem("paper"), 50, 1, isolated=False)
    assert verified.verified and not debug.verified
    report = write_report([verified, debug], tmp_path / "r").read_text()
    assert "1 run of `random-search` is **unverified**" in report


# -- femu study ------------------------------------------------------------------------------------
STUDY = [(cp.BuildsTheProblemFromScratch, "failed", 0), (cp.EvaluatesFromAFork, "ok", BUDGET),
         (cp.ClaimsBudgetSpent, "failed", 5), (cp.ClaimsTimeout, "failed", 5), (cp.PatchesTheHarness, "stopped", 3),
         (cp.ForgesItsEnd, "stopped", 3), (cp.PrintsALot, "ok", BUDGET), (cp.Hangs, "timeout", 2)]


def _femu(*args, **env_vars) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE), os.environ.get("PYTHONPATH", "")]), **env_vars)
    return subprocess.run([sys.executable, "-m", "femu", *args], env=env, capture_output=True, text=True,
                          timeout=900)


@pytest.mark.parametrize("workers", ["0", "2"])
def test_no_route_gains_anything_through_femu_study(tmp_path, workers):
    names = [plugin(c) for c, _, _ in STUDY] + ["random-search"]
    store = tmp_path / "s"
    done = _femu("study", "--optimizers", ",".join(names), "--seeds", "0", "--budget", str(BUDGET), "--store",
                 str(store), "--workers", workers, "--time-limit", "3", "--no-progress")
    assert done.returncode == 0, done.stderr
    assert done.stdout.count("\n") == 1 and done.stdout.startswith("femu study: 9 runs"), done.stdout
    assert "PLUGIN-" not in done.stdout + done.stderr
    runs = {r.optimizer: r for r in Store(store).runs()}
    for cls, status, n_evals in STUDY:
        r = runs[plugin(cls)]
        assert (r.status, r.n_evals) == (status, n_evals), (cls.__name__, r.error)
        assert r.verified
    assert "PLUGIN-STDOUT {not json" in runs[plugin(cp.PrintsALot)].output
    # the patcher ran before random-search in the same study: random-search is as it is alone
    alone = adapters.run("random-search", make_problem("paper"), BUDGET, 0)
    assert (runs["random-search"].status, runs["random-search"].best_f) == ("ok", alone.best_f)
    assert not list((store / "runs").glob("*.claim"))


def test_runs_with_other_settings_are_never_pooled_in_a_report(tmp_path):
    store = tmp_path / "s"
    for x0, seeds in (("none", "0-1"), ("all", "2-3")):
        done = _femu("study", "--optimizers", "random-search", "--seeds", seeds, "--budget", "50", "--store",
                     str(store), "--x0", x0, "--no-progress", "--workers", "0")
        assert done.returncode == 0, done.stderr
    done = _femu("report", str(store), "--out", str(tmp_path / "r"))
    assert done.returncode == 0, done.stderr
    report = (tmp_path / "r" / "report.md").read_text()
    assert "`random-search` was run with 2 different settings" in report
    assert "random-search [x0=none]" in report and "random-search [x0=all]" in report
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    seeds = {name: s["seeds"] for g in summary for name, s in g["solvers"].items()}
    assert seeds == {"random-search [x0=all]": [2, 3], "random-search [x0=none]": [0, 1]}


# -- names from user input -------------------------------------------------------------------------
def test_names_from_user_input_become_safe_distinct_file_names():
    keys = [run_key("paper", name, 100, 0) for name in
            ("../../../../escaped", "..%2F..", "a/b", "a_b", ".hidden", "x" * 400, "x" * 401)]
    assert len(set(keys)) == len(keys)
    for key in keys:
        assert "/" not in key and not key.startswith(".") and len(key) <= 200 and "\0" not in key
    # the names the project has always used keep their keys (existing stores stay readable)
    assert run_key("hframe-freq/12/1", "random-search", 100, 0) == "hframe-freq+12+1__random-search__b100__s0"
    # a plugin's module:Class (or path/file.py:Class) keeps no ':' in its file name (issue 41);
    # stores written with it stay readable (test_a_store_with_a_colon_in_a_record_name_is_read_and_resumed)
    assert run_key("paper", "tests.mod:Cls", 5, 1) == "paper__tests.mod%3ACls__b5__s1"
    assert ":" not in run_key("paper", "/home/u/my_opt.py:MyOpt", 5, 1)
    assert safe_name("../x") == "%2E.%2Fx"


def test_a_store_with_a_colon_in_a_record_name_is_read_and_resumed(tmp_path):
    """A record an earlier version stored as ``paper__mod:Cls__b5__s1.json`` is read under its new
    key, counts as done for a study started again, and a rewrite of that run leaves one record."""
    import dataclasses

    from femu.studies.study import run_study

    store = tmp_path / "s"
    run_study("random-search", "0", 10, store, workers=0)
    (new,) = Store(store).runs_dir.glob("*.json")
    rec = json.loads(new.read_text())
    rec["optimizer"] = "sample_plugins:TinyES"
    del rec["mac"]  # an earlier version's record: written before records carried a MAC
    key = run_key(rec["variant"], rec["optimizer"], rec["budget"], rec["seed"])
    assert ":" not in key
    legacy = new.parent / (key.replace("%3A", ":") + ".json")
    legacy.write_text(json.dumps(rec))
    new.unlink()
    s = Store(store)
    assert s.keys() == {key} and s.read(key).optimizer == "sample_plugins:TinyES"
    assert s.record_path(key) == legacy
    s.write(dataclasses.replace(s.read(key)))
    assert sorted(p.name for p in s.runs_dir.glob("*.json")) == [key + ".json"]


# -- femu reproduce, with installed plugins --------------------------------------------------------
ENTRY_POINTS = {"prints-a-lot": "PrintsALot", "hangs": "Hangs", "../../../../escaped": "ClaimsBudgetSpent",
                "from-scratch": "BuildsTheProblemFromScratch"}


def _install_plugins(site: Path) -> None:
    """A distribution with entry points in group femu.optimizers, found on the path (as pip installs it)."""
    info = site / "femu_cheats-0.1.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: femu-cheats\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(
        "[femu.optimizers]\n" + "".join(f"{k} = cheating_plugins:{v}\n" for k, v in ENTRY_POINTS.items()))


def test_femu_reproduce_keeps_its_json_clean_stops_a_hanging_plugin_and_writes_only_in_its_store(tmp_path):
    site, out = tmp_path / "site", tmp_path / "deep" / "er" / "out"
    _install_plugins(site)
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE), str(site), os.environ.get("PYTHONPATH", "")]))
    done = subprocess.run([sys.executable, "-m", "femu", "reproduce", "--seeds", "1", "--budget", "100",
                           "--time-limit", "3", "--out", str(out), "--json", "--workers", "2"],
                          env=env, capture_output=True, text=True, timeout=900, cwd=tmp_path)
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads(done.stdout)  # valid JSON: nothing a plugin printed is in it
    assert "PLUGIN-" not in done.stdout + done.stderr
    solvers = result["solvers"]
    assert solvers["hangs"]["statuses"] == {"timeout": 1}
    assert solvers["../../../../escaped"]["statuses"] == {"failed": 1}
    assert solvers["from-scratch"]["statuses"] == {"failed": 1}
    assert solvers["prints-a-lot"]["statuses"] == {"ok": 1} and solvers["prints-a-lot"]["n_evals"] == 100
    store = Store(out / "store")
    runs = {r.optimizer: r for r in store.runs()}
    assert "PLUGIN-CHILD" in runs["prints-a-lot"].output
    assert all(r.verified for r in runs.values())
    # the escaped name's record is in the store, and nothing was written beside it
    assert (store.runs_dir / f"{run_key('paper', '../../../../escaped', 100, 0)}.json").exists()
    written = {p for p in tmp_path.rglob("*") if p.is_file()}
    assert all(site in p.parents or out in p.parents for p in written), sorted(map(str, written))


# -- the core a sandboxed run is pinned to ---------------------------------------------------------
def test_core_claims_spread_runs_over_the_cores_and_forget_ended_ones(tmp_path):
    """Runs sharing a worker server each take the least claimed core; a claim of a thread that
    has ended counts for nothing; a claims file that is not a regular file, or whose lock
    another process holds, is refused (the run then goes unpinned), never waited on for long."""
    from adapters.sandbox import _release_core, claim_core

    claims = str(tmp_path / "cores")
    ended = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    dead = int(ended.stdout)
    with open(claims, "w") as fh:
        fh.write(f"{dead} 0\n{dead} 0\nnot a line\n")
    mine = claim_core({0, 1, 2}, claims)  # the dead claims dropped: all free, so the core this thread is on
    other = claim_core({0, 1, 2}, claims, tid=os.getppid())  # a live process: a core nobody holds
    third = claim_core({0, 1, 2}, claims, tid=1)
    assert sorted([mine, other, third]) == [0, 1, 2]
    assert claim_core({0, 1, 2}, claims, tid=os.getpid() + 10**6) in (0, 1, 2)  # no such pid: dropped later
    _release_core(claims, tid=os.getppid())
    _release_core(claims, tid=1)
    _release_core(claims)
    assert open(claims).read() == ""  # every live claim released, the dead one dropped
    holder = subprocess.Popen([sys.executable, "-c", "import fcntl, sys, time; fh = open(sys.argv[1]); "
                               "fcntl.flock(fh, fcntl.LOCK_EX); print('locked', flush=True); time.sleep(30)", claims],
                              stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline() == "locked\n"
        with pytest.raises(BlockingIOError):  # a lock somebody holds: given up after CLAIMS_LOCK_S
            claim_core({0, 1}, claims)
    finally:
        holder.kill()
        holder.wait()
    os.unlink(claims)
    os.mkfifo(claims)
    with pytest.raises(OSError, match="not a regular file"):
        claim_core({0, 1}, claims)


def test_a_parallel_studys_runs_are_pinned_to_different_cores(tmp_path):
    """`femu study --workers 2`: the two runs under way at once (each optimizer with its
    evaluating process on one core) are on two cores, not both on the core they started on."""
    allowed = os.sched_getaffinity(0)
    store, barrier = tmp_path / "s", tmp_path / "barrier"
    barrier.mkdir()
    done = _femu("study", "--optimizers", "sample_plugins:PrintsItsCores", "--seeds", "0-1", "--budget", "20",
                 "--store", str(store), "--workers", "2", "--no-progress",
                 FEMU_CORE_CLAIMS=str(tmp_path / "cores"),  # this study's claims only: no other session's
                 FEMU_TEST_BARRIER=str(barrier))  # both runs under way at once (sample_plugins.PrintsItsCores)
    assert done.returncode == 0, done.stderr
    runs = list(Store(store).runs())
    cores = [json.loads(r.output.split("CORES ")[1].splitlines()[0]) for r in runs]
    assert len(runs) == 2 and all(r.status == "ok" and r.verified for r in runs), [r.error for r in runs]
    assert all(len(c) == 1 and c[0] in allowed for c in cores), cores
    assert len({c[0] for c in cores}) == min(2, len(allowed)), cores


def test_processes_with_worker_servers_of_their_own_share_the_core_claims(tmp_path):
    """Two processes that each start their own worker server (as each Dask worker process does)
    claim their cores in one file: their runs under way at once are on two cores."""
    allowed = os.sched_getaffinity(0)
    code = ("import adapters; from adapters.variants import make_problem; "
            "r = adapters.run('sample_plugins:PrintsItsCores', make_problem('paper'), 20, 0); "
            "print(r.status, r.output.split('CORES ')[1].splitlines()[0], flush=True)")
    (tmp_path / "barrier").mkdir()
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE), os.environ.get("PYTHONPATH", "")]),
               FEMU_CORE_CLAIMS=str(tmp_path / "cores"), FEMU_TEST_BARRIER=str(tmp_path / "barrier"))
    procs = [subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True) for _ in range(2)]
    outs = [p.communicate(timeout=600) for p in procs]
    assert all(p.returncode == 0 for p in procs), outs
    status = [out.split(" ", 1) for out, _ in outs]
    assert all(s == "ok" for s, _ in status), outs
    cores = [json.loads(c) for _, c in status]
    assert all(len(c) == 1 and c[0] in allowed for c in cores), cores
    assert len({c[0] for c in cores}) == min(2, len(allowed)), cores
