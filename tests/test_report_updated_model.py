"""The report shows the updated model (issue 23): each optimizer's best run's parameters beside
the initial ones (table and bar chart), the frame in its first modes (initial and updated), the
MAC matrix of the updated modes (against the measured ones when the data have shapes), and the
best J known on the convergence plot. Values are checked against the runs and an independent
MAC written out here; figures are checked to be written."""

from __future__ import annotations

import json
import re
import struct

import numpy as np
import pytest

from adapters.variants import make_problem
from fe_problem.suite import PAPER_F_OPT
from femu.reports import figures as figs
from femu.reports.study import summarize, write_report
from femu.studies.store import Store
from femu.studies.study import run_study


@pytest.fixture(scope="module")
def paper(tmp_path_factory):
    store = tmp_path_factory.mktemp("paper") / "store"
    run_study(["random-search", "cma-es"], [0, 1], 200, store, workers=0, progress=False)
    runs = Store(store).runs()
    out = tmp_path_factory.mktemp("paper-report")
    path = write_report(runs, out)
    return runs, path, path.read_text()


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):
    store = tmp_path_factory.mktemp("synthetic") / "store"
    run_study(["random-search"], [0], 100, store, variants=("synthetic",), workers=0, progress=False)
    runs = Store(store).runs()
    out = tmp_path_factory.mktemp("synthetic-report")
    path = write_report(runs, out)
    return runs, path, path.read_text()


def _table(md: str, header_start: str) -> tuple[list[str], dict]:
    lines = md.splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith(f"| {header_start} |"))
    header = [c.strip() for c in lines[start].strip("|").split("|")]
    rows = {}
    for ln in lines[start + 2:]:
        if not ln.startswith("|"):
            break
        cells = [c.strip() for c in ln.strip("|").split("|")]
        rows[cells[0]] = dict(zip(header, cells))
    return header, rows


