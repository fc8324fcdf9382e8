"""Install by use (issue 41): the core runs without any extra, and a feature whose extra is missing
says in one line which one to install (adapters/extras.py).

A Python "without" the extras is this one with their modules blocked: a sitecustomize.py on
PYTHONPATH refuses to import them, in every process the command starts (the sandbox's workers,
a study's children), as a core install (`pip install femu-bench`) would.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from adapters.extras import EXTRA_OF

ROOT = Path(__file__).resolve().parents[1]
BLOCK = """\
import sys
class _Block:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] in {blocked!r}:
            raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
sys.meta_path.insert(0, _Block())
"""


#: libraries the core install does not have that no feature requires: the progress bars fall back to
#: plain lines without rich ('all'); statsmodels and pandas are the tests' references only
NOT_CORE = ("rich", "statsmodels", "pandas")


@pytest.fixture(scope="module")
def core_env(tmp_path_factory):
    """An environment whose Pythons cannot import any extra's module."""
    site = tmp_path_factory.mktemp("core-site")
    (site / "sitecustomize.py").write_text(BLOCK.format(blocked=tuple(EXTRA_OF) + NOT_CORE))
    path = os.pathsep.join([str(site), os.environ.get("PYTHONPATH", "")]).rstrip(os.pathsep)
    return dict(os.environ, PYTHONPATH=path, COLUMNS="200")


def femu(env, *args, cwd=None) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "femu", *map(str, args)], env=env, cwd=cwd, capture_output=True,
                          text=True, timeout=600)


def test_the_block_holds_in_the_processes_a_command_starts(core_env):
    proc = subprocess.run([sys.executable, "-c", "import optuna"], env=core_env, capture_output=True, text=True)
    assert proc.returncode == 1 and "No module named 'optuna'" in proc.stderr


def test_core_model_and_a_study_of_the_designs_optimizers_run_without_any_extra(core_env, tmp_path):
    proc = femu(core_env, "model", "hframe", "--json")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["frequencies_hz"][0] == pytest.approx(56.287, abs=1e-3)
    store = tmp_path / "store"
    proc = femu(core_env, "study", "--optimizers", "pymoo-ga,deap-ga,pyswarms-pso,scipy-sa", "--seeds", "0",
                "--budget", "60", "--store", store, "--workers", "0", "--no-progress")
    assert proc.returncode == 0, proc.stderr
    records = [json.loads(p.read_text()) for p in (store / "runs").glob("*.json")]
    assert sorted(r["optimizer"] for r in records) == ["deap-ga", "pymoo-ga", "pyswarms-pso", "scipy-sa"]
    assert all(r["status"] == "ok" and r["n_evals"] == 60 for r in records), [(r["optimizer"], r["error"]) for r in records]


def test_core_diagnose_runs_without_any_extra(core_env, tmp_path):
    import fe_problem as fp

    data = fp.save_modal_data(fp.synthetic_measurement("hframe", 8, freq_noise=0.002, shape_noise=0.02, seed=4),
                              tmp_path / "d.json")
    proc = femu(core_env, "diagnose", data, "--json")
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout)["cause"]["kind"] == "none"


def _one_line(proc, extra: str, what: str) -> None:
    assert proc.returncode == 2 and proc.stdout == "", (proc.stdout, proc.stderr)
    assert proc.stderr.count("\n") == 1 and "Traceback" not in proc.stderr, proc.stderr
    assert f"{what} needs the '{extra}' extra: pip install 'femu-bench[{extra}]'" in proc.stderr, proc.stderr


