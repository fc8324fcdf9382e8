"""Print the README's Speed tables (Markdown) from a benchmark run's JSON: the 39-DOF table
(test_bench_evaluate.py) and the scale table (test_bench_scale.py), each if its figures are in it.

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


def _ms(seconds: float) -> str:
    return f"{seconds * 1e3:.1f} ms" if seconds < 1 else f"{seconds:.2f} s"


def scale_table(figures: dict) -> str:
    """The scale table (test_bench_scale.py): per size our evaluate and OpenSeesPy, the ratio,
    the accuracy, then the log-log slopes."""
    per_item = figures["per_item"]
    sizes = sorted(int(k.split(":")[1]) for k in per_item if k.startswith("evaluate_scale:"))
    if not sizes:
        raise ValueError("no figure 'evaluate_scale:N' in the benchmark JSON: run benchmarks/test_bench_scale.py")
    lines = ["| free DOFs | parameters | `evaluate`, one point | bare Cholesky + ARPACK floor | evaluate / floor "
             "| OpenSeesPy rebuild + eigen | speed-up over OpenSeesPy "
             "| max rel. diff of the 10 frequencies to the reference |", "|---|---|---|---|---|---|---|---|"]
    for n in sizes:
        ours, ops = per_item[f"evaluate_scale:{n}"], per_item.get(f"opensees_scale:{n}")
        floor = per_item.get(f"floor_scale:{n}")
        ratio = f"{ops['min_s'] / ours['min_s']:.1f}x" if ops else ""
        over = f"{ours['min_s'] / floor['min_s']:.2f}x" if floor else ""
        lines.append(f"| {n:,} | {ours['n_params']} | {_ms(ours['min_s'])} | {_ms(floor['min_s']) if floor else ''} "
                     f"| {over} | {_ms(ops['min_s']) if ops else ''} | {ratio} | {ours['max_rel_diff_to_reference']:.1e} |")
    for r in figures.get("slopes", []):
        goal = "" if r["goal"] is None else f" (goal <= {r['goal']:g}: {'met' if r['met'] else '**not met**'})"
        lines.append(f"\n{r['label']}: {r['slope']:.2f}{goal}")
    w1, w2 = per_item.get("batch_scale:3000:w1"), per_item.get("batch_scale:3000:w2")
    if w1 and w2:
        cpu = ""
        if "cpu_this_process_s" in w2:
            cpu = (f"; CPU per point: {_ms(w1['cpu_this_process_s'])} in 1 process, "
                   f"{_ms(w2['cpu_this_process_s'])} here + {_ms(w2['cpu_workers_s'])} in the worker with 2")
        lines.append(f"\nA batch of 4 points at 3,000 DOFs: {_ms(w1['min_s'])} per point with 1 process, "
                     f"{_ms(w2['min_s'])} with 2 ({w1['min_s'] / w2['min_s']:.2f}x){cpu}.")
    diag = sorted((int(k.split(":")[1]), v) for k, v in per_item.items() if k.startswith("diagnosis:"))
    if diag:
        lines += ["", "| `fp.diagnose`, one solver process | wall | CPU | cause |", "|---|---|---|---|"]
        lines += [f"| {n:,} free DOFs | {_ms(v['min_s'])} | {_ms(v['cpu_s'])} | {v['cause']}"
                  + (" (several candidates cannot be told apart) |" if v["cause"] == "undetermined"
                     else f" {v['location']} |") for n, v in diag]
    return "\n".join(lines) + "\n"


def main(argv: list[str]) -> int:
    """`python benchmarks/readme_tables.py BENCH_JSON`: print the table; exit 2 on bad input."""
    if len(argv) != 1:
        print(__doc__, file=sys.stderr)
        return 2
    path = Path(argv[0])
    try:
        figures = json.loads(path.read_text())["femu_figures"]
        tables = []
        if "evaluate_paper" in figures["per_item"]:
            tables.append(speed_table(figures))
        if any(k.startswith("evaluate_scale:") for k in figures["per_item"]):
            tables.append(scale_table(figures))
        if not tables:
            tables.append(speed_table(figures))  # names what is missing
        sys.stdout.write("\n".join(tables))
    except (OSError, ValueError, KeyError) as exc:
        print(f"readme_tables: {path}: {exc if not isinstance(exc, KeyError) else f'no field {exc}'}",
              file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
