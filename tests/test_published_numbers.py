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


@pytest.fixture(scope="module")
def hframe_modes():
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["model", "hframe", "--modes", "10"]) == 0
    return [float(m[1]) for m in re.finditer(r"^\s+\d+\s+([\d.]+)$", out.getvalue(), re.M)]


def test_hframe_page_nominal_frequencies_and_their_match_to_the_paper(hframe_modes):
    import math

    page = " ".join((ROOT / "docs" / "hframe.md").read_text().split())
    said = _number(r"Nominal elastic frequencies \(Hz\), modes 1-10: ([\d., ]+)\.", page, "docs/hframe.md")
    assert len(hframe_modes) == 10
    assert [f"{f:.3f}" for f in hframe_modes] == [s.strip() for s in said.split(",")]  # as `femu model` prints them
    # "reproduce the paper's initial-model frequencies to within X %": X is the worst mode's
    # difference to the paper's Table 1 (its "initial" column, read from the same page), rounded up
    text = (ROOT / "docs" / "hframe.md").read_text()
    table = re.findall(r"^\| (\d) \| [\d.]+ \| ([\d.]+) \|", text[text.index("## The published data"):], re.M)
    paper = [float(v) for _, v in table[:5]]
    worst = max(abs(f / p - 1) * 100 for f, p in zip(hframe_modes, paper))
    bound = f"{math.ceil(worst * 100) / 100:.2f}"
    for name in ("docs/hframe.md", "README.md"):
        text = " ".join((ROOT / name).read_text().split())
        assert _number(r"initial-model frequencies to within ([\d.]+) %", text, name) == bound


def test_the_space_frames_first_frequencies_on_the_elements_page():
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["model", "frame3d", "--modes", "5"]) == 0
    printed = re.findall(r"^\s+\d+\s+([\d.]+)$", out.getvalue(), re.M)
    page = " ".join((ROOT / "docs" / "model-elements.md").read_text().split())
    said = _number(r"its first frequencies are ([\d., ]+) Hz", page, "docs/model-elements.md")
    assert [s.strip() for s in said.split(",")] == printed  # as `femu model frame3d --modes 5` prints them


def test_the_long_run_check_finds_every_table_it_compares():
    # benchmarks/check_published.py (an hour of CPU: run before a stop) compares the diagnosis, reproduce
    # and suite tables with the pages; here only that each table it looks for is where it looks
    import importlib.util

    spec = importlib.util.spec_from_file_location("check_published", ROOT / "benchmarks" / "check_published.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    headers = {"diagnosis-standard": ("| truth \\ answer |", "| class | cases | right |"),
               "diagnosis-more": ("| class | cases | right |",), "diagnosis-real": ("| class | cases | right |",),
               "reproduce": ("|  | f1 | f2 |",), "adapter-references": ("| built-in | reference | problem |",)}
    for row in mod.TABLES:
        job, k, page, anchor = row[:4]
        lines = (ROOT / page).read_text().splitlines()
        first, end = mod.table_after(lines, anchor, row[4] if len(row) > 4 else 0)
        assert end - first >= 3 and lines[first].startswith(headers[job][min(k, len(headers[job]) - 1)]), (page, anchor)
    said = mod._suite_lines((ROOT / mod.SUITE_PAGE).read_text())
    assert said[0].startswith("# ") and not any(s.startswith("Made by") or s == "## Costs" for s in said)
    assert mod.tables("a\n| x |\n|---|\n| 1 |\nb\n| y |\n") == [["| x |", "|---|", "| 1 |"], ["| y |"]]


def test_the_long_run_check_reports_a_page_that_differs(tmp_path, capsys):
    import importlib.util

    spec = importlib.util.spec_from_file_location("check_published", ROOT / "benchmarks" / "check_published.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    lines = (ROOT / "docs" / "diagnosis-tables.md").read_text().splitlines()
    first, end = mod.table_after(lines, "## Classes of real structures (seed 5)")
    page_table = lines[first:end]
    (tmp_path / "diagnosis-real.md").write_text("\n".join(page_table) + "\n")  # what the page says: no difference
    assert mod.main(["--only", "diagnosis-real", "--reuse", "--dir", str(tmp_path)]) == 0
    changed = page_table[:2] + [page_table[2].replace("| 4 |", "| 5 |", 1)] + page_table[3:]
    (tmp_path / "diagnosis-real.md").write_text("\n".join(changed) + "\n")
    assert mod.main(["--only", "diagnosis-real", "--reuse", "--dir", str(tmp_path)]) == 1
    out = capsys.readouterr().out
    assert f"-{page_table[2]}" in out and f"+{changed[2]}" in out
