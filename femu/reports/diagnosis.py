"""Rendering of a diagnosis: text helpers shared with the terminal summary, and the Markdown
report with PNG figures that `femu diagnose --out DIR` writes.

A report renders the record (`Diagnosis.to_dict()`) and computes nothing new, except what
it draws: the mode shapes of the calibrated and extended models over the whole frame (one
modal analysis each) and the measured shapes scaled onto them by least squares. The
significance threshold on the candidate chart is the record's own test turned around (see
`threshold_chi2_drop`).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from fe_problem import AffineModel, FrameModel, ModalData, elements, mac, modal_analysis

from .render import figure, markdown_table, save_figure

#: How many measured modes the shape figure draws.
N_SHAPE_MODES = 4
#: How many candidates the candidate chart shows (the rest screened lower and were not fitted).
MAX_CANDIDATE_ROWS = 40
#: The drawn mode shapes' largest nodal translation, as a fraction of the frame's size.
SHAPE_AMPLITUDE = 0.12

CALIBRATED_COLOR = "#1f5fa8"
EXTENDED_COLOR = "#e07b00"
MEASURED_COLOR = "#c0142b"


# == text shared by the terminal summary and the report ========================================
def fmt(v, digits: int = 4) -> str:
    """A number with `digits` significant digits; '-' for a missing one (None/NaN)."""
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    if isinstance(v, (int, float)):
        return f"{v:.{digits}g}"
    return str(v)


def hz(v) -> str:
    """A frequency in Hz with two decimals; '-' for a missing one."""
    return "-" if v is None else f"{v:.2f}"


def pct(v) -> str:
    """A signed percentage with two decimals; '-' for a missing one."""
    return "-" if v is None else f"{v:+.2f}"


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


def coordinate_labels(record: dict) -> list[str]:
    """'1x', '11y', ... one per measured coordinate, in the data's order."""
    return [f"{node}{d}" for node, d in record["residuals"]["measured_dofs"]]


def cause_text(cause: dict) -> str:
    """One line: the kind and place with its estimate, 'none', or 'cannot tell apart: ...'."""
    if cause["kind"] == "none":
        return "none: " + cause.get("explanation", "no candidate is significant")
    if not cause.get("identifiable", True):
        agreed = []
        if cause["kind"] != "undetermined":
            agreed.append(f"all {cause['kind']}")
        if cause.get("location"):
            agreed.append(f"all at {location_text(cause['location'])}")
        tail = f" ({'; '.join(agreed)})" if agreed else ""
        return "cannot tell apart: " + ", ".join(cause.get("indistinguishable", [])) + tail
    return f"{cause['kind']} at {location_text(cause['location'])}: {estimate_text(cause['estimate'])}"


def threshold_chi2_drop(selection: dict) -> float | None:
    """The chi^2 drop the best candidate needs to be significant, as the record states it."""
    value = selection.get("threshold_chi2_drop")
    return None if value is None else float(value)


def best_label(record: dict) -> str | None:
    """The label of the candidate with the lowest chi^2 (the one the test was applied to)."""
    fitted = [c for c in record["candidates"] if c.get("fitted") and c.get("chi2") is not None]
    return min(fitted, key=lambda c: c["chi2"])["label"] if fitted else None


# == figures ===================================================================================
def deformed_frame(model: FrameModel, u: np.ndarray, scale: float, n_points: int = 25) -> np.ndarray:
    """Element curves (n_elements, n_points, 2) in metres of the frame displaced by scale * u
    (u: one value per nodal DOF in `model.dofs` order); see `fe_problem.elements.deformed_frame`."""
    return elements.deformed_frame(model, u, scale, n_points)


def _translation_dofs(model: FrameModel) -> list[tuple[int, str]]:
    return [(n.id, d) for n in model.nodes for d in ("x", "y")]


