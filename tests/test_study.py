"""Studies: the grid, the executors (in-process, local pool, Dask), the store, resume after a
kill, failures and hangs, progress, and the `femu study` / `femu results` commands.

The mechanics use random-search with small budgets; failure and hang cases use plugins
defined here, reached in worker processes through their import path "module:Class"."""

import json
import math
import multiprocessing
import os
import pty
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import adapters

from adapters import run
from femu.cli import main
from femu.studies.store import Store
from femu.studies.study import parse_seeds, run_study
from adapters.variants import make_problem
from sample_plugins import Hangs, HangsTellingPid, hang_was_ended, NeedsFifty, Raises, ReturnsNaN, Slow

FEMU = [str(Path(sys.executable).parent / "femu")]


# -- plugins for failure cases -------------------------------------------------------------


class _NaNProblem:
    """A problem whose evaluations come back NaN (a broken model)."""

    n_var, xl, xu, name = 3, np.zeros(3), np.ones(3), "nan-problem"

    def evaluate(self, X):
        return np.full(len(X), np.nan)


def plugin(cls) -> str:
    return f"{cls.__module__}:{cls.__name__}"


SAME = ("optimizer", "variant", "seed", "budget", "n_evals", "best_f", "best_x", "trace", "status", "options")


def essentials(runs):
    return [{k: getattr(r, k) for k in SAME} for r in runs]


