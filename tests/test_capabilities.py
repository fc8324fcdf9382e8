"""Capabilities as data: every built-in declares them, `femu optimizers` lists them, the
anytime declarations hold (a short and a long run with one seed visit the same first points),
the contract helper for plugins catches what it is meant to, and the benchmark report uses
fixed-budget values below the budget only for anytime optimizers."""

import json
import re
from pathlib import Path

import numpy as np
import pytest

import adapters
from adapters.budget import min_budget
from adapters.capabilities import CAPABILITIES, capabilities, describe
from adapters.registry import BUILTINS, get
from adapters.testing import _visited, check_optimizer
from adapters.variants import make_problem
from femu.cli import main

import sample_plugins

ROOT = Path(__file__).resolve().parents[1]


class Recording:
    """The paper problem, every point it evaluates kept in order (also least-squares points)."""

    def __init__(self):
        self.problem = make_problem("paper")
        self.n_var, self.xl, self.xu, self.x0 = self.problem.n_var, self.problem.xl, self.problem.xu, self.problem.x0
        self.name = "hframe:paper"
        self.points = []

    def evaluate(self, X):
        X = np.atleast_2d(np.asarray(X, dtype=float))
        self.points.extend(X.copy())
        return self.problem.evaluate(X)

    def least_squares(self, x, charged=None):
        self.points.append(np.array(x, dtype=float))
        return self.problem.least_squares(x, charged=charged)


def visited(name, budget, seed=3):
    p = Recording()
    r = adapters.run(name, p, budget, seed)
    assert r.status == "ok" and r.n_evals == budget, (name, r.status, r.error)
    return _visited(p.points)


ANYTIME = [n for n in BUILTINS if capabilities(get(n))["anytime"]]
NOT_ANYTIME = [n for n in BUILTINS if not capabilities(get(n))["anytime"]]


def test_every_builtin_declares_every_capability_as_a_bool():
    for name in BUILTINS:
        cls = get(name)
        for flag in CAPABILITIES:
            assert isinstance(cls.__dict__.get(flag), bool), (name, flag)  # declared, not inherited or guessed
    assert set(NOT_ANYTIME) == {"deap-ga", "scipy-sa", "nevergrad-ngopt"}
    assert [n for n in BUILTINS if capabilities(get(n))["uses_gradients"]] == ["sensitivity"]


@pytest.mark.parametrize("name", ANYTIME)
def test_an_anytime_builtin_visits_the_first_points_of_a_longer_run(name):
    short_budget = max(min_budget(get(name), 12), 30) + 7  # not a whole generation
    short, long = visited(name, short_budget), visited(name, 3 * short_budget)
    assert len(short) >= 2 and len(long) > len(short)
    for i, (a, b) in enumerate(zip(short, long)):
        np.testing.assert_array_equal(a, b, err_msg=f"{name}: point {i} of the run of budget {short_budget}")


@pytest.mark.parametrize("name", ["scipy-sa", "deap-ga"])
def test_a_builtin_declared_not_anytime_really_follows_the_budget(name):
    budgets = {"scipy-sa": (400, 3000), "deap-ga": (60, 600)}[name]
    short, long = (visited(name, b) for b in budgets)
    k = len(short)
    assert not all(np.array_equal(a, b) for a, b in zip(short, long[:k])), name


def test_femu_optimizers_lists_capabilities_defaults_and_versions(capsys):
    assert main(["optimizers", "--json"]) == 0
    listed = {e["name"]: e for e in json.loads(capsys.readouterr().out)}
    assert list(listed)[: len(BUILTINS)] == list(BUILTINS)
    from importlib.metadata import version

    for name in BUILTINS:
        e = listed[name]
        assert {k: e[k] for k in CAPABILITIES} == capabilities(get(name))
        assert e["distribution"] == "femu-bench" and e["version"] == version("femu-bench")
        assert e == json.loads(json.dumps(describe(name, get(name))))
    assert listed["cma-es"]["options"]["sigma0"] == 0.3 and listed["cma-es"]["library"] == "cma"
    assert listed["cma-es"]["library_version"] == version("cma")
    assert listed["pymoo-ga"]["options"] == {"pop_size": None, "eliminate_duplicates": True}
    assert main(["optimizers"]) == 0
    text = capsys.readouterr().out
    row = next(line for line in text.splitlines() if line.startswith("scipy-sa "))
    assert re.match(r"scipy-sa\s+no\s+no\s+no\s+yes\s+femu-bench", row)
    assert "sensitivity: restarts=True, ftol=1e-10" in text
    assert main(["optimizers", "no-such-method"]) == 2
    assert "unknown optimizer 'no-such-method'" in capsys.readouterr().err