def plot_shapes(model: FrameModel, extended: FrameModel | None, data: ModalData, record: dict, path: Path,
                n_modes: int = N_SHAPE_MODES) -> Path | None:
    """The frame deformed in a few measured modes: the calibrated model's shape, the extended
    model's, and the measured coordinates as arrows (scaled onto the model by least squares).

    Draws the first `n_modes` paired measured modes (those with a measured shape first)."""
    res = record["residuals"]
    pairing = np.array(res["paired_model_mode"]) - 1
    has_shape = data.has_shape
    paired = np.flatnonzero(pairing >= 0)
    chosen = sorted([i for i in paired if has_shape[i]][:n_modes]) or sorted(paired[:n_modes].tolist())
    if not chosen:
        return None
    n_elastic = AffineModel(model).n_elastic
    k = min(int(pairing.max()) + 1 + 4, n_elastic)
    calibrated = modal_analysis(model, k)
    ext = modal_analysis(extended, min(k + 2, AffineModel(extended).n_elastic)) if extended is not None else None
    trans = _translation_dofs(model)

    xy = np.array([[n.x, n.y] for n in model.nodes])
    extent = np.ptp(xy, axis=0)
    size = float(np.max(extent))
    # a tall frame reads best as one row of panels, a wide one in two columns
    aspect = float((extent[0] + 0.3 * size) / (extent[1] + 0.3 * size))
    ncols = len(chosen) if aspect < 0.8 else min(2, len(chosen))
    nrows = math.ceil(len(chosen) / ncols)
    panel_h = 4.6
    fig, axes = figure(ncols * max(2.6, panel_h * aspect + 0.3), nrows * panel_h + 0.7, nrows, ncols, sharey=True)
    for ax in axes.ravel()[len(chosen):]:
        ax.set_visible(False)
    undeformed = deformed_frame(model, np.zeros(3 * len(model.nodes)), 0.0, 2)
    pos = {nd.id: (nd.x, nd.y) for nd in model.nodes}
    for ax, i in zip(axes.ravel(), chosen):
        p = pairing[i]
        u = calibrated.shapes[:, p]
        t = calibrated.at(trans)[:, p]
        scale = SHAPE_AMPLITUDE * size / np.max(np.hypot(t[0::2], t[1::2]))
        for seg in undeformed:
            ax.plot(seg[:, 0], seg[:, 1], color="0.75", lw=1.0, zorder=1)
        for n, seg in enumerate(deformed_frame(model, u, scale)):
            ax.plot(seg[:, 0], seg[:, 1], color=CALIBRATED_COLOR, lw=2.0, zorder=2,
                    label="calibrated model" if n == 0 else None)
        title = [f"mode {i + 1}: measured {res['measured_hz'][i]:.2f} Hz",
                 f"calibrated{'' if p == i else f' (mode {p + 1})'} {res['model_hz'][i]:.2f} Hz"
                 + (f", MAC {res['mac'][i]:.4f}" if res["mac"][i] is not None else "")]
        if ext is not None:
            # the extended model's mode that tracks this one: the largest MAC over the frame
            te = ext.at(trans)
            q = int(np.argmax(mac(t[:, None], te)[0]))
            a = float(te[:, q] @ t / (te[:, q] @ te[:, q]))
            for n, seg in enumerate(deformed_frame(extended, a * ext.shapes[:, q], scale)):
                ax.plot(seg[:, 0], seg[:, 1], color=EXTENDED_COLOR, lw=1.6, ls="--", zorder=3,
                        label=f"extended model ({best_label(record)})" if n == 0 else None)
            title.append(f"extended {ext.frequencies_hz[q]:.2f} Hz")
        if has_shape[i]:
            drawn = [c for c, (_, d) in enumerate(data.dofs) if d in ("x", "y")]
            m = data.shapes[:, i]
            at = calibrated.at(data.dofs)[:, p]
            a = float(m @ at / (m @ m))  # least-squares scale (and sign) of the measured shape
            base = np.array([pos[data.dofs[c][0]] for c in drawn])
            along_x = np.array([data.dofs[c][1] == "x" for c in drawn])
            v = scale * a * m[drawn]
            dxy = np.stack([np.where(along_x, v, 0.0), np.where(along_x, 0.0, v)], axis=1)
            ax.quiver(base[:, 0], base[:, 1], dxy[:, 0], dxy[:, 1], angles="xy", scale_units="xy", scale=1,
                      color=MEASURED_COLOR, width=0.007, headwidth=4.5, headlength=5, headaxislength=4.5,
                      minlength=0, zorder=4)
            ax.plot(*(base + dxy).T, "o", ms=4, color=MEASURED_COLOR, zorder=5, ls="none",
                    label="measured (arrow from rest)")
        else:
            title.append("(no measured shape)")
        title = "\n".join(title)
        ax.set_title(title, fontsize=8.5)
        ax.set_aspect("equal")
        ax.margins(0.08)
        ax.tick_params(labelsize=7)
        ax.set_xlabel("x (m)", fontsize=8)
        ax.grid(True, alpha=0.2)
    for ax in axes[:, 0]:
        ax.set_ylabel("y (m)", fontsize=8)
    handles, labels = axes[0, 0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="outside lower center", ncols=len(labels), fontsize=8.5, frameon=False)
    fig.suptitle(f"Mode shapes of {model.name} (amplitude arbitrary; measured shapes scaled onto the "
                 "calibrated model by least squares)", fontsize=9)
    save_figure(fig, path)
    return path


