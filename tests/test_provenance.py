"""Provenance in every report and summary: femu-bench's version and commit, the suite version,
host, date and library versions (adapters.provenance), and the suite version in every record."""

import io
import json
import platform
import subprocess
from datetime import datetime, timezone
from importlib.metadata import version
from pathlib import Path

import pytest

from adapters.provenance import git_commit, provenance
from fe_problem.suite import SUITE_VERSION
from femu.cli import main
from femu.studies.store import Store

ROOT = Path(__file__).resolve().parents[1]


def _git(*args):
    try:
        out = subprocess.run(["git", "-C", str(ROOT), *args], capture_output=True, text=True, timeout=10)
    except OSError:
        return None
    return out.stdout.strip() if out.returncode == 0 else None


def _check(p: dict, runs: int):
    assert p["femu_bench"] == version("femu-bench") and p["suite_version"] == SUITE_VERSION
    assert p["commit"] == _git("rev-parse", "HEAD")  # None outside a git work tree
    assert p["host"] == platform.node() and p["versions"]["numpy"] == version("numpy")
    made = datetime.fromisoformat(p["date_utc"])
    assert made.tzinfo is not None and abs((datetime.now(timezone.utc) - made).total_seconds()) < 3600
    assert p["records"]["runs"] == runs and p["records"]["suite_versions"] == {SUITE_VERSION: runs}
    assert p["records"]["hosts"] == {platform.node(): runs}


def test_git_commit_and_a_directory_outside_git(tmp_path):
    commit, dirty = git_commit()
    assert commit == _git("rev-parse", "HEAD")
    if commit is not None:
        assert dirty == bool(_git("status", "--porcelain", "--untracked-files=no"))
    assert git_commit(tmp_path) == (None, None)
    assert set(provenance()) >= {"femu_bench", "commit", "suite_version", "host", "date_utc", "versions"}


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    path = tmp_path_factory.mktemp("prov") / "store"
    assert main(["study", "--optimizers", "random-search,cma-es", "--seeds", "0-1", "--budget", "30", "--store",
                 str(path), "--workers", "0", "--no-progress"]) == 0
    return path


def test_every_record_carries_the_suite_version(store):
    runs = Store(store).runs()
    assert runs and all(r.suite_version == SUITE_VERSION for r in runs)
    raw = json.loads(next((store / "runs").glob("*.json")).read_text())
    assert raw["suite_version"] == SUITE_VERSION


def test_report_summary_and_stats_state_their_provenance(store, tmp_path, capsys):
    out = tmp_path / "rep"
    assert main(["report", str(store), "--out", str(out)]) == 0
    md = (out / "report.md").read_text()
    assert "## Provenance" in md and f"suite version {SUITE_VERSION}" in md and f"femu-bench {version('femu-bench')}" in md
    for group in json.loads((out / "summary.json").read_text()):
        _check(group["provenance"], 4)
    # a study where two solvers share a problem also gets benchmark.md and stats.json-like numbers
    assert "## Provenance" in (out / "benchmark.md").read_text()
    capsys.readouterr()
    assert main(["report", str(store), "--json"]) == 0
    _check(json.loads(capsys.readouterr().out)["provenance"], 4)


def test_reproduce_states_its_provenance(tmp_path, monkeypatch, capsys):
    import femu.reproduce as rp

    monkeypatch.setattr(rp, "solvers", lambda budget: (["random-search"], {}))
    res = rp.reproduce(seeds=2, budget=20, out=tmp_path / "r", workers=0, log=io.StringIO())
    _check(res["provenance"], 2)
    assert "## Provenance" in (tmp_path / "r" / "report.md").read_text()
    from femu.reports.reproduce import render_text

    assert f"suite version {SUITE_VERSION}" in render_text(res).splitlines()[-1]


def test_citation_cff_has_cff_1_2_0s_required_fields_and_the_projects_version():
    import re

    import yaml

    cff = yaml.safe_load((ROOT / "CITATION.cff").read_text())
    text = (ROOT / "pyproject.toml").read_text()  # tomllib is Python 3.11's; the project runs on 3.10
    project = {k: re.search(rf'^{k} = "([^"]+)"$', text, re.M)[1] for k in ("version", "license")}
    # CFF 1.2.0's schema: required authors (at least one person or entity), cff-version, message, title
    assert cff["cff-version"] == "1.2.0"
    assert isinstance(cff["message"], str) and cff["message"] and isinstance(cff["title"], str) and cff["title"]
    assert isinstance(cff["authors"], list) and cff["authors"]
    for a in cff["authors"]:  # an entity has a name; a person at least a family or given name
        assert isinstance(a, dict) and (a.get("name") or a.get("family-names") or a.get("given-names")), a
    assert set(cff) <= {"cff-version", "message", "title", "authors", "type", "version", "license", "keywords",
                        "abstract", "date-released", "doi", "identifiers", "repository-code", "url", "preferred-citation",
                        "references", "commit", "contact", "license-url", "repository", "repository-artifact"}
    assert cff["type"] in ("software", "dataset")
    assert str(cff["version"]) == project["version"] and cff["license"] == project["license"] == "MIT"
    assert (ROOT / "LICENSE").read_text().startswith("MIT License\n")