def test_a_run_record_keeps_capabilities_effective_options_and_distribution():
    r = adapters.run("cma-es", make_problem("paper"), 30, 0, sigma0=0.2)
    assert r.options == {"sigma0": 0.2}
    assert r.effective_options == {"sigma0": 0.2, "popsize": None, "incpopsize": 2, "bipop": False,
                                   "restarts": 1000, "cma_options": None}
    assert r.capabilities == capabilities(get("cma-es")) and r.distribution == "femu-bench"
    back = adapters.RunResult.from_dict(json.loads(json.dumps(r.to_dict())))
    assert back.effective_options == r.effective_options and back.capabilities == r.capabilities


class Loud:
    name = "loud"
    anytime = True

    def minimize(self, objective, bounds, budget, rng, x0=None):
        print("generation 1")
        while True:
            objective(rng.uniform(bounds[0], bounds[1], (10, len(bounds[0]))))


class Unseeded:
    name = "unseeded"

    def minimize(self, objective, bounds, budget, rng, x0=None):
        while True:
            objective(np.random.default_rng().uniform(bounds[0], bounds[1], (10, len(bounds[0]))))


class FalselyAnytime:
    name = "falsely-anytime"
    anytime = True

    def minimize(self, objective, bounds, budget, rng, x0=None):
        step = 1.0 / budget  # the schedule follows the budget
        u = rng.random(len(bounds[0]))
        while True:
            u = np.clip(u + step * rng.standard_normal(len(u)), 0, 1)
            objective(bounds[0] + u * (bounds[1] - bounds[0]))


class IgnoresX0:
    """Declares supports_x0 and never looks at x0 (the example plugin's trap, issue 41)."""
    name = "ignores-x0"
    supports_x0 = True

    def minimize(self, objective, bounds, budget, rng, x0=None):
        while True:
            objective(rng.uniform(bounds[0], bounds[1], (10, len(bounds[0]))))


@pytest.mark.parametrize("cls, message", [
    (IgnoresX0, "x0 contract: a run given x0 evaluated exactly the points of the run without it"),
    (Loud, "silence contract: the run wrote to stdout/stderr: 'generation 1"),
    (Unseeded, "seeding contract: two runs with one seed evaluated different points"),
    (FalselyAnytime, "anytime contract: the run of budget 1 did not visit the first 1 points"),
])
def test_check_optimizer_catches_a_broken_plugin(cls, message):
    with pytest.raises(AssertionError, match=re.escape(message)):
        check_optimizer(cls)


def test_check_optimizer_refuses_a_flag_that_is_not_a_bool():
    with pytest.raises(ValueError, match="capability 'anytime' must be True or False, got 'yes'"):
        check_optimizer(sample_plugins.BadFlag)
    with pytest.raises(ValueError, match="capability 'anytime' must be True or False"):
        adapters.run("sample_plugins:BadFlag", make_problem("paper"), 10, 0)  # its worker says so


def test_the_plugin_page_example_keeps_the_contract():
    text = (ROOT / "docs" / "plugins.md").read_text()
    code = re.search(r"```python\n(import numpy as np\n.*?)```", text, re.S).group(1)
    namespace = {}
    exec(compile(code, "docs/plugins.md", "exec"), namespace)
    cls = namespace["MyMethod"]
    cls.__module__ = __name__  # reachable as module:Class for the harness
    globals()["MyMethod"] = cls
    facts = check_optimizer(cls, popsize=10)
    assert facts["capabilities"] == {"anytime": True, "uses_gradients": False, "batch": True, "supports_x0": True}


