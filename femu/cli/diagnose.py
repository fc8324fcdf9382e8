"""find the physics the model is missing from measured data

Compares the model with the measured modes, tries every candidate effect (a loss or gain of
stiffness, an added or spread mass, a soft support, a flexible joint, shear deformation), keeps
the causes the data prove beyond the stated noise and says whether the result fits. Example:

  femu diagnose crack.json --out diag/
  femu diagnose measured.json --model bridge.json     # a model given as matrices (its manifest)

Without options it prints a summary. --json prints the whole record as JSON, the only thing on
stdout. --out DIR writes extended.model.json (the model with the causes found, when there is
one), diagnosis.json, report.md and its figures (shapes.png, frequency_errors.png,
correlation.png when shapes were measured, candidates.png), naming every file it wrote.
Progress and warnings go to stderr. The method and its tests: docs/diagnosis.md; a model given as
matrices (a term softer or stiffer, a mass or a spring at a measured DOF, several terms at once):
docs/matrix-model.md.
"""

from __future__ import annotations


import contextlib
import os
import sys
import warnings
from pathlib import Path
from typing import TYPE_CHECKING

# the diagnosis and its reports load when the command runs, not for `femu --help` (issue 25)
if TYPE_CHECKING:
    from fe_problem.diagnosis import Diagnosis
from femu.reports.diagnosis_text import (answer_lines, cause_text, causes_lines, coordinate_labels, data_check_lines,
                                         estimate_text, evidence_lines, fmt, hz, mode_ranges, noise_text, pct,
                                         significance_beside_another_class, threshold_chi2_drop, verdict_lines)

#: How many alternatives and COMAC coordinates the terminal summary lists.
N_ALTERNATIVES = 5
COMAC_PER_LINE = 8


def _stderr(msg: str) -> None:
    print(f"femu diagnose: {msg}", file=sys.stderr)


def _positive(value, option: str) -> float:
    from fe_problem.diagnosis.core import check_noise

    return check_noise(value, option)



def _check_out(out: str) -> Path:
    from ._args import EMPTY_PATH

    if not out.strip():
        raise ValueError(f"--out: {EMPTY_PATH}")
    path = Path(out)
    if path.exists() and not path.is_dir():
        raise ValueError(f"--out {out}: exists and is not a directory")
    return path


@contextlib.contextmanager
def _stdout_to_stderr():
    """File descriptor 1 pointed at stderr inside: what a library writes to the C-level stdout
    (LAPACK's and ARPACK's messages) goes to stderr, so that stdout holds only the command's
    output (`--json`: the JSON alone). Python's own `sys.stdout` is flushed before and after."""
    try:
        sys.stdout.flush()
        saved = os.dup(1)
    except (OSError, ValueError):  # no fd 1 to redirect (closed, or not a file)
        yield
        return
    try:
        os.dup2(2, 1)
        yield
    finally:
        try:
            sys.stdout.flush()
        except (OSError, ValueError):
            pass
        os.dup2(saved, 1)
        os.close(saved)


def _p_text(p) -> str:
    """A p-value; one that underflowed to 0 is shown as the bound it is."""
    return "< 1e-300" if p == 0 else f"= {fmt(p, 3)}"


def add_arguments(d) -> None:
    d.add_argument("data", help="a modal-data file (JSON or UFF 55) or a shipped dataset (paper)")
    d.add_argument("--model", default=None, help="model name, model file or matrix-model manifest "
                                                  "(default: the data's model)")
    d.add_argument("--out", default=None, metavar="DIR",
                   help="directory for the extended model, diagnosis.json, report.md and its figures")
    d.add_argument("--json", action="store_true", help="print the diagnosis record as JSON on stdout")
    d.add_argument("--freq-noise", type=float, default=None,
                   help="std of a measured frequency, relative (default 0.002 = 0.2 %%)")
    d.add_argument("--shape-noise", type=float, default=None,
                   help="std of a measured shape entry as a fraction of the largest |entry| of its mode, the "
                        "usual convention (default 0.02 = 2 %% of the peak); the record's goodness_of_fit gives "
                        "the noise the data imply")
    d.add_argument("--keep-faulty", action="store_true",
                   help="fit the channels and modes the data checks find faulty (a reversed or swapped channel, "
                        "exchanged shapes, a mode identified twice) instead of leaving them out; either way an "
                        "answer on faulty data is not decisive")
    d.add_argument("--evidence", choices=("laplace", "nested"), default="laplace",
                   help="how the model classes' evidence is found: laplace (at the fitted optimum, the default) "
                        "or nested (the best classes by Laplace sampled with dynesty, seeded; slower; needs "
                        "pip install \"femu-bench[nested]\")")


