"""A diagnosis in words: the number formats and sentences shared by the terminal summary
(`femu diagnose`) and the Markdown report (`femu diagnose --out`), and the report's Markdown.

Everything here reads a `fe_problem.Diagnosis` by its attributes and computes nothing new.
"""

from __future__ import annotations

import math

from typing import TYPE_CHECKING

if TYPE_CHECKING:  # annotations only: `femu --help` loads this without the diagnosis (issue 25)
    from fe_problem.diagnosis import Cause, Diagnosis, Selection

from .render import markdown_table


def fmt(v, digits: int = 4) -> str:
    """A number with `digits` significant digits; '-' for a missing one (None/NaN)."""
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    if isinstance(v, (int, float)):
        return f"{v:.{digits}g}"
    return str(v)


def _missing(v) -> bool:
    return v is None or not math.isfinite(v)


def hz(v) -> str:
    """A frequency in Hz with two decimals; '-' for a missing one (None/NaN)."""
    return "-" if _missing(v) else f"{v:.2f}"


def pct(v) -> str:
    """A signed percentage with two decimals; '-' for a missing one (None/NaN)."""
    return "-" if _missing(v) else f"{v:+.2f}"


def location_text(location: dict | None) -> str:
    """'node 9', 'node 8, element 11'; 'whole frame' for an effect without a place."""
    if not location:
        return "whole frame"
    return ", ".join(f"{k} {v}" for k, v in location.items())


def estimate_text(estimate: dict | None) -> str:
    """'mass_kg 0.03896, mass_ratio 0.02198' (keys as in the record, with their units)."""
    if not estimate:
        return "-"
    parts = []
    for k, v in estimate.items():
        if isinstance(v, dict):
            v = "{" + ", ".join(f"{kk}: {fmt(vv)}" for kk, vv in v.items()) + "}"
        parts.append(f"{k} {fmt(v)}")
    return ", ".join(parts)


def coordinate_labels(diag: Diagnosis) -> list[str]:
    """'1x', '11y', ... one per measured coordinate, in the data's order."""
    return [f"{node}{d}" for node, d in diag.residuals.measured_dofs]


def cause_text(cause: Cause) -> str:
    """One line: the kind and place with its estimate, 'none', or 'cannot tell apart: ...'."""
    if cause.is_none:
        return "none: " + (cause.explanation or "no candidate is significant")
    if not cause.identifiable:
        agreed = []
        if cause.kind != "undetermined":
            agreed.append(f"all {cause.kind}")
        if cause.location:
            agreed.append(f"all at {location_text(cause.location)}")
        tail = f" ({'; '.join(agreed)})" if agreed else ""
        return "cannot tell apart: " + ", ".join(cause.indistinguishable) + tail
    return f"{cause.kind} at {location_text(cause.location)}: {estimate_text(cause.estimate)}" + implausible_text(cause)


def implausible_text(cause) -> str:
    """' [IMPLAUSIBLE: why]' for an estimate beyond a physical bound, else ''."""
    return "" if getattr(cause, "plausible", True) else f" [IMPLAUSIBLE: {cause.implausible_because}]"


