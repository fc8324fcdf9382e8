"""The code blocks of README.md and docs/*.md: find them, run them, regenerate sample outputs.

Every fenced block carries a language. `bash` and `python` blocks are run by tests/test_docs.py,
page by page, in order, each page in a fresh copy of the repository's files (a fresh clone as a
reader has it), each block in its own process: a block must stand on its own (its imports
included); files one block writes, the next may read. Blocks fenced `console` or `text` are
synopses and sample outputs, not run; `json`, `toml` and the like are data.

HTML comments on the lines just above a fence steer a block (they do not show on GitHub):

    <!-- docs-test: file NAME -->           write this (data) block to NAME before the next blocks
    <!-- docs-test: ci: OLD => NEW | ... --> a long block: CI (and the default test run) runs it with
                                            each OLD replaced by NEW (each OLD must be in the block);
                                            FEMU_DOCS_FULL=1 runs it as written
    <!-- docs-sample: COMMAND -->           the next block (console/text) is COMMAND's output, shown
                                            after a line `$ COMMAND`; the test runs COMMAND too and
                                            compares its output with the block, timings aside;
                                            `python tests/docs_blocks.py --regenerate` rewrites the block

`$FEMU_DOCS_VENV` in a replacement is the environment the tests run in.

Usage: python tests/docs_blocks.py [--list] [--regenerate] [PAGE ...]
"""

from __future__ import annotations

import argparse
import difflib
import os
import re
import shutil
import subprocess
import sys
import tempfile
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

#: Languages whose blocks run, and those that are text or data.
RUN = ("bash", "python")
TEXT = ("console", "text")
DATA = ("json", "toml", "yaml", "csv", "ini")

_FENCE = re.compile(r"^(```+)\s*([A-Za-z0-9_+-]*)\s*$")
_MARK = re.compile(r"^<!--\s*docs-(test|sample):\s*(.*?)\s*-->\s*$")


class DocsError(Exception):
    """A page's block or marker that cannot be run or understood, with page and line."""


@dataclass
class Block:
    """One fenced block: its page, the line of its opening fence (1-based), language, text and
    the markers above it."""

    page: Path
    line: int
    lang: str
    text: str
    file: str | None = None
    ci: list[tuple[str, str]] = field(default_factory=list)
    sample: str | None = None

    @property
    def where(self) -> str:
        return f"{self.page.relative_to(ROOT) if self.page.is_relative_to(ROOT) else self.page}:{self.line}"

    def code(self, full: bool) -> str:
        """The text to run: as written with `full`, else with the CI replacements."""
        text = self.text
        if not full:
            for old, new in self.ci:
                text = text.replace(old, new)
        return text


def pages() -> list[Path]:
    """README.md and every docs/*.md page."""
    return [ROOT / "README.md"] + sorted((ROOT / "docs").glob("*.md"))


def blocks(page: Path) -> list[Block]:
    """The fenced blocks of `page`, in order; a block without a language, an unclosed fence, a
    malformed marker or a CI replacement not found in its block is a DocsError naming the line."""
    lines = page.read_text(encoding="utf-8").split("\n")
    rel = page.relative_to(ROOT) if page.is_relative_to(ROOT) else page
    out: list[Block] = []
    marks: list[tuple[int, str, str]] = []
    i = 0
    while i < len(lines):
        m = _MARK.match(lines[i])
        if m:
            marks.append((i + 1, m.group(1), m.group(2)))
            i += 1
            continue
        f = _FENCE.match(lines[i])
        if not f:
            if lines[i].strip():
                marks = []  # a marker steers only the block right below it
            i += 1
            continue
        ticks, lang = f.group(1), f.group(2).lower()
        j = i + 1
        while j < len(lines) and lines[j].strip() != ticks:
            j += 1
        if j == len(lines):
            raise DocsError(f"{rel}:{i + 1}: a code fence that is never closed")
        if not lang:
            raise DocsError(f"{rel}:{i + 1}: a code block without a language: fence it `bash` or `python` "
                            "(it is run by tests/test_docs.py), `console`/`text` (a synopsis or sample output) "
                            "or the data's format")
        b = Block(page, i + 1, lang, "\n".join(lines[i + 1:j]) + "\n")
        for line_no, kind, body in marks:
            if kind == "sample":
                b.sample = body
            elif body.startswith("file "):
                b.file = body[5:].strip()
            elif body.startswith("ci:"):
                for pair in body[3:].split(" | "):
                    if " => " not in pair:
                        raise DocsError(f"{rel}:{line_no}: a CI replacement is 'OLD => NEW', got {pair.strip()!r}")
                    old, new = (s.strip() for s in pair.split(" => ", 1))
                    if old not in b.text:
                        raise DocsError(f"{rel}:{line_no}: the CI replacement's {old!r} is not in the block below it")
                    b.ci.append((old, new))
            else:
                raise DocsError(f"{rel}:{line_no}: unknown docs-test marker {body!r} (file NAME, or ci: OLD => NEW)")
        if b.sample is not None and lang not in TEXT:
            raise DocsError(f"{rel}:{i + 1}: a docs-sample block is output: fence it `console` or `text`")
        if b.file and lang in RUN:
            raise DocsError(f"{rel}:{i + 1}: a docs-test file block is data, not a {lang} block")
        out.append(b)
        marks = []
        i = j + 1
    return out


def fresh_copy(dest: Path) -> Path:
    """The repository's files (tracked and new, not ignored) copied into `dest`: a fresh clone."""
    listed = subprocess.run(["git", "ls-files", "-z", "-co", "--exclude-standard"], cwd=ROOT, check=True,
                            capture_output=True).stdout.decode().split("\0")
    for rel in filter(None, listed):
        src = ROOT / rel
        if src.is_file():
            (dest / rel).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / rel)
    return dest


