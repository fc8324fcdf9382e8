"""The example plugin package (examples/optimizer-plugin) installed in a fresh virtual
environment, found through its entry point, run by `femu study --option` and reported; and a
plugin named module:Class found in the current directory."""

import json
import os
import site
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "optimizer-plugin"


@pytest.fixture(scope="module")
def venv(tmp_path_factory):
    """A fresh venv that sees this environment's packages (femu-bench, numpy, scipy ...) through a
    .pth file, with the example installed into it alone (--no-deps)."""
    where = tmp_path_factory.mktemp("venv")
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(where)], check=True)
    py = where / "bin" / "python"
    own = subprocess.run([str(py), "-c", "import site; print(site.getsitepackages()[0])"], check=True,
                         capture_output=True, text=True).stdout.strip()
    # addsitedir, not a plain path: femu-bench's editable install is itself a .pth file there
    parent = dict.fromkeys(p for p in sys.path + site.getsitepackages() if p.endswith("site-packages"))
    Path(own, "femu_parent.pth").write_text("".join(f"import site; site.addsitedir({p!r})\n" for p in parent))
    subprocess.run([str(py), "-m", "pip", "install", "-q", "--no-deps", str(EXAMPLE)], check=True,
                   capture_output=True, text=True)
    return py


def femu(py, *args, cwd=None):
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    return subprocess.run([str(py), "-m", "femu", *args], capture_output=True, text=True, cwd=cwd, env=env,
                          timeout=600)


def test_example_plugin_is_listed_run_with_options_and_reported(venv, tmp_path):
    listed = femu(venv, "optimizers", "example-de", "--json")
    assert listed.returncode == 0, listed.stderr
    (entry,) = json.loads(listed.stdout)
    assert entry["distribution"] == "femu-example-de" and entry["version"] == "0.1.0"
    assert entry["anytime"] is True and entry["batch"] is True and entry["options"]["popsize"] == 15
    # the plugin is not visible to this (the parent) environment: the test is about the new one
    assert "example-de" not in subprocess.run([sys.executable, "-m", "femu", "optimizers"], capture_output=True,
                                              text=True).stdout
    store = tmp_path / "store"
    done = femu(venv, "study", "--optimizers", "example-de,random-search", "--suite", "hframe-freq/12/1",
                "--seeds", "0-1", "--budget", "240", "--store", str(store), "--workers", "0", "--no-progress",
                "--option", "example-de.popsize=10", "--option", "example-de.mutation=[0.4, 0.9]")
    assert done.returncode == 0, done.stderr
    assert "4 runs" in done.stdout and "4 ok" in done.stdout
    records = [json.loads(p.read_text()) for p in sorted((store / "runs").glob("*.json"))]
    de = [r for r in records if r["optimizer"] == "example-de"]
    assert len(de) == 2
    for r in de:
        assert r["status"] == "ok" and r["n_evals"] == 240
        assert r["options"] == {"popsize": 10, "mutation": [0.4, 0.9]}
        assert r["effective_options"] == {"popsize": 10, "mutation": [0.4, 0.9], "recombination": 0.7,
                                          "strategy": "best1bin"}
        assert (r["distribution"], r["distribution_version"]) == ("femu-example-de", "0.1.0")
        assert r["capabilities"] == {"anytime": True, "uses_gradients": False, "batch": True, "supports_x0": True}
    # popsize 10 on 12 parameters: generations of 120, so the first improvement after the
    # initial population is dated after evaluation 120
    assert any(n > 120 for n, _ in de[0]["trace"])
    rnd = next(r for r in records if r["optimizer"] == "random-search")
    assert rnd["distribution"] == "femu-bench" and rnd["capabilities"]["anytime"] is True
    reported = femu(venv, "report", str(store), "--out", str(tmp_path / "report"))
    assert reported.returncode == 0, reported.stderr
    text = (tmp_path / "report" / "report.md").read_text()
    assert "example-de" in text and "Not anytime" not in text
    # a misspelt option is one line naming the option and the plugin's options
    bad = femu(venv, "study", "--optimizers", "example-de", "--suite", "hframe-freq/12/1", "--seeds", "0",
               "--budget", "240", "--store", str(tmp_path / "bad"), "--workers", "0", "--option", "example-de.popsiz=3")
    assert bad.returncode == 2 and bad.stderr.count("\n") == 1
    assert "'example-de' has no option 'popsiz'; its options: popsize, mutation, recombination, strategy" in bad.stderr


def test_a_plugin_in_the_current_directory_is_found_as_module_class(tmp_path):
    (tmp_path / "my_method.py").write_text(textwrap.dedent('''
        import numpy as np

        class Halton:
            """Scrambled Halton points, a batch of 32 at a time."""
            name = "halton"
            anytime = True
            batch = True

            def minimize(self, objective, bounds, budget, rng, x0=None, scramble=True):
                from scipy.stats import qmc
                sampler = qmc.Halton(len(bounds[0]), scramble=scramble, seed=rng)
                while True:
                    objective(qmc.scale(sampler.random(32), bounds[0], bounds[1]))
        '''))
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    done = subprocess.run([sys.executable, "-m", "femu", "study", "--optimizers", "my_method:Halton",
                           "--seeds", "0", "--budget", "50", "--store", "s", "--workers", "1", "--no-progress",
                           "--option", "my_method:Halton.scramble=false"],
                          cwd=tmp_path, capture_output=True, text=True, env=env, timeout=600)
    assert done.returncode == 0, done.stderr
    (record,) = [json.loads(p.read_text()) for p in (tmp_path / "s" / "runs").glob("*.json")]
    assert record["status"] == "ok" and record["n_evals"] == 50
    assert record["effective_options"] == {"scramble": False} and record["distribution"] is None
    assert record["capabilities"] == {"anytime": True, "uses_gradients": False, "batch": True, "supports_x0": True}
    # elsewhere the module is not found: one line naming it
    other = tmp_path / "elsewhere"
    other.mkdir()
    missing = subprocess.run([sys.executable, "-m", "femu", "optimizers", "my_method:Halton"], cwd=other,
                             capture_output=True, text=True, env=env)
    assert missing.returncode == 2 and "cannot import 'Halton' from module 'my_method'" in missing.stderr


def test_a_module_class_name_is_resolved_without_scanning_the_installed_entry_points(monkeypatch):
    """An import path cannot be an entry point's name (a colon ends that name), so it is
    resolved without reading every installed package's entry points (10-15 ms at load 6, once
    on each side of a sandboxed run); a registry name still is looked up there."""
    from adapters import registry

    def scan():
        raise AssertionError("the installed entry points were scanned")

    monkeypatch.setattr(registry, "_plugins", scan)
    assert registry.check_name("adapters.random_search:RandomSearch") == "adapters.random_search:RandomSearch"
    assert registry.get("adapters.random_search:RandomSearch") is registry.get("random-search")
    with pytest.raises(AssertionError, match="scanned"):
        registry.check_name("no-such-optimizer")