def answer_lines(diag: Diagnosis) -> list[str]:
    """The answer as the best class by evidence: its family and log evidence, whether the data
    decide it ('cannot tell apart A from B (log evidence a against b)'), and, when it is not a
    local class, where the local search's causes are."""
    a = getattr(diag, "answer", None)
    if a is None:
        return []
    ru = a.runner_up
    best = ru is None or ru["log_evidence"] <= a.log_evidence
    lines = [f"{'best class by evidence' if best else 'answer, though not the best class by evidence'}: {a.label} "
             f"({a.family}), log evidence {fmt(a.log_evidence)}"
             + (", decisive (the next answer more than a factor of 10 below)" if a.decisive and ru else "")]
    because = getattr(a, "not_decisive_because", None)
    if because:
        lines.append(f"not decisive: {because}")
    elif not a.decisive and ru is not None and best:
        lines.append(f"cannot tell apart {a.label} from {ru['label']} (log evidence {fmt(a.log_evidence)} against "
                     f"{fmt(ru['log_evidence'])})")
    elif ru is not None and not best:
        lines.append(f"{ru['label']} has more evidence (log evidence {fmt(ru['log_evidence'])} against "
                     f"{fmt(a.log_evidence)}), but " + ("no candidate is significant" if a.family == "none" else
                                                        "the local search chose within the local family"))
    if not a.is_local and not diag.causes:
        lines.append("no local candidate is significant: the local search named nothing (the answer is the best "
                     "class, as the calibrated model misfits)")
    elif not a.is_local:
        found = ", ".join(c.label or f"{c.kind} ({len(c.indistinguishable)} candidates tie)" for c in diag.causes)
        lines.append(f"the local search named {found} (the local class; its causes are in the record's causes)")
    return lines


def significance_beside_another_class(diag: Diagnosis, p_text: str) -> str | None:
    """The significance test's outcome in words when the answer is not the local search's (a
    distributed, sparse or model-form class), else None (the p-value line is the answer's own).
    The test asks whether any local candidate is there; beside another class its p-value (a
    'p 0.193 ... significant below 0.01' next to a thinner member) read as the answer's. p_text:
    the adjusted p-value as the caller shows it."""
    a = getattr(diag, "answer", None)
    if a is None or a.is_local:
        return None
    sel = diag.selection
    test = f"p {p_text} adjusted over {sel.n_candidates} candidates, significant below {fmt(sel.alpha, 2)}"
    if diag.cause.p_adjusted >= sel.alpha:
        return (f"the local search found nothing significant ({test}): the answer comes from the evidence "
                "between model classes, not from that test")
    return (f"the local search found a significant cause ({test}), but the answer comes from the evidence "
            "between model classes, which puts another class first")


#: How many model classes the evidence table shows.
N_CLASSES = 6


def evidence_lines(diag: Diagnosis) -> list[str]:
    """The model classes ranked by evidence, the best few, and the factor-of-10 note."""
    ev = diag.evidence
    if ev is None or not ev.classes:
        return []
    rows = ev.classes[:N_CLASSES]
    width = max(len(c.label) for c in rows)
    nested = ev.method == "nested"
    how = ("nested: the best classes by Laplace sampled with dynesty, +- its error; rows without one: Laplace"
           if nested else ev.method)
    lines = [f"Model classes by evidence ({how}; log evidence against the calibrated model, dispersion "
             f"{fmt(ev.dispersion, 3)}; held-out %: the held-out modes' mean error, refitted without them):",
             f"  {'class':<{width}}  {'family':<11} params  {'chi^2':>8}  {'log ev.':>8}"
             + ("  +- error" if nested else "") + "  held-out %"]
    for c in rows:
        err = "" if not nested else f"  {fmt(c.log_evidence_error, 2) if c.method == 'nested' else '-':>8}"
        lines.append(f"  {c.label:<{width}}  {c.family:<11} {c.n_parameters:>6}  {fmt(c.chi2):>8}  "
                     f"{fmt(c.log_evidence):>8}{err}  {fmt(c.held_out_error_pct, 3)}")
    if ev.note:
        lines.append(f"  {ev.note}")
    return lines + [""]


def data_check_lines(diag: Diagnosis) -> list[str]:
    """The faults found in the data, one line each, and what that means for the diagnosis."""
    if not diag.data_checks:
        return []
    lines = [f"DATA CHECKS: {len(diag.data_checks)} fault(s) of the data found"]
    lines += [f"  - {c.kind}: {c.text}" for c in diag.data_checks]
    leave = getattr(diag, "left_out", None) or {}
    if leave:
        what = "; ".join(f"{k} " + ", ".join("".join(map(str, v)) if isinstance(v, list) else str(v) for v in vals)
                         for k, vals in leave.items())
        lines.append(f"  the diagnosis below left out of its fit: {what} (--keep-faulty fits them); its answer is "
                     "not decisive")
    else:
        lines.append("  the diagnosis below ran on the data as given; the fault(s) may explain its misfit and causes")
    return lines + [""]