def run(args) -> int:
    """Entry point of `femu diagnose` (args: data, model, out, json, freq_noise, shape_noise, evidence,
    keep_faulty)."""
    from fe_problem import diagnose, load_any_model, load_modal_data, save_model
    from fe_problem.matrix_model import MatrixModel, save_matrix_model
    from fe_problem.jsonutil import dumps
    from femu.reports.diagnosis import write_json, write_report

    freq_noise, shape_noise = getattr(args, "freq_noise", None), getattr(args, "shape_noise", None)
    freq_noise = None if freq_noise is None else _positive(freq_noise, "--freq-noise")
    shape_noise = None if shape_noise is None else _positive(shape_noise, "--shape-noise")
    data = load_modal_data(args.data)
    model = data.load_model() if args.model is None else load_any_model(args.model)
    out = _check_out(args.out) if args.out is not None else None  # before the work: a bad --out fails at once
    if getattr(args, "evidence", "laplace") == "nested":
        from fe_problem.diagnosis.nested import require_dynesty

        require_dynesty()  # a missing optional dependency: one line, exit 2, before the work
    if sys.stderr.isatty():  # progress for a person waiting; logs and pipes get results and errors only
        _stderr(f"diagnosing {data.source} ({data.n_modes} modes) against model {model.name} ...")
    with warnings.catch_warnings(record=True) as caught, _stdout_to_stderr():
        warnings.simplefilter("always")
        diag = diagnose(model, data, freq_noise=freq_noise, shape_noise=shape_noise,
                        evidence=getattr(args, "evidence", "laplace"), keep_faulty=getattr(args, "keep_faulty", False))
    for msg in dict.fromkeys(str(w.message) for w in caught):
        _stderr(f"warning: {msg}")

    written = []
    if out is not None:
        from femu.reports.render import make_out_dir

        make_out_dir(out)  # only now, so that bad data leave no empty directory behind
        extended_file = None
        if isinstance(diag.extended_model, MatrixModel):  # its manifest, every matrix file beside it
            extended_file = "extended.model.json"
            written.append(save_matrix_model(diag.extended_model, out / extended_file, copy_files=True))
        elif diag.extended_model is not None:
            extended_file = "extended.model.json"
            written.append(save_model(diag.extended_model, out / extended_file))
        written.append(write_json(diag, out / "diagnosis.json"))
        from fe_problem.diagnosis.datachecks import without

        # the report draws the data the diagnosis fitted: the faulty channels and modes left out
        written.extend(write_report(diag, model, without(data, diag.left_out), out, extended_file))

    if args.json:
        sys.stdout.write(dumps(diag) + "\n")
        for w in diag.warnings:
            _stderr(f"warning: {w}")
        for p in written:
            _stderr(f"wrote {p}")
        return 0
    print(summary_text(diag, data.source, model.name))
    for p in written:
        print(f"wrote {p}")
    return 0


# == the terminal summary =====================================================================
def summary_text(diag: Diagnosis, data_source: str, model_name: str) -> str:
    """The human-readable summary of a diagnosis (plain text, ~100 columns)."""
    res, sel = diag.residuals, diag.selection
    lines = [f"Diagnosis of model {model_name} against {data_source}",
             f"  {len(res.correlation.measured_hz)} measured modes at {len(res.measured_dofs)} coordinates; noise: "
             + noise_text(diag), ""]
    found = causes_lines(diag)
    lines += (data_check_lines(diag) + _cause_lines(diag) + verdict_lines(diag) + [""] + (found + [""] if found else [])
              + evidence_lines(diag) + _residual_lines(diag) + _alternative_lines(diag) + _gain_lines(diag))
    if diag.warnings:
        lines += ["", "Warnings:"] + [f"  - {w}" for w in diag.warnings]
    return "\n".join(lines)


