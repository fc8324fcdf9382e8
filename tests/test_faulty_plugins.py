"""Plugins that try to spend more than their budget, or die in every way a process can: each
gets an honest record (failed, timeout or ok with exactly its budget), nothing is lost, and
nothing a plugin started outlives its run. Also: two studies on one store never run a run
twice, and damaged run records are named with what to do.

The plugins are classes of this module, reached in worker processes as "module:Class"."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import psutil
import pytest

import adapters
from adapters.variants import make_problem
from femu.cli import main
from femu.studies.store import Store
from femu.studies.study import run_study


def plugin(cls) -> str:
    return f"{__name__}:{cls.__name__}"


def _points(bounds, rng, n):
    return rng.uniform(*bounds, size=(n, len(bounds[0])))


# -- plugins that try to spend more than their budget ------------------------------------------
class UsesTheProblemBehind:
    def minimize(self, objective, bounds, budget, rng):
        objective.problem.evaluate(_points(bounds, rng, 5000))


class ReachesTheProblemThroughAClosure:
    def minimize(self, objective, bounds, budget, rng):
        cells = [c.cell_contents for c in objective._evaluate.__closure__]
        evaluate = next(c for c in cells if callable(c))
        evaluate(_points(bounds, rng, 500))
        objective(_points(bounds, rng, 1))


class FindsTheProblemAndResetsItsCount:
    """Finds the problem among all live objects, evaluates behind the harness and sets the
    problem's own public counter back."""

    def minimize(self, objective, bounds, budget, rng):
        import gc

        problem = next(o for o in gc.get_objects() if type(o).__name__ == "UpdatingProblem")
        problem.evaluate(_points(bounds, rng, 500))
        problem.n_evals = 0
        objective(_points(bounds, rng, 1))


class ResetsTheCounter:
    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 100))
        objective.n_evals = 0


class ResetsTheHiddenCounter:
    def minimize(self, objective, bounds, budget, rng):
        for _ in range(5):
            objective._n_evals = 0
            objective(_points(bounds, rng, 100))


class RaisesItsBudget:
    def minimize(self, objective, bounds, budget, rng):
        objective._budget = 10**6
        objective(_points(bounds, rng, 500))


class WritesTheBudget:
    def minimize(self, objective, bounds, budget, rng):
        objective.budget = 10**6


class AsksForTooMuch:
    """One batch far larger than its budget: the rows that fit are evaluated, no more."""

    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 10 * budget))


class ReturnsGarbage:
    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 7))
        return "garbage"


class SendsBadPoints:
    def minimize(self, objective, bounds, budget, rng):
        objective(np.ones((3, 5)))


class CallsSysExit:
    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 4))
        sys.exit(3)


class ReplacesTheRecorder:
    """Shadows the objective's bookkeeping method, so that its evaluations are not charged."""

    def minimize(self, objective, bounds, budget, rng):
        objective._record = lambda X, f: None
        for _ in range(5):
            objective(_points(bounds, rng, 100))


class SwallowsTheStopSignal:
    """Catches the end of the budget and keeps asking: each further call is refused unevaluated."""

    def minimize(self, objective, bounds, budget, rng):
        for _ in range(10):
            try:
                objective(_points(bounds, rng, 200))
            except adapters.BudgetExhausted:
                pass


class SendsNaN:
    def minimize(self, objective, bounds, budget, rng):
        X = _points(bounds, rng, 4)
        X[2, 3] = np.nan
        objective(X)


class SendsPointsOutOfBounds:
    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 2) * 1e3)


class RaisesInItsOwnCode:
    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 6))
        return 1 / 0


class Cancelled(BaseException):
    """An exception outside Exception, as some async and test libraries raise."""


class RaisesABaseException:
    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 2))
        raise Cancelled("cancelled by its own library")


