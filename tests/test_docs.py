"""Every `bash` and `python` block of README.md and docs/*.md runs (tests/docs_blocks.py).

Each page runs in order in a fresh copy of the repository, each block in its own process. A
long block runs in the shorter form its `docs-test: ci:` marker states (FEMU_DOCS_FULL=1 runs it
as written). A failure names the page and the line of the block.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
import docs_blocks as db  # noqa: E402

FULL = os.environ.get("FEMU_DOCS_FULL", "") == "1"


def _ids(pages):
    return [str(p.relative_to(db.ROOT)) for p in pages]


@pytest.mark.parametrize("page", db.pages(), ids=_ids(db.pages()))
def test_the_blocks_of_a_page_run_in_order(page, tmp_path):
    try:
        db.run_page(page, tmp_path, full=FULL)
    except db.DocsError as exc:
        pytest.fail(str(exc), pytrace=False)


def test_every_block_has_a_language_and_every_marker_applies():
    problems = []
    for page in db.pages():
        try:
            db.blocks(page)
        except db.DocsError as exc:
            problems.append(str(exc))
    assert not problems, "\n".join(problems)


def test_the_pages_have_runnable_blocks_and_the_readme_fits_a_screen_budget():
    """The runner is not vacuous: the README's examples are among the blocks it runs."""
    readme = db.blocks(db.ROOT / "README.md")
    run = [b for b in readme if b.lang in db.RUN]
    assert len(run) >= 6
    assert any("femu diagnose" in b.text for b in run) and any("femu identify" in b.text for b in run)
    assert any("adapters.run" in b.text for b in run) and any("femu study" in b.text for b in run)
    assert (db.ROOT / "README.md").stat().st_size <= 16 * 1024
    for page in db.pages()[1:]:  # each page opens with its title, then a sentence on what it is for
        lines = page.read_text().split("\n")
        first = [s for s in lines[1:] if s.strip()][0]
        assert lines[0].startswith("# ") and first[0] not in "#`|<!-", f"{page.name}: open with what the page is for"


#: issue 41: a page a user reads in minutes
MAX_WORDS = 3000


def test_every_docs_page_is_under_3000_words_and_opens_with_its_purpose():
    """Each page under docs/ (the README is not: issue 41 names the docs pages) has fewer than
    3,000 words (whitespace-separated, as `wc -w` counts) and its first paragraph after the title
    says whom the page is for ("This page is for ..."). One test for all pages (one xdist unit:
    tests/cputime.py makes each parametrized docs test a unit of its own)."""
    problems = []
    for page in db.pages()[1:]:
        text = page.read_text()
        words = len(text.split())
        if words >= MAX_WORDS:
            problems.append(f"{page.name}: {words} words, the limit is {MAX_WORDS}: split it")
        first = [s for s in text.split("\n")[1:] if s.strip()][0]
        if not first.startswith("This page is for "):
            problems.append(f"{page.name}: open with what the page is for, not {first[:60]!r}")
    assert not problems, "\n".join(problems)


def _page(tmp_path: Path, text: str) -> Path:
    page = tmp_path / "page.md"
    page.write_text(text)
    return page


def test_a_failing_block_is_named_by_page_and_line(tmp_path):
    page = _page(tmp_path, "# t\n\n```bash\ntrue\n```\n\ntext\n\n```python\nimport nonexistent_module_xyz\n```\n")
    with pytest.raises(db.DocsError, match=r"page.md:9: the python block failed \(exit 1\)"):
        db.run_page(page, tmp_path / "w")


def test_a_block_without_language_and_a_stale_ci_replacement_are_refused(tmp_path):
    with pytest.raises(db.DocsError, match=r"page.md:3: a code block without a language"):
        db.blocks(_page(tmp_path, "# t\n\n```\nfemu x\n```\n"))
    with pytest.raises(db.DocsError, match=r"page.md:3: the CI replacement's '--seeds 0-9' is not in the block"):
        db.blocks(_page(tmp_path, "# t\n\n<!-- docs-test: ci: --seeds 0-9 => --seeds 0 -->\n```bash\nfemu x\n```\n"))


