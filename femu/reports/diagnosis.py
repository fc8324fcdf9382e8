"""Figures of a diagnosis and the files `femu diagnose --out DIR` writes: report.md with its
PNG figures, and diagnosis.json.

A report renders the record (a `fe_problem.Diagnosis`, read by its attributes; the words are
in diagnosis_text.py) and computes nothing new, except what it draws: the mode shapes of the
calibrated and extended models over the whole frame (one modal analysis each) and the measured
shapes scaled onto them by least squares. Every frame drawn carries its node and element
numbers, so that a place the cause names can be found on it. The significance threshold on the
candidate chart is the record's own test turned around (`Selection.threshold_chi2_drop`).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from fe_problem import AffineModel, FrameModel, ModalData, elements, mac, modal_analysis
from fe_problem.diagnosis import Diagnosis
from fe_problem.jsonutil import dumps
from fe_problem.safe_files import write_text

from .diagnosis_text import (best_label, coordinate_labels, fmt, location_text, mode_ranges, render_markdown,
                             threshold_chi2_drop)
from .render import figure, save_figure

#: How many candidates the candidate chart shows (the rest screened lower and were not fitted).
MAX_CANDIDATE_ROWS = 40
#: The drawn mode shapes' largest nodal translation, as a fraction of the frame's size.
SHAPE_AMPLITUDE = 0.12
#: At most this many mode panels side by side in the shape figure.
MAX_SHAPE_COLUMNS = 4

CALIBRATED_COLOR = "#1f5fa8"
EXTENDED_COLOR = "#e07b00"
MEASURED_COLOR = "#c0142b"
CAUSE_COLOR = "#ffd21f"


# == figures ===================================================================================
#: The drawing of a space model: an isometric view with z up, u = (x - y) cos 30 deg,
#: v = z + (x + y) sin 30 deg (rows: the screen u and v of a unit step along x, y, z).
ISOMETRIC = np.array([[math.cos(math.pi / 6), -math.cos(math.pi / 6), 0.0], [0.5, 0.5, 1.0]])


def projected(model: FrameModel, points: np.ndarray) -> np.ndarray:
    """Points (..., layout.dimension) in metres on the drawing plane (..., 2): a planar model's
    (x, y) as they are, a space model's in the `ISOMETRIC` view."""
    points = np.asarray(points, dtype=float)
    return points if model.layout.dimension == 2 else points @ ISOMETRIC.T


def deformed_frame(model: FrameModel, u: np.ndarray, scale: float, n_points: int = 25) -> np.ndarray:
    """Element curves (n_elements, n_points, 2) on the drawing plane (`projected`), metres, of
    the frame displaced by scale * u (u: one value per nodal DOF in `model.dofs` order); see
    `fe_problem.elements.deformed_frame`."""
    return projected(model, elements.deformed_frame(model, u, scale, n_points))


def _translation_dofs(model: FrameModel) -> list[tuple[int, str]]:
    return [(n.id, d) for n in model.nodes for d in model.layout.translations]


#: Above this many measured coordinates the COMAC bars name only the three lowest.
MAX_NAMED_COORDINATES = 40

#: Above this many elements a frame's numbers would cover it: only the cause's place is numbered.
MAX_NUMBERED_ELEMENTS = 60


