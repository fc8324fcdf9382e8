"""Issue 39: plugins that cannot reach each other, the store or the truth. Each attack is a plugin
(tests/cheating_plugins.py, or a module of its own when the attack is its import-time code), run
through `adapters.run` and `femu study` as a user would; each fails or gains nothing."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import adapters
import cheating_plugins as cp
from adapters.sandbox import json_depth, loads_bounded
from adapters.variants import make_problem
from femu.studies.store import Store

HERE = Path(__file__).parent
BUDGET = 300


def plugin(cls) -> str:
    return f"{cls.__module__}:{cls.__name__}"


def _femu(*args, **env_vars) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(HERE), os.environ.get("PYTHONPATH", "")]), **env_vars)
    return subprocess.run([sys.executable, "-m", "femu", *args], env=env, capture_output=True, text=True,
                          timeout=900)


# -- 1. bounded parsing ---------------------------------------------------------------------------------


def _nesting(text: str) -> int:
    """The nesting of a JSON text, by walking what json parsed (a second, independent count)."""
    import json

    def depth(v):
        if isinstance(v, list):
            return 1 + max(map(depth, v), default=0)
        if isinstance(v, dict):
            return 1 + max(map(depth, v.values()), default=0)
        return 0

    return depth(json.loads(text))


@pytest.mark.parametrize("text", ['5', '[]', '{"a": [1, {"b": "]]]["}]}', '["\\"[[[", [[]]]', '[{"k": {}}, []]',
                                  '"{[\\\\"', '{"a\\"[": [[[[1]]]]}'])
def test_the_depth_bound_counts_nesting_as_the_parser_sees_it(text):
    assert json_depth(text.encode()) == _nesting(text)


def test_a_message_nested_too_deep_is_a_protocol_fault_never_a_recursion_error():
    with pytest.raises(ValueError, match="nested more than 32 deep"):
        loads_bounded(b"[" * 200_000 + b"]" * 200_000)
    assert loads_bounded(b"[" * 32 + b"]" * 32) is not None


def test_a_run_that_ends_with_deep_json_fails_its_own_run_and_adapters_run_does_not_raise():
    problem = make_problem("paper")
    r = adapters.run(plugin(cp.EndsWithDeepJSON), problem, BUDGET, 0)
    assert (r.status, r.n_evals) == ("failed", 3) and "protocol" in r.error and "deep" in r.error, r.error
    assert problem.points_evaluated == 3 and r.verified


def test_a_plugin_whose_ready_message_is_deep_fails_its_own_run_named():
    problem = make_problem("paper")
    r = adapters.run("describes_itself_deeply:DescribesItselfDeeply", problem, BUDGET, 0)
    assert (r.status, r.n_evals) == ("failed", 0) and "describes_itself_deeply" in r.error, r.error
    assert "deep" in r.error and problem.points_evaluated == 0


# -- 2. no plugin code in the shared worker server ------------------------------------------------------


def _study(store: Path, names: list[str]):
    done = _femu("study", "--optimizers", ",".join(names), "--seeds", "0", "--budget", str(BUDGET), "--store",
                 str(store), "--workers", "0", "--no-progress")
    return done, ({r.optimizer: r for r in Store(store).runs()} if store.is_dir() else {})


def test_a_plugin_that_fails_to_describe_itself_fails_its_own_runs_only_named(tmp_path):
    done, runs = _study(tmp_path / "s", ["describes_itself_deeply:DescribesItselfDeeply", "random-search"])
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("femu study: 2 runs"), done.stdout
    bad = runs["describes_itself_deeply:DescribesItselfDeeply"]
    assert bad.status == "failed" and bad.n_evals == 0 and "describes_itself_deeply" in bad.error, bad.error
    assert runs["random-search"].status == "ok" and runs["random-search"].n_evals == BUDGET


def test_a_plugins_import_time_code_never_reaches_another_optimizers_worker(tmp_path):
    """The plugin's import negates every value a proxy returns; cma-es, an honest optimizer whose
    search follows the values it gets, runs in the same study (its server preloads cma-es)."""
    done, runs = _study(tmp_path / "s", ["flips_signs_on_import:FlipsSigns", "cma-es"])
    assert done.returncode == 0, done.stderr
    alone = adapters.run("cma-es", make_problem("paper"), BUDGET, 0)
    assert runs["cma-es"].n_evals == alone.n_evals == BUDGET
    assert runs["cma-es"].best_f == alone.best_f and runs["cma-es"].best_x == alone.best_x
    flipped = runs["flips_signs_on_import:FlipsSigns"]  # its own run: it harmed only its own view
    assert flipped.status == "ok" and flipped.n_evals == BUDGET


# -- 3. confinement by the kernel's means ---------------------------------------------------------------


def _probe(r) -> dict:
    import json

    line = next(line for line in r.output.splitlines() if line.startswith("PROBE "))
    return json.loads(line[len("PROBE "):])


@pytest.fixture(scope="module")
def probed(tmp_path_factory):
    """A run of ProbesItsConfinement through adapters.run: a secret file in a directory the
    worker may not read (outside every readable one), another in a hidden one under a writable
    directory (as a study's store is hidden), the FE package's data, and places to write."""
    import tempfile

    from adapters.confine import HIDDEN_ENV

    outside = Path(tempfile.mkdtemp(prefix="femu-test-outside-"))  # /tmp, not the tests' writable basetemp
    (outside / "secret.json").write_text("{}")
    hidden = tmp_path_factory.mktemp("hidden")
    (hidden / "record.json").write_text("{}")
    fe_data = next((Path(adapters.__file__).parent.parent / "fe_problem").glob("*.json"))
    old = os.environ.get(HIDDEN_ENV)
    os.environ[HIDDEN_ENV] = str(hidden)
    try:
        problem = make_problem("paper")
        r = adapters.run(plugin(cp.ProbesItsConfinement), problem, BUDGET, 0, evaluator=os.getpid(),
                         read=[str(outside / "secret.json"), str(hidden / "record.json"), str(fe_data)],
                         write=[str(outside / "planted"), str(hidden / "planted"), str(Path.cwd() / "planted"),
                                str(tmp_path_factory.mktemp("allowed") / "file")])
    finally:
        if old is None:
            del os.environ[HIDDEN_ENV]
        else:
            os.environ[HIDDEN_ENV] = old
    yield r, problem, outside, hidden, fe_data
    import shutil

    shutil.rmtree(outside)


def test_a_probing_plugin_runs_honestly_and_its_record_says_what_held(probed):
    r, problem, *_ = probed
    assert r.status == "ok" and r.n_evals == problem.points_evaluated == BUDGET, r.error
    held = r.sandbox
    assert held["session"] and held["undumpable"] and held["limits"] and held["peer_checked"], held
    from adapters.confine import landlock_abi

    assert held["landlock_abi"] == landlock_abi() and held["filesystem"] == (landlock_abi() > 0), held
    assert held["own_uid"] == (os.geteuid() == 0), held


def test_a_worker_signals_no_process_but_its_own_and_reads_no_memory(probed):
    r, *_ = probed
    found = _probe(r)
    # where neither a uid of its own nor Landlock's signal scope is offered, the record says so
    assert r.sandbox["signals"] == (os.geteuid() == 0 or r.sandbox["landlock_abi"] >= 6)
    assert r.sandbox["signals"] or found["signalled"] > 0
    if r.sandbox["signals"]:
        assert found["signalled"] == 0 and not found["evaluator_signalled"] and not found["server_signalled"], found
    assert found["evaluator_mem"] == "PermissionError" and found["server_mem"] == "PermissionError", found


def test_a_worker_holds_no_more_open_files_than_its_limit(probed):
    from adapters.confine import OPEN_FILES

    r, *_ = probed
    assert r.sandbox["limits"]
    assert _probe(r)["files_opened"] < OPEN_FILES < 4000  # its own few already open count too


def test_a_worker_cannot_have_its_server_start_a_process_for_it(probed):
    r, *_ = probed
    found = _probe(r)
    assert not found["new_worker"].startswith("pid"), found  # the server closed its connection unanswered


def test_a_worker_reads_and_writes_only_where_it_is_allowed(probed):
    r, problem, outside, hidden, fe_data = probed
    found = _probe(r)
    assert r.sandbox["filesystem"] == (r.sandbox["landlock_abi"] > 0)  # where none is offered, it says so
    assert found["own_tmp"] == "ok"
    assert list(found["write"].values()).count("ok") == 1, found  # the tests' writable directory
    if r.sandbox["filesystem"]:
        assert found["read"] == {str(outside / "secret.json"): "PermissionError",
                                 str(hidden / "record.json"): "PermissionError", str(fe_data): "PermissionError"}
        writes = found["write"]
        assert [writes[str(outside / "planted")], writes[str(hidden / "planted")],
                writes[str(Path.cwd() / "planted")]] == ["PermissionError"] * 3, found
        assert not (outside / "planted").exists() and not (hidden / "planted").exists()


def test_a_plugin_finds_its_studys_store_and_can_neither_read_nor_change_it(tmp_path):
    import json

    store = tmp_path / "s"
    done, runs = _study(store, [plugin(cp.ReachesForTheStore), "random-search"])
    assert done.returncode == 0, done.stderr
    r = runs[plugin(cp.ReachesForTheStore)]
    assert r.status == "ok", r.error
    line = next(line for line in r.output.splitlines() if line.startswith("STORE "))
    found = json.loads(line[len("STORE "):])
    assert found["store"] == str(store), found  # it found it: the path is no secret
    assert (found["read"], found["write"]) == ("PermissionError", "PermissionError"), found
    assert not (store / "runs" / "planted.json").exists()


def test_a_study_that_cannot_be_confined_needs_unconfined_and_its_report_marks_the_runs(tmp_path):
    """FEMU_LANDLOCK=off stands for a kernel without Landlock: the study is refused, naming the
    flag; with --unconfined it runs, its records say the filesystem was not confined, and the
    report marks them."""
    store = tmp_path / "s"
    args = ["study", "--optimizers", "random-search", "--seeds", "0", "--budget", "20", "--store", str(store),
            "--workers", "0", "--no-progress"]
    refused = _femu(*args, FEMU_LANDLOCK="off")
    assert refused.returncode == 2 and "--unconfined" in refused.stderr and "no Landlock" in refused.stderr
    assert refused.stderr.count("\n") == 1 and not store.exists()
    done = _femu(*args, "--unconfined", FEMU_LANDLOCK="off")
    assert done.returncode == 0, done.stderr
    (r,) = Store(store).runs()
    assert r.status == "ok" and r.verified and r.sandbox["filesystem"] is False and r.sandbox["session"]
    report = _femu("report", str(store), "--out", str(tmp_path / "r"))
    assert report.returncode == 0, report.stderr
    text = (tmp_path / "r" / "report.md").read_text()
    assert "**unconfined**" in text and "without filesystem" in text
    confined = tmp_path / "c"
    assert _femu(*args[:8], str(confined), *args[9:]).returncode == 0
    assert _femu("report", str(confined), "--out", str(tmp_path / "rc")).returncode == 0
    assert "unconfined" not in (tmp_path / "rc" / "report.md").read_text()


# -- 4. a tamper-evident store ---------------------------------------------------------------------------


def test_a_changed_record_is_refused_by_femu_report_named_and_a_stripped_one_flagged(tmp_path):
    import hashlib
    import hmac
    import json
    import stat

    store = tmp_path / "s"
    done, runs = _study(store, ["random-search"])
    assert done.returncode == 0, done.stderr
    key = store / ".key"
    assert stat.S_IMODE(key.stat().st_mode) == 0o600
    (path,) = (store / "runs").glob("*.json")
    record = json.loads(path.read_text())
    # the MAC checked by a second, independent computation: HMAC-SHA256 of the canonical JSON
    body = json.dumps({k: v for k, v in record.items() if k != "mac"}, sort_keys=True, separators=(",", ":"))
    assert record["mac"] == hmac.new(key.read_bytes(), body.encode(), hashlib.sha256).hexdigest()
    assert _femu("report", str(store), "--out", str(tmp_path / "r0")).returncode == 0
    # a better best_f, still a valid record: refused, the file named
    changed = dict(record, best_f=record["best_f"] / 10)
    path.write_text(json.dumps(changed))
    refused = _femu("report", str(store), "--out", str(tmp_path / "r1"))
    assert refused.returncode == 2 and str(path) in refused.stderr and "MAC does not match" in refused.stderr
    assert refused.stderr.count("\n") == 1, refused.stderr
    # the MAC stripped: read, and flagged in the report
    path.write_text(json.dumps({k: v for k, v in changed.items() if k != "mac"}))
    flagged = _femu("report", str(store), "--out", str(tmp_path / "r2"))
    assert flagged.returncode == 0, flagged.stderr
    assert "**no MAC**" in (tmp_path / "r2" / "report.md").read_text()
