"""The study report: summary records computed from the runs (femu.reports.summary), then
Markdown (femu.reports.markdown) and PNG figures (femu.reports.figures), all written through
femu.reports.render. A report renders records and computes nothing new.

`write_report(store_or_runs, out_dir)` writes DIR/report.md, DIR/summary.json and the figures
(convergence, ECDF, overhead, mean error vs the paper); with ``ioh`` also DIR/ioh. Runs on suite
problems (`femu study --suite`) get the benchmark report instead (femu.reports.benchmark:
DIR/report.md, DIR/stats.json), and runs on variants beside them DIR/variants.md.
"""

from __future__ import annotations

from pathlib import Path

from fe_problem.jsonutil import dumps
from fe_problem.safe_files import write_text
from femu.studies.store import Store

from femu.studies.tasks import is_suite_id

from .benchmark import write_benchmark
from .figures import plot_convergence, plot_ecdf, plot_errors, plot_overhead
from .markdown import render_markdown
from .records import GroupSummary
from .render import make_out_dir
from .summary import best_so_far, paper_comparison, summarize  # noqa: F401  (the report's public names)

__all__ = ["best_so_far", "paper_comparison", "render_files", "render_markdown", "summarize", "write_report"]


def write_report(store_or_runs, out_dir, ioh: bool = False, source: str | None = None) -> Path:
    """Write OUT/report.md, OUT/summary.json and PNG figures for a Store, a store path or a
    list of RunResults; with `ioh`, also OUT/ioh (IOHprofiler files). `source` says in the
    report where the runs come from (default: the store's path). Returns report.md's path."""
    if isinstance(store_or_runs, (str, Path)):
        store_or_runs = Store(store_or_runs)
    if isinstance(store_or_runs, Store):
        default, runs = f"store `{store_or_runs.path}`", store_or_runs.runs()
    else:
        default, runs = "a list of runs", list(store_or_runs)
    source = source or default
    if not runs:
        raise ValueError(f"{source}: no finished runs to report on")
    suite = [r for r in runs if is_suite_id(r.variant)]
    variants = [r for r in runs if not is_suite_id(r.variant)]
    if suite:  # the benchmark report; runs on the named variants get theirs in variants.md
        path = write_benchmark(suite, out_dir, source)
        if variants:
            other = render_files(summarize(variants), out_dir, source, name="variants.md")
            with path.open("a") as f:
                f.write(f"\nThe runs on problem variants (not suite problems) are reported in [{other.name}]({other.name}).\n")
    else:
        path = render_files(summarize(runs), out_dir, source)
    if ioh:
        from .ioh import export_runs
        export_runs(runs, Path(out_dir) / "ioh")
    return path


def render_files(groups: list[GroupSummary], out_dir, source: str, name: str = "report.md") -> Path:
    """Render summary records as OUT/<name> (report.md), OUT/summary.json and the PNG figures."""
    out = make_out_dir(out_dir)
    figures = {}
    for g in groups:
        stem = f"{g.variant}_b{g.budget}"
        made = {"convergence": plot_convergence(g, out / f"convergence_{stem}.png"),
                "errors": plot_errors(g, out / f"errors_{stem}.png"),
                "overhead": plot_overhead(g, out / f"overhead_{stem}.png")}
        if len(g.targets):
            made["ecdf"] = plot_ecdf(g, out / f"ecdf_{stem}.png")
        figures[(g.variant, g.budget)] = {k: p.name for k, p in made.items()}
    write_text(out / "summary.json", dumps([g.to_dict() for g in groups]))
    path = out / name
    write_text(path, render_markdown(groups, figures, source))
    return path