def environment() -> dict:
    """The environment blocks run in: this interpreter's environment first on PATH, without the
    test run's own PYTEST_* variables: a reader's shell has none, and a block's pytest that saw
    PYTEST_XDIST_WORKER would take itself for an xdist worker (pytest-benchmark then disables
    the benchmarks and refuses --benchmark-only)."""
    venv_bin = str(Path(sys.executable).parent)
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTEST_")}
    return dict(env, PATH=venv_bin + os.pathsep + os.environ.get("PATH", ""), FEMU_DOCS_VENV=sys.prefix,
                OPENBLAS_NUM_THREADS="1", MPLBACKEND="Agg", PYTHONDONTWRITEBYTECODE="1")


def run_block(b: Block, cwd: Path, full: bool, timeout_s: float = 1800) -> subprocess.CompletedProcess:
    """Run one bash or python block in `cwd`; a DocsError naming page and line when it fails."""
    code = b.code(full)
    if b.lang == "bash":
        args = ["bash", "-e", "-o", "pipefail", "-c", code]
    else:
        args = [sys.executable, "-c", code]
    try:
        proc = subprocess.run(args, cwd=cwd, env=environment(), capture_output=True, text=True, timeout=timeout_s)
    except subprocess.TimeoutExpired:
        raise DocsError(f"{b.where}: the {b.lang} block ran longer than {timeout_s:.0f} s") from None
    if proc.returncode != 0:
        tail = "\n".join((proc.stderr or proc.stdout).strip().splitlines()[-15:])
        raise DocsError(f"{b.where}: the {b.lang} block failed (exit {proc.returncode}):\n{code}--- its output:\n{tail}")
    return proc


def run_sample(b: Block, cwd: Path) -> str:
    """The output of a docs-sample's command, as the block shows it."""
    proc = subprocess.run(["bash", "-o", "pipefail", "-c", b.sample], cwd=cwd, env=environment(),
                          capture_output=True, text=True, timeout=1800)
    if proc.returncode != 0:
        raise DocsError(f"{b.where}: the sample's command {b.sample!r} failed (exit {proc.returncode}):\n"
                        f"{proc.stderr.strip()[-2000:]}")
    return f"$ {b.sample}\n{proc.stdout.rstrip()}\n"


_TIME = re.compile(r"\b\d+(?:\.\d+)? ?(?:s|ms|us)\b")


def _untimed(text: str) -> str:
    """A sample's text with its timings masked: a run's seconds are the machine's, the rest is
    the command's (benchmarks/published.toml lists a sample's timings as `machine` figures)."""
    return _TIME.sub("<time>", text.rstrip("\n"))


def rel_of(page: Path) -> str:
    return str(page.relative_to(ROOT)) if page.is_relative_to(ROOT) else str(page)


def run_page(page: Path, workdir: Path, full: bool = False, regenerate: bool = False) -> list[Block]:
    """Run `page`'s blocks in order in a fresh copy of the repository under `workdir`; with
    `regenerate`, rewrite its sample blocks from their commands. Returns the blocks run."""
    work = fresh_copy(workdir)
    done, new_samples = [], {}
    for b in blocks(page):
        if b.file:
            (work / b.file).write_text(b.text, encoding="utf-8")
        elif b.lang in RUN:
            run_block(b, work, full)
            done.append(b)
        elif b.sample is not None:
            new_samples[b.line] = run_sample(b, work)
            if not regenerate and _untimed(new_samples[b.line]) != _untimed(b.text):
                shown = "\n".join(difflib.unified_diff(b.text.splitlines(), new_samples[b.line].splitlines(),
                                                       "the page", "the command", lineterm=""))
                raise DocsError(f"{b.where}: the sample is not what {b.sample!r} prints (timings aside; "
                                f"`python tests/docs_blocks.py --regenerate {rel_of(page)}` rewrites it):\n{shown}")
            done.append(b)
    if regenerate and new_samples:
        lines = page.read_text(encoding="utf-8").split("\n")
        for b in sorted((b for b in blocks(page) if b.line in new_samples), key=lambda b: -b.line):
            end = b.line + len(b.text.rstrip("\n").split("\n"))
            lines[b.line:end] = new_samples[b.line].rstrip("\n").split("\n")
        page.write_text("\n".join(lines), encoding="utf-8")
    return done


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("pages", nargs="*", help="pages (default: README.md and docs/*.md)")
    p.add_argument("--list", action="store_true", help="list the blocks and what is done with each")
    p.add_argument("--regenerate", action="store_true", help="rewrite the sample outputs of the pages")
    p.add_argument("--full", action="store_true", help="run long blocks as written, not in their CI form")
    a = p.parse_args(argv)
    chosen = [Path(s).resolve() for s in a.pages] or pages()
    try:
        for page in chosen:
            if a.list:
                for b in blocks(page):
                    what = ("writes " + b.file) if b.file else ("sample: " + b.sample) if b.sample else (
                        "runs" + (" (CI form)" if b.ci else "") if b.lang in RUN else "not run")
                    print(f"{b.where}\t{b.lang}\t{what}")
                continue
            if a.regenerate and not any(b.sample for b in blocks(page)):
                continue
            with tempfile.TemporaryDirectory(prefix="femu-docs-") as tmp:
                run_page(page, Path(tmp), full=a.full, regenerate=a.regenerate)
            print(f"{page.relative_to(ROOT)}: ok" + (" (samples rewritten)" if a.regenerate else ""))
    except DocsError as exc:
        print(f"docs_blocks: {exc}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