@pytest.mark.parametrize("cls,status,says,n_evals", [
    (UsesTheProblemBehind, "failed", "has no attribute 'problem'", 0),
    (ReachesTheProblemThroughAClosure, "failed", "budget bypassed: the problem evaluated 501 points but the run was "
                                                 "charged 1", 1),
    (ResetsTheCounter, "failed", "'n_evals' is read-only", 100),
    (FindsTheProblemAndResetsItsCount, "failed", "budget bypassed: the problem evaluated 501 points but the run was "
                                                 "charged 1", 1),
    (ResetsTheHiddenCounter, "failed", "budget bypassed: the problem evaluated 500 points but the run was "
                                       "charged 100", 100),
    (RaisesItsBudget, "failed", "budget overrun: 500 evaluations charged against a budget of 300", 500),
    (WritesTheBudget, "failed", "'budget' is read-only", 0),
    (AsksForTooMuch, "ok", None, 300),
    (ReturnsGarbage, "stopped", None, 7),
    (SendsBadPoints, "failed", "ValueError", 0),
    (CallsSysExit, "failed", "SystemExit: the optimizer called sys.exit(3)", 4),
    (ReplacesTheRecorder, "failed", "budget bypassed: the problem evaluated 500 points but the run was charged 0", 0),
    (SwallowsTheStopSignal, "ok", None, 300),
    (SendsNaN, "failed", "ValueError", 0),
    (SendsPointsOutOfBounds, "failed", "ValueError", 0),
    (RaisesInItsOwnCode, "failed", "ZeroDivisionError", 6),
    (RaisesABaseException, "failed", "Cancelled: cancelled by its own library", 2),
])
def test_a_plugin_gets_the_record_it_earned(cls, status, says, n_evals):
    r = adapters.run(plugin(cls), make_problem("paper"), 300, 0)
    assert r.status == status, r.error
    assert r.n_evals == n_evals
    assert (says is None and r.error is None) or says in r.error


def test_the_objective_exposes_no_problem_and_only_read_only_counters():
    objective = adapters.BudgetedObjective(make_problem("paper"), 10)
    assert not hasattr(objective, "problem")
    for name in adapters.BudgetedObjective.READ_ONLY:
        with pytest.raises(AttributeError):
            setattr(objective, name, 0)
    xl, _ = objective.bounds
    xl[:] = 0.0  # a copy: the box the harness checks is not the plugin's to change
    assert np.all(objective.bounds[0] > 0)


# -- plugins that end their process -------------------------------------------------------------
class ExitsHard:
    def minimize(self, objective, bounds, budget, rng):
        objective(_points(bounds, rng, 3))
        os._exit(7)


class Segfaults:
    def minimize(self, objective, bounds, budget, rng):
        os.kill(os.getpid(), signal.SIGSEGV)


class Interrupted:
    def minimize(self, objective, bounds, budget, rng):
        raise KeyboardInterrupt


class SpawnsAndHangs:
    """Starts a process of its own (as a solver binary would), writes its pid, and hangs."""

    def minimize(self, objective, bounds, budget, rng, pid_file):
        child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(600)"])
        Path(pid_file).write_text(str(child.pid))
        time.sleep(600)


def test_a_plugin_that_ends_its_process_leaves_a_failed_record_and_the_study_goes_on(tmp_path):
    names = [plugin(ExitsHard), plugin(Segfaults), plugin(Interrupted), "random-search"]
    res = run_study(names, "0", 100, tmp_path / "s", workers=2, progress=False)
    runs = {r.optimizer: r for r in res.runs}
    for name in names[:2]:
        assert runs[name].status == "failed" and "exited with code" in runs[name].error, runs[name].error
    # a KeyboardInterrupt no Ctrl-C caused is the plugin's: a failed run, its evaluations kept
    interrupted = runs[names[2]]
    assert interrupted.status == "failed" and interrupted.error.startswith("KeyboardInterrupt: raised by the optimizer")
    assert runs["random-search"].status == "ok" and runs["random-search"].n_evals == 100
    assert len(Store(tmp_path / "s").runs()) == 4


