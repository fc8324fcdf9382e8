"""Check (or rewrite) the `femu reproduce` tables of README.md and docs/benchmark-studies.md against the
command that makes them.

    python benchmarks/readme_reproduce.py [--out femu-reproduce] [--write]

Runs `femu reproduce --markdown --out OUT` (its defaults: 5 seeds, 1000 evaluations; resumable,
so a store already in OUT is reused), and compares the table it prints with README.md's in
"What `femu reproduce` found" and docs/benchmark-studies.md's below its `femu reproduce --markdown`
block. Exit 0 when they are the same; else prints both and exits 1 (with --write, puts the
command's table in the pages and exits 0). A few
minutes of CPU (mlp-surrogate's training most of it): run it before a release, not in CI.
The README names the Python and library versions the table was made with; other versions can
move a row.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
HEADING = "## What `femu reproduce` found"
#: The pages that show the table, and the line after which it comes.
PAGES = (("README.md", HEADING), ("docs/benchmark-studies.md", "femu reproduce --markdown"))


def readme_table(text: str, anchor: str = HEADING) -> tuple[int, int]:
    """(first, end) line indices of the first Markdown table after the line `anchor`."""
    lines = text.splitlines()
    start = lines.index(anchor)
    first = next(i for i in range(start, len(lines)) if lines[i].startswith("|"))
    end = next((i for i in range(first, len(lines)) if not lines[i].startswith("|")), len(lines))
    return first, end


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="femu-reproduce", help="the reproduce output directory (its store is reused)")
    ap.add_argument("--write", action="store_true", help="put the command's table in README.md")
    args = ap.parse_args(argv)
    done = subprocess.run([sys.executable, "-m", "femu", "reproduce", "--markdown", "--out", args.out],
                          capture_output=True, text=True)
    if done.returncode != 0:
        print(done.stderr, file=sys.stderr)
        return done.returncode
    made = done.stdout.strip().splitlines()
    status = 0
    for page, anchor in PAGES:
        path = ROOT / page
        lines = path.read_text().splitlines()
        first, end = readme_table("\n".join(lines), anchor)
        if lines[first:end] == made:
            print(f"{page}: its reproduce table is what `femu reproduce --markdown` prints")
        elif args.write:
            path.write_text("\n".join(lines[:first] + made + lines[end:]) + "\n")
            print(f"{page}: reproduce table rewritten")
        else:
            print(f"{page} says:\n" + "\n".join(lines[first:end]) + "\n\n`femu reproduce --markdown` prints:\n"
                  + "\n".join(made))
            status = 1
    return status


if __name__ == "__main__":
    sys.exit(main())