def test_a_missing_extra_is_one_line_naming_it(core_env, tmp_path):
    _one_line(femu(core_env, "study", "--optimizers", "optuna-tpe", "--seeds", "0", "--budget", "20", "--store",
                   tmp_path / "s1", "--workers", "0"), "optimizers", "optimizer 'optuna-tpe'")
    _one_line(femu(core_env, "study", "--optimizers", "random-search", "--seeds", "0", "--budget", "20", "--store",
                   tmp_path / "s2", "--scheduler", "tcp://127.0.0.1:8786"), "cluster", "--scheduler (a Dask cluster)")
    from fe_problem import synthetic_frf
    from fe_problem.identification.frf_io import write_npz

    frf = tmp_path / "h.npz"
    write_npz(synthetic_frf("hframe", band_hz=(5, 100), resolution_hz=0.5), frf)
    _one_line(femu(core_env, "identify", frf, "--out", tmp_path / "ident"), "identify",
              "modal identification (femu identify)")
    assert not (tmp_path / "s1").exists() and not (tmp_path / "s2" / "runs").exists()
    uff = fp_save_uff(tmp_path / "m.uff")
    _one_line(femu(core_env, "diagnose", uff, "--json"), "import", f"{uff}: reading or writing a UFF file")


def fp_save_uff(path: Path) -> Path:
    import fe_problem as fp

    return fp.save_modal_data(fp.synthetic_measurement("hframe", 4, seed=1), path)


def test_femu_optimizers_lists_the_unavailable_with_their_extra(core_env):
    proc = femu(core_env, "optimizers")
    assert proc.returncode == 0, proc.stderr
    listed = proc.stdout.split("\nunavailable here (their extra is not installed):\n")
    assert len(listed) == 2, proc.stdout
    for name in ("nevergrad-ngopt", "optuna-cmaes", "optuna-tpe"):
        assert re.search(rf"^{name}: optimizer '{name}' needs the 'optimizers' extra: pip install "
                         r"'femu-bench\[optimizers\]'", listed[1], re.M), listed[1]
        assert not re.search(rf"^{name}\s", listed[0], re.M)
    for name in ("pymoo-ga", "deap-ga", "pyswarms-pso", "scipy-sa", "cma-es"):
        assert re.search(rf"^{name}\s", listed[0], re.M), name
    proc = femu(core_env, "optimizers", "--json")
    assert {e["name"] for e in json.loads(proc.stdout)}.isdisjoint({"nevergrad-ngopt", "optuna-cmaes", "optuna-tpe"})
    assert proc.stderr.count("needs the 'optimizers' extra") == 3


def test_reproduce_leaves_out_what_needs_an_extra_and_says_so():
    """The names reproduce runs are what is installed: the left-out say which extra they need
    (femu/reproduce.solvers, run in a process where the optimizers extra is blocked)."""
    code = BLOCK.format(blocked=("optuna", "nevergrad", "cmaes")) + (
        "import json\nfrom femu.reproduce import solvers\nnames, out = solvers(1000)\n"
        "print(json.dumps([names, out]))")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    names, out = json.loads(proc.stdout.splitlines()[-1])
    assert set(out) == {"nevergrad-ngopt", "optuna-cmaes", "optuna-tpe"}
    assert all("needs the 'optimizers' extra: pip install 'femu-bench[optimizers]'" in v for v in out.values())
    assert {"pymoo-ga", "deap-ga", "pyswarms-pso", "scipy-sa", "cma-es", "random-search"} <= set(names)


def test_the_core_dependencies_hold_no_library_of_an_extra():
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10: pytest's own TOML reader
        import tomli as tomllib
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    core = " ".join(project["dependencies"]).lower()
    for lib in ("dask", "optuna", "nevergrad", "cmaes", "ioh", "sdypy", "pyuff", "rich", "statsmodels", "pandas"):
        assert not re.search(rf"(^|\s|\"){lib}\b", core), lib
    extras = project["optional-dependencies"]
    for extra in set(EXTRA_OF.values()):
        assert extra in extras and f"femu-bench[" in extras["all"][0] and extra in extras["all"][0], extra


def test_without_rich_the_progress_is_plain_lines_on_stderr(monkeypatch, capsys):
    """The core install has no rich: a study's progress (on a terminal) is one line per finished run."""
    from femu.studies import progress

    monkeypatch.setattr(progress, "has_rich", lambda: False)
    with progress.Progress(3, 1, 0, enabled=True) as bar:
        bar.running(2)
        bar.done(failed=False)
        bar.done(failed=True)
    out, err = capsys.readouterr()
    assert out == "" and err.splitlines() == ["runs 2/3 done · 2 running · 0 failed",
                                              "runs 3/3 done · 2 running · 1 failed"]