def plot_frequency_errors(record: dict, path: Path) -> Path:
    """Left: the calibrated model's frequency error per measured mode. Right: the held-out
    modes' error when predicted by the calibrated and the extended model (the gain)."""
    res, gain = record["residuals"], record["gain"]
    err = np.array([np.nan if v is None else v for v in res["error_pct"]], dtype=float)
    modes = np.arange(1, len(err) + 1)
    held = set(gain.get("held_out_modes", []))
    fig, axes = figure(10.0, 3.9, 1, 2, width_ratios=[max(len(err), 3), max(len(held), 1) + 1.5])
    ax = axes[0, 0]
    colors = ["#8aa9cc" if m in held else CALIBRATED_COLOR for m in modes]
    ax.bar(modes, np.nan_to_num(err), color=colors, edgecolor="k", lw=0.4)
    for m, e in zip(modes, err):
        if not np.isfinite(e):
            ax.text(m, 0, "unpaired", rotation=90, ha="center", va="bottom", fontsize=8, color=MEASURED_COLOR)
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(modes)
    ax.set_xlabel("measured mode (pale: held out in the gain test)")
    ax.set_ylabel("frequency error (%)")
    ax.set_title(f"Calibrated model (global stiffness scale {fmt(res['global_scale'], 5)}), all modes",
                 fontsize=9)
    ax.grid(True, axis="y", alpha=0.3)

    ax = axes[0, 1]
    if gain.get("held_out_modes"):
        hm = np.array(gain["held_out_modes"])
        x = np.arange(len(hm))
        before = np.array([np.nan if v is None else v for v in gain["before"]["error_pct"]], dtype=float)
        ax.bar(x - 0.2, np.nan_to_num(before), 0.4, color=CALIBRATED_COLOR, label="calibrated (before)")
        if "after" in gain:
            after = np.array([np.nan if v is None else v for v in gain["after"]["error_pct"]], dtype=float)
            ax.bar(x + 0.2, np.nan_to_num(after), 0.4, color=EXTENDED_COLOR, label="extended (after)")
        ax.set_xticks(x, [str(m) for m in hm])
        ax.set_xlim(-0.9, len(hm) - 0.1)
        ax.axhline(0, color="k", lw=0.8)
        ax.set_ylabel("frequency error (%)")
        ax.legend(fontsize=7.5, loc="best")
        fit_modes = gain.get("fit_modes", [])
        ax.set_title(f"Held-out modes (both models\nrefitted on modes {mode_ranges(fit_modes)})", fontsize=9)
        ax.set_xlabel("held-out mode")
    else:
        ax.text(0.5, 0.5, gain.get("note", "no held-out modes"), ha="center", va="center", fontsize=9,
                transform=ax.transAxes, wrap=True)
        ax.set_xticks([])
    ax.grid(True, axis="y", alpha=0.3)
    save_figure(fig, path)
    return path


def plot_correlation(record: dict, path: Path) -> Path | None:
    """COMAC per measured coordinate (calibrated model) and the MAC matrix with its pairing;
    None when no shapes were measured."""
    res = record["residuals"]
    if res.get("comac") is None or res.get("mac_matrix") is None:
        return None
    cm = np.array(res["comac"], dtype=float)
    labels = coordinate_labels(record)
    mm = np.array(res["mac_matrix"], dtype=float)
    fig, axes = figure(11.0, 4.2, 1, 2, width_ratios=[max(len(cm), 4), mm.shape[1] * 0.9])
    ax = axes[0, 0]
    order_low = np.argsort(cm)[:3]
    colors = [MEASURED_COLOR if k in order_low else CALIBRATED_COLOR for k in range(len(cm))]
    ax.bar(np.arange(len(cm)), cm, color=colors, edgecolor="k", lw=0.4)
    ax.set_xticks(np.arange(len(cm)), labels, rotation=60, fontsize=8)
    lo = min(float(cm.min()), 0.98)
    ax.set_ylim(max(0.0, lo - 0.2 * (1 - lo)), 1.0005)
    ax.set_xlabel("measured coordinate (node, direction); red: the three lowest")
    ax.set_ylabel("COMAC")
    ax.set_title(f"COMAC of the calibrated model over the paired modes (mean {fmt(res.get('mean_comac'), 4)})",
                 fontsize=9)
    ax.grid(True, axis="y", alpha=0.3)

    ax = axes[0, 1]
    im = ax.imshow(mm, vmin=0, vmax=1, cmap="Blues", aspect="auto")
    for r, p in enumerate(res["paired_model_mode"]):
        if p is not None and p > 0:
            ax.add_patch(_rect(p - 1, r))
    ax.set_xticks(np.arange(mm.shape[1]), np.arange(1, mm.shape[1] + 1), fontsize=7)
    ax.set_yticks(np.arange(mm.shape[0]), np.arange(1, mm.shape[0] + 1), fontsize=7)
    ax.set_xlabel("model mode")
    ax.set_ylabel("measured mode")
    ax.set_title("MAC matrix (boxes: the pairing)", fontsize=9)
    fig.colorbar(im, ax=ax, shrink=0.85)
    save_figure(fig, path)
    return path