def noise_text(diag: Diagnosis) -> str:
    """'frequencies 0.2 %, shape entries 2 % of each mode's largest entry (default)'."""
    sel, source = diag.selection, (diag.noise.source if diag.noise else "stated")
    text = (f"frequencies {fmt(100 * sel.freq_noise, 3)} %, shape entries {fmt(100 * sel.shape_noise, 3)} % of "
            f"each mode's largest entry ({source})")
    n_f, n_s, m = diag.noise.data_deviations if diag.noise else (0, 0, 0)
    if n_f or n_s:
        text += (f"; the data's own deviations instead for {n_f} of {m} frequencies and {n_s} of {m} shapes "
                 "(docs/modal-data-format.md)")
    return text


def verdict_lines(diag: Diagnosis) -> list[str]:
    """The goodness-of-fit verdict, plainly: adequate or not, and the noise the misfit implies."""
    v = diag.verdict
    if v is None:
        return []
    head = "VERDICT: adequate" if v.adequate else "VERDICT: NOT ADEQUATE"
    lines = [f"{head}: {v.explanation}"]
    implied = [f"frequencies {fmt(100 * v.implied_freq_noise, 3)} %"] if v.implied_freq_noise is not None else []
    if v.implied_shape_noise is not None:
        implied.append(f"shapes {fmt(100 * v.implied_shape_noise, 3)} %")
    if implied:
        lines.append("  noise the final model's misfit implies: " + ", ".join(implied))
    return lines


def causes_lines(diag: Diagnosis) -> list[str]:
    """Every cause found, in order of evidence, with its estimate's interval."""
    answer = getattr(diag, "answer", None)
    local = answer is None or answer.is_local
    if (local and len(diag.causes) < 2 and not any(c.interval for c in diag.causes)) or not diag.causes:
        return []
    lines = [f"Causes found, in order of evidence ({len(diag.causes)}):" if local else
             f"Causes the local search found, in order of evidence ({len(diag.causes)}; the local class, not the "
             "answer):"]
    for k, c in enumerate(diag.causes, 1):
        if not c.identifiable:
            lines.append(f"  {k}. cannot tell apart: {', '.join(c.indistinguishable)}")
            continue
        ranges = [f"{key} {fmt(v[0], 4)} to {fmt(v[1], 4)}" for key, v in c.interval.items()
                  if key != "level" and isinstance(v, list) and None not in v]
        level = f" ({fmt(100 * c.interval.get('level', 0.95), 2)} % interval: {'; '.join(ranges[:2])})" if ranges else ""
        lines.append(f"  {k}. {c.kind} at {location_text(c.location)}: {estimate_text(c.estimate)}{level}"
                     + implausible_text(c))
    return lines


def threshold_chi2_drop(selection: Selection) -> float | None:
    """The chi^2 drop the best candidate needs to be significant, as the record states it."""
    value = selection.threshold_chi2_drop
    return None if _missing(value) else float(value)


def best_label(diag: Diagnosis) -> str | None:
    """The label of the candidate with the lowest chi^2 (the one the test was applied to)."""
    best = diag.best
    return None if best is None else best.label


def mode_ranges(modes) -> str:
    """Mode numbers as ranges: [1, 2, 3, 5] -> '1-3, 5'."""
    modes = sorted(int(m) for m in modes)
    out, k = [], 0
    while k < len(modes):
        j = k
        while j + 1 < len(modes) and modes[j + 1] == modes[j] + 1:
            j += 1
        out.append(str(modes[k]) if j == k else f"{modes[k]}-{modes[j]}")
        k = j + 1
    return ", ".join(out) or "-"


# == Markdown ==================================================================================
def _table(header: list[str], rows: list[list]) -> list[str]:
    """A Markdown table followed by a blank line (sections are joined line by line)."""
    return markdown_table(header, rows) + [""]


