"""The study report: summary records computed from the runs (femu.reports.summary), then
Markdown (femu.reports.markdown) and PNG figures (femu.reports.figures), all written through
femu.reports.render. A report renders records and computes nothing new.

`write_report(store_or_runs, out_dir)` writes DIR/report.md, DIR/summary.json and the figures
(convergence, ECDF, overhead, mean error vs the paper, updated parameters, the frame in its
first modes, MAC matrices); with ``ioh`` also DIR/ioh, with ``coco`` DIR/coco. Runs on suite
problems (`femu study --suite`) get the benchmark report instead (femu.reports.benchmark:
DIR/report.md, DIR/stats.json), and runs on variants beside them DIR/variants.md; a study of
variants only where two solvers share a problem gets the benchmark report as DIR/benchmark.md.
"""

from __future__ import annotations

from pathlib import Path

from adapters.sandbox import REQUIRED, is_confined
from fe_problem.jsonutil import dumps
from fe_problem.safe_files import write_text
from femu.studies.store import Store

from femu.studies.tasks import is_suite_id, variant_stem

from .benchmark import write_benchmark
from .figures import (plot_convergence, plot_ecdf, plot_errors, plot_mac, plot_mode_shapes, plot_overhead,
                      plot_parameters)
from .markdown import render_markdown
from .records import GroupSummary
from .render import make_out_dir, provenance_lines, report_provenance
from .summary import best_so_far, paper_comparison, summarize  # noqa: F401  (the report's public names)

__all__ = ["best_so_far", "paper_comparison", "render_files", "render_markdown", "summarize", "write_report"]


def write_report(store_or_runs, out_dir, ioh: bool = False, source: str | None = None, coco: bool = False,
                 unsigned: list[str] | None = None) -> Path:
    """Write OUT/report.md, OUT/summary.json and PNG figures for a Store, a store path or a
    list of RunResults; with `ioh`, also OUT/ioh (IOHprofiler files); with `coco`, OUT/coco
    (COCO data for cocopp). `source` says in the report where the runs come from (default: the
    store's path); `unsigned`: keys of records without a MAC, flagged in the notes (default:
    the store's). Returns report.md's path."""
    if isinstance(store_or_runs, (str, Path)):
        store_or_runs = Store(store_or_runs)
    if isinstance(store_or_runs, Store):
        default, runs = f"store `{store_or_runs.path}`", store_or_runs.runs()
    else:
        default, runs = "a list of runs", list(store_or_runs)
    source = source or default
    if not runs:
        raise ValueError(f"{source}: no finished runs to report on")
    runs, notes = settings_apart(runs)
    if unsigned is None:  # the keys of the store's records without a MAC (Store.unsigned)
        unsigned = store_or_runs.unsigned() if isinstance(store_or_runs, Store) else []
    if unsigned:  # a changed record is refused (Store.read); one without its MAC is flagged here
        notes.append(f"{len(unsigned)} record{'s' if len(unsigned) != 1 else ''} of this store carr"
                     f"{'y' if len(unsigned) != 1 else 'ies'} **no MAC** (written before the store signed its "
                     f"records, or stripped of it): {', '.join(f'`{k}`' for k in unsigned[:5])}"
                     f"{' ...' if len(unsigned) > 5 else ''}")
    suite = [r for r in runs if is_suite_id(r.variant)]
    variants = [r for r in runs if not is_suite_id(r.variant)]
    if suite:  # the benchmark report; runs on the named variants get theirs in variants.md
        path = write_benchmark(suite, out_dir, source)
        if variants:
            other = render_files(summarize(variants), out_dir, source, name="variants.md", runs=variants)
            with path.open("a") as f:
                f.write(f"\nThe runs on problem variants (not suite problems) are reported in [{other.name}]({other.name}).\n")
    else:
        path = render_files(summarize(runs), out_dir, source, runs=runs)
        if shared_problem(runs):  # the benchmark statistics of any study with a comparison to make
            other = write_benchmark(runs, out_dir, source, name="benchmark.md")
            with path.open("a") as f:
                f.write(f"\nThe benchmark statistics of these runs (targets, ERT, comparisons, aggregated ECDF, "
                        f"profiles) are in [{other.name}]({other.name}).\n")
    if notes:
        with path.open("a") as f:
            f.write("\n## Notes on the runs\n\n" + "".join(f"- {n}\n" for n in notes))
    if ioh:
        from .ioh import export_runs
        export_runs(runs, Path(out_dir) / "ioh")
    if coco:
        from .coco import export_coco
        export_coco(runs, Path(out_dir) / "coco")
    return path


