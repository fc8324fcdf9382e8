"""Print the README's Speed table (Markdown) from a benchmark run's JSON.

    OPENBLAS_NUM_THREADS=1 python -m pytest benchmarks --benchmark-only --benchmark-json bench.json
    python benchmarks/readme_tables.py bench.json

The figures are those conftest.py files under "femu_figures" (per-item times, minimum over
rounds, and the ratios between benchmarks of the same session). The README's other measured
table, the paper's comparison, is printed by `femu reproduce --markdown`.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

#: (figure key, the row's label), in the README's order.
ROWS = (
    ("evaluate_paper", "`UpdatingProblem.evaluate`"),
    ("loop_paper", "per-sample loop: element-by-element assembly + `scipy.linalg.eigh` (values only)"),
    ("eigvalsh_bare", "bare batched `numpy.linalg.eigvalsh`, 2000 stacked 39x39"),
    ("eigh_bare", "bare batched `numpy.linalg.eigh`, 2000 stacked 39x39"),
    ("evaluate_synthetic", "`evaluate` with shapes (synthetic variant, eigenvectors)"),
)


def _us(seconds: float) -> str:
    """A per-sample time in microseconds, as the README shows it."""
    return f"{seconds * 1e6:.0f} us"


def _ratio_cell(r: dict) -> str:
    """How a ratio reads in the table, with its goal."""
    met = "met" if r["met"] else "**not met**"
    if r["slow"] == "loop_paper":
        return f"evaluate is {r['ratio_min']:.1f}x faster (goal {r['goal']:g}x: {met})"
    if r["fast"] == "evaluate_synthetic":
        return f"{r['ratio_min']:.2f}x the speed of the bare `eigh` (goal >= {r['goal']:g}x: {met})"
    return f"evaluate at {r['ratio_min']:.2f}x its speed (goal >= {r['goal']:g}x: {met})"


def speed_table(figures: dict) -> str:
    """The Speed table from the "femu_figures" object of a benchmark JSON."""
    per_item = figures["per_item"]
    by_slow = {r["slow"]: r for r in figures["ratios"] if r["fast"] == "evaluate_paper"}
    synthetic = next((r for r in figures["ratios"] if r["fast"] == "evaluate_synthetic"), None)
    lines = ["| | per sample | ratio |", "|---|---|---|"]
    for key, label in ROWS:
        if key not in per_item:
            raise ValueError(f"no figure {key!r} in the benchmark JSON: run the whole benchmarks/ suite")
        ratio = by_slow.get(key) if key != "evaluate_synthetic" else synthetic
        lines.append(f"| {label} | {_us(per_item[key]['min_s'])} | {_ratio_cell(ratio) if ratio else ''} |")
    return "\n".join(lines) + "\n"


def main(argv: list[str]) -> int:
    """`python benchmarks/readme_tables.py BENCH_JSON`: print the table; exit 2 on bad input."""
    if len(argv) != 1:
        print(__doc__, file=sys.stderr)
        return 2
    path = Path(argv[0])
    try:
        figures = json.loads(path.read_text())["femu_figures"]
        sys.stdout.write(speed_table(figures))
    except (OSError, ValueError, KeyError) as exc:
        print(f"readme_tables: {path}: {exc if not isinstance(exc, KeyError) else f'no field {exc}'}",
              file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
