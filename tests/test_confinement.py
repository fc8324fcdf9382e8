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