def _joined(curves: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Curves (n, k, 2) as one polyline (x, y) broken by NaN: one line to draw, not n (a frame
    of hundreds of elements in eight panels would otherwise be thousands of lines)."""
    gap = np.full((curves.shape[0], 1, 2), np.nan)
    xy = np.concatenate([curves, gap], axis=1).reshape(-1, 2)
    return xy[:, 0], xy[:, 1]


def draw_numbered_frame(ax, model: FrameModel, cause_location: dict | None = None) -> None:
    """The undeformed frame in grey with its node numbers (plain) and element numbers (boxed);
    the place a cause names (an element or a node) is marked in yellow. A frame of more than
    `MAX_NUMBERED_ELEMENTS` elements has only the cause's element and node numbered."""
    where = cause_location or {}
    every = len(model.elements) <= MAX_NUMBERED_ELEMENTS
    at = projected(model, model.coordinates)
    xy = {n.id: at[k] for k, n in enumerate(model.nodes)}
    segs = np.array([[xy[e.node_i], xy[e.node_j]] for e in model.elements])
    ax.plot(*_joined(segs), color="0.75", lw=1.0, zorder=1)
    for e, seg in zip(model.elements, segs):
        if where.get("element") == e.id:
            ax.plot(seg[:, 0], seg[:, 1], color=CAUSE_COLOR, lw=7.0, alpha=0.8, zorder=0, solid_capstyle="butt")
        if every or where.get("element") == e.id:
            ax.text(*seg.mean(axis=0), str(e.id), fontsize=6.5, color="0.3", ha="center", va="center", zorder=6,
                    bbox={"boxstyle": "square,pad=0.15", "fc": "white", "ec": "0.6", "lw": 0.5, "alpha": 0.85})
    ax.plot(at[:, 0], at[:, 1], "o", ms=2.5, color="0.55", zorder=1.5, ls="none")
    for node in model.nodes:
        marked = where.get("node") == node.id
        if marked:
            ax.plot(*xy[node.id], "o", ms=9, color=CAUSE_COLOR, zorder=1.5)
        if every or marked:
            ax.annotate(str(node.id), tuple(xy[node.id]), xytext=(3, 3), textcoords="offset points", fontsize=6.5,
                        color="0.15", zorder=6)


def _shape_layout(model: FrameModel, n_panels: int):
    """A figure with one panel per mode (a tall frame in up to MAX_SHAPE_COLUMNS columns, a
    wide one in two) and the frame's size in metres."""
    extent = np.ptp(projected(model, model.coordinates), axis=0)
    size = float(np.max(extent))
    aspect = float((extent[0] + 0.3 * size) / (extent[1] + 0.3 * size))
    most = MAX_SHAPE_COLUMNS if aspect < 0.8 else 2
    ncols = math.ceil(n_panels / math.ceil(n_panels / most))  # rows as full as they can be: 5 -> 3 + 2
    nrows = math.ceil(n_panels / ncols)
    panel_h = 4.6
    fig, axes = figure(ncols * max(2.6, panel_h * aspect + 0.3), nrows * panel_h + 0.7, nrows, ncols, sharey=True)
    for ax in axes.ravel()[n_panels:]:
        ax.set_visible(False)
    return fig, axes, size


def _draw_measured(ax, model: FrameModel, data: ModalData, i: int, at_dofs: np.ndarray | None,
                   scale: float) -> None:
    """Measured mode i as arrows from rest, scaled onto the model's shape at the measured
    coordinates by least squares (`at_dofs`), or, for a mode that pairs with no model mode, so
    that its largest entry is drawn at the figure's amplitude."""
    at = projected(model, model.coordinates)
    pos = {nd.id: at[k] for k, nd in enumerate(model.nodes)}
    trans = model.layout.translations
    # each measured translation is an arrow along its axis, as drawn (`projected`)
    axis = projected(model, np.eye(model.layout.dimension))
    drawn = [c for c, (_, d) in enumerate(data.dofs) if d in trans]
    m = data.shapes[:, i]
    a = 1.0 / np.max(np.abs(m[drawn])) if at_dofs is None else float(m @ at_dofs / (m @ m))
    base = np.array([pos[data.dofs[c][0]] for c in drawn])
    v = scale * a * m[drawn]
    dxy = v[:, None] * axis[[("x", "y", "z").index(data.dofs[c][1]) for c in drawn]]
    ax.quiver(base[:, 0], base[:, 1], dxy[:, 0], dxy[:, 1], angles="xy", scale_units="xy", scale=1,
              color=MEASURED_COLOR, width=0.007, headwidth=4.5, headlength=5, headaxislength=4.5,
              minlength=0, zorder=4)
    ax.plot(*(base + dxy).T, "o", ms=4, color=MEASURED_COLOR, zorder=5, ls="none",
            label="measured (arrow from rest)")


def _draw_mode(ax, diag: Diagnosis, model: FrameModel, extended: FrameModel | None, data: ModalData, i: int,
               calibrated, ext, size: float) -> None:
    """One panel: measured mode i, the calibrated model's paired mode, the extended model's
    mode that tracks it, the measured shape; titled with frequencies and MAC."""
    c = diag.residuals.correlation
    p = int(c.model_index[i])
    draw_numbered_frame(ax, model, diag.cause.location)
    title = [f"mode {i + 1}: measured {c.measured_hz[i]:.2f} Hz"]
    if p < 0:  # pairs with no model mode: the measured shape alone, on the numbered frame
        title.append("pairs with no model mode")
        if data.has_shape[i]:
            _draw_measured(ax, model, data, i, None, SHAPE_AMPLITUDE * size)
        return _finish_panel(ax, title)
    t = calibrated.at(_translation_dofs(model))[:, p]
    k = len(model.layout.translations)
    scale = SHAPE_AMPLITUDE * size / np.max(np.linalg.norm(t.reshape(-1, k), axis=1))
    ax.plot(*_joined(deformed_frame(model, calibrated.shapes[:, p], scale)), color=CALIBRATED_COLOR, lw=2.0,
            zorder=2, label="calibrated model")
    title.append(f"calibrated{'' if p == i else f' (mode {p + 1})'} {c.model_hz[i]:.2f} Hz"
                 + (f", MAC {c.mac[i]:.4f}" if np.isfinite(c.mac[i]) else ""))
    if ext is not None:
        # the extended model's mode that tracks this one: the largest MAC over the frame
        te = ext.at(_translation_dofs(model))
        q = int(np.argmax(mac(t[:, None], te)[0]))
        a = float(te[:, q] @ t / (te[:, q] @ te[:, q]))
        ax.plot(*_joined(deformed_frame(extended, a * ext.shapes[:, q], scale)), color=EXTENDED_COLOR, lw=1.6,
                ls="--", zorder=3, label=f"extended model ({best_label(diag)})")
        title.append(f"extended {ext.frequencies_hz[q]:.2f} Hz")
    if data.has_shape[i]:
        _draw_measured(ax, model, data, i, calibrated.at(data.dofs)[:, p], scale)
    else:
        title.append("(no measured shape)")
    return _finish_panel(ax, title)


def _finish_panel(ax, title: list[str]) -> None:
    ax.set_title("\n".join(title), fontsize=8.5)
    ax.set_aspect("equal")
    ax.margins(0.08)
    ax.tick_params(labelsize=7)
    ax.set_xlabel("x (m)", fontsize=8)
    ax.grid(True, alpha=0.2)


def plot_shapes(diag: Diagnosis, model: FrameModel, extended: FrameModel | None, data: ModalData,
                path: Path) -> Path | None:
    """The frame deformed in every measured mode: the calibrated model's shape, the extended
    model's, and the measured coordinates as arrows (scaled onto the model by least squares),
    on the undeformed frame with its node and element numbers and the cause's place marked."""
    chosen = list(range(len(diag.residuals.correlation.measured_hz)))
    if not chosen:
        return None
    pairing = diag.residuals.correlation.model_index
    k = min(int(pairing.max()) + 1 + 4, AffineModel(model).n_elastic)
    calibrated = modal_analysis(model, k)
    ext = modal_analysis(extended, min(k + 2, AffineModel(extended).n_elastic)) if extended is not None else None
    fig, axes, size = _shape_layout(model, len(chosen))
    for ax, i in zip(axes.ravel(), chosen):
        _draw_mode(ax, diag, model, extended, data, i, calibrated, ext, size)
    for ax in axes[:, 0]:
        ax.set_ylabel("y (m)" if model.layout.dimension == 2 else "isometric view, z up (m)", fontsize=8)
    handles = {}
    for ax in axes.ravel():  # every kind of line once, whichever panel drew it first
        for h, label in zip(*ax.get_legend_handles_labels()):
            handles.setdefault(label, h)
    where = diag.cause.location
    fig.legend(list(handles.values()), list(handles), loc="outside lower center", ncols=len(handles),
               fontsize=8.5, frameon=False)
    fig.suptitle(f"Mode shapes of {model.name} (amplitude arbitrary; measured shapes scaled onto the calibrated "
                 "model by least squares)\nnumbers: nodes, boxed: elements"
                 + ("" if len(model.elements) <= MAX_NUMBERED_ELEMENTS else " (only the cause's place is numbered)")
                 + (f"; yellow: the cause's place ({location_text(where)})" if where else ""), fontsize=9)
    save_figure(fig, path)
    return path


def plot_frequency_errors(diag: Diagnosis, path: Path) -> Path:
    """Left: the calibrated model's frequency error per measured mode. Right: the held-out
    modes' error when predicted by the calibrated and the extended model (the gain)."""
    res, gain = diag.residuals, diag.gain
    err = np.asarray(res.correlation.error_pct, dtype=float)
    modes = np.arange(1, len(err) + 1)
    held = set(gain.held_out_modes)
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
    ax.set_title(f"Calibrated model (global stiffness scale {fmt(res.global_scale, 5)}), all modes", fontsize=9)
    ax.grid(True, axis="y", alpha=0.3)
    _plot_gain(axes[0, 1], gain)
    save_figure(fig, path)
    return path


def _plot_gain(ax, gain) -> None:
    if not gain.held_out_modes:
        ax.text(0.5, 0.5, gain.note or "no held-out modes", ha="center", va="center", fontsize=9,
                transform=ax.transAxes, wrap=True)
        ax.set_xticks([])
        ax.grid(True, axis="y", alpha=0.3)
        return
    hm = np.array(gain.held_out_modes)
    x = np.arange(len(hm))
    ax.bar(x - 0.2, np.nan_to_num(gain.before.error_pct), 0.4, color=CALIBRATED_COLOR, label="calibrated (before)")
    if gain.after is not None:
        ax.bar(x + 0.2, np.nan_to_num(gain.after.error_pct), 0.4, color=EXTENDED_COLOR, label="extended (after)")
    ax.set_xticks(x, [str(m) for m in hm])
    ax.set_xlim(-0.9, len(hm) - 0.1)
    ax.axhline(0, color="k", lw=0.8)
    ax.set_ylabel("frequency error (%)")
    ax.legend(fontsize=7.5, loc="best")
    ax.set_title(f"Held-out modes (both models\nrefitted on modes {mode_ranges(gain.fit_modes)})", fontsize=9)
    ax.set_xlabel("held-out mode")
    ax.grid(True, axis="y", alpha=0.3)


def plot_correlation(diag: Diagnosis, path: Path) -> Path | None:
    """COMAC per measured coordinate (calibrated model; node number and direction) and the MAC
    matrix with its pairing; None when no shapes were measured."""
    c = diag.residuals.correlation
    if c.comac is None or c.mac_matrix is None:
        return None
    cm = np.asarray(c.comac, dtype=float)
    mm = np.asarray(c.mac_matrix, dtype=float)
    # many coordinates (a large model): the bars share the width with the MAC matrix as 24
    # would, and only the three lowest are named
    fig, axes = figure(11.0, 4.2, 1, 2, width_ratios=[min(max(len(cm), 4), 24), mm.shape[1] * 0.9])
    ax = axes[0, 0]
    order_low = np.argsort(cm)[:3]
    colors = [MEASURED_COLOR if k in order_low else CALIBRATED_COLOR for k in range(len(cm))]
    ax.bar(np.arange(len(cm)), cm, color=colors, edgecolor="k", lw=0.4)
    named = np.arange(len(cm)) if len(cm) <= MAX_NAMED_COORDINATES else np.sort(order_low)
    ax.set_xticks(named, [coordinate_labels(diag)[k] for k in named], rotation=60, fontsize=8)
    lo = min(float(cm.min()), 0.98)
    ax.set_ylim(max(0.0, lo - 0.2 * (1 - lo)), 1.0005)
    ax.set_xlabel("measured coordinate (node number, direction); red: the three lowest")
    ax.set_ylabel("COMAC")
    ax.set_title(f"COMAC of the calibrated model over the paired modes (mean {fmt(c.mean_comac, 4)})", fontsize=9)
    ax.grid(True, axis="y", alpha=0.3)

    ax = axes[0, 1]
    im = ax.imshow(mm, vmin=0, vmax=1, cmap="Blues", aspect="auto")
    for r, p in enumerate(c.model_index):
        if p >= 0:
            ax.add_patch(_rect(p, r))
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


def plot_candidates(diag: Diagnosis, path: Path) -> Path:
    """chi^2 drop per candidate: first-order screening for all, the proper fit for those
    fitted; the cause (or the candidates it cannot tell apart) highlighted; the drop the best
    needed to be significant marked."""
    from matplotlib.patches import Patch

    rows = diag.candidates[:MAX_CANDIDATE_ROWS]  # in screening order: every fitted one comes first
    hidden = len(diag.candidates) - len(rows)
    cause, selection = diag.cause, diag.selection
    chosen = set(cause.indistinguishable or ([cause.label] if cause.label else []))
    threshold = threshold_chi2_drop(selection)
    floor = 0.1  # log axis: a drop below this (0 when the effect can only worsen the fit) gets no bar
    y = np.arange(len(rows))[::-1]
    fig, axes = figure(8.4, 1.4 + 0.2 * len(rows))
    ax = axes[0, 0]
    for yy, r in zip(y, rows):
        drop = r.screen_chi2_drop or 0.0
        if drop >= floor:
            ax.barh(yy, drop, 0.8, color="0.84", edgecolor="0.6", lw=0.4)
        else:
            ax.text(floor * 1.1, yy, "0", va="center", fontsize=6.5, color="0.45")
        if r.fitted and r.chi2_drop is not None and r.chi2_drop >= floor:
            ax.barh(yy, r.chi2_drop, 0.45, edgecolor="k", lw=0.4,
                    color=EXTENDED_COLOR if r.label in chosen else CALIBRATED_COLOR)
    handles = [Patch(color="0.84", ec="0.6", label="screened (first order)"),
               Patch(color=CALIBRATED_COLOR, label="fitted")]
    if chosen:
        handles.append(Patch(color=EXTENDED_COLOR, label="the cause" if len(chosen) == 1
                             else "fitted, cannot tell apart"))
    if threshold is not None:
        ax.axvline(threshold, color=MEASURED_COLOR, ls="--", lw=1.3)
        handles.append(ax.plot([], [], color=MEASURED_COLOR, ls="--", lw=1.3,
                               label=f"drop needed for significance at alpha {fmt(selection.alpha, 2)}: "
                                     f"{fmt(threshold, 3)}")[0])
    ax.set_yticks(y, [r.label for r in rows], fontsize=7)
    for tick, r in zip(ax.get_yticklabels(), rows):
        if r.label in chosen:
            tick.set_fontweight("bold")
    ax.set_xscale("log")
    ax.set_xlim(left=floor)
    ax.set_xlabel("chi^2 drop against the calibrated model (log scale)"
                  + (f"\n({hidden} candidates with smaller screened drops not shown)" if hidden else ""))
    ax.set_ylim(-0.7, len(rows) - 0.3)
    verdict = ("none" if cause.is_none else cause.label if cause.identifiable
               else f"cannot tell {len(chosen)} apart")
    ax.set_title(f"Candidates: {selection.n_candidates} screened, {selection.n_fitted} fitted; cause: {verdict}",
                 fontsize=9)
    ax.grid(True, axis="x", which="both", alpha=0.25)
    ax.legend(handles=handles, fontsize=7.5, loc="lower right")
    save_figure(fig, path)
    return path


# == the files ==================================================================================
def write_report(diag: Diagnosis, model: FrameModel, data: ModalData, out_dir: Path,
                 extended_file: str | None = None) -> list[Path]:
    """Write DIR/report.md and its PNG figures for a diagnosis; returns every path written (the
    figures, then the report).

    model: the model diagnosed; data: the measured data (for the measured shapes);
    extended_file: the extended model's file name in DIR, if one was written."""
    out_dir = Path(out_dir)
    figures, written = {}, []
    # a model given as matrices has no geometry to draw its shapes on
    shapes = (lambda p: plot_shapes(diag, model, diag.extended_model, data, p)) if isinstance(model, FrameModel) \
        else (lambda p: None)
    for role, draw in (("shapes", shapes),
                       ("frequency_errors", lambda p: plot_frequency_errors(diag, p)),
                       ("correlation", lambda p: plot_correlation(diag, p)),
                       ("candidates", lambda p: plot_candidates(diag, p))):
        path = draw(out_dir / f"{role}.png")
        if path is not None:
            figures[role] = path.name
            written.append(path)
    report = out_dir / "report.md"
    write_text(report, render_markdown(diag, figures, data.source, model.name, extended_file))
    return written + [report]


def write_json(diag: Diagnosis, path: Path) -> Path:
    """The record (`Diagnosis.to_dict()`) as strict JSON, as `femu diagnose --json` prints it."""
    write_text(path, dumps(diag) + "\n")
    return Path(path)
