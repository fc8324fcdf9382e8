"""The report of `femu update`: report.md and its MAC figure, rendered from the update record
(femu/update.py) through render.py; it computes nothing the record does not hold."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from .render import figure, markdown_table, save_figure


def _num(v, fmt: str = ".4g") -> str:
    return "-" if v is None else format(v, fmt)


def _err(model_hz, measured_hz) -> str:
    return "-" if model_hz is None else f"{(model_hz - measured_hz) / measured_hz * 100:+.2f}"


def mac_figure(mac_initial, mac_updated, path: Path) -> Path:
    """The MAC matrices (measured x model modes) of the initial and the updated model side by side."""
    fig, axes = figure(9.0, 4.2, 1, 2)
    for ax, m, title in zip(axes[0], (mac_initial, mac_updated), ("initial model", "updated model")):
        im = ax.imshow(m, vmin=0.0, vmax=1.0, cmap="viridis", aspect="auto")
        ax.set_title(f"MAC, {title}")
        ax.set_xlabel("model mode")
        ax.set_ylabel("measured mode")
        ax.set_xticks(range(m.shape[1]), [str(k + 1) for k in range(m.shape[1])])
        ax.set_yticks(range(m.shape[0]), [str(k + 1) for k in range(m.shape[0])])
    fig.colorbar(im, ax=axes[0].tolist(), shrink=0.8)
    return save_figure(fig, path)


def report_lines(record: dict, figure_name: str | None) -> list[str]:
    """report.md as lines."""
    r = record
    lines = [f"# Model update: {Path(r['model']).name} to {Path(r['data']).name}", "",
             f"Model `{r['model']}`, data `{r['data']}`; {r['parameters_note']}. Optimizer `{r['optimizer']}`, "
             f"budget {r['budget']} evaluations ({r['n_evals']} spent, status {r['status']}), seed {r['seed']}.", "",
             "## Verdict", "", r["verdict"], "",
             f"Objective (balanced, docs/update.md): {r['objective']['initial']:.6g} initial, "
             f"{r['objective']['updated']:.6g} updated. Mean |frequency error| of the fitted modes: "
             f"{_num(r['mean_abs_frequency_error_pct']['initial'], '.2f')} % initial, "
             f"{_num(r['mean_abs_frequency_error_pct']['updated'], '.2f')} % updated.", "",
             "## Frequencies before and after", "",
             "Each measured mode paired with a model mode by MAC where its shape was measured, by frequency "
             "otherwise (the pairing shown per model).", ""]
    rows = []
    for i, m in enumerate(r["modes"]):
        rows.append([i + 1 if not m["held_out"] else f"{i + 1} (held out)", f"{m['measured_hz']:.4g}",
                     f"{m['frequency_std_hz']:.3g}" + ("" if m["stated_std"] else " (default)"),
                     _num(m["initial_hz"]), _num(m["model_mode_initial"], "d"), _err(m["initial_hz"], m["measured_hz"]),
                     _num(m["mac_initial"], ".3f"), _num(m["updated_hz"]), _num(m["model_mode_updated"], "d"),
                     _err(m["updated_hz"], m["measured_hz"]), _num(m["mac_updated"], ".3f")])
    lines += markdown_table(["mode", "measured Hz", "std Hz", "initial Hz", "model mode", "error %", "MAC",
                             "updated Hz", "model mode", "error %", "MAC"], rows) + [""]
    if figure_name:
        lines += [f"![MAC matrices]({figure_name})", ""]
    held = [(i, m) for i, m in enumerate(r["modes"]) if m["held_out"]]
    if held:
        h = r["held_out_mean_abs_frequency_error_pct"]
        lines += ["## Held-out modes", "",
                  f"{len(held)} measured mode(s) kept out of the fit and predicted by the updated model: mean "
                  f"|frequency error| {_num(h['initial'], '.2f')} % initial, {_num(h['updated'], '.2f')} % updated. "
                  "The 95 % range of a prediction carries the parameters' covariance through the frequency's "
                  "sensitivities (linearised; none where a parameter is not identifiable).", ""]
        rows = []
        for i, m in held:
            rng = m["updated_hz_range_95"]
            inside = "-" if rng is None else ("yes" if rng[0] <= m["measured_hz"] <= rng[1] else "no")
            rows.append([i + 1, f"{m['measured_hz']:.4g}", _num(m["initial_hz"]), _num(m["updated_hz"]),
                         "-" if rng is None else f"[{rng[0]:.4g}, {rng[1]:.4g}]", inside])
        lines += markdown_table(["mode", "measured Hz", "initial Hz", "predicted Hz", "95 % range Hz",
                                 "measured inside"], rows) + [""]
    lines += ["## Parameters", "",
              "95 % intervals from the Jacobian at the estimate, each kind of data weighed by its error scale "
              "(below); `not identifiable` where the data do not pin the parameter down within its bounds.", ""]
    rows = []
    for p in r["parameters"]:
        change = (p["estimate"] - p["initial"]) / p["initial"] * 100 if p["initial"] else None
        iv = p["interval_95"]
        flags = [f for f, on in (("at bound", p["at_bound"]), ("not identifiable", not p["identifiable"])) if on]
        rows.append([p["name"], p["kind"], ", ".join(map(str, p["targets"])), f"{p['initial']:.5g}",
                     f"{p['estimate']:.5g}", _num(change, "+.2f"),
                     "not identifiable" if iv is None else f"[{iv[0]:.5g}, {iv[1]:.5g}]",
                     f"[{p['lower']:.4g}, {p['upper']:.4g}]", ", ".join(flags)])
    lines += markdown_table(["parameter", "kind", "targets", "initial", "estimate", "change %", "95 % interval",
                             "bounds", "flags"], rows) + [""]
    names = [p["name"] for p in r["parameters"]]
    corr = r["correlation"]
    strong = [(names[i], names[j], corr[i][j]) for i in range(len(names)) for j in range(i + 1, len(names))
              if corr[i][j] is not None and abs(corr[i][j]) >= 0.9]
    lines += ["## Correlations between parameters", ""]
    if len(names) <= 12:
        lines += markdown_table([""] + names, [[n] + [_num(v, "+.2f") for v in row] for n, row in zip(names, corr)])
        lines += [""]
    lines += [("Strongly correlated (|r| >= 0.9): " + "; ".join(f"{a} and {b} ({v:+.2f})" for a, b, v in strong)
               + ": the data fix their combination better than each.") if strong
              else "No two parameters correlate by 0.9 or more.", ""]
    n = r["noise"]
    rows = [[k, n["n"][k], f"{n['chi2'][k]:.4g}", f"{n['chi2'][k] / n['n'][k]:.3g}", f"{n['scale'][k]:.3g}"]
            for k in n["chi2"]]
    lines += ["## Misfit against the noise", "",
              f"Deviations stated for {n['stated']['frequencies']} of {n['stated']['modes']} frequencies and "
              f"{n['stated']['shapes']} shapes; the rest take the default noise (docs/update.md).", ""]
    lines += markdown_table(["kind", "entries", "chi^2", "chi^2 per entry", "error scale"], rows)
    lines += ["", f"chi^2 {n['chi2_total']:.4g} on {n['dof']} degrees of freedom: reduced chi^2 "
                  f"{_num(n['reduced_chi2'], '.3g')}, p = {_num(n['p_value'], '.3g')}.", ""]
    return lines


def write_update_report(record: dict, mac_initial, mac_updated, out: Path) -> dict:
    """report.md (and mac.png where shapes were measured) in `out`; {name: path}."""
    from fe_problem.safe_files import write_text

    out = Path(out)
    files = {}
    name = None
    if mac_initial is not None:
        rows = np.isfinite(mac_initial).all(axis=1)
        files["mac"] = mac_figure(mac_initial[rows], mac_updated[rows], out / "mac.png")
        name = "mac.png"
    files["report"] = write_text(out / "report.md", "\n".join(report_lines(record, name)) + "\n")
    return files
