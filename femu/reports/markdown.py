"""The Markdown of a study report, rendered from its summary records (femu.reports.records)
through femu.reports.render.markdown_table."""

from __future__ import annotations

import math

import numpy as np

from .figures import parameter_unit
from .records import GroupSummary, PaperComparison
from .render import markdown_table

#: The paper's method names and the optimizers here that play their part.
PAPER_COUNTERPART = {"PSO": "mlp-surrogate", "SA": "scipy-sa", "GA": "pymoo-ga, deap-ga"}


def _f(x, fmt=".2f") -> str:
    """`x` formatted, "n/a" when missing or not finite."""
    return "n/a" if x is None or not math.isfinite(x) else format(x, fmt)


def _cell(median, q1, q3, fmt=".2f") -> str:
    """'median (IQR)'."""
    if not math.isfinite(median):
        return "n/a"
    return f"{format(median, fmt)} ({format(q3 - q1, fmt)})"


def _table1_rows(g: GroupSummary) -> list[tuple[str, object, object, object]]:
    """The rows of Table 1, one per model: (label, frequencies Hz, absolute errors %, mean
    absolute error %), each a plain array/number (reference) or a spread (an optimizer's runs)."""
    p = g.paper
    rows = []
    if p is not None:
        rows.append(("initial (paper)", p.initial_hz, p.abs_error_pct["initial"], p.mean_abs_error_pct["initial"]))
    rows.append(("initial (ours)", g.initial_hz, np.abs(g.initial_error_pct), g.initial_mean_abs_error_pct))
    if p is not None:
        rows += [(f"{k} (paper)", v, p.abs_error_pct[k], p.mean_abs_error_pct[k]) for k, v in p.updated_hz.items()]
    rows += [(s.optimizer, s.frequencies_hz, s.abs_error_pct, s.mean_abs_error_pct) for s in g.solvers]
    return rows


def _value(v, i, fmt) -> str:
    """Entry i of a reference array (plain) or of an ArraySpread (median and IQR)."""
    if v is None:
        return "n/a"
    if hasattr(v, "median"):
        return _cell(v.median[i], v.q1[i], v.q3[i], fmt)
    return _f(v[i], fmt)


def _table1(g: GroupSummary) -> list[str]:
    """Table 1 transposed so that it fits a page: one row per model, one column per mode, in
    two tables (frequencies, then absolute errors; a third for MAC when shapes were measured)."""
    p = g.paper
    m = len(g.measured_hz)
    paper_fmt = ".1f" if p is not None else ".2f"  # the paper gives 1 decimal
    freq_head = ["model"] + [f"f{i + 1}" for i in range(m)]
    freq_rows = [["measured"] + [_f(g.measured_hz[i], paper_fmt) for i in range(m)]]
    err_head = ["model"] + [f"err {i + 1}" for i in range(m)] + ["mean abs err %"]
    if p is not None and not g.has_shapes:
        err_head.append("mean COMAC")
    err_rows = []
    for label, hz, err, mean in _table1_rows(g):
        ref = not hasattr(hz, "median") and hz is not None
        fmt = ".1f" if ref and "(paper)" in label else ".2f"
        freq_rows.append([label] + [_value(hz, i, fmt) for i in range(m)])
        if hasattr(mean, "median"):
            mean_cell = f"**{_cell(mean.median, mean.q1, mean.q3)}**"
        else:
            mean_cell = f"**{_f(mean)}**"
        row = [label] + [_value(err, i, ".2f") for i in range(m)] + [mean_cell]
        if p is not None and not g.has_shapes:
            key = {"initial (paper)": "initial"}.get(label, label.replace(" (paper)", ""))
            row.append(_f(p.mean_comac_text.get(key), ".4g") if "(paper)" in label else "n/a")
        err_rows.append(row)
    lines = ["Natural frequencies (Hz):", ""] + markdown_table(freq_head, freq_rows)
    lines += ["", "Absolute frequency errors (%):", ""] + markdown_table(err_head, err_rows)
    if g.has_shapes:
        mac_head = ["model"] + [f"MAC {i + 1}" for i in range(m)] + ["mean COMAC"]
        mac_rows = [["initial (ours)"] + [_f(g.initial_mac[i], ".3f") for i in range(m)]
                    + [_f(g.initial_mean_comac, ".3f")]]
        for s in g.solvers:
            mac_rows.append([s.optimizer] + [_value(s.mac, i, ".3f") for i in range(m)]
                            + [_cell(s.mean_comac.median, s.mean_comac.q1, s.mean_comac.q3, ".3f")])
        lines += ["", "MAC of the paired modes and mean COMAC:", ""] + markdown_table(mac_head, mac_rows)
    return lines