def render_markdown(diag: Diagnosis, figures: dict, data_source: str, model_name: str,
                    extended_file: str | None) -> str:
    """The report's Markdown from the record; `figures` maps a figure's role to its file name."""
    sel = diag.selection
    md = [f"# Diagnosis of model `{model_name}` against `{data_source}`", "",
          f"{len(diag.residuals.correlation.measured_hz)} measured modes, {len(diag.residuals.measured_dofs)} "
          f"measured coordinates. Noise model: {noise_text(diag)}.", ""]
    md += [line.replace("DATA CHECKS:", "**Data checks:**", 1) for line in data_check_lines(diag)]
    md += _cause_section(diag, extended_file)
    md += [line.replace("VERDICT:", "**Verdict:**", 1) for line in verdict_lines(diag)] + [""]
    md += causes_lines(diag) + [""]
    md += ["## Model classes by evidence", "", "```"] + evidence_lines(diag)[:-1] + ["```", ""] \
        if diag.evidence is not None else []
    md += _residuals_section(diag, figures)
    md += _gain_section(diag)
    md += ["## Candidates", "",
           f"{sel.n_candidates} candidates screened by their first-order chi^2 drop, the {sel.n_fitted} "
           "most promising fitted (grid over the effect size, then a bounded refinement).", ""]
    if "candidates" in figures:
        md += [f"![candidates]({figures['candidates']})", ""]
    md += _table(["candidate", "screened drop", "fitted drop", "distance to best", "estimate"],
                 [[c.label, fmt(c.screen_chi2_drop), fmt(c.chi2_drop), fmt(c.delta_to_best),
                   estimate_text(c.estimate)] for c in diag.candidates if c.fitted])
    md += ["### Selection", "", f"{sel.method}.", ""]
    md += _table(["alpha", "statistic", "p (single)", "p (adjusted)", "dispersion", "ambiguity chi^2"],
                 [[fmt(sel.alpha, 2), fmt(sel.statistic), fmt(sel.p_value, 3), fmt(sel.p_adjusted, 3),
                   fmt(sel.dispersion), fmt(sel.ambiguity_chi2, 3)]])
    if diag.warnings:
        md += ["## Warnings", ""] + [f"- {w}" for w in diag.warnings] + [""]
    md += ["The full record is in [`diagnosis.json`](diagnosis.json).", ""]
    return "\n".join(md)


def _cause_section(diag: Diagnosis, extended_file: str | None) -> list[str]:
    cause, sel = diag.cause, diag.selection
    md = ["## Cause", "", f"**{cause_text(cause)}**", "",
          "- " + (significance_beside_another_class(diag, fmt(cause.p_adjusted, 3))
                  or f"adjusted p-value {fmt(cause.p_adjusted, 3)} (likelihood ratio against the calibrated model, "
                     f"Bonferroni over {sel.n_candidates} candidates; significant below {fmt(sel.alpha, 2)})")]
    best, needed = diag.best, threshold_chi2_drop(sel)
    if best is not None and needed is not None:
        md.append(f"- the best candidate, {best.label}, lowers chi^2 by {fmt(best.chi2_drop)}; significance needs "
                  f"{fmt(needed, 3)}")
    md += [f"- {line}" for line in answer_lines(diag)]
    if cause.explanation and not cause.is_none:
        md.append(f"- {cause.explanation}")
    if extended_file:
        md.append(f"- extended model: [`{extended_file}`]({extended_file}) (calibrated, with the effect"
                  + ("; the best of the candidates that cannot be told apart" if not cause.identifiable else "")
                  + ")")
    md += [""]
    if diag.alternatives:
        md += ["### " + ("Closest candidates (none significant)" if cause.is_none else "Alternatives"), "",
               f"chi^2 distance to the best (scaled by the dispersion {fmt(sel.dispersion, 3)}); below "
               f"{fmt(sel.ambiguity_chi2, 3)} the data cannot tell a candidate from the best.", ""]
        md += _table(["candidate", "kind", "place", "estimate", "chi^2 drop", "distance to best"],
                     [[a.label, a.kind, location_text(a.location), estimate_text(a.estimate), fmt(a.chi2_drop),
                       fmt(a.delta_to_best)] for a in diag.alternatives])
    return md