def _independent_mac(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """MAC_ij = |a_i . b_j|^2 / ((a_i . a_i)(b_j . b_j)), written out loop by loop."""
    out = np.empty((a.shape[1], b.shape[1]))
    for i in range(a.shape[1]):
        for j in range(b.shape[1]):
            out[i, j] = float(a[:, i] @ b[:, j]) ** 2 / (float(a[:, i] @ a[:, i]) * float(b[:, j] @ b[:, j]))
    return out


def _png(path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path} is not a PNG"
    return struct.unpack(">II", data[16:24])


def test_the_updated_moduli_of_each_best_run_are_tabled_beside_the_initial_ones(paper):
    runs, path, md = paper
    header, rows = _table(md, "model | J")
    assert header[2:14] == [f"E{k}" for k in range(1, 13)]
    assert [rows["initial"][f"E{k}"] for k in range(1, 13)] == ["70.0"] * 12
    assert rows["lower bound"]["E1"] == "60.0" and rows["upper bound"]["E12"] == "80.0"
    summary = json.loads((path.parent / "summary.json").read_text())[0]["solvers"]
    for name in ("random-search", "cma-es"):
        mine = [r for r in runs if r.optimizer == name]
        best = min(mine, key=lambda r: r.best_f)
        row = rows[f"{name} (seed {best.seed})"]
        assert row["J"] == f"{best.best_f:.5g}"
        cells = [row[f"E{k}"].strip("*") for k in range(1, 13)]
        assert cells == [f"{v / 1e9:.1f}" for v in best.best_x]
        # bold exactly where the run sits within 0.1 % of the range of a bound
        pinned = (np.asarray(best.best_x) <= 6e10 + 2e7) | (np.asarray(best.best_x) >= 8e10 - 2e7)
        assert [row[f"E{k}"].startswith("**") for k in range(1, 13)] == pinned.tolist()
        assert row["at a bound"] == f"{int(pinned.sum())} of 12"
        assert summary[name]["best_run"] == {"seed": best.seed, "best_f": best.best_f, "x": list(best.best_x)}
    assert (path.parent / "parameters_paper_b200.png").exists()


def test_the_frame_drawing_and_the_mac_matrix_of_initial_and_updated_modes(paper):
    runs, path, md = paper
    best = min(runs, key=lambda r: r.best_f)
    problem = make_problem("paper")
    init, upd = problem.modal(None, 5), problem.modal(best.best_x, 5)
    modes = json.loads((path.parent / "summary.json").read_text())[0]["modes"]
    assert (modes["optimizer"], modes["seed"], modes["best_f"]) == (best.optimizer, best.seed, best.best_f)
    np.testing.assert_allclose(modes["frequencies_updated_hz"], upd.frequencies_hz, rtol=1e-12)
    np.testing.assert_allclose(modes["frequencies_initial_hz"], init.frequencies_hz, rtol=1e-12)
    # the paper's data have no shapes: initial against updated, over every node's translations
    assert modes["mac_measured_updated"] is None
    moving = [(n.id, d) for n in problem.model.nodes for d in ("x", "y")]
    expect = _independent_mac(init.at(moving), upd.at(moving))
    np.testing.assert_allclose(modes["mac_initial_updated"], expect, rtol=1e-10, atol=1e-14)
    _, table = _table(md, "initial | updated 1")
    shown = np.array([[float(table[str(i + 1)][f"updated {j + 1}"]) for j in range(5)] for i in range(5)])
    np.testing.assert_allclose(shown, expect, atol=5e-4)
    assert f"The updated model is the group's best run: {best.optimizer}, seed {best.seed}" in md
    for name in ("modes", "mac"):
        w, h = _png(path.parent / f"{name}_paper_b200.png")
        assert w >= 600 and h >= 350


def test_with_measured_shapes_the_mac_is_measured_against_updated(synthetic):
    runs, path, md = synthetic
    (best,) = runs
    problem = make_problem("synthetic")
    data = problem.data
    upd = problem.modal(best.best_x, len(data.frequencies_hz))
    expect = _independent_mac(data.shapes, upd.at(data.dofs))
    modes = json.loads((path.parent / "summary.json").read_text())[0]["modes"]
    np.testing.assert_allclose(modes["mac_measured_updated"], expect, rtol=1e-9, atol=1e-12)
    _, table = _table(md, "measured | updated 1")
    assert float(table["3"]["updated 3"]) == pytest.approx(expect[2, 2], abs=5e-4)
    # the per-mode MAC table of the paired modes is its own table, one row per model
    header, rows = _table(md, "model | MAC 1")
    assert header[-1] == "mean COMAC" and {"initial (ours)", "random-search"} <= set(rows)
    assert (path.parent / "mac_synthetic_b100.png").exists()


def test_the_convergence_plot_draws_the_best_known_j(paper, tmp_path, monkeypatch):
    runs, _, md = paper
    (g,) = summarize(runs)
    assert g.best_known_f == PAPER_F_OPT and "fe_problem.suite.PAPER_F_OPT" in g.best_known_how
    assert f"the best J known, {PAPER_F_OPT:.5g}" in md
    drawn = {}
    monkeypatch.setattr(figs, "save_figure", lambda fig, path: drawn.setdefault("fig", fig))
    figs.plot_convergence(g, tmp_path / "c.png")
    (ax,) = drawn["fig"].axes
    lines = [ln for ln in ax.get_lines() if ln.get_label().startswith("best known J")]
    assert len(lines) == 1 and list(lines[0].get_ydata()) == [PAPER_F_OPT, PAPER_F_OPT]


def test_table1_is_split_and_transposed_to_fit_a_page(paper):
    _, _, md = paper
    section = md.split("### Table 1 rebuilt", 1)[1].split("### Solvers", 1)[0]
    headers = re.findall(r"^\| model \|.*$", section, flags=re.M)
    assert len(headers) == 2  # frequencies, then errors
    assert all(h.count("|") - 1 <= 8 for h in headers), headers