def test_a_timed_out_plugin_takes_its_own_processes_with_it(tmp_path):
    pid_file = tmp_path / "child.pid"
    res = run_study([plugin(SpawnsAndHangs)], "0", 100, tmp_path / "s", workers=1, time_limit_s=1.0, progress=False,
                    options={plugin(SpawnsAndHangs): {"pid_file": str(pid_file)}})
    assert res.runs[0].status == "timeout", res.runs[0].error
    pid = int(pid_file.read_text())
    deadline = time.time() + 10
    while psutil.pid_exists(pid) and psutil.Process(pid).status() != psutil.STATUS_ZOMBIE and time.time() < deadline:
        time.sleep(0.1)
    assert not psutil.pid_exists(pid) or psutil.Process(pid).status() == psutil.STATUS_ZOMBIE


# -- one store, two studies ---------------------------------------------------------------------
def test_two_studies_on_one_store_never_run_a_run_twice(tmp_path):
    store = tmp_path / "s"
    argv = [sys.executable, "-m", "femu", "study", "--optimizers", "random-search,deap-ga", "--seeds", "0-5",
            "--budget", "3000", "--store", str(store), "--workers", "1", "--no-progress"]
    procs = [subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for _ in range(2)]
    outs = [p.communicate(timeout=600) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], outs
    new = [int(out.split("(")[1].split(" new")[0]) for out, _ in outs]
    assert sum(new) == 12, outs  # every run done once, by one of the two
    assert sorted(Store(store).keys()) == sorted(
        f"paper__{o}__b3000__s{s}" for o in ("random-search", "deap-ga") for s in range(6))
    assert not list((store / "runs").glob("*.claim"))


def test_a_claim_left_by_a_killed_study_is_taken_over(tmp_path):
    store = Store(tmp_path / "s")
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    claim = store.runs_dir / "paper__random-search__b50__s0.claim"
    claim.parent.mkdir(parents=True)
    import socket
    claim.write_text(json.dumps({"pid": dead.pid, "host": socket.gethostname()}))
    with pytest.warns(UserWarning, match=f"claimed by process {dead.pid}, which ended without recording it"):
        res = run_study("random-search", "0", 50, store, workers=0, progress=False)
    assert res.n_new == 1 and res.n_elsewhere == 0 and not claim.exists()


def test_a_claim_of_a_live_process_is_left_to_it(tmp_path):
    store = Store(tmp_path / "s")
    claim = store.runs_dir / "paper__random-search__b50__s1.claim"
    claim.parent.mkdir(parents=True)
    import socket
    claim.write_text(json.dumps({"pid": os.getppid(), "host": socket.gethostname()}))
    res = run_study("random-search", "0-2", 50, store, workers=0, progress=False)
    assert res.n_new == 2 and res.n_elsewhere == 1 and len(res.runs) == 2
    assert "1 runs left to another process" in res.summary()
    assert claim.exists()


# -- damaged and hand-edited run records -----------------------------------------------------------
EDITS = [
    ({"best_f": "abc"}, "field 'best_f'"),
    ({"best_f": -1}, "field 'best_f'"),
    ({"trace": "garbage"}, "field 'trace'"),
    ({"trace": [[5, 1.0], [3, 0.5]]}, "field 'trace'"),
    ({"budget": "3000"}, "field 'budget'"),
    ({"n_evals": -5}, "field 'n_evals'"),
    ({"n_evals": 51}, "field 'n_evals'"),
    ({"status": "weird"}, "field 'status'"),
    ({"seed": 7}, "not the file's name"),
    ({"optimizer": 3}, "field 'optimizer'"),
    ({"best_x": ["a"]}, "field 'best_x'"),
    ({"wall_s": -1}, "field 'wall_s'"),
    ({"format": "femu.run/9"}, "field 'format'"),
    ({"fe_cpu_s": "fast"}, "field 'fe_cpu_s'"),
    ({"n_jacobians": -1}, "field 'n_jacobians'"),
    ({"x0": "some"}, "field 'x0'"),
]