def _rect(col: int, row: int):
    from matplotlib.patches import Rectangle
    return Rectangle((col - 0.5, row - 0.5), 1, 1, fill=False, ec=MEASURED_COLOR, lw=1.5)


def plot_candidates(record: dict, path: Path) -> Path:
    """chi^2 drop per candidate: first-order screening for all, the proper fit for those
    fitted; the cause (or the candidates it cannot tell apart) highlighted; the drop the best
    needed to be significant marked."""
    from matplotlib.patches import Patch

    rows = record["candidates"][:MAX_CANDIDATE_ROWS]  # in screening order: every fitted one comes first
    hidden = len(record["candidates"]) - len(rows)
    cause = record["cause"]
    chosen = set(cause.get("indistinguishable") or ([cause["label"]] if cause.get("label") else []))
    threshold = threshold_chi2_drop(record["selection"])
    floor = 0.1  # log axis: a drop below this (0 when the effect can only worsen the fit) gets no bar
    y = np.arange(len(rows))[::-1]
    fig, axes = figure(8.4, 1.4 + 0.2 * len(rows))
    ax = axes[0, 0]
    for yy, r in zip(y, rows):
        drop = r["screen_chi2_drop"] or 0.0
        if drop >= floor:
            ax.barh(yy, drop, 0.8, color="0.84", edgecolor="0.6", lw=0.4)
        else:
            ax.text(floor * 1.1, yy, "0", va="center", fontsize=6.5, color="0.45")
        if r.get("fitted") and r.get("chi2_drop") is not None and r["chi2_drop"] >= floor:
            ax.barh(yy, r["chi2_drop"], 0.45, edgecolor="k", lw=0.4,
                    color=EXTENDED_COLOR if r["label"] in chosen else CALIBRATED_COLOR)
    handles = [Patch(color="0.84", ec="0.6", label="screened (first order)"),
               Patch(color=CALIBRATED_COLOR, label="fitted")]
    if chosen:
        handles.append(Patch(color=EXTENDED_COLOR, label="the cause" if len(chosen) == 1
                             else "fitted, cannot tell apart"))
    if threshold is not None:
        ax.axvline(threshold, color=MEASURED_COLOR, ls="--", lw=1.3)
        handles.append(ax.plot([], [], color=MEASURED_COLOR, ls="--", lw=1.3,
                               label=f"drop needed for significance at alpha {fmt(record['selection']['alpha'], 2)}: "
                                     f"{fmt(threshold, 3)}")[0])
    ax.set_yticks(y, [r["label"] for r in rows], fontsize=7)
    for tick, r in zip(ax.get_yticklabels(), rows):
        if r["label"] in chosen:
            tick.set_fontweight("bold")
    ax.set_xscale("log")
    ax.set_xlim(left=floor)
    ax.set_xlabel("chi^2 drop against the calibrated model (log scale)"
                  + (f"\n({hidden} candidates with smaller screened drops not shown)" if hidden else ""))
    ax.set_ylim(-0.7, len(rows) - 0.3)
    verdict = ("none" if cause["kind"] == "none" else cause["label"] if cause.get("identifiable", True)
               else f"cannot tell {len(chosen)} apart")
    ax.set_title(f"Candidates: {record['selection'].get('n_candidates')} screened, "
                 f"{record['selection'].get('n_fitted')} fitted; cause: {verdict}", fontsize=9)
    ax.grid(True, axis="x", which="both", alpha=0.25)
    ax.legend(handles=handles, fontsize=7.5, loc="lower right")
    save_figure(fig, path)
    return path


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


