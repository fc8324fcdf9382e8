"""Every figure in README.md and docs/*.md is registered in benchmarks/published.toml with how it
is checked (tests/published_figures.py: what counts as a figure, the exemption rule, the scopes).

A new number in a page that the rule takes for a figure fails here until it is registered; an
anchor that no longer matches its page fails; a timing without the machine, load, date and
script it was measured with fails; a figure said to be recomputed by a test names a test that
exists and reads that page.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
import published_figures as pf  # noqa: E402

ROOT = pf.ROOT
#: figures produced by a command and not (yet) recomputed anywhere: this count may only fall
MAX_UNCHECKED_FIGURES = 204


@pytest.fixture(scope="module")
def inventory():
    entries = pf.load()
    owned, loose, problems = pf.coverage(entries)
    return entries, owned, loose, problems


def test_every_entry_is_complete_and_its_anchor_is_on_its_page_once(inventory):
    entries, _, _, problems = inventory
    for k, e in enumerate(entries):
        where = f"entry {k} ({e.get('page')}: {e.get('anchor', '')[:50]!r})"
        if e.get("kind") not in pf.KINDS:
            problems.append(f"{where}: kind {e.get('kind')!r} is not one of {pf.KINDS}")
        if e.get("scope", "block") not in pf.SCOPES:
            problems.append(f"{where}: scope {e.get('scope')!r} is not one of {pf.SCOPES}")
        need = {"given": ("source",), "test": ("command", "test"), "script": ("command", "script"),
                "machine": ("command",), "history": ("command",), "unchecked": ("command",)}.get(e.get("kind"), ())
        problems += [f"{where}: no {f!r}" for f in need if not str(e.get(f, "")).strip()]
    assert not problems, "\n".join(problems)


def test_every_figure_on_every_page_is_registered(inventory):
    _, _, loose, _ = inventory
    shown = [f"{f.page}:{f.line}: {f.text!r} is a figure no entry of benchmarks/published.toml covers" for f in loose]
    assert not shown, f"{len(shown)} unregistered figures:\n" + "\n".join(shown[:60])


def test_every_entry_covers_a_figure(inventory):
    # an entry that covers nothing is stale (its figures moved or went)
    entries, owned, _, problems = inventory
    assert not problems
    idle = [f"{e['page']}: {e['anchor'][:60]!r}" for k, e in enumerate(entries) if k not in owned]
    assert not idle, "entries that cover no figure:\n" + "\n".join(idle)


_WHEN = re.compile(r"\b20\d\d-\d\d-\d\d\b|\b(?=[0-9a-f]*\d)(?=[0-9a-f]*[a-f])[0-9a-f]{7,40}\b")
_LOAD = re.compile(r"\bload\b|\bquiet\b", re.I)
_MACHINE = re.compile(r"\bcores?\b|\bCPUs?\b|machine", re.I)
_SCRIPT = re.compile(r"benchmarks/[\w/]+\.py|tests/[\w/]+\.py|\.ci/run|/usr/bin/time|\bfemu [a-z]+\b")


def _marking(page: pf.Page, entry: dict) -> str:
    a, b = pf.span(page, entry)
    text = page.text[a:b]
    marks = entry.get("marking", [])
    for mark in [marks] if isinstance(marks, str) else marks:
        m, n = pf.span(page, {"anchor": mark, "scope": "block"})
        text += " " + page.text[m:n]
    return " ".join(text.split())


def test_every_timing_says_where_when_at_what_load_and_how_to_measure_it_again(inventory):
    entries, _, _, _ = inventory
    bad = []
    for e in entries:
        if e.get("kind") != "machine":
            continue
        text = _marking(pf.parse(ROOT / e["page"]), e)
        missing = [what for what, rx in (("the date or commit", _WHEN), ("the load", _LOAD),
                                         ("the machine", _MACHINE), ("the script or command", _SCRIPT))
                   if not rx.search(text)]
        if missing:
            bad.append(f"{e['page']}: {e['anchor'][:60]!r}: its text does not say {', '.join(missing)}")
    assert not bad, "\n".join(bad)


def test_a_past_run_says_when_it_was_made(inventory):
    entries, _, _, _ = inventory
    bad = []
    for e in entries:
        if e.get("kind") == "history":
            text = _marking(pf.parse(ROOT / e["page"]), e)
            if not _WHEN.search(text):
                bad.append(f"{e['page']}: {e['anchor'][:60]!r}: a past run without its date or commit")
    assert not bad, "\n".join(bad)


def test_a_test_entry_names_a_test_that_exists_and_names_its_page(inventory):
    entries, _, _, _ = inventory
    bad = []
    for e in entries:
        if e.get("kind") != "test":
            continue
        path, _, name = e["test"].partition("::")
        src = (ROOT / path).read_text() if (ROOT / path).is_file() else ""
        # tests/test_docs.py runs every page (its samples compared with their commands' output)
        every_page = path == "tests/test_docs.py" and name == "test_the_blocks_of_a_page_run_in_order"
        if not re.search(rf"^\s*def {re.escape(name)}\(", src, re.M):
            bad.append(f"{e['page']}: {e['anchor'][:50]!r}: no test {e['test']}")
        elif not every_page and Path(e["page"]).name not in src:
            bad.append(f"{e['page']}: {e['anchor'][:50]!r}: {path} never names {Path(e['page']).name}")
    assert not bad, "\n".join(bad)


def test_a_script_entry_names_a_script_that_compares_that_page(inventory):
    entries, _, _, _ = inventory
    bad = []
    for e in entries:
        if e.get("kind") == "script":
            path = ROOT / e["script"].split()[0]
            if not path.is_file() or e["page"] not in path.read_text():
                bad.append(f"{e['page']}: {e['anchor'][:50]!r}: {e['script']} does not name {e['page']}")
    assert not bad, "\n".join(bad)


def test_figures_waiting_for_a_check_do_not_grow(inventory):
    entries, owned, _, _ = inventory
    n = sum(len(owned.get(k, [])) for k, e in enumerate(entries) if e.get("kind") == "unchecked")
    assert n <= MAX_UNCHECKED_FIGURES, (f"{n} figures are registered as 'unchecked' (at most {MAX_UNCHECKED_FIGURES}): "
                                        "check them in a test or a script instead")


def test_the_rule_finds_figures_and_exempts_what_it_says():
    page = pf.Page("x.md", "")
    text = ("# T\n\nIt took 1.7 s at load 3 (`node=8`, f1, 2026-11-28, version 0.1.0, commit e58561b); "
            "node 8 of seed 5 moved; 60 of 60 right; 3,881 candidates; 35x faster; 12 %; 64 MiB, 4 GPa.\n\n"
            "| a | b |\n|---|---|\n| 4 | x2 |\n\n```bash\npython run.py 2026 --budget 300\n```\n")
    p = ROOT / "tests" / "_published_rule_probe.md"
    try:
        p.write_text(text)
        page = pf.parse(p)
    finally:
        p.unlink()
    got = [f.text for f in pf.figures(page)]
    assert got == ["1.7", "60", "60", "3,881", "35", "12", "64", "4"]