def snapshot(store: Path) -> dict:
    """Every file in a store: bytes and mtime."""
    return {p.relative_to(store): (p.read_bytes(), p.stat().st_mtime_ns)
            for p in sorted(store.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def dask_address():
    from dask.distributed import LocalCluster

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    yield cluster.scheduler_address
    cluster.close()


# -- input ---------------------------------------------------------------------------------
def test_seed_specs():
    assert parse_seeds("0-29") == list(range(30))
    assert parse_seeds("0,3,7") == [0, 3, 7]
    assert parse_seeds(" 0-2, 10 ") == [0, 1, 2, 10]
    assert parse_seeds([4, np.int64(2)]) == [4, 2]


@pytest.mark.parametrize("spec, says", [
    ("5-2", "runs backwards"), ("a", "'a' is not a seed"), ("-1", "'-1' is not a seed"),
    ("", "empty seed"), ("1,,2", "empty seed"), ("0-3,2", "seed 2 is given twice"), ("1.5", "not a seed")])
def test_bad_seeds_exit_2_with_one_line(tmp_path, capsys, spec, says):
    store = tmp_path / "s"
    assert main(["study", "--optimizers", "random-search", "--seeds", spec, "--budget", "10",
                 "--store", str(store), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("femu study: error: --seeds") and says in err
    assert not store.exists()


@pytest.mark.parametrize("args, says", [
    (["--optimizers", "nope"], "unknown optimizer 'nope'; available: pymoo-ga"),
    (["--optimizers", "random-search,random-search"], "'random-search' is given twice"),
    (["--optimizers", "no_such_module:X"], "cannot import 'X' from module 'no_such_module'"),
    (["--optimizers", f"{NeedsFifty.__module__}:NeedsFifty", "--budget", "49"], "needs at least 50 evaluations"),
    (["--budget", "0"], "--budget: must be an integer >= 1"),
    (["--variants", "paper,moon"], "unknown problem variant 'moon'; available: paper, synthetic"),
    (["--time-limit", "0"], "--time-limit: must be a positive number"),
    (["--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "exclude each other"),
    (["--workers", "-1"], "--workers: must be an integer >= 0"),
    (["--scheduler", "nonsense://x"], "--scheduler nonsense://x: unknown address scheme 'nonsense'"),
])
def test_bad_study_input_exits_2_before_anything_runs(tmp_path, capsys, args, says):
    store = tmp_path / "s"
    base = {"--optimizers": "random-search", "--seeds": "0-1", "--budget": "10", "--store": str(store)}
    for flag, value in zip(args[::2], args[1::2]):
        base[flag] = value
    assert main(["study", *[x for kv in base.items() for x in kv], "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and says in err, err
    assert not store.exists()


def test_store_that_is_a_file(tmp_path, capsys):
    f = tmp_path / "store.txt"
    f.write_text("not a store")
    assert main(["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "10",
                 "--store", str(f), "--no-progress"]) == 2
    assert f"{f}: a store is a directory, this is a file" in capsys.readouterr().err
    assert main(["results", str(f)]) == 2
    assert "a store is a directory" in capsys.readouterr().err
    assert f.read_text() == "not a store"


@pytest.mark.parametrize("content", ['{"optimizer": "random-search", "seed": 1, "bud', '"abc"', "[]", "{}"])
def test_corrupt_run_file_is_named_and_nothing_is_touched(tmp_path, capsys, content):
    store = tmp_path / "s"
    run_study("random-search", "0-1", 50, store, workers=0, progress=False)
    bad = store / "runs" / "paper__random-search__b50__s1.json"
    bad.write_text(content)  # half-written, or not a record
    before = snapshot(store)
    argv = ["study", "--optimizers", "random-search", "--seeds", "0-3", "--budget", "50", "--store", str(store),
            "--no-progress"]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and f"{bad}: not a readable run record" in err
    assert main(["results", str(store), "--json"]) == 2
    assert f"{bad}: not a readable run record" in capsys.readouterr().err
    assert snapshot(store) == before


def test_changed_options_on_resume_are_refused(tmp_path):
    store = tmp_path / "s"
    res = run_study(["random-search"], [0], 60, store, workers=0, progress=False,
                    options={"random-search": {"batch_size": 7}})
    assert res.runs[0].options == {"batch_size": 7} and res.runs[0].n_evals == 60
    assert res.runs[0].trace[0][0] <= 7  # the first improvement comes from the first batch of 7
    with pytest.raises(ValueError, match=r"b60__s0.json: stored with options \{'batch_size': 7\}, asked for \{\}"):
        run_study(["random-search"], [0], 60, store, workers=0, progress=False)
    with pytest.raises(ValueError, match="options given for 'cma-es', which is not among"):
        run_study(["random-search"], [0], 60, store, workers=0, progress=False, options={"cma-es": {}})


# -- executors give the same records -------------------------------------------------------
def test_same_seed_same_record_in_process_in_pool_and_on_dask(tmp_path, dask_address):
    grid = dict(optimizers="random-search", seeds="3,11", budget=200, variants=("paper", "synthetic"), progress=False)
    inproc = run_study(store=tmp_path / "a", workers=0, **grid)
    pool = run_study(store=tmp_path / "b", workers=2, **grid)
    dask = run_study(store=tmp_path / "c", scheduler=dask_address, **grid)
    # with a time limit each Dask run goes through a child interpreter and JSON (seed 3 only: a
    # Python start per run)
    dask_child = run_study(store=tmp_path / "d", scheduler=dask_address, time_limit_s=60,
                           **{**grid, "seeds": "3"})
    direct = [run("random-search", make_problem(v), 200, s, variant=v) for v in ("paper", "synthetic") for s in (3, 11)]

    assert [r.status for r in inproc.runs] == ["ok"] * 4
    assert len({r.best_f for r in inproc.runs}) == 4  # four different runs, not one copied
    for other in (pool, dask):
        assert essentials(other.runs) == essentials(inproc.runs)
    assert essentials(dask_child.runs) == essentials([r for r in inproc.runs if r.seed == 3])
    assert essentials(direct) == essentials(inproc.runs)
    # and what is stored is what was returned
    for res in (inproc, pool, dask, dask_child):
        assert essentials(Store(res.store).runs()) == essentials(sorted(res.runs, key=lambda r: (r.variant, r.seed)))
    assert pool.executor == "local pool, 2 workers" and dask.executor == f"Dask scheduler {dask_address}"


def test_hang_on_dask_is_killed_and_recorded(tmp_path, dask_address):
    t0 = time.perf_counter()
    # a limit long enough for random-search's 100 evaluations on a loaded machine
    res = run_study([plugin(Hangs), "random-search"], "0", 100, tmp_path / "s", scheduler=dask_address,
                    time_limit_s=2.0, progress=False)
    hang, rs = res.runs
    # stopped by the sandbox at its limit: its 2 evaluations are kept (before: lost with a killed process)
    assert hang.status == "timeout" and hang.n_evals == 2 and "time limit of 2.0 s" in hang.error, hang.error
    assert rs.status == "ok" and rs.n_evals == 100
    assert time.perf_counter() - t0 < 30


# -- failures, hangs, retry ----------------------------------------------------------------
def test_a_problem_returning_nan_fails_the_run():
    r = adapters.run("random-search", _NaNProblem(), 10, 0)
    assert r.status == "failed" and "NaN" in r.error and r.n_evals >= 1


def test_failing_plugins_are_stored_and_the_study_goes_on(tmp_path, capsys):
    store = tmp_path / "s"
    names = f"random-search,{plugin(Raises)},{plugin(ReturnsNaN)}"
    argv = ["study", "--optimizers", names, "--seeds", "0-1", "--budget", "100", "--store", str(store),
            "--workers", "2", "--no-progress"]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"femu study: 6 runs in {store} (6 new, 0 kept): 2 ok, 4 failed, 0 timeout;")
    runs = {(r.optimizer, r.seed): r for r in Store(store).runs()}
    assert len(runs) == 6
    raised, nan = runs[(plugin(Raises), 0)], runs[(plugin(ReturnsNaN), 1)]
    assert raised.status == "failed" and "RuntimeError: plugin bug" in raised.error and raised.n_evals == 5
    assert nan.status == "failed" and "'problem' is read-only" in nan.error and nan.n_evals == 0
    assert runs[("random-search", 1)].status == "ok"

    # started again: failed runs are kept as they are ...
    before = snapshot(store / "runs")
    assert main(argv) == 0
    assert "(0 new, 6 kept): 2 ok, 4 failed" in capsys.readouterr().out
    assert snapshot(store / "runs") == before
    # ... unless asked to run them again; the ok runs stay untouched
    assert main(argv + ["--retry-failed"]) == 0
    assert "(4 new, 2 kept): 2 ok, 4 failed" in capsys.readouterr().out
    after = snapshot(store / "runs")
    ok_files = [p for p in before if "random-search" in str(p)]
    assert len(ok_files) == 2 and all(after[p] == before[p] for p in ok_files)
    assert all(after[p][1] != before[p][1] for p in before if p not in ok_files)


def test_hanging_plugin_is_terminated_and_recorded_as_timeout(tmp_path):
    """No wall-clock bound on the study (a loaded machine can take any time to start processes):
    the behaviour is checked. The hung plugin is stopped by the sandbox's deadline (the error
    only that path writes), not before its limit as the evaluating side measured it, its
    evaluations kept, and its process (which would sleep an hour) is gone."""
    from adapters.sandbox import worker_deadline_s

    (tmp_path / "pids").mkdir()  # not beside the store: a directory that holds a store is list-only to workers
    pid_file = tmp_path / "pids" / "hangs.pid"
    hangs = plugin(HangsTellingPid)
    res = run_study([hangs, plugin(Slow), "random-search"], "0", 100, tmp_path / "s", workers=2,
                    time_limit_s=2.0, progress=False, options={hangs: {"pid_file": str(pid_file)}})
    hang, slow, rs = res.runs
    # stopped by the sandbox at its limit: its 2 evaluations are kept (before: lost with a killed process)
    assert hang.status == "timeout" and hang.n_evals == 2, hang.error
    stopped = re.fullmatch(r"stopped after ([0-9.]+) s: the optimizer passed its time limit of 2\.0 s without asking "
                           r"for an evaluation; the evaluations done until then are kept", hang.error)
    assert stopped, hang.error
    # the limit honoured: its worker killed at 2 s + 0.5 s + 5 %, not earlier
    assert float(stopped.group(1)) >= round(worker_deadline_s(2.0), 1) and hang.wall_s >= worker_deadline_s(2.0)
    assert hang_was_ended(pid_file)
    # the cooperative limit keeps what was evaluated (a 0.05 s pause per evaluation: ~40 in 2 s)
    assert slow.status == "timeout" and 0 < slow.n_evals < 100 and math.isfinite(slow.best_f)
    assert rs.status == "ok" and rs.n_evals == 100
    assert not [p for p in multiprocessing.active_children() if p.name.startswith("femu ")]  # the hung one is gone
    stored = {r.optimizer: r.status for r in Store(tmp_path / "s").runs()}
    assert stored == {hangs: "timeout", plugin(Slow): "timeout", "random-search": "ok"}


# -- kill and resume -----------------------------------------------------------------------
def test_killed_study_resumes_keeping_finished_runs(tmp_path):
    store = tmp_path / "s"
    n = 10
    cmd = FEMU + ["study", "--optimizers", "random-search", "--seeds", f"0-{n - 1}", "--budget", "1000",
                  "--store", str(store), "--workers", "1"]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    runs_dir = store / "runs"
    while time.perf_counter() - t0 < 60 and len(list(runs_dir.glob("*.json"))) < 2:
        assert proc.poll() is None, proc.communicate()
        time.sleep(0.01)
    proc.send_signal(signal.SIGKILL)
    proc.communicate()
    kept = sorted(runs_dir.glob("*.json"))
    assert 2 <= len(kept) < n, "the study should have been killed part way"
    for p in kept:  # only whole records
        assert json.loads(p.read_text())["format"] == "femu.run/1"
    before = {p.name: (p.read_bytes(), p.stat().st_mtime_ns) for p in kept}

    out = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    # stdout is not a terminal: no bar, only the summary line
    assert out.stdout.count("\n") == 1
    assert out.stdout.startswith(f"femu study: {n} runs in {store} ({n - len(kept)} new, {len(kept)} kept): {n} ok, ")
    for name, (data, mtime) in before.items():
        p = runs_dir / name
        assert p.read_bytes() == data and p.stat().st_mtime_ns == mtime
    runs = Store(store).runs()
    assert [r.seed for r in runs] == list(range(n)) and all(r.status == "ok" and r.n_evals == 1000 for r in runs)
    # the resumed store holds exactly what an uninterrupted study gives (a kept and a new run)
    for r in (runs[0], runs[-1]):
        assert essentials([r]) == essentials([run("random-search", make_problem("paper"), 1000, r.seed)])
    print(f"kill/resume test: {time.perf_counter() - t0:.1f} s")


# -- the store's manifest and `femu results` -----------------------------------------------
def test_study_json_records_the_request_and_its_history(tmp_path):
    store = tmp_path / "s"
    run_study("random-search", "0", 20, store, workers=0, progress=False)
    first = json.loads((store / "study.json").read_text())
    assert first["format"] == "femu.study/1" and first["history"] == []
    assert first["optimizers"] == ["random-search"] and first["seeds"] == [0] and first["budget"] == 20
    assert first["variants"] == ["paper"] and first["executor"] == "in-process"
    assert first["versions"]["numpy"] == np.__version__ and first["started"].endswith("+00:00")
    run_study("random-search", "0-1", 20, store, workers=1, progress=False)
    second = json.loads((store / "study.json").read_text())
    assert second["seeds"] == [0, 1] and second["executor"] == "local pool, 1 worker"
    assert second["history"] == [{k: v for k, v in first.items() if k not in ("format", "history")}]


def test_results_json_and_table(tmp_path, capsys):
    store = tmp_path / "s"
    assert main(["study", "--optimizers", "random-search", "--seeds", "0-1", "--budget", "30", "--store", str(store),
                 "--variants", "synthetic,paper", "--workers", "0", "--no-progress"]) == 0
    capsys.readouterr()
    assert main(["results", str(store), "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [(r["variant"], r["seed"]) for r in rows] == [("paper", 0), ("paper", 1), ("synthetic", 0), ("synthetic", 1)]
    for r in rows:
        assert r["optimizer"] == "random-search" and r["budget"] == 30 and r["n_evals"] == 30 and r["status"] == "ok"
        assert len(r["best_x"]) == 12 and r["best_f"] == r["trace"][-1][1]
        assert r["wall_s"] >= r["fe_s"] > 0 and r["cpu_s"] > 0
    stored = json.loads((store / "runs" / "synthetic__random-search__b30__s1.json").read_text())
    assert isinstance(stored.pop("mac"), str)  # the store's seal on the record (Store.sign), not a field of it
    assert rows[3] == stored

    assert main(["results", str(store)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split() == ["variant", "optimizer", "budget", "seed", "status", "n_evals", "best_f", "wall_s"]
    assert lines[2].split()[:6] == ["paper", "random-search", "30", "0", "ok", "30"]
    assert float(lines[2].split()[6]) == pytest.approx(rows[0]["best_f"], rel=1e-5)
    assert lines[-1] == f"4 runs in {store}"

    assert main(["results", str(tmp_path / "nothing")]) == 2
    assert "no such store" in capsys.readouterr().err


# -- progress ------------------------------------------------------------------------------
def _run_on_terminal(argv, cwd) -> str:
    """Run femu with stdout on a pseudo-terminal; everything it wrote."""
    master, slave = pty.openpty()
    # PYTHONPATH: the femu process imports this module for its test plugins
    env = dict(os.environ, TERM="xterm", COLUMNS="120", PYTHONPATH=str(Path(__file__).parent))
    proc = subprocess.Popen(FEMU + argv, stdout=slave, stderr=slave, stdin=subprocess.DEVNULL, cwd=cwd, env=env)
    os.close(slave)
    chunks = []
    while True:
        try:
            data = os.read(master, 65536)
        except OSError:  # EIO: the terminal's other end is closed
            break
        if not data:
            break
        chunks.append(data)
    os.close(master)
    out = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", b"".join(chunks).decode(errors="replace"))  # no colours
    assert proc.wait(60) == 0, out
    return out


def test_progress_bar_on_a_terminal_and_off_with_no_progress(tmp_path):
    argv = ["study", "--optimizers", f"random-search,{plugin(Raises)}", "--seeds", "0-1", "--budget", "50",
            "--workers", "0"]
    shown = _run_on_terminal(argv + ["--store", "a"], tmp_path)
    assert "runs" in shown and "4/4 done · 0 running · 2 failed" in shown
    assert "femu study: 4 runs in a (4 new, 0 kept): 2 ok, 2 failed, 0 timeout;" in shown
    quiet = _run_on_terminal(argv + ["--store", "b", "--no-progress"], tmp_path)
    # no bar: the summary, after the warnings the study has (2 seeds cannot separate two solvers)
    lines = quiet.strip().splitlines()
    assert lines[-1].startswith("femu study: 4 runs in b (4 new") and "done ·" not in quiet
    assert all(line.startswith("femu study: warning: with 2 seed(s)") for line in lines[:-1]) and len(lines) == 2


def test_x0_is_a_study_option_given_to_every_solver_or_none(tmp_path, capsys):
    """--x0 all gives every solver the model's initial point (stored in each record and the
    manifest); a store of one x0 is not silently extended with the other."""
    store = tmp_path / "s"
    argv = ["study", "--optimizers", "cma-es,sensitivity", "--seeds", "0", "--budget", "60", "--store", str(store),
            "--workers", "0", "--no-progress"]
    assert main(argv + ["--x0", "all"]) == 0
    records = [json.loads(p.read_text()) for p in sorted((store / "runs").glob("*.json"))]
    assert [r["x0"] for r in records] == ["all", "all"]
    x0_value = make_problem("paper").evaluate(make_problem("paper").x0)[0]
    sens = next(r for r in records if r["optimizer"] == "sensitivity")
    assert sens["trace"][0][1] == pytest.approx(x0_value, rel=1e-9)  # its first point is x0
    assert json.loads((store / "study.json").read_text())["x0"] == "all"
    capsys.readouterr()
    assert main(argv) == 2
    assert "stored with x0 all, asked for --x0 none; use another store" in capsys.readouterr().err
    other = [a if a != str(store) else str(tmp_path / "t") for a in argv]
    with pytest.raises(SystemExit) as stop:
        main(other + ["--x0", "some"])
    assert stop.value.code == 2
    assert "argument --x0: invalid choice: 'some'" in capsys.readouterr().err and not (tmp_path / "t").exists()


@pytest.mark.parametrize("workers", ["0", "1"])
def test_in_process_mode_records_unverified_runs_and_the_report_says_so(tmp_path, capsys, workers):
    """`femu study --in-process` (debugging): the same runs as in a worker (same seed, same
    points), each record unverified, study.json and the summary line saying so, and the report
    naming the unverified runs."""
    base = ["study", "--optimizers", "random-search", "--seeds", "0-1", "--budget", "30", "--workers", workers,
            "--no-progress"]
    assert main(base + ["--store", str(tmp_path / "iso")]) == 0
    assert main(base + ["--store", str(tmp_path / "dbg"), "--in-process"]) == 0
    summary = capsys.readouterr().out.strip().splitlines()[-1]
    assert "2 unverified" in summary and "--in-process" in summary, summary
    iso, dbg = Store(tmp_path / "iso").runs(), Store(tmp_path / "dbg").runs()
    assert [r.verified for r in iso] == [True, True] and [r.verified for r in dbg] == [False, False]
    assert [(r.best_f, r.best_x, r.trace) for r in iso] == [(r.best_f, r.best_x, r.trace) for r in dbg]
    assert json.loads((tmp_path / "dbg" / "study.json").read_text())["in_process"] is True
    assert json.loads((tmp_path / "iso" / "study.json").read_text())["in_process"] is False
    assert main(["report", str(tmp_path / "dbg"), "--out", str(tmp_path / "r")]) == 0
    assert "2 runs of `random-search` are **unverified**" in (tmp_path / "r" / "report.md").read_text()
    assert main(["report", str(tmp_path / "iso"), "--out", str(tmp_path / "r2")]) == 0
    assert "unverified" not in (tmp_path / "r2" / "report.md").read_text()


def test_in_process_help_says_what_it_costs(capsys):
    with pytest.raises(SystemExit):
        main(["study", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "--in-process" in text and "recorded as unverified" in text