def test_blocks_share_files_but_not_variables_and_the_ci_form_applies(tmp_path):
    page = _page(tmp_path, "# t\n\n<!-- docs-test: file a.json -->\n```json\n{\"a\": 1}\n```\n\n"
                           "<!-- docs-test: ci: 41 => 42 -->\n```python\nimport json\nx = json.load(open('a.json'))['a'] + 41\n"
                           "open('b.txt', 'w').write(str(x))\n```\n\n```bash\ntest \"$(cat b.txt)\" = 43\n```\n")
    db.run_page(page, tmp_path / "w1")  # the CI form: 1 + 42
    with pytest.raises(db.DocsError, match=r"page.md:15: the bash block failed"):
        db.run_page(page, tmp_path / "w2", full=True)  # as written: 1 + 41
    page2 = _page(tmp_path, "# t\n\n```python\nx = 1\n```\n\n```python\nprint(x)\n```\n")
    with pytest.raises(db.DocsError, match=r"(?s)page.md:7: .*NameError"):
        db.run_page(page2, tmp_path / "w3")


def test_a_pages_pytest_benchmark_runs_when_the_docs_test_is_an_xdist_worker(tmp_path, monkeypatch):
    """A block's own pytest does not inherit the test run's PYTEST_XDIST_WORKER (it would take itself
    for a worker: pytest-benchmark then refuses --benchmark-only, as docs/scale.md's block did)."""
    monkeypatch.setenv("PYTEST_XDIST_WORKER", "gw1")
    monkeypatch.setenv("PYTEST_XDIST_WORKER_COUNT", "2")
    assert not any(k.startswith("PYTEST_") for k in db.environment())
    page = _page(tmp_path, "# t\n\n```bash\nprintf 'def test_b(benchmark):\\n    benchmark(sum, range(9))\\n' > test_b.py\n"
                           "python -m pytest -q -p no:cacheprovider test_b.py --benchmark-only --benchmark-json b.json\n"
                           "test -s b.json\n```\n")
    db.run_page(page, tmp_path / "w")


def test_samples_are_regenerated_from_their_command(tmp_path):
    page = _page(tmp_path, "# t\n\n<!-- docs-sample: echo hello; echo world -->\n```console\nold\n```\n\nend\n")
    db.run_page(page, tmp_path / "w", regenerate=True)
    assert page.read_text() == ("# t\n\n<!-- docs-sample: echo hello; echo world -->\n```console\n"
                                "$ echo hello; echo world\nhello\nworld\n```\n\nend\n")


def test_the_script_lists_the_blocks():
    out = subprocess.run([sys.executable, str(Path(db.__file__)), "--list", str(db.ROOT / "README.md")],
                         capture_output=True, text=True, check=True).stdout
    assert "README.md:" in out and "\tpython\truns" in out


def test_no_block_installs_into_the_environment_the_tests_run_in():
    """A block run as written by the tests must not `pip install` (a `pip install -e .` from the
    page's fresh copy would point the test environment's own install at that temporary copy, so
    that every later test imports the copy, and none once it is deleted): an install block
    carries a `docs-test: ci:` replacement that checks its result instead."""
    installs = [b.where for page in db.pages() for b in db.blocks(page)
                if b.lang == "bash" and re.search(r"(^|[\s/])pip3? install", b.code(FULL))]
    assert installs == []


def test_a_sample_that_is_not_what_its_command_prints_fails_timings_aside(tmp_path):
    ok = _page(tmp_path, "# t\n\n<!-- docs-sample: echo took 0.2 s, 3 modes -->\n```console\n"
                         "$ echo took 0.2 s, 3 modes\ntook 9.75 s, 3 modes\n```\n")
    db.run_page(ok, tmp_path / "a")  # the seconds are the machine's
    bad = _page(tmp_path, "# t\n\n<!-- docs-sample: echo 3 modes -->\n```console\n$ echo 3 modes\n4 modes\n```\n")
    with pytest.raises(db.DocsError, match="is not what 'echo 3 modes' prints"):
        db.run_page(bad, tmp_path / "b")
