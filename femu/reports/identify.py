"""The identification report: stabilisation chart with the chosen poles, the FRF sum with the
synthesised fit over it, the identified shapes, and the table of modes with their spread.

Renders an `fe_problem.Identification` (and the summary record of `summary_record`); computes
nothing that is not in them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fe_problem.safe_files import write_text

from .render import figure, markdown_table, save_figure


def summary_record(ident) -> dict:
    """The JSON-ready summary of an identification: modes with frequency, damping, MPC and spread."""
    d, meta = ident.data, ident.data.meta
    modes = [{"mode": k + 1, "frequency_hz": float(d.frequencies_hz[k]), "damping_ratio": meta["damping_ratio"][k],
              "mpc": meta["mpc"][k], **meta["uncertainty"][k]} for k in range(d.n_modes)]
    return {"model": d.model, "frf_files": meta["frf_files"], "reference": meta["reference"],
            "band_hz": meta["band_hz"], "n_lines": meta["n_lines"], "resolution_hz": meta["resolution_hz"],
            "form": meta["form"], "units": meta["units"], "scaling": meta["scaling"], "modes": modes,
            "coordinates": [list(c) for c in d.dofs], "warnings": meta["warnings"]}


def plot_stabilisation(ident, path: Path) -> Path:
    """Pole frequency against model order (unstable, stable, chosen) over the FRF sum."""
    ch = ident.chart
    fig, ax = figure(8.0, 4.8)
    ax = ax[0, 0]
    twin = ax.twinx()
    twin.semilogy(ident.frequency_hz, ident.frf_sum, color="0.75", lw=0.8, zorder=0)
    twin.set_ylabel(f"FRF sum |H| ({ident.data.meta['units']})")
    ax.set_zorder(twin.get_zorder() + 1)
    ax.patch.set_visible(False)
    chosen = np.isin(ch.cluster, ch.chosen) & (ch.cluster >= 0)
    ax.plot(ch.frequency_hz[~ch.stable], ch.order[~ch.stable], "o", ms=2.5, mfc="none", mec="0.55", label="unstable")
    other = ch.stable & ~chosen
    ax.plot(ch.frequency_hz[other], ch.order[other], "+", ms=5, color="tab:orange", label="stable, not a mode")
    ax.plot(ch.frequency_hz[chosen], ch.order[chosen], "x", ms=5, color="tab:blue", label="stable, chosen")
    for f in ident.data.frequencies_hz:
        ax.axvline(f, color="tab:blue", lw=0.6, alpha=0.5)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel("model order (pole pairs)")
    ax.set_xlim(ident.frequency_hz[0], ident.frequency_hz[-1])
    ax.legend(loc="upper left", fontsize=8, framealpha=0.9)
    ax.set_title("Stabilisation chart (LSCF): frequency, damping and shape stable against the order below")
    return save_figure(fig, path)


def plot_fit(ident, path: Path) -> Path:
    """The measured FRF sum and the synthesised one (global LSFD of the chosen poles)."""
    fig, ax = figure(8.0, 4.0)
    ax = ax[0, 0]
    ax.semilogy(ident.frequency_hz, ident.frf_sum, color="0.3", lw=0.9, label="measured")
    ax.semilogy(ident.frequency_hz, np.abs(ident.fit).sum(0), color="tab:red", lw=0.9, ls="--",
                label="synthesised from the identified modes")
    for f in ident.data.frequencies_hz:
        ax.axvline(f, color="tab:blue", lw=0.5, alpha=0.4)
    ax.set_xlabel("frequency (Hz)")
    ax.set_ylabel(f"sum over channels of |H| ({ident.data.meta['units']})")
    ax.legend(fontsize=8)
    return save_figure(fig, path)


def plot_shapes(ident, path: Path) -> Path:
    """One bar chart per identified mode over the measured coordinates."""
    d = ident.data
    n = d.n_modes
    cols = min(4, n)
    rows = -(-n // cols)
    fig, axes = figure(2.4 * cols + 0.5, 2.0 * rows + 0.4, rows, cols, sharex=True)
    labels = [f"{node}{dr}" for node, dr in d.dofs]
    for k, ax in enumerate(axes.flat):
        if k >= n:
            ax.set_visible(False)
            continue
        ax.bar(np.arange(len(labels)), d.shapes[:, k], color="tab:blue")
        ax.axhline(0, color="0.4", lw=0.5)
        ax.set_title(f"mode {k + 1}: {d.frequencies_hz[k]:.2f} Hz", fontsize=9)
        ax.set_xticks(np.arange(len(labels)))
        ax.set_xticklabels(labels, rotation=90, fontsize=7)
    return save_figure(fig, path)


def render_markdown(record: dict, figures: dict) -> str:
    """The report's Markdown text from the summary record and figure file names."""
    lines = [f"# Identification of {', '.join(record['frf_files'])}", "",
             f"Model {record['model']}; reference {record['reference'][0]} {record['reference'][1]}; "
             f"{len(record['coordinates'])} measured coordinates; band {record['band_hz'][0]:g}-{record['band_hz'][1]:g} Hz "
             f"({record['n_lines']} lines, {record['resolution_hz']:g} Hz); {record['form']} in {record['units']}; "
             f"shapes {record['scaling']}.", ""]
    rows = [[m["mode"], f"{m['frequency_hz']:.3f}", f"{m['frequency_std_hz']:.3g}", f"{100 * m['damping_ratio']:.3f}",
             f"{100 * m['damping_std']:.3g}", f"{m['mpc']:.4f}", f"{m['mac_min']:.4f}",
             f"{m['n_orders']} ({m['orders'][0]}-{m['orders'][1]})"] for m in record["modes"]]
    lines += markdown_table(["mode", "frequency Hz", "std Hz", "damping %", "std %", "MPC", "min MAC over orders",
                             "stable orders"], rows)
    lines += ["", "Spread (std, min MAC) is over the orders where the mode is stable.", ""]
    for title, key in (("Stabilisation chart", "stabilisation"), ("FRF sum and the synthesised fit", "fit"),
                       ("Identified shapes", "shapes")):
        lines += [f"## {title}", "", f"![{title}]({figures[key]})", ""]
    if record["warnings"]:
        lines += ["## Warnings", ""] + [f"- {w}" for w in record["warnings"]] + [""]
    return "\n".join(lines)


def write_report(ident, out: Path) -> Path:
    """Write report.md and its three figures into `out`; returns the report's path."""
    out = Path(out)
    figures = {"stabilisation": plot_stabilisation(ident, out / "stabilisation.png").name,
               "fit": plot_fit(ident, out / "fit.png").name, "shapes": plot_shapes(ident, out / "shapes.png").name}
    path = out / "report.md"
    write_text(path, render_markdown(summary_record(ident), figures))
    return path
