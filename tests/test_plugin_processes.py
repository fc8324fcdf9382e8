"""Plugins that end or interrupt the process they run in, or leave processes of their own:
in this process (``--workers 0``) a plugin's KeyboardInterrupt or sys.exit() is a failed run
and the study goes on, a real Ctrl-C stops the study with its finished runs kept, and a plugin
that ends the process (os._exit, a segfault) loses only its own run, which the next study on
the store runs again (its claim is stale, with a warning). In worker processes, the processes a
plugin started end with its run.

The plugins are classes of this module and of test_faulty_plugins, reached as "module:Class"
(also by `femu` programs started with this directory on PYTHONPATH)."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest

from femu.cli import main
from femu.studies.store import Store, run_key
from femu.studies.study import run_study
from sample_plugins import CallsSysExit, ExitsHard, Interrupted, Segfaults, SleepsLong, SpawnsAndReturns

HERE = Path(__file__).parent


def plugin(cls) -> str:
    return f"{cls.__module__}:{cls.__name__}"


def _points(bounds, rng, n):
    return rng.uniform(*bounds, size=(n, len(bounds[0])))


def _femu(*args, **kw) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE), os.environ.get("PYTHONPATH", "")]))
    return subprocess.Popen([sys.executable, "-m", "femu", *args], env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kw)


def _study_args(optimizers: str, store: Path, workers: str) -> list[str]:
    return ["study", "--optimizers", optimizers, "--seeds", "0", "--budget", "100", "--store", str(store),
            "--workers", workers, "--no-progress"]


def test_in_process_a_plugins_interrupt_and_exit_are_failed_runs_and_the_study_goes_on(tmp_path, capsys):
    names = [plugin(Interrupted), plugin(CallsSysExit), "random-search"]
    assert main(_study_args(",".join(names), tmp_path / "s", "0")) == 0
    assert "3 runs in" in capsys.readouterr().out
    runs = {r.optimizer: r for r in Store(tmp_path / "s").runs()}
    assert (runs[names[0]].status, runs[names[0]].n_evals) == ("failed", 0)
    assert runs[names[0]].error == "KeyboardInterrupt: raised by the optimizer (no Ctrl-C was pressed)"
    assert (runs[names[1]].status, runs[names[1]].n_evals) == ("failed", 4)
    assert runs[names[1]].error == "SystemExit: the optimizer called sys.exit(3)"
    assert (runs["random-search"].status, runs["random-search"].n_evals) == ("ok", 100)


def test_in_process_a_real_ctrl_c_stops_the_study_and_keeps_what_is_finished(tmp_path, ctrl_c_is_pythons):
    store = tmp_path / "s"
    p = _femu(*_study_args(f"random-search,{plugin(SleepsLong)}", store, "0"))
    claim = store / "runs" / f"{run_key('paper', plugin(SleepsLong), 100, 0)}.claim"
    done = store / "runs" / "paper__random-search__b100__s0.json"  # the run before it is finished
    deadline = time.time() + 120
    while not (claim.exists() and done.exists()) and time.time() < deadline:
        time.sleep(0.1)
    time.sleep(1.0)  # the run is in its sleep
    p.send_signal(signal.SIGINT)
    try:
        out, err = p.communicate(timeout=60)
    except subprocess.TimeoutExpired:  # not left running into the tests after this one
        p.kill()
        out, err = p.communicate()
        pytest.fail(f"the study did not stop within 60 s of its Ctrl-C: {out!r} {err!r}")
    assert p.returncode == 130, (out, err)
    assert "interrupted; the finished runs are in" in err and "Traceback" not in err, err
    assert [r.optimizer for r in Store(store).runs()] == ["random-search"]
    assert not claim.exists()


@pytest.mark.parametrize("cls,code,n_evals", [(ExitsHard, 7, 3), (Segfaults, -signal.SIGSEGV, 0)])
def test_in_process_a_plugin_that_ends_its_process_ends_only_its_worker(tmp_path, cls, code, n_evals):
    """With --workers 0 the study runs in this process, but every optimizer in a worker of its own
    (adapters.sandbox): a plugin's os._exit or segfault ends its worker, not the study (before the
    sandbox it ended the study); its evaluations until then are kept, its claim released."""
    store = tmp_path / "s"
    first = _femu(*_study_args(f"random-search,{plugin(cls)}", store, "0"))
    out, err = first.communicate(timeout=300)
    assert first.returncode == 0, (out, err)
    assert "(2 new, 0 kept): 1 ok, 1 failed" in out
    runs = {r.optimizer: r for r in Store(store).runs()}
    assert runs[plugin(cls)].status == "failed" and f"exited with code {code}" in runs[plugin(cls)].error
    assert runs[plugin(cls)].n_evals == n_evals and runs[plugin(cls)].verified
    assert not list((store / "runs").glob("*.claim"))


def test_a_study_killed_mid_run_leaves_a_stale_claim_that_the_next_study_retakes(tmp_path):
    store = tmp_path / "s"
    p = _femu(*_study_args(f"random-search,{plugin(SleepsLong)}", store, "0"))
    claim = store / "runs" / f"{run_key('paper', plugin(SleepsLong), 100, 0)}.claim"
    done = store / "runs" / "paper__random-search__b100__s0.json"
    deadline = time.time() + 120
    while not (claim.exists() and done.exists()) and time.time() < deadline:
        time.sleep(0.1)
    time.sleep(0.5)
    p.kill()  # kill -9: no clean-up runs
    p.communicate(timeout=60)
    assert claim.exists() and json.loads(claim.read_text())["pid"] == p.pid
    again = _femu(*_study_args(f"random-search,{plugin(SleepsLong)}", store, "1") + ["--time-limit", "2"])
    out, err = again.communicate(timeout=300)
    assert again.returncode == 0, (out, err)
    assert f"was claimed by process {p.pid}, which ended without recording it" in err
    runs = {r.optimizer: r for r in Store(store).runs()}
    assert runs[plugin(SleepsLong)].status == "timeout" and runs[plugin(SleepsLong)].n_evals == 2
    assert not list((store / "runs").glob("*.claim"))


def test_a_worker_ends_the_processes_its_plugin_left_behind(tmp_path):
    (tmp_path / "pids").mkdir()  # not beside the store: a directory that holds a store is list-only to workers
    pid_file = tmp_path / "pids" / "child.pid"
    res = run_study([plugin(SpawnsAndReturns)], "0", 50, tmp_path / "s", workers=1, progress=False,
                    options={plugin(SpawnsAndReturns): {"pid_file": str(pid_file)}})
    assert res.runs[0].status == "stopped" and res.runs[0].n_evals == 2, res.runs[0].error
    pid = int(pid_file.read_text())
    assert not psutil.pid_exists(pid) or psutil.Process(pid).status() == psutil.STATUS_ZOMBIE


def test_a_claim_whose_pid_now_belongs_to_another_process_is_stale(tmp_path):
    """A pid is reused once its process is gone: the claim records its owner's start time."""
    store = Store(tmp_path / "s")
    claim = store.runs_dir / "paper__random-search__b50__s0.claim"
    claim.parent.mkdir(parents=True)
    import socket

    me = psutil.Process()
    claim.write_text(json.dumps({"pid": me.pid, "host": socket.gethostname(), "started": me.create_time() - 100}))
    with pytest.warns(UserWarning, match=f"was claimed by process {me.pid}, which ended"):
        res = run_study("random-search", "0", 50, store, workers=0, progress=False)
    assert res.n_new == 1 and not claim.exists()
    claim.write_text(json.dumps({"pid": me.pid, "host": socket.gethostname(), "started": me.create_time()}))
    res = run_study("random-search", "0", 60, store, workers=0, progress=False)  # another run: not claimed
    assert res.n_new == 1 and claim.exists()
    assert store.claim("paper__random-search__b50__s0") is False  # the live owner's claim is kept


def test_the_cli_says_what_a_module_class_name_does_and_where_optimizers_run():
    from femu.cli import build_parser

    sub = build_parser()._subparsers._group_actions[0].choices["study"]
    text = " ".join(sub.format_help().split())
    assert "imports that module, and so runs its top-level code" in text
    assert "0: run in this process (each optimizer still runs in a worker process of its own" in text
    assert "--time-limit TIME_LIMIT wall-clock seconds per run" in text and "(default: 3600.0)" in text