def shared_problem(runs) -> bool:
    """Whether at least two solvers ran a common problem (a comparison can be made)."""
    solvers: dict = {}
    for r in runs:
        solvers.setdefault(r.variant, set()).add(r.optimizer)
    return any(len(v) >= 2 for v in solvers.values())


def _settings(r) -> tuple:
    return (r.x0, dumps(r.options, indent=None))


def settings_apart(runs) -> tuple[list, list[str]]:
    """The runs with each optimizer's label carrying its settings where its runs differ in them
    (x0, options), so that runs made with other settings are never pooled into one solver, and
    the notes the report adds: which optimizers were split, and how many runs are unverified
    (their optimizer ran in the problem's own process, adapters.run(..., isolated=False), or
    they were recorded before the sandbox: their counts rest on the harness's cross-checks)."""
    from dataclasses import replace

    settings: dict[str, set] = {}
    for r in runs:
        settings.setdefault(r.optimizer, set()).add(_settings(r))
    notes, out = [], []
    for name, seen in sorted(settings.items()):
        if len(seen) > 1:
            notes.append(f"`{name}` was run with {len(seen)} different settings (x0, options); each is reported as "
                         f"a solver of its own: " + "; ".join(f"x0 {x0}, options {opts}" for x0, opts in sorted(seen)))
    for r in runs:
        if len(settings[r.optimizer]) > 1:
            label = f"{r.optimizer} [x0={r.x0}" + (f", options={dumps(r.options, indent=None)}" if r.options else "") + "]"
            r = replace(r, optimizer=label)
        out.append(r)
    unverified = sorted({r.optimizer for r in out if not r.verified})
    if unverified:
        n = sum(1 for r in out if not r.verified)
        notes.append(f"{n} run{'s' if n != 1 else ''} of {', '.join(f'`{u}`' for u in unverified)} "
                     f"{'are' if n != 1 else 'is'} **unverified**: the optimizer ran in the problem's own process "
                     f"(adapters.run(..., isolated=False), or a record made before the sandbox), where a plugin "
                     f"can reach the problem behind its budget")
    unconfined = [r for r in out if r.verified and r.sandbox and not is_confined(r.sandbox)]
    if unconfined:
        n = len(unconfined)
        held = lambda r: ", ".join(k for k in REQUIRED if r.sandbox.get(k) is not True)  # noqa: E731
        notes.append(f"{n} run{'s' if n != 1 else ''} of {', '.join(f'`{u}`' for u in sorted({r.optimizer for r in unconfined}))} "
                     f"{'were' if n != 1 else 'was'} **unconfined** (`femu study --unconfined`): its worker ran "
                     f"without {held(unconfined[0])}, where a plugin can reach other runs, the store or the machine")
    return out, notes


def render_files(groups: list[GroupSummary], out_dir, source: str, name: str = "report.md", runs=()) -> Path:
    """Render summary records as OUT/<name> (report.md), OUT/summary.json and the PNG figures,
    each with its provenance (`render.report_provenance` of `runs`, the runs summarised): in
    report.md a section, in summary.json each group's "provenance"."""
    out = make_out_dir(out_dir)
    prov = report_provenance(runs)
    figures = {}
    for g in groups:
        stem = f"{variant_stem(g.variant)}_b{g.budget}"
        made = {"convergence": plot_convergence(g, out / f"convergence_{stem}.png"),
                "errors": plot_errors(g, out / f"errors_{stem}.png"),
                "overhead": plot_overhead(g, out / f"overhead_{stem}.png")}
        if len(g.targets):
            made["ecdf"] = plot_ecdf(g, out / f"ecdf_{stem}.png")
        if g.parameters is not None and any(s.best_x is not None for s in g.solvers):
            made["parameters"] = plot_parameters(g, out / f"parameters_{stem}.png")
        if g.modes is not None:
            if hasattr(g.modes.model, "nodes"):  # drawn on a frame; a matrix model has no drawing
                made["modes"] = plot_mode_shapes(g, out / f"modes_{stem}.png")
            made["mac"] = plot_mac(g, out / f"mac_{stem}.png")
        figures[(g.variant, g.budget)] = {k: p.name for k, p in made.items()}
    write_text(out / "summary.json", dumps([{**g.to_dict(), "provenance": prov} for g in groups]))
    path = out / name
    write_text(path, render_markdown(groups, figures, source) + "\n" + "\n".join(provenance_lines(prov)))
    return path
