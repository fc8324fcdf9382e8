"""The one rendering module: Markdown tables and figure files, shared by every report.

Reports render records: they compute nothing that is not already in them. Figures are drawn on
a matplotlib ``Figure`` (no pyplot state, safe in any thread or process) and saved here.
"""

from __future__ import annotations

from pathlib import Path

from fe_problem.safe_files import open_for_writing

#: Resolution of every saved figure (dots per inch).
DPI = 110


def markdown_table(header: list[str], rows: list[list]) -> list[str]:
    """A Markdown table as lines: a header row, the separator, one line per row (cells str())."""
    out = ["| " + " | ".join(str(h) for h in header) + " |", "|" + "|".join("---" for _ in header) + "|"]
    return out + ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]


def report_provenance(runs) -> dict:
    """The provenance a report states: this process's (`adapters.provenance.provenance`: femu-bench
    version and commit, suite version, host, date, library versions) and the runs' own
    (`runs_provenance`: hosts, suite and femu-bench versions recorded in them)."""
    from adapters.provenance import provenance, runs_provenance

    return {**provenance(), "records": runs_provenance(runs)}


def provenance_lines(p: dict) -> list[str]:
    """A report's "Provenance" section (Markdown lines) from `report_provenance`'s dict."""
    def counts(d: dict) -> str:
        return ", ".join(f"{k} ({n})" for k, n in d.items()) or "none"

    commit = "not in a git work tree" if p["commit"] is None else p["commit"][:12] + (" (with local changes)"
                                                                                     if p["commit_dirty"] else "")
    libs = ", ".join(f"{k} {v}" for k, v in p["versions"].items() if v is not None)
    rec = p["records"]
    return ["## Provenance", "",
            f"- made with femu-bench {p['femu_bench']}, commit {commit}, suite version {p['suite_version']}",
            f"- on {p['host']} ({p['platform']}, {p.get('cpus')} CPUs, load average "
            f"{'unknown' if not p.get('load_average') else ' / '.join(map(str, p['load_average']))}), {p['date_utc']}",
            f"- libraries: {libs}",
            f"- the {rec['runs']} runs: hosts {counts(rec['hosts'])}; suite versions {counts(rec['suite_versions'])}; "
            f"femu-bench {counts(rec['femu_bench'])}", ""]


def figure(width: float = 7.5, height: float = 4.6, nrows: int = 1, ncols: int = 1, **subplots):
    """A new figure of ``width`` x ``height`` inches and its axes as a (nrows, ncols) array."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=DPI, layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False, **subplots)
    return fig, axes


def make_out_dir(path, flag: str = "--out") -> Path:
    """Create the output directory `path` (and its parents) and return it; ValueError naming
    `flag`, the path and the reason (a read-only place, a file on the way, ...) if it cannot."""
    path = Path(path)
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise ValueError(f"{flag} {path}: cannot create the directory ({exc.strerror or exc})") from None
    return path


def save_figure(fig, path) -> Path:
    """Write ``fig`` to ``path`` (PNG by its suffix) and return the path."""
    path = Path(path)
    with open_for_writing(path, binary=True) as fh:  # never through a link standing at the name
        fig.savefig(fh, format=path.suffix.lstrip(".") or "png")
    return path


def solver_colors(names) -> dict:
    """One colour per solver name, in the given order; never grey, which marks references
    (the initial model, the paper's numbers)."""
    from matplotlib import colormaps

    tab10, tab20 = colormaps["tab10"], colormaps["tab20"]
    palette = [tab10(i) for i in range(10) if i != 7] + [tab20(i) for i in range(1, 20, 2) if i not in (15,)]
    return {n: palette[i % len(palette)] for i, n in enumerate(names)}