def _cause_lines(diag: Diagnosis) -> list[str]:
    cause, sel = diag.cause, diag.selection
    head = "CAUSE" if diag.adequate is not False or cause.is_none else "CAUSE (best explanation, NOT an adequate fit)"
    lines = [f"{head}: {cause_text(cause)}"] + [f"  {line}" for line in answer_lines(diag)] + [
             "  " + (significance_beside_another_class(diag, _p_text(cause.p_adjusted).removeprefix("= "))
                     or f"p {_p_text(cause.p_adjusted)} (adjusted over {sel.n_candidates} candidates; "
                        f"significant below {fmt(sel.alpha, 2)})")]
    best, needed = diag.best, threshold_chi2_drop(sel)
    if cause.is_none and best is not None and needed is not None:
        lines.append(f"  best candidate {best.label}: chi^2 drop {fmt(best.chi2_drop)}, {fmt(needed, 3)} needed")
    return lines + [""]


def _residual_lines(diag: Diagnosis) -> list[str]:
    res = diag.residuals
    c = res.correlation
    lines = [f"Calibrated model: global stiffness scale {fmt(res.global_scale, 6)}, chi^2 {fmt(res.chi2)} "
             f"over {res.n_residuals} residuals",
             "  mode  measured Hz   model Hz   error %     MAC  model mode"]
    for k, p in enumerate(c.paired_model_mode):
        lines.append(f"  {k + 1:4d}  {hz(c.measured_hz[k]):>11}  {hz(c.model_hz[k]):>9}  "
                     f"{pct(c.error_pct[k]):>8}  {fmt(c.mac[k], 4):>6}  {p if p > 0 else 'none':>10}")
    summary = f"  mean |error| {fmt(c.mean_abs_error_pct, 3)} %"
    if c.mean_mac is not None:
        summary += f", mean MAC {fmt(c.mean_mac, 4)}, mean COMAC {fmt(c.mean_comac, 4)}"
    lines.append(summary)
    if c.comac is not None:
        cells = [f"{label:>4} {v:.3f}" for label, v in zip(coordinate_labels(diag), c.comac)]
        lines.append("  COMAC:" + "".join(("\n        " if i and i % COMAC_PER_LINE == 0 else "  ") + cell
                                          for i, cell in enumerate(cells)))
    else:
        lines.append("  COMAC: - (no measured shapes)")
    lines.append("  pinned at a bound by a +-1/7 modulus update: "
                 + (", ".join(f"{p.parameter} ({p.bound})" for p in res.pinned_parameters) or "none"))
    if res.unpaired_modes:
        lines.append(f"  measured modes paired with no model mode: {list(res.unpaired_modes)}")
    return lines + [""]


def _alternative_lines(diag: Diagnosis) -> list[str]:
    alts, sel = diag.alternatives[:N_ALTERNATIVES], diag.selection
    if not alts:
        return []
    title = "Closest candidates, none significant" if diag.cause.is_none else "Alternatives"
    lines = [f"{title} (chi^2 drop against the calibrated model; distance to the best, below "
             f"{fmt(sel.ambiguity_chi2, 2)}: cannot tell apart)"]
    width = max(len(a.label) for a in alts)
    for a in alts:
        lines.append(f"  {a.label:<{width}}  drop {fmt(a.chi2_drop):>6}  "
                     f"distance {fmt(a.delta_to_best):>6}   {estimate_text(a.estimate)}")
    return lines + [""]


def _gain_lines(diag: Diagnosis) -> list[str]:
    gain = diag.gain
    if not gain.held_out_modes:
        return [f"Held-out gain: {gain.note or 'no modes held out'}"]
    b, a = gain.before, gain.after
    lines = [f"Held-out mode(s) {mode_ranges(gain.held_out_modes)} (models refitted on modes "
             f"{mode_ranges(gain.fit_modes)}): calibrated" + (" -> extended" if a else "")]
    for q, key, d in (("mean |frequency error| %", "mean_abs_error_pct", 3), ("mean MAC", "mean_mac", 4),
                      ("mean COMAC", "mean_comac", 4)):
        if getattr(b, key) is not None:
            lines.append(f"  {q:<25} {fmt(getattr(b, key), d)}" + (f" -> {fmt(getattr(a, key), d)}" if a else ""))
    for k, m in enumerate(gain.held_out_modes):
        ranged = ""
        if a and len(gain.prediction_interval_hz) > k:
            lo, hi = gain.prediction_interval_hz[k]
            ranged = f" (predicted {hz(a.model_hz[k])} Hz, 95 % range {hz(lo)}-{hz(hi)}; measured {hz(b.measured_hz[k])})"
        lines.append(f"  mode {m}: error {pct(b.error_pct[k])} %" + (f" -> {pct(a.error_pct[k])} %" if a else "")
                     + ranged)
    return lines