def _parameter_table(g: GroupSummary) -> list[str]:
    """The updated parameters of each optimizer's best run beside the initial values: one row
    per model, one column per parameter; values at a bound in bold."""
    q = g.parameters
    unit, f = parameter_unit(g)
    fmt = ".1f" if unit == "GPa" else ".4g"
    head = ["model", "J"] + list(q.labels) + ["at a bound"]
    rows = [["initial", "", *[_f(v * f, fmt) for v in q.x0], ""],
            ["lower bound", "", *[_f(v * f, fmt) for v in q.lower], ""],
            ["upper bound", "", *[_f(v * f, fmt) for v in q.upper], ""]]
    for s in g.solvers:
        if s.best_x is None:
            rows.append([s.optimizer, "n/a", *["n/a"] * len(q.labels), ""])
            continue
        at = q.at_bound(s.best_x)
        cells = [f"**{_f(v * f, fmt)}**" if b else _f(v * f, fmt) for v, b in zip(s.best_x, at)]
        rows.append([f"{s.optimizer} (seed {s.best_seed})", _f(s.best_run_f, ".5g"), *cells,
                     f"{int(np.count_nonzero(at))} of {len(at)}"])
    return markdown_table(head, rows)


def _mac_table(values: np.ndarray, rows: str) -> list[str]:
    k = values.shape[1]
    head = [rows] + [f"updated {j + 1}" for j in range(k)]
    return markdown_table(head, [[str(i + 1)] + [_f(v, ".3f") for v in r] for i, r in enumerate(values)])


def _solver_table(g: GroupSummary) -> list[str]:
    head = ["optimizer", "runs", "failed", "best_f median (IQR)", "mean abs err % median (IQR)",
            "n_evals", "wall s", "CPU s", "FE s", "overhead s", "overhead ms/eval"]
    rows = []
    for s in g.solvers:
        rows.append([s.optimizer, str(s.n_runs), str(s.n_failed),
                     _cell(s.best_f.median, s.best_f.q1, s.best_f.q3, ".4g"),
                     _cell(s.mean_abs_error_pct.median, s.mean_abs_error_pct.q1, s.mean_abs_error_pct.q3),
                     _f(s.n_evals.median, ".0f"), _f(s.wall_s.median, ".3g"), _f(s.cpu_s.median, ".3g"),
                     _f(s.fe_s.median, ".3g"), _f(s.overhead_s.median, ".3g"),
                     _f(s.overhead_ms_per_eval.median, ".3g")])
    return markdown_table(head, rows)


def _paper_section(p: PaperComparison) -> list[str]:
    rows = [["initial", _f(p.mean_abs_error_pct["initial"]), _f(p.mean_error_pct_text.get("initial")),
             _f(p.mean_comac_text.get("initial"), ".4g"), "", ""]]
    for k in p.updated_hz:
        rows.append([k, _f(p.mean_abs_error_pct[k]), _f(p.mean_error_pct_text.get(k)),
                     _f(p.mean_comac_text.get(k), ".4g"), _f(p.cpu_minutes_text.get(k), ".0f"),
                     PAPER_COUNTERPART.get(k, "")])
    lines = ["### The paper's own numbers", "",
             "Mean absolute frequency error recomputed from the frequencies of the paper's Table 1, "
             "beside the percentages its text states:", ""]
    lines += markdown_table(["method", "mean abs err % (from Table 1)", "mean err % (paper's text)", "mean COMAC (text)",
                     "CPU minutes (text)", "counterpart here"], rows)
    bad = ", ".join(p.disagreements) or "none"
    lines += ["", f"The paper's text percentages do not all agree with its own table: they differ from what "
              f"the table's frequencies imply for {bad}. We compare against the table. The paper's "
              "\"PSO\" method is in fact a response surface (an MLP trained on FE runs, minimised by a GA); "
              "its counterpart here is mlp-surrogate, and pyswarms-pso runs the standard PSO the paper "
              "describes. The measured mode shapes are not published, so MAC/COMAC cannot be recomputed "
              "for the paper's data (the paper's COMAC values are quoted from its text).", ""]
    return lines


def _not_anytime(names) -> list[str]:
    """The optimizers among `names` that do not declare anytime = True (or cannot be loaded)."""
    from adapters.capabilities import capabilities
    from adapters.registry import get

    out = []
    for name in names:
        try:
            if not capabilities(get(name))["anytime"]:
                out.append(name)
        except ValueError:
            out.append(name)
    return out