def render_markdown(record: dict, figures: dict, data_source: str, model_name: str,
                    extended_file: str | None) -> str:
    """The report's Markdown from the record; `figures` maps a figure's role to its file name."""
    res, gain, sel, cause = record["residuals"], record["gain"], record["selection"], record["cause"]
    n_modes = len(res["measured_hz"])
    md = [f"# Diagnosis of model `{model_name}` against `{data_source}`", "",
          f"{n_modes} measured modes, {len(res['measured_dofs'])} measured coordinates. Noise model: "
          f"frequencies {fmt(100 * sel['freq_noise'], 3)} %, shape entries {fmt(100 * sel['shape_noise'], 3)} % "
          "of the mode's RMS.", "", "## Cause", "", f"**{cause_text(cause)}**", ""]
    md += [f"- adjusted p-value {fmt(cause.get('p_adjusted'), 3)} (likelihood ratio against the calibrated model, "
           f"Bonferroni over {sel['n_candidates']} candidates; significant below {fmt(sel['alpha'], 2)})"]
    best, needed = best_label(record), threshold_chi2_drop(sel)
    if best is not None and needed is not None:
        drop = next(c["chi2_drop"] for c in record["candidates"] if c["label"] == best)
        md.append(f"- the best candidate, {best}, lowers chi^2 by {fmt(drop)}; significance needs {fmt(needed, 3)}")
    if cause.get("explanation") and cause["kind"] != "none":
        md.append(f"- {cause['explanation']}")
    if extended_file:
        md.append(f"- extended model: [`{extended_file}`]({extended_file}) (calibrated, with the effect"
                  + ("; the best of the candidates that cannot be told apart" if not cause.get("identifiable", True)
                     else "") + ")")
    md += [""]
    if record["alternatives"]:
        md += ["### " + ("Closest candidates (none significant)" if cause["kind"] == "none" else "Alternatives"), "",
               f"chi^2 distance to the best (scaled by the dispersion {fmt(sel['dispersion'], 3)}); below "
               f"{fmt(sel['ambiguity_chi2'], 3)} the data cannot tell a candidate from the best.", ""]
        md += _table(["candidate", "kind", "place", "estimate", "chi^2 drop", "distance to best"],
                     [[a["label"], a["kind"], location_text(a["location"]), estimate_text(a["estimate"]),
                       fmt(a["chi2_drop"]), fmt(a["delta_to_best"])] for a in record["alternatives"]])

    md += ["## What the calibrated model gets wrong", "",
           f"Global stiffness-to-mass scale {fmt(res['global_scale'], 6)}; chi^2 {fmt(res['chi2'])} over "
           f"{res['n_residuals']} residuals (reduced {fmt(res['reduced_chi2'])}); mean |frequency error| "
           f"{fmt(res.get('mean_abs_error_pct'), 3)} %" + (f", mean MAC {fmt(res['mean_mac'], 4)}, mean COMAC "
                                                          f"{fmt(res['mean_comac'], 4)}" if res.get("mean_mac") else "")
           + ".", ""]
    md += _table(["measured mode", "measured (Hz)", "model (Hz)", "error (%)", "MAC", "model mode"],
                 [[k + 1, hz(res["measured_hz"][k]), hz(res["model_hz"][k]), pct(res["error_pct"][k]),
                   fmt(res["mac"][k], 4), res["paired_model_mode"][k] if res["paired_model_mode"][k] > 0 else "none"]
                  for k in range(n_modes)])
    if "frequency_errors" in figures:
        md += [f"![frequency errors]({figures['frequency_errors']})", ""]
    if res.get("comac") is not None:
        md += ["COMAC per measured coordinate:", ""]
        md += _table(coordinate_labels(record), [[fmt(v, 4) for v in res["comac"]]])
    if "correlation" in figures:
        md += [f"![COMAC and MAC matrix]({figures['correlation']})", ""]
    pinned = res.get("pinned_parameters") or []
    md += ["Element moduli that a bounded update (+-1/7 around the calibrated value) drives to a bound: "
           + (", ".join(f"{p['parameter']} ({p['bound']}, {fmt(p['value_pa'])} Pa)" for p in pinned) or "none")
           + ".", ""]
    if res.get("unpaired_modes"):
        md += [f"Measured modes that pair with no model mode: {res['unpaired_modes']}.", ""]
    if "shapes" in figures:
        md += [f"![mode shapes]({figures['shapes']})", ""]

    md += ["## Gain on held-out modes", ""]
    if gain.get("held_out_modes"):
        md += [f"Held out: mode(s) {mode_ranges(gain['held_out_modes'])}; both models refitted on modes "
               f"{mode_ranges(gain['fit_modes'])} and predict them.", ""]
        b, a = gain["before"], gain.get("after")
        header = ["held-out mode", "measured (Hz)", "calibrated (Hz)", "error (%)", "MAC"]
        if a:
            header += ["extended (Hz)", "error (%)", "MAC"]
        rows = []
        for k, m in enumerate(gain["held_out_modes"]):
            row = [m, hz(b["measured_hz"][k]), hz(b["model_hz"][k]), pct(b["error_pct"][k]), fmt(b["mac"][k], 4)]
            if a:
                row += [hz(a["model_hz"][k]), pct(a["error_pct"][k]), fmt(a["mac"][k], 4)]
            rows.append(row)
        md += _table(header, rows)
        md += _table(["", "calibrated (before)", "extended (after)"],
                     [[q, fmt(b.get(key), 4), fmt(a.get(key), 4) if a else "-"]
                      for q, key in (("mean abs frequency error (%)", "mean_abs_error_pct"),
                                     ("mean MAC", "mean_mac"), ("mean COMAC", "mean_comac"))
                      if b.get(key) is not None])
        if gain.get("estimate_from_fit_modes"):
            md += [f"Estimate from the fit modes alone: {estimate_text(gain['estimate_from_fit_modes'])}.", ""]
    else:
        md += [gain.get("note", "no modes held out") + ".", ""]

    md += ["## Candidates", "",
           f"{sel['n_candidates']} candidates screened by their first-order chi^2 drop, the {sel['n_fitted']} "
           "most promising fitted (grid over the effect size, then a bounded refinement).", ""]
    if "candidates" in figures:
        md += [f"![candidates]({figures['candidates']})", ""]
    md += _table(["candidate", "screened drop", "fitted drop", "distance to best", "estimate"],
                 [[c["label"], fmt(c["screen_chi2_drop"]), fmt(c.get("chi2_drop")), fmt(c.get("delta_to_best")),
                   estimate_text(c.get("estimate"))] for c in record["candidates"] if c.get("fitted")])
    md += ["### Selection", "", f"{sel['method']}.", ""]
    md += _table(["alpha", "statistic", "p (single)", "p (adjusted)", "dispersion", "ambiguity chi^2"],
                 [[fmt(sel["alpha"], 2), fmt(sel["statistic"]), fmt(sel["p_value"], 3), fmt(sel["p_adjusted"], 3),
                   fmt(sel["dispersion"]), fmt(sel["ambiguity_chi2"], 3)]])
    if record["warnings"]:
        md += ["## Warnings", ""] + [f"- {w}" for w in record["warnings"]] + [""]
    md += ["The full record is in [`diagnosis.json`](diagnosis.json).", ""]
    return "\n".join(md)


def write_report(record: dict, model: FrameModel, extended: FrameModel | None, data: ModalData,
                 out_dir: Path, extended_file: str | None = None) -> Path:
    """Write DIR/report.md and its PNG figures for a diagnosis record; returns the report's path.

    model: the model diagnosed; extended: the diagnosis's extended model (or None); data: the
    measured data (for the measured shapes); extended_file: the extended model's file name in
    DIR, if one was written."""
    out_dir = Path(out_dir)
    figures = {}
    for role, draw in (("shapes", lambda p: plot_shapes(model, extended, data, record, p)),
                       ("frequency_errors", lambda p: plot_frequency_errors(record, p)),
                       ("correlation", lambda p: plot_correlation(record, p)),
                       ("candidates", lambda p: plot_candidates(record, p))):
        if draw(out_dir / f"{role}.png") is not None:
            figures[role] = f"{role}.png"
    path = out_dir / "report.md"
    path.write_text(render_markdown(record, figures, data.source, model.name, extended_file))
    return path


def write_json(record: dict, path: Path) -> Path:
    """The record as strict JSON (no NaN: the record holds None for a missing number)."""
    Path(path).write_text(json.dumps(record, indent=1, allow_nan=False) + "\n")
    return Path(path)