def _residuals_section(diag: Diagnosis, figures: dict) -> list[str]:
    res = diag.residuals
    c = res.correlation
    md = ["## What the calibrated model gets wrong", "",
          f"Global stiffness-to-mass scale {fmt(res.global_scale, 6)}; chi^2 {fmt(res.chi2)} over "
          f"{res.n_residuals} residuals (reduced {fmt(res.reduced_chi2)}); mean |frequency error| "
          f"{fmt(c.mean_abs_error_pct, 3)} %" + (f", mean MAC {fmt(c.mean_mac, 4)}, mean COMAC "
                                                 f"{fmt(c.mean_comac, 4)}" if c.mean_mac else "") + ".", ""]
    md += _table(["measured mode", "measured (Hz)", "model (Hz)", "error (%)", "MAC", "model mode"],
                 [[k + 1, hz(c.measured_hz[k]), hz(c.model_hz[k]), pct(c.error_pct[k]), fmt(c.mac[k], 4),
                   p if p > 0 else "none"] for k, p in enumerate(c.paired_model_mode)])
    if "frequency_errors" in figures:
        md += [f"![frequency errors]({figures['frequency_errors']})", ""]
    if c.comac is not None:
        md += ["COMAC per measured coordinate:", ""]
        md += _table(coordinate_labels(diag), [[fmt(v, 4) for v in c.comac]])
    if "correlation" in figures:
        md += [f"![COMAC and MAC matrix]({figures['correlation']})", ""]
    md += ["Element moduli that a bounded update (+-1/7 around the calibrated value) drives to a bound: "
           + (", ".join(f"{p.parameter} ({p.bound}, {fmt(p.value_pa)} Pa)" for p in res.pinned_parameters)
              or "none") + ".", ""]
    if res.unpaired_modes:
        md += [f"Measured modes that pair with no model mode: {list(res.unpaired_modes)}.", ""]
    if "shapes" in figures:
        md += [f"![mode shapes]({figures['shapes']})", ""]
    return md


def _gain_section(diag: Diagnosis) -> list[str]:
    gain = diag.gain
    md = ["## Gain on held-out modes", ""]
    if not gain.held_out_modes:
        return md + [(gain.note or "no modes held out") + ".", ""]
    md += [f"Held out: mode(s) {mode_ranges(gain.held_out_modes)}; both models refitted on modes "
           f"{mode_ranges(gain.fit_modes)} and predict them.", ""]
    b, a = gain.before, gain.after
    header = ["held-out mode", "measured (Hz)", "calibrated (Hz)", "error (%)", "MAC"]
    if a:
        header += ["extended (Hz)", "error (%)", "MAC"]
    rows = []
    for k, m in enumerate(gain.held_out_modes):
        row = [m, hz(b.measured_hz[k]), hz(b.model_hz[k]), pct(b.error_pct[k]), fmt(b.mac[k], 4)]
        if a:
            row += [hz(a.model_hz[k]), pct(a.error_pct[k]), fmt(a.mac[k], 4)]
        rows.append(row)
    md += _table(header, rows)
    md += _table(["", "calibrated (before)", "extended (after)"],
                 [[q, fmt(getattr(b, key), 4), fmt(getattr(a, key), 4) if a else "-"]
                  for q, key in (("mean abs frequency error (%)", "mean_abs_error_pct"),
                                 ("mean MAC", "mean_mac"), ("mean COMAC", "mean_comac"))
                  if getattr(b, key) is not None])
    if gain.estimate_from_fit_modes:
        md += [f"Estimate from the fit modes alone: {estimate_text(gain.estimate_from_fit_modes)}.", ""]
    return md
