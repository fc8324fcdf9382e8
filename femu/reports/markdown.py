"""The Markdown of a study report, rendered from its summary records (femu.reports.records)
through femu.reports.render.markdown_table."""

from __future__ import annotations

import math

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


def _table1(g: GroupSummary) -> list[str]:
    p = g.paper
    head = ["mode", "measured"]
    if p is not None:
        head += ["initial (paper)"]
    head += ["initial (ours)"]
    if p is not None:
        head += [f"{k} (paper)" for k in p.updated_hz]
    head += [s.optimizer for s in g.solvers]
    rows = []
    for i in range(len(g.measured_hz)):
        r = [str(i + 1), _f(g.measured_hz[i], ".1f" if p is not None else ".2f")]  # the paper gives 1 decimal
        if p is not None:
            r.append(_f(p.initial_hz[i], ".1f"))
        r.append(_f(g.initial_hz[i]))
        if p is not None:
            r += [_f(v[i], ".1f") for v in p.updated_hz.values()]
        for s in g.solvers:
            fr = s.frequencies_hz
            r.append("n/a" if fr is None else _cell(fr.median[i], fr.q1[i], fr.q3[i]))
        rows.append(r)
    # per-mode absolute errors, then the mean
    for i in range(len(g.measured_hz)):
        r = [f"abs err % {i + 1}", ""]
        if p is not None:
            r.append(_f(p.abs_error_pct["initial"][i]))
        r.append(_f(abs(g.initial_error_pct[i])))
        if p is not None:
            r += [_f(p.abs_error_pct[k][i]) for k in p.updated_hz]
        for s in g.solvers:
            a = s.abs_error_pct
            r.append("n/a" if a is None else _cell(a.median[i], a.q1[i], a.q3[i]))
        rows.append(r)
    r = ["**mean abs err %**", ""]
    if p is not None:
        r.append(f"**{_f(p.mean_abs_error_pct['initial'])}**")
    r.append(f"**{_f(g.initial_mean_abs_error_pct)}**")
    if p is not None:
        r += [f"**{_f(p.mean_abs_error_pct[k])}**" for k in p.updated_hz]
    r += [f"**{_cell(s.mean_abs_error_pct.median, s.mean_abs_error_pct.q1, s.mean_abs_error_pct.q3)}**"
          for s in g.solvers]
    rows.append(r)
    if g.has_shapes:
        for i in range(len(g.measured_hz)):
            r = [f"MAC {i + 1}", ""] + [_f(g.initial_mac[i], ".3f")]
            r += ["n/a" if s.mac is None else _cell(s.mac.median[i], s.mac.q1[i], s.mac.q3[i], ".3f")
                  for s in g.solvers]
            rows.append(r)
        r = ["mean COMAC", "", _f(g.initial_mean_comac, ".3f")]
        r += [_cell(s.mean_comac.median, s.mean_comac.q1, s.mean_comac.q3, ".3f") for s in g.solvers]
        rows.append(r)
    elif p is not None:
        r = ["mean COMAC", "", _f(p.mean_comac_text.get("initial"), ".3g"), "n/a"]
        r += [_f(p.mean_comac_text.get(k), ".4g") for k in p.updated_hz]
        r += ["n/a"] * len(g.solvers)
        rows.append(r)
    return markdown_table(head, rows)


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
             "100 (f_model - f_measured) / f_measured.", "",
             "**The H-frame geometry is a reconstruction**: the paper (T. Marwala, \"Dynamic model updating "
             "using particle swarm optimization method\") gives no dimensions; ours reproduces its "
             "initial-model frequencies to about 0.15 %.", ""]
    for g in groups:
        lines += [f"## Variant `{g.variant}`, budget {g.budget} FE evaluations per run", ""]
        title = "Table 1 rebuilt" if g.paper is not None else "Frequencies"
        lines += [f"### {title}: natural frequencies (Hz) and absolute errors (%)", ""]
        lines += _table1(g)
        lines += ["", "### Solvers", ""] + _solver_table(g) + [""]
        if g.paper is not None:
            lines += _paper_section(g.paper)
        fig = figures.get((g.variant, g.budget), {})
        captions = {"convergence": "Convergence (best-so-far vs evaluations)",
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

