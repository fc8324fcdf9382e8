"""The layers' contracts: the plugin protocol, the one budget rule, run provenance, the CLI's
self-description, and adapters free of the application's libraries."""

import ast
import json
from pathlib import Path

import pytest

import adapters
from adapters import Optimizer, OptimizerBase, check_budget, get, min_budget
from adapters.provenance import RUN_LIBRARIES
from adapters.variants import make_problem
from femu import cli
from femu.studies.seeds import parse_seed_count


@pytest.mark.parametrize("name", list(adapters.registry.BUILTINS))
def test_every_builtin_implements_the_protocol(name):
    opt = get(name)()
    assert isinstance(opt, Optimizer) and opt.name == name
    need = opt.min_budget(12)
    assert isinstance(need, int) and need >= 1


def test_min_budget_follows_n_var_and_options():
    assert min_budget(get("scipy-sa"), 12) == 25 and min_budget(get("scipy-sa"), 3) == 7
    assert min_budget(get("cma-es"), 12) == 11 and min_budget(get("cma-es"), 12, popsize=20) == 20
    # GAs: one initial population, sized to the dimension and not the budget (max(20, n_var // 2),
    # at most 100: adapters.budget.ga_population, so that the GAs are anytime)
    for name, option in (("pymoo-ga", "pop_size"), ("deap-ga-stock", "population")):
        assert [min_budget(get(name), n) for n in (2, 12, 96, 200, 400)] == [20, 20, 48, 100, 100]
        assert min_budget(get(name), 12, **{option: 40}) == 40
    assert min_budget(get("sensitivity"), 12) == 13 and min_budget(get("sensitivity"), 96) == 97

    class Old:  # an older plugin: a plain attribute
        min_budget = 7

    class New(OptimizerBase):
        MIN_BUDGET = 9

    assert min_budget(Old, 12) == 7 and min_budget(New, 12) == 9 and min_budget(object, 12) == 1


def test_one_budget_message_in_the_harness_the_study_and_reproduce(tmp_path, capsys):
    with pytest.raises(ValueError, match=r"^budget must be an integer >= 1 \(FE evaluations\), got 0$"):
        check_budget(0)
    with pytest.raises(ValueError, match=r"^--budget: must be an integer >= 1 \(FE evaluations\), got 0$"):
        check_budget(0, "--budget")
    for cmd in (["study", "--optimizers", "random-search", "--seeds", "0", "--store", str(tmp_path / "s")],
                ["reproduce", "--out", str(tmp_path / "r")]):
        assert cli.main([*cmd, "--budget", "0"]) == 2
        assert "--budget: must be an integer >= 1 (FE evaluations), got 0" in capsys.readouterr().err
    # the minimum budget with the optimizer's options: pymoo-ga with pop_size 40 runs on 40, not 39
    with pytest.raises(ValueError, match="'pymoo-ga' needs a budget of at least 40 evaluations, got 39"):
        adapters.run("pymoo-ga", make_problem("paper"), 39, 0, pop_size=40)
    assert adapters.run("pymoo-ga", make_problem("paper"), 40, 0, pop_size=40).n_evals == 40


def test_every_run_record_names_its_library_versions():
    r = adapters.run("random-search", make_problem("paper"), 10, 0)
    assert set(r.versions) == {"python", *RUN_LIBRARIES}
    assert all(isinstance(r.versions[k], str) for k in ("python", "numpy", "scipy", "pymoo", "femu-bench"))
    assert adapters.RunResult.from_dict(json.loads(json.dumps(r.to_dict()))).versions == r.versions


def test_reproduce_seeds_are_a_count_or_the_study_syntax():
    assert parse_seed_count("3") == parse_seed_count(3) == [0, 1, 2]
    assert parse_seed_count("0-2") == [0, 1, 2] and parse_seed_count("5-5") == [5]
    assert parse_seed_count("1,4") == [1, 4]
    for bad, says in (("0", "count of seeds must be >= 1"), ("2-1", "runs backwards"), ("a", "not a seed")):
        with pytest.raises(ValueError, match=says):
            parse_seed_count(bad)


def _commands():
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    return sub.choices


@pytest.mark.parametrize("name", ["model", "study", "results", "report", "reproduce"])
def test_every_argument_has_help_and_defaults_are_shown(name, capsys):
    parser = _commands()[name]
    for action in parser._actions:
        assert action.help and action.help.strip(), (name, action.dest)
    with pytest.raises(SystemExit):
        cli.main([name, "--help"])
    text = " ".join(capsys.readouterr().out.split())
    for action in parser._actions:
        if action.option_strings and action.default not in (None, False, "==SUPPRESS=="):
            assert f"default: {action.default}" in text or f"default {action.default}" in text, (name, action.dest)


def test_adapters_import_none_of_the_applications_libraries():
    """adapters/ is the plugin layer: its own modules import no CLI, plotting, progress or cluster
    library and nothing of the application (the optimizer libraries may import what they like)."""
    banned = {"argparse", "matplotlib", "rich", "dask", "distributed", "femu"}
    root = Path(adapters.__file__).parent
    found = []
    for path in sorted(root.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) and not node.level else [])
            found += [(path.name, n) for n in names if n.split(".")[0] in banned]
    assert len(list(root.glob("*.py"))) >= 10 and found == []
