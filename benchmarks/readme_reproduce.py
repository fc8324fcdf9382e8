"""Check (or rewrite) README.md's `femu reproduce` table against the command that makes it.

    python benchmarks/readme_reproduce.py [--out femu-reproduce] [--write]

Runs `femu reproduce --markdown --out OUT` (its defaults: 5 seeds, 1000 evaluations; resumable,
so a store already in OUT is reused), and compares the table it prints with the one in
README.md's section "What `femu reproduce` found". Exit 0 when they are the same; else prints
both and exits 1 (with --write, puts the command's table in README.md and exits 0). A few
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


def readme_table(text: str) -> tuple[int, int]:
    """(first, end) line indices of the first Markdown table after HEADING in README's lines."""
    lines = text.splitlines()
    start = lines.index(HEADING)
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
    readme = ROOT / "README.md"
    lines = readme.read_text().splitlines()
    first, end = readme_table("\n".join(lines))
    if lines[first:end] == made:
        print("README.md's reproduce table is what `femu reproduce --markdown` prints")
        return 0
    if args.write:
        readme.write_text("\n".join(lines[:first] + made + lines[end:]) + "\n")
        print("README.md's reproduce table rewritten")
        return 0
    print("README.md says:\n" + "\n".join(lines[first:end]) + "\n\n`femu reproduce --markdown` prints:\n"
          + "\n".join(made))
    return 1


if __name__ == "__main__":
    sys.exit(main())
