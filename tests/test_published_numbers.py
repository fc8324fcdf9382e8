"""Figures the docs publish, produced by the commands that make them (the quick ones): a number in
a page that drifts from what its command prints fails here."""

import re
from pathlib import Path

import pytest

from femu.cli import main

ROOT = Path(__file__).resolve().parents[1]


def _number(pattern: str, text: str, where: str) -> str:
    m = re.search(pattern, " ".join(text.split()))
    assert m, f"{where}: no match for {pattern!r}"
    return m[1]


@pytest.fixture(scope="module")
def paper_diagnosis(tmp_path_factory):
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["diagnose", "paper"]) == 0
    return out.getvalue()


def test_diagnosis_page_on_the_papers_data(paper_diagnosis):
    page = (ROOT / "docs" / "diagnosis-real-data.md").read_text()
    said = " ".join(page[page.index("## On the paper's data"):].split())
    out = paper_diagnosis
    # "a linear trend of the modulus along the span has 15.17 more in log evidence than no effect"
    ev = _number(r"log evidence ([\d.]+) against 0\), but no candidate is significant", out, "femu diagnose paper")
    assert _number(r"along the span has ([\d.]+) more in log evidence", said, "docs/diagnosis-real-data.md") == ev
    assert "stiffness_trend@trend=linear_span+ has more evidence" in out
    # "drops chi^2 by 807 where 855 is needed after the correction for 166 candidates (p = 0.016)"
    drop = float(_number(r"chi\^2 drop ([\d.]+), \d+ needed", out, "femu diagnose paper"))
    need = _number(r"chi\^2 drop [\d.]+, (\d+) needed", out, "femu diagnose paper")
    assert _number(r"drops chi\^2 by (\d+) where", said, "docs/diagnosis-real-data.md") == f"{drop:.0f}"
    assert _number(r"where (\d+) is needed", said, "docs/diagnosis-real-data.md") == need
    n = _number(r"adjusted over (\d+) candidates", out, "femu diagnose paper")
    assert _number(r"correction for (\d+) candidates", said, "docs/diagnosis-real-data.md") == n
    p = float(_number(r"p = ([\d.]+) \(adjusted", out, "femu diagnose paper"))
    assert _number(r"candidates \(p = ([\d.]+)\)", said, "docs/diagnosis-real-data.md") == f"{p:.2g}"
    noise = float(_number(r"misfit implies: frequencies ([\d.]+) %", out, "femu diagnose paper"))
    assert _number(r"misfit implies ([\d.]+) % frequency noise", said, "docs/diagnosis-real-data.md") == f"{noise:.1f}"
    assert "CAUSE: none" in out and "VERDICT: NOT ADEQUATE" in out


def test_the_readme_reproduce_table_is_where_the_check_script_looks():
    # benchmarks/readme_reproduce.py (minutes of CPU: run before a release) compares README.md's
    # table with `femu reproduce --markdown`; here only that it finds that table and its form
    import importlib.util

    spec = importlib.util.spec_from_file_location("readme_reproduce", ROOT / "benchmarks" / "readme_reproduce.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    text = (ROOT / "README.md").read_text()
    first, end = mod.readme_table(text)
    table = text.splitlines()[first:end]
    assert table[0] == "|  | f1 | f2 | f3 | f4 | f5 | mean abs error % |"  # femu.reports.reproduce.render_markdown's
    assert table[2].startswith("| measured | 53.9 | 117.3 |") and table[-1].startswith("| paper PSO / SA / GA (Table 1) |")