@pytest.mark.parametrize("edit,says", EDITS, ids=[str(e) for e, _ in EDITS])
def test_a_hand_edited_record_is_named_with_a_redo_hint_and_skipped_when_asked(tmp_path, capsys, edit, says):
    store = tmp_path / "s"
    run_study("random-search", "0-1", 50, store, workers=0, progress=False)
    bad = store / "runs" / "paper__random-search__b50__s1.json"
    bad.write_text(json.dumps({**json.loads(bad.read_text()), **edit}))
    for argv in (["results", str(store)], ["report", str(store), "--out", str(tmp_path / "r")]):
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert len(err.strip().splitlines()) == 1 and str(bad) in err and says in err, err
        assert "delete the file and run the same `femu study` command again" in err and "--skip-invalid" in err
    assert main(["results", str(store), "--skip-invalid", "--json"]) == 0
    out, err = capsys.readouterr()
    assert [r["seed"] for r in json.loads(out)] == [0]
    assert "warning: left out" in err and str(bad) in err
    assert main(["report", str(store), "--out", str(tmp_path / "r"), "--skip-invalid"]) == 0
    assert (tmp_path / "r" / "report.md").exists()


# -- a damaged study manifest ----------------------------------------------------------------------
MANIFEST_EDITS = [
    ({"format": "femu.study/7"}, "field 'format'"),
    ({"seeds": "0-9"}, "field 'seeds'"),
    ({"seeds": [0, -3]}, "field 'seeds'"),
    ({"budget": 0}, "field 'budget'"),
    ({"budget": 1.5}, "field 'budget'"),
    ({"optimizers": [3]}, "field 'optimizers'"),
    ({"variants": None}, "field 'variants'"),
    ({"time_limit_s": -2}, "field 'time_limit_s'"),
    ({"options": [1]}, "field 'options'"),
    ({"retry_failed": "yes"}, "field 'retry_failed'"),
    ({"started": "yesterday"}, "field 'started'"),
    ({"executor": None}, "field 'executor'"),
    ({"versions": {"numpy": 2}}, "field 'versions'"),
    ({"history": "none"}, "field 'history'"),
    ({"history": [{"optimizers": ["random-search"]}]}, "field 'history[0].seeds': missing"),
    ({"history": [7]}, "field 'history[0]'"),
]


@pytest.mark.parametrize("edit,says", MANIFEST_EDITS, ids=[str(e) for e, _ in MANIFEST_EDITS])
def test_a_damaged_manifest_is_named_and_never_overwritten(tmp_path, capsys, edit, says):
    store = tmp_path / "s"
    argv = ["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "50", "--store", str(store),
            "--workers", "0", "--no-progress"]
    assert main(argv) == 0
    manifest = store / "study.json"
    manifest.write_text(json.dumps({**json.loads(manifest.read_text()), **edit}))
    before = manifest.read_bytes()
    capsys.readouterr()
    assert main(argv[:4] + ["0-1"] + argv[5:]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and str(manifest) in err and says in err, err
    assert "the runs are kept" in err
    assert manifest.read_bytes() == before and not (store / "runs" / "paper__random-search__b50__s1.json").exists()


def test_a_manifest_of_an_earlier_version_without_optional_fields_is_read(tmp_path):
    store = tmp_path / "s"
    run_study("random-search", "0", 50, store, workers=0, progress=False)
    manifest = store / "study.json"
    old = {k: v for k, v in json.loads(manifest.read_text()).items()
           if k not in ("suite", "time_limit_s", "options", "retry_failed", "host", "versions", "history")}
    manifest.write_text(json.dumps(old))
    res = run_study("random-search", "0-1", 50, store, workers=0, progress=False)
    assert res.n_new == 1
    assert json.loads(manifest.read_text())["history"][0]["seeds"] == [0]
