"""Plugins that try to spend more than their budget, or die in every way a process can: each
gets an honest record (failed, timeout or ok with exactly its budget), nothing is lost, and
nothing a plugin started outlives its run. Also: two studies on one store never run a run
twice, and damaged run records are named with what to do.

Each optimizer runs in a worker process without the problem (adapters.sandbox): a cheat that
reached the problem in the evaluating process finds nothing there, and one that tampers with
its objective changes only its own copy, so it gains nothing (status ok, exactly its budget, the
problem evaluated exactly the points charged). In the problem's own process (isolated=False,
for debugging) the harness's cross-checks still catch them.

The plugins are classes of tests/sample_plugins.py, reached in worker processes as "module:Class"."""

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
from sample_plugins import (AsksForTooMuch, CallsSysExit, ExitsHard, FindsTheProblemAndResetsItsCount, Interrupted,
                            RaisesABaseException, RaisesInItsOwnCode, RaisesItsBudget, ReachesTheProblemThroughAClosure,
                            ReplacesTheRecorder, ResetsTheCounter, ResetsTheHiddenCounter, ReturnsGarbage, Segfaults,
                            SendsBadPoints, SendsNaN, SendsPointsOutOfBounds, SpawnsAndHangs, SwallowsTheStopSignal,
                            UsesTheProblemBehind, WritesTheBudget)


def plugin(cls) -> str:
    return f"{cls.__module__}:{cls.__name__}"


# -- plugins that try to spend more than their budget ------------------------------------------
ISOLATED = [
    (UsesTheProblemBehind, "failed", "has no attribute 'problem'", 0),
    (ReachesTheProblemThroughAClosure, "failed", "has no attribute '_evaluate'", 0),
    (ResetsTheCounter, "failed", "'n_evals' is read-only", 100),
    (FindsTheProblemAndResetsItsCount, "failed", "StopIteration", 0),  # no problem among the worker's objects
    (ResetsTheHiddenCounter, "ok", None, 300),  # its own copy of the count: every point was charged
    (RaisesItsBudget, "ok", None, 300),  # its own copy of the budget: 300 of its 500 points evaluated
    (WritesTheBudget, "failed", "'budget' is read-only", 0),
    (AsksForTooMuch, "ok", None, 300),
    (ReturnsGarbage, "stopped", None, 7),
    (SendsBadPoints, "failed", "ValueError", 0),
    (CallsSysExit, "failed", "SystemExit: the optimizer called sys.exit(3)", 4),
    (ReplacesTheRecorder, "ok", None, 300),  # the recorder it replaced is not the one that counts
    (SwallowsTheStopSignal, "ok", None, 300),
    (SendsNaN, "failed", "ValueError", 0),
    (SendsPointsOutOfBounds, "failed", "ValueError", 0),
    (RaisesInItsOwnCode, "failed", "ZeroDivisionError", 6),
    (RaisesABaseException, "failed", "Cancelled: cancelled by its own library", 2),
]


@pytest.mark.parametrize("cls,status,says,n_evals", ISOLATED, ids=[c[0].__name__ for c in ISOLATED])
def test_a_sandboxed_plugin_gets_the_record_it_earned_and_nothing_more(cls, status, says, n_evals):
    problem = make_problem("paper")
    r = adapters.run(plugin(cls), problem, 300, 0)
    assert r.status == status, r.error
    assert r.n_evals == n_evals
    assert (says is None and r.error is None) or says in r.error
    assert r.verified
    assert problem.points_evaluated == n_evals  # nothing evaluated that was not charged


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
def test_in_the_problems_process_the_harness_catches_what_a_plugin_earned(cls, status, says, n_evals):
    r = adapters.run(plugin(cls), make_problem("paper"), 300, 0, isolated=False)
    assert not r.verified
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
    (tmp_path / "pids").mkdir()  # not beside the store: a directory that holds a store is list-only to workers
    pid_file = tmp_path / "pids" / "child.pid"
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
