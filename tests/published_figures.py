"""The published-figures inventory (benchmarks/published.toml) and the rule that finds figures in
README.md and docs/*.md. Used by tests/test_published_inventory.py (the checker) and by
benchmarks/check_published.py.

A *figure* is a number a reader takes as a result. In a page's prose, list items, table rows and
its `text`/`console` blocks (a command's output), after inline code spans, link targets, dates
(YYYY-MM-DD), versions (x.y.z) and numbers glued to a letter or identifier (f1, node=8, 39x39,
e58561b) are removed, a number is a figure when

- it stands in a table row (every number of a table, counts included), or
- it has a decimal fraction (15.17), an exponent (3.1e+04) or a thousands separator (3,881), or
- a unit of time, size, ratio or share follows it (%, x, s, ms, us, min, minutes, seconds, h,
  hours, Hz, kB, MB, GB, MiB, GiB), or
- it is a count of a count ("8 of 8", "12/10/10/8").

Exempt by that rule: plain integers in prose (indices, seeds, sizes of a plan: "node 8", "seed 5",
"4 modes"), and everything in `bash`, `python`, `json` and `toml` blocks (commands and input
files a user writes; tests/test_docs.py runs the bash and python ones).

An inventory entry covers figures by its `scope`: `section` (the heading `anchor` and everything
under it up to the next heading of the same or a higher level), `block` (the paragraph, list
item, table or fenced block in which `anchor` occurs) or `text` (the numbers inside the anchor's
own text). A figure belongs to its most specific entry (text, then block, then section).
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
INVENTORY = ROOT / "benchmarks" / "published.toml"
KINDS = ("test", "script", "machine", "history", "given", "unchecked")
SCOPES = ("text", "block", "section")
#: fenced blocks whose numbers are input, not results
EXEMPT_BLOCKS = ("bash", "python", "json", "toml")

_CODE = re.compile(r"`[^`\n]*`")
_LINK = re.compile(r"\]\([^)]*\)")
_DATE = re.compile(r"\b\d{4}-\d{2}-\d{2}(T[\d:+.]+)?")
_VERSION = re.compile(r"\b\d+\.\d+\.\d+\b")
_HEX = re.compile(r"\b(?=[0-9a-f]*[a-f])(?=[0-9a-f]*\d)[0-9a-f]{7,40}\b")
_NUM = re.compile(r"(?<![\w.@/=^'\-+])[-+]?\d+(?:,\d{3})*(?:\.\d+)?(?:e[-+]?\d+)?(?![\w.]*[A-Za-z_(])"
                  r"|(?<![\w.@/=^'\-+])[-+]?\d+(?:,\d{3})*(?:\.\d+)?(?:e[-+]?\d+)?(?=\s?(?:%|x\b|s\b|ms\b|us\b|min\b|minutes?\b|seconds?\b|h\b|hours?\b|Hz\b|[kKMG]i?B\b))")
_UNIT = re.compile(r"\s?(?:%|x\b|s\b|ms\b|us\b|min\b|minutes?\b|seconds?\b|h\b|hours?\b|Hz\b|[kKMG]i?B\b)")
_OF = re.compile(r"^\s?(?:of|/)\s?\d")


@dataclass
class Figure:
    page: str
    line: int  # 1-based
    start: int  # offset in the page's text
    text: str


@dataclass
class Block:
    first: int  # offset of the block's first character
    end: int
    section: tuple[int, int]  # the innermost heading's (offset, level)


@dataclass
class Page:
    name: str
    text: str
    blocks: list[Block] = field(default_factory=list)
    headings: list[tuple[int, int, int, str]] = field(default_factory=list)  # offset, end of section, level, line
    scanned: list[tuple[int, int, bool]] = field(default_factory=list)  # (first, end, is a table row)


def pages() -> list[Path]:
    return [ROOT / "README.md"] + sorted((ROOT / "docs").glob("*.md"))


def _blank(s: str) -> str:
    return " " * len(s)


def parse(path: Path) -> Page:
    text = path.read_text()
    page = Page(str(path.relative_to(ROOT)), text)
    lines = text.split("\n")
    offs, o = [], 0
    for ln in lines:
        offs.append(o)
        o += len(ln) + 1
    fence = None
    cur: list[int] | None = None  # [first offset, end offset]

    def close():
        nonlocal cur
        if cur is not None:
            page.blocks.append(Block(cur[0], cur[1], (0, 0)))
        cur = None

    kind_prev = None
    for i, ln in enumerate(lines):
        a, b = offs[i], offs[i] + len(ln)
        if fence is not None:
            if ln.strip() == "```":  # as tests/docs_blocks.py reads a fence
                cur[1] = b
                close()
                fence = None
            else:
                if fence not in EXEMPT_BLOCKS:
                    page.scanned.append((a, b, False))
                cur[1] = b
            continue
        if ln.startswith("```"):
            close()
            fence = ln[3:].strip()
            cur = [a, b]
            continue
        if ln.startswith("#"):
            close()
            level = len(ln) - len(ln.lstrip("#"))
            page.headings.append((a, len(text), level, ln))
            page.scanned.append((a, b, False))
            page.blocks.append(Block(a, b, (0, 0)))
            continue
        if not ln.strip():
            close()
            kind_prev = None
            continue
        is_table = ln.startswith("|")
        item = re.match(r"\s{0,3}(?:[-*]|\d+\.)\s", ln) is not None
        kind = "table" if is_table else "prose"
        if cur is None or kind != kind_prev or (item and not is_table):
            close()
            cur = [a, b]
        else:
            cur[1] = b
        kind_prev = kind
        page.scanned.append((a, b, is_table))
    close()
    # section ends: the next heading of the same or a higher level
    hs = page.headings
    for k, (a, _, level, ln) in enumerate(hs):
        end = next((h[0] for h in hs[k + 1:] if h[2] <= level), len(text))
        hs[k] = (a, end, level, ln)
    return page


def figures(page: Page) -> list[Figure]:
    out = []
    for a, b, table in page.scanned:
        s = page.text[a:b]
        for rx in (_CODE, _LINK, _DATE, _VERSION, _HEX):
            s = rx.sub(lambda m: _blank(m[0]), s)
        for m in _NUM.finditer(s):
            tok = m[0]
            after = s[m.end():m.end() + 6]
            figure = (table or "." in tok or "e" in tok or "," in tok or _UNIT.match(after) is not None
                      or _OF.match(after) is not None
                      or re.search(r"(?:\d\s?of\s?|\d/)$", s[max(0, m.start() - 6):m.start()]) is not None)
            if figure:
                line = page.text.count("\n", 0, a + m.start()) + 1
                out.append(Figure(page.name, line, a + m.start(), tok))
    return out


def _norm(s: str) -> str:
    return " ".join(s.split())


def find_anchor(page: Page, anchor: str) -> list[int]:
    """Offsets in the page where `anchor` occurs (whitespace-insensitive)."""
    words = anchor.split()
    rx = re.compile(r"\s+".join(re.escape(w) for w in words))
    return [m.start() for m in rx.finditer(page.text)]


def span(page: Page, entry: dict) -> tuple[int, int]:
    """The (first, end) offsets an entry covers; ValueError when its anchor is missing or not unique."""
    hits = find_anchor(page, entry["anchor"])
    if len(hits) != 1:
        raise ValueError(f"{page.name}: anchor {entry['anchor']!r} found {len(hits)} times (must be once)")
    at = hits[0]
    scope = entry.get("scope", "block")
    if scope == "text":
        m = re.compile(r"\s+".join(re.escape(w) for w in entry["anchor"].split())).match(page.text, at)
        return at, m.end()
    if scope == "section":
        for a, end, _, _ in page.headings:
            if a == at:
                return a, end
        raise ValueError(f"{page.name}: section anchor {entry['anchor']!r} is not a heading line")
    for bl in page.blocks:
        if bl.first <= at <= bl.end:
            return bl.first, bl.end
    raise ValueError(f"{page.name}: anchor {entry['anchor']!r} is in no block")


def load() -> list[dict]:
    data = tomllib.loads(INVENTORY.read_text())
    return data["figure"]


def coverage(entries: list[dict]) -> tuple[dict[int, list], list[Figure], list[str]]:
    """(entry index -> its figures, uncovered figures, problems with the entries)."""
    problems: list[str] = []
    by_page: dict[str, list[tuple[int, int, int, int]]] = {}
    parsed = {str(p.relative_to(ROOT)): parse(p) for p in pages()}
    rank = {"text": 0, "block": 1, "section": 2}
    for k, e in enumerate(entries):
        if e.get("page") not in parsed:
            problems.append(f"entry {k}: page {e.get('page')!r} is not README.md or docs/*.md")
            continue
        try:
            a, b = span(parsed[e["page"]], e)
        except (ValueError, KeyError) as exc:
            problems.append(f"entry {k}: {exc}")
            continue
        by_page.setdefault(e["page"], []).append((rank[e.get("scope", "block")], b - a, a, b, k))
    owned: dict[int, list] = {}
    loose = []
    for name, page in parsed.items():
        spans = sorted(by_page.get(name, []))
        for f in figures(page):
            k = next((s[4] for s in spans if s[2] <= f.start < s[3]), None)
            if k is None:
                loose.append(f)
            else:
                owned.setdefault(k, []).append(f)
    return owned, loose, problems


def section_text(page: Page, first: int, end: int) -> str:
    return _norm(page.text[first:end])