def render_markdown(groups: list[GroupSummary], figures: dict, source: str) -> str:
    """The report text from the summary records; `figures` maps (variant, budget) to
    {kind: file name}."""
    n_runs = sum(s.n_runs for g in groups for s in g.solvers)
    lines = ["# femu-bench report", "", f"Source: {source}; {n_runs} runs in {len(groups)} group(s) "
             "(problem variant x budget).", "",
             "Every number is a median over seeds with the interquartile range (Q3 - Q1) in parentheses. "
             "Updated frequencies are those of the model at each run's best point; errors are "
             "100 (f_model - f_measured) / f_measured.", ""]
    if any(not g.variant.startswith("user:") for g in groups):  # not said of a user's own model
        lines += ["**The H-frame geometry is a reconstruction**: the paper (T. Marwala, \"Dynamic model updating "
                  "using particle swarm optimization method\") gives no dimensions; ours reproduces its "
                  "initial-model frequencies to about 0.15 %.", ""]
    for g in groups:
        lines += [f"## Variant `{g.variant}`, budget {g.budget} FE evaluations per run", ""]
        title = "Table 1 rebuilt" if g.paper is not None else "Frequencies"
        lines += [f"### {title}: natural frequencies (Hz) and absolute errors (%)", ""]
        lines += _table1(g)
        lines += ["", "### Solvers", ""] + _solver_table(g) + [""]
        fig = figures.get((g.variant, g.budget), {})
        if g.parameters is not None and any(s.best_x is not None for s in g.solvers):
            unit = parameter_unit(g)[0]
            lines += ["### The updated parameters", "",
                      f"Each optimizer's best run (lowest J over its seeds) beside the initial values and the "
                      f"bounds, in {unit}; **bold**: at a bound (within 0.1 % of the range). A parameter "
                      "pinned at a bound is one the data push past what the model allows.", ""]
            lines += _parameter_table(g) + [""]
            if "parameters" in fig:
                lines += [f"![Updated parameters]({fig['parameters']})", "", "*Updated parameters of each "
                          "optimizer's best run, each bar from the initial value (black) to the updated one; dashed: the "
                          "bounds.*", ""]
        if g.modes is not None:
            m = g.modes
            lines += ["### Initial and updated model", "",
                      f"The updated model is the group's best run: {m.optimizer}, seed {m.seed}, J = {m.best_f:.5g}.",
                      ""]
            if "modes" in fig:
                lines += [f"![The frame in its first modes]({fig['modes']})", "",
                          "*The frame in its first modes: initial model wide orange, updated model blue, on the "
                          "undeformed frame (grey).*", ""]
            if m.mac_measured_updated is not None:
                lines += ["MAC of the measured modes (rows) against the updated model's (columns):", ""]
                lines += _mac_table(m.mac_measured_updated, "measured") + [""]
            else:
                lines += ["These data have no measured shapes: no MAC against the measurement. MAC of the "
                          "initial model's modes (rows) against the updated model's (columns), over the "
                          "translations of every node:", ""]
                lines += _mac_table(m.mac_initial_updated, "initial") + [""]
            if "mac" in fig:
                lines += [f"![MAC matrices]({fig['mac']})", "", "*MAC matrices of the updated modes.*", ""]
        if g.paper is not None:
            lines += _paper_section(g.paper)
        captions = {"convergence": "Convergence (best-so-far vs evaluations)"
                    + (f"; dashed: the best J known, {g.best_known_f:.5g} ({g.best_known_how})"
                       if g.best_known_f is not None else ""),
                    "ecdf": "Fixed-target ECDF (targets log-spaced from the worst first value to the best found)",
                    "errors": "Mean absolute frequency error", "overhead": "Solver overhead per evaluation"}
        for kind, cap in captions.items():
            if kind in fig:
                lines += [f"![{cap}]({fig[kind]})", "", f"*{cap}.*", ""]
        one = _not_anytime([s.optimizer for s in g.solvers])
        if one:
            lines += [f"Not anytime: {', '.join(f'`{o}`' for o in one)}. Their schedule follows the budget (`femu "
                      f"optimizers`), so their curves below {g.budget} evaluations are from runs of budget {g.budget}, "
                      "not what runs of a smaller budget would find.", ""]
        failures = [(s.optimizer, *f) for s in g.solvers for f in s.failures]
        if failures:
            lines += ["### Failed runs", ""]
            lines += markdown_table(["optimizer", "seed", "status", "error"],
                            [[o, str(seed), st, e.replace("|", "\\|")] for o, seed, st, e in failures])
            lines.append("")
    return "\n".join(lines) + "\n"

