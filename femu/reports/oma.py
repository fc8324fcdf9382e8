"""The report of an ambient identification (`femu identify --oma`): the stabilisation diagram with
the chosen clusters marked, the singular values of the spectral density matrix, the identified
shapes drawn on the model, and the table of modes with their spreads.

Renders an `fe_problem.identification.ambient.AmbientIdentification` through its summary record
(`summary_record`, which is identification.json); computes nothing that is not in them.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from fe_problem.safe_files import write_text

from .render import figure, markdown_table, save_figure


def _label(c) -> str:
    return str(c) if isinstance(c, int) else f"{c[0]}:{c[1]}"


def summary_record(ident) -> dict:
    """The JSON-ready record of an ambient identification: everything report.md shows."""
    d, meta = ident.data, ident.data.meta
    modes = [{"mode": k + 1, "frequency_hz": m["frequency_hz"], "frequency_std_hz": m["frequency_std_hz"],
              "damping_ratio": m["damping_ratio"], "damping_std": m["damping_std"], "mpc": m["mpc"],
              "mpd_deg": m["mpd_deg"], "n_poles": m["n_poles"], "shape": list(map(float, m["shape"])),
              "shape_std": None if m["shape_std"] is None else list(map(float, m["shape_std"]))}
             for k, m in enumerate(ident.modes)]
    charts = [{"order": c.order, "frequency_hz": c.frequency_hz, "damping": c.damping, "stable": c.stable,
               "cluster": c.cluster, "chosen": list(c.chosen)} for c in ident.charts]
    return {"format": "femu.oma-identification/2", "model": d.model, "files": meta["files"],
            "method": ident.method, "fs_hz": meta["fs_hz"], "band_hz": meta["band_hz"], "order": meta["order"],
            "uncertainty": ident.uncertainty, "references": meta["references"],
            "dropped_channels": meta["dropped_channels"], "coordinates": [_label(c) for c in d.dofs],
            "modes": modes, "stabilisation": charts,
            "spectral_density": [{"frequency_hz": f, "singular_values": sv} for f, sv in ident.psd],
            "warnings": list(ident.warnings)}


def summary_text(record: dict) -> str:
    """The terminal summary: one line per mode with its standard deviations."""
    lines = [f"Identified {len(record['modes'])} modes from {', '.join(record['files'])} by {record['method']} "
             f"({_model_text(record)}, {len(record['coordinates'])} channels, band "
             f"{record['band_hz'][0]:g}-{record['band_hz'][1]:g} Hz) in {record['wall_s']:.2f} s",
             "  mode  frequency Hz   std Hz  damping %   std %    MPC  MPD deg  poles"]
    for m in record["modes"]:
        lines.append(f"  {m['mode']:4d}  {m['frequency_hz']:12.4f}  {_fmt(m['frequency_std_hz'], 7)}  "
                     f"{100 * m['damping_ratio']:9.3f}  {_fmt(m['damping_std'], 6, 100)}  {m['mpc']:.3f}  "
                     f"{m['mpd_deg']:7.2f}  {m['n_poles']:5d}")
    lines.append(f"  standard deviations: {record['uncertainty']}")
    lines += [f"  warning: {w}" for w in record["warnings"]]
    return "\n".join(lines)


def _model_text(record: dict) -> str:
    return "no model: channels by label" if record["model"] is None else f"model {record['model']}"


def _fmt(v, width: int, scale: float = 1.0) -> str:
    return f"{'-':>{width}}" if v is None else f"{scale * v:{width}.3g}"


def plot_stabilisation(record: dict, path: Path) -> Path:
    """Pole frequency against model order per setup: every pole, the stable ones, the chosen
    clusters (one colour each), over the first singular value of the spectral density."""
    charts = record["stabilisation"]
    fig, axes = figure(8.0, 3.6 * len(charts) + 0.6, len(charts), 1)
    for i, (ax, ch, sd) in enumerate(zip(axes[:, 0], charts, record["spectral_density"])):
        twin = ax.twinx()
        twin.semilogy(sd["frequency_hz"], np.asarray(sd["singular_values"])[0], color="0.75", lw=0.8, zorder=0)
        twin.set_ylabel("1st singular value")
        ax.set_zorder(twin.get_zorder() + 1)
        ax.patch.set_visible(False)
        f, o = np.asarray(ch["frequency_hz"]), np.asarray(ch["order"])
        st, cl = np.asarray(ch["stable"], bool), np.asarray(ch["cluster"])
        ax.plot(f[~st], o[~st], "o", ms=2, mfc="none", mec="0.6", label="pole")
        ax.plot(f[st], o[st], "+", ms=4, color="tab:orange", label="stable (soft criteria)")
        for k, lab in enumerate(ch["chosen"]):
            m = cl == lab
            ax.plot(f[m], o[m], "x", ms=5, color="tab:blue", label="chosen cluster" if k == 0 else None)
        for m in record["modes"]:
            ax.axvline(m["frequency_hz"], color="tab:blue", lw=0.6, alpha=0.5)
        ax.set_xlim(*record["band_hz"])
        ax.set_ylabel("model order")
        ax.set_title(f"{record['files'][i]}: stabilisation ({record['method']})", fontsize=9)
        ax.legend(loc="upper left", fontsize=7, framealpha=0.9)
    axes[-1, 0].set_xlabel("frequency (Hz)")
    return save_figure(fig, path)


def plot_singular_values(record: dict, path: Path) -> Path:
    """The singular values of the spectral density matrix, one panel per setup, identified modes marked."""
    sds = record["spectral_density"]
    fig, axes = figure(8.0, 3.4 * len(sds) + 0.4, len(sds), 1)
    for ax, sd, name in zip(axes[:, 0], sds, record["files"]):
        for k, s in enumerate(np.asarray(sd["singular_values"])):
            ax.semilogy(sd["frequency_hz"], s, lw=0.9, label=f"singular value {k + 1}")
        for m in record["modes"]:
            ax.axvline(m["frequency_hz"], color="tab:blue", lw=0.5, alpha=0.5)
        ax.set_ylabel("(m/s^2)^2/Hz")
        ax.set_title(f"{name}: singular values of the spectral density", fontsize=9)
        ax.legend(fontsize=8)
    axes[-1, 0].set_xlabel("frequency (Hz)")
    return save_figure(fig, path)


def plot_shapes(record: dict, model, path: Path) -> Path:
    """Each identified mode as arrows at the measured translations on the drawn model (a band of
    one standard deviation as a thin bar), or as bars over the channels without a model (none
    named, or a matrix model)."""
    import math

    from .diagnosis import draw_numbered_frame, projected

    modes = record["modes"]
    n = len(modes)
    cols = min(4, n)
    rows = math.ceil(n / cols)
    fig, axes = figure(3.0 * cols + 0.4, 3.4 * rows + 0.4, rows, cols)
    for ax in axes.ravel()[n:]:
        ax.set_visible(False)
    coords = record["coordinates"]
    if model is None:  # no frame to draw on (no model, or a matrix model): bars over the channels
        for ax, m in zip(axes.ravel(), modes):
            shape = np.asarray(m["shape"])
            err = None if m["shape_std"] is None else np.asarray(m["shape_std"])
            ax.bar(np.arange(shape.size), shape, yerr=err, color="#c0142b", ecolor="0.2", capsize=2)
            ax.set_xticks(np.arange(shape.size), coords, rotation=90, fontsize=6)
            ax.axhline(0.0, color="0.5", lw=0.6)
            std = "" if m["frequency_std_hz"] is None else f" ± {m['frequency_std_hz']:.3g}"
            ax.set_title(f"mode {m['mode']}: {m['frequency_hz']:.3f}{std} Hz\nMPC {m['mpc']:.3f}", fontsize=8)
        return save_figure(fig, path)
    labels = [tuple(c.split(":")) for c in coords]
    at = projected(model, model.coordinates)
    pos = {nd.id: at[k] for k, nd in enumerate(model.nodes)}
    size = float(np.ptp(at, axis=0).max()) or 1.0
    axis = projected(model, np.eye(model.layout.dimension))
    trans = model.layout.translations
    drawn = [j for j, (_, d) in enumerate(labels) if d in trans]
    for ax, m in zip(axes.ravel(), modes):
        draw_numbered_frame(ax, model)
        shape = np.asarray(m["shape"])
        a = 0.15 * size / max(np.abs(shape[drawn]).max(), 1e-300) if drawn else 0.0
        for j in drawn:
            node, d = int(labels[j][0]), labels[j][1]
            v = a * shape[j] * axis[("x", "y", "z").index(d)]
            ax.annotate("", xy=tuple(pos[node] + v), xytext=tuple(pos[node]),
                        arrowprops={"arrowstyle": "->", "color": "#c0142b", "lw": 1.4}, zorder=4)
            if m["shape_std"] is not None:
                e = a * m["shape_std"][j] * axis[("x", "y", "z").index(d)]
                tip = pos[node] + v
                ax.plot([tip[0] - e[0], tip[0] + e[0]], [tip[1] - e[1], tip[1] + e[1]], color="0.2", lw=2.5,
                        alpha=0.5, zorder=5)
        ax.set_aspect("equal")
        ax.axis("off")
        std = "" if m["frequency_std_hz"] is None else f" ± {m['frequency_std_hz']:.3g}"
        ax.set_title(f"mode {m['mode']}: {m['frequency_hz']:.3f}{std} Hz\nMPC {m['mpc']:.3f}", fontsize=8)
    return save_figure(fig, path)


def render_markdown(record: dict, figures: dict) -> str:
    """report.md from the record and the figure file names."""
    lines = [f"# Ambient identification of {', '.join(record['files'])}", "",
             f"Method {record['method']} (pyOMA2); {_model_text(record)}; {len(record['coordinates'])} channels at "
             f"{record['fs_hz']:g} Hz; band {record['band_hz'][0]:g}-{record['band_hz'][1]:g} Hz"
             + (f"; model orders up to {record['order']}" if record["order"] else "")
             + (f"; setups merged through the reference channels {', '.join(record['references'])}"
                if record["references"] else "") + ".", "",
             f"Standard deviations: {record['uncertainty']}.", ""]
    rows = [[m["mode"], f"{m['frequency_hz']:.4f}", _fmt(m["frequency_std_hz"], 0).strip(),
             f"{100 * m['damping_ratio']:.3f}", _fmt(m["damping_std"], 0, 100).strip(),
             "-" if m["shape_std"] is None else f"{max(m['shape_std']):.3g}",
             f"{m['mpc']:.4f}", f"{m['mpd_deg']:.2f}", m["n_poles"]] for m in record["modes"]]
    lines += markdown_table(["mode", "frequency Hz", "std Hz", "damping %", "std %", "largest shape std", "MPC",
                             "MPD deg", "poles"], rows)
    lines += ["", "Shapes are real (rotated onto the real axis), scaled to a largest entry of 1; MPC 1 and "
              "MPD 0 deg are a real mode.", ""]
    if record["dropped_channels"]:
        lines += ["Dropped channels: " + ", ".join(f"{d['channel']} of {d['file']} ({d['kind']})"
                                                   for d in record["dropped_channels"]), ""]
    for title, key in (("Stabilisation diagram", "stabilisation"),
                       ("Singular values of the spectral density matrix", "singular_values"),
                       ("Identified shapes " + ("per channel" if record["model"] is None else "on the model"),
                        "shapes")):
        lines += [f"## {title}", "", f"![{title}]({figures[key]})", ""]
    if record["warnings"]:
        lines += ["## Warnings", ""] + [f"- {w}" for w in record["warnings"]] + [""]
    return "\n".join(lines)


def write_report(ident, record: dict, out: Path) -> Path:
    """Write report.md and its three figures into `out`; returns the report's path."""
    from fe_problem.any_model import load_any_model
    from fe_problem.model import FrameModel

    out = Path(out)
    model = load_any_model(ident.data.model) if ident.data.model else None
    model = model if isinstance(model, FrameModel) else None  # a matrix model has no frame to draw
    figures = {"stabilisation": plot_stabilisation(record, out / "stabilisation.png").name,
               "singular_values": plot_singular_values(record, out / "singular-values.png").name,
               "shapes": plot_shapes(record, model, out / "shapes.png").name}
    path = out / "report.md"
    write_text(path, render_markdown(record, figures))
    return path
