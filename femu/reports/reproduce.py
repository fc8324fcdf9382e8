"""The tables of `femu reproduce`: `render_text` for a terminal and `render_markdown` for the
README (``femu reproduce --markdown`` prints exactly the README's table), both from the
summary dict that femu.reproduce.reproduce returns."""

from __future__ import annotations

from .markdown import PAPER_COUNTERPART
from .render import markdown_table


def _fmt(x, spec) -> str:
    """`x` formatted to `spec`, "n/a" right-aligned when missing."""
    return format("n/a", ">" + spec.split(".")[0]) if x is None else format(x, spec)


def render_text(res: dict) -> str:
    """The result as a table for a terminal."""
    n_modes = len(res["measured_hz"])
    freq = "  ".join(f"{'f' + str(i + 1):>7}" for i in range(n_modes))
    lines = [f"The paper's comparison on variant {res['variant']!r}: {res['budget']} FE evaluations per run, "
             f"medians over {res['seeds']} seeds", "",
             f"{'':<22}{freq}  {'mean|err|%':>10}  {'best_f':>10}  {'n_evals':>7}  {'wall s':>7}  status"]

    def row(label, hz, err, best=None, n=None, wall=None, status=""):
        f = "  ".join(_fmt(v, "7.1f") for v in hz) if hz else "  ".join(f"{'n/a':>7}" for _ in range(n_modes))
        return (f"{label:<22}{f}  {_fmt(err, '10.2f')}  {_fmt(best, '10.3e')}  {_fmt(n, '7.0f')}  "
                f"{_fmt(wall, '7.2f')}  {status}")

    lines.append(row("measured", res["measured_hz"], None))
    lines.append(row("initial (ours)", res["initial_hz"], res["initial_mean_abs_error_pct"]))
    for name, s in res["solvers"].items():
        lines.append(row(name, s["frequencies_hz"], s["mean_abs_error_pct"], s["best_f"], s["n_evals"],
                         s["wall_s"], s["status"]))
    for k, hz in res["paper"]["updated_hz"].items():
        lines.append(row(f"paper {k} (Table 1)", hz, res["paper"]["mean_abs_error_pct_from_table"][k]))
    lines += ["", "Mean errors of the paper's methods are recomputed from its Table 1; its text states "
              + ", ".join(f"{k} {v} %" for k, v in res["paper"]["mean_error_pct_text"].items())
              + " (not all consistent with the table). The H-frame geometry is a reconstruction.",
              f"Report: {res['report']}   store: {res['store']}   ({res['wall_s']:.1f} s)"]
    if res.get("provenance"):
        p = res["provenance"]
        commit = "no git commit" if p["commit"] is None else "commit " + p["commit"][:12] + ("+" if p["commit_dirty"] else "")
        lines.append(f"femu-bench {p['femu_bench']} ({commit}), suite version {p['suite_version']}, {p['host']}, "
                     f"{p['date_utc']}")
    return "\n".join(lines)


def _paper_labels() -> dict[str, str]:
    """Optimizer name -> its label with the paper's method it stands for."""
    out = {}
    for method, names in PAPER_COUNTERPART.items():
        shown = f'"{method}"' if method == "PSO" else method  # the paper's "PSO" is a response surface
        for name in names.split(", "):
            out[name] = f"{name} (the paper's {shown})"
    return out


def _cells(hz, err) -> tuple:
    """A row's numbers as shown: frequencies to 0.1 Hz, the error to 0.01 %."""
    return tuple(_fmt(v, ".1f") for v in hz) + (_fmt(err, ".2f"),)


def render_markdown(res: dict) -> str:
    """The README's table: measured, initial, every solver (solvers whose shown numbers are
    identical share one row), sorted by median mean absolute error, then the paper's methods."""
    n_modes = len(res["measured_hz"])
    labels = _paper_labels()
    rows: dict[tuple, list[str]] = {}
    order = sorted(res["solvers"].items(),
                   key=lambda kv: (kv[1]["mean_abs_error_pct"] is None, kv[1]["mean_abs_error_pct"] or 0.0))
    for name, s in order:
        hz = s["frequencies_hz"] or [None] * n_modes
        rows.setdefault(_cells(hz, s["mean_abs_error_pct"]), []).append(name)
    body = [["measured", *(_fmt(v, ".1f") for v in res["measured_hz"]), ""],
            ["initial (ours)", *_cells(res["initial_hz"], res["initial_mean_abs_error_pct"])]]
    for cells, names in rows.items():
        label = ", ".join(names) if len(names) > 1 else labels.get(names[0], names[0])
        body.append([label, *cells])
    table = res["paper"]["mean_abs_error_pct_from_table"]
    methods = list(res["paper"]["updated_hz"])
    body.append([f"paper {' / '.join(methods)} (Table 1)", *[""] * n_modes,
                 " / ".join(_fmt(table[k], ".2f") for k in methods)])
    head = ["", *(f"f{i + 1}" for i in range(n_modes)), "mean abs error %"]
    return "\n".join(markdown_table(head, body)) + "\n"