def test_the_report_leaves_out_fixed_budget_values_below_the_budget_of_an_optimizer_not_anytime(tmp_path):
    from femu.reports.benchmark import benchmark_statistics, render_benchmark
    from femu.studies.study import run_study

    result = run_study("scipy-sa,random-search", "0-1", 200, tmp_path / "s", suite="hframe-freq/12/1", workers=0,
                       progress=False)
    s = benchmark_statistics(list(result.runs))
    assert s["one_budget"] == {"scipy-sa": 200}
    budgets = {(fb.solver, fb.budget) for fb in s["fixed_budget"]}
    assert budgets == {("random-search", 2), ("random-search", 20), ("random-search", 200), ("scipy-sa", 200)}
    text = render_benchmark(s, {"ert": "e.png", "ecdf": "c.png", "aggregate": "a.png", "profiles": "p.png",
                                "fixed_budget": {}, "convergence": {}, "cd": "d.png"},
                            "test")
    assert "Not anytime: `scipy-sa` (budget 200)" in text
    row = next(line for line in text.splitlines() if line.startswith("| hframe-freq/12 | scipy-sa |"))
    assert row.count("not anytime") == 2
    # a record written before capabilities were recorded: the class's declaration decides
    old = [adapters.RunResult.from_dict({k: v for k, v in r.to_dict().items() if k != "capabilities"})
           for r in result.runs]
    assert benchmark_statistics(old)["one_budget"] == {"scipy-sa": 200}


def test_the_study_report_says_which_curves_are_from_one_budget(tmp_path, capsys):
    from femu.studies.study import run_study

    run_study("scipy-sa,random-search", "0-1", 60, tmp_path / "s", workers=0, progress=False)
    assert main(["report", str(tmp_path / "s"), "--out", str(tmp_path / "r")]) == 0
    text = (tmp_path / "r" / "report.md").read_text()
    assert "Not anytime: `scipy-sa`. Their schedule follows the budget" in text
    assert "`random-search`. Their" not in text


@pytest.mark.parametrize("isolated", [True, False])
def test_adapters_run_refuses_an_option_the_optimizer_does_not_take_as_the_cli_does(isolated):
    """`adapters.run('cma-es', p, 200, 0, sigma=0.3)` (cma-es's option is sigma0): one ValueError
    before anything runs, the CLI's words (capabilities.check_options), not a failed run with a
    TypeError inside."""
    p = make_problem("paper")
    with pytest.raises(ValueError, match=r"^optimizer 'cma-es' has no option 'sigma'; its options: .*sigma0"):
        adapters.run("cma-es", p, 200, 0, sigma=0.3, isolated=isolated)
    r = adapters.run("cma-es", p, 200, 0, sigma0=0.3, isolated=isolated)  # the option it takes still runs
    assert r.status == "ok" and r.n_evals == 200


def test_a_plugin_installed_with_target_records_its_distribution_and_version(tmp_path, monkeypatch):
    """`pip install --target DIR` of a distribution (femu-my-method 0.3) whose module has another
    name (my_method): the run record names the distribution and its version, found in the
    dist-info beside the module (before: none, the module's name is no distribution's)."""
    target = tmp_path / "target"
    (target / "my_method").mkdir(parents=True)
    (target / "my_method" / "__init__.py").write_text(
        "class MyMethod:\n    name = 'my-method'\n\n    def minimize(self, objective, bounds, budget, rng):\n"
        "        while True:\n            objective(rng.uniform(bounds[0], bounds[1], (5, len(bounds[0]))))\n")
    info = target / "femu_my_method-0.3.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: femu-my-method\nVersion: 0.3\n")
    (info / "RECORD").write_text("my_method/__init__.py,,\nfemu_my_method-0.3.dist-info/METADATA,,\n")
    monkeypatch.syspath_prepend(str(target))
    from adapters.capabilities import distribution_of
    from adapters.registry import get

    assert distribution_of(get("my_method:MyMethod")) == ("femu-my-method", "0.3")
    for isolated in (False, True):
        r = adapters.run("my_method:MyMethod", make_problem("paper"), 20, 0, isolated=isolated)
        assert r.status == "ok" and (r.distribution, r.distribution_version) == ("femu-my-method", "0.3"), r
