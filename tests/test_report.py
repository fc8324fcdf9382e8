"""Reports and IOHprofiler export, on a small real study of the paper's problem."""

import json
import math
import re
import struct

import numpy as np
import pytest

from fe_problem.suite import PAPER_F_OPT
from femu import cli
from femu.reports.ioh import (FUNCTION_IDS, PREFIX, check_export, export_runs, improvements, ioh_terms, read_ioh,
                                 run_logged)
from femu.reports.study import summarize, write_report
from femu.studies.store import Store
from femu.studies.study import run_study
from adapters.variants import make_problem
from sample_plugins import Broken, TinyES

SEEDS = [0, 1, 2]
BUDGET = 300


TINY = f"{TinyES.__module__}:TinyES"
BROKEN = f"{Broken.__module__}:Broken"


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    store = tmp_path_factory.mktemp("study") / "store"
    run_study(["random-search", TINY, BROKEN], SEEDS, BUDGET, store, workers=0, progress=False)
    return Store(store)


@pytest.fixture(scope="module")
def report(study, tmp_path_factory):
    out = tmp_path_factory.mktemp("report")
    path = write_report(study, out)
    return path, path.read_text()


def _table_rows(md: str, first_header: str) -> dict:
    """{first cell: [cells]} of the Markdown table whose header starts with `first_header`."""
    lines = md.splitlines()
    start = next(i for i, ln in enumerate(lines) if ln.startswith(f"| {first_header} |"))
    header = [c.strip() for c in lines[start].strip("|").split("|")]
    rows = {}
    for ln in lines[start + 2:]:
        if not ln.startswith("|"):
            break
        cells = [c.strip() for c in ln.strip("|").split("|")]
        rows[cells[0]] = dict(zip(header, cells))
    return rows


def _median_iqr(cell: str) -> tuple[float, float]:
    m = re.fullmatch(r"\**([-+0-9.e]+) \(([-+0-9.e]+)\)\**", cell)
    assert m, f"not a 'median (IQR)' cell: {cell!r}"
    return float(m[1]), float(m[2])


def test_report_has_table1_the_papers_numbers_and_caveats(report):
    _, md = report
    assert "Table 1 rebuilt" in md
    # Table 1 transposed to fit a page: one row per model, one column per mode (frequencies,
    # then absolute errors); the paper's Table 1, row by row (modes 1 and 5)
    rows = _table_rows(md, "model | f1")
    assert rows["measured"]["f1"] == "53.9" and rows["measured"]["f5"] == "445.1"
    assert rows["initial (paper)"]["f1"] == "56.2" and rows["initial (paper)"]["f3"] == "228.4"
    assert [rows["PSO (paper)"][f"f{i}"] for i in range(1, 6)] == ["53.9", "117.8", "208.5", "253.8", "438.5"]
    assert rows["GA (paper)"]["f2"] == "122.0" and rows["SA (paper)"]["f5"] == "437.0"
    # the paper's mean errors recomputed from its table: PSO 0.41, SA 0.74, GA 1.80, initial 5.51
    errors = _table_rows(md, "model | err 1")
    assert [errors[k]["mean abs err %"] for k in ("initial (paper)", "PSO (paper)", "SA (paper)", "GA (paper)")] == \
        ["**5.51**", "**0.41**", "**0.74**", "**1.80**"]
    # every table of the report fits a page: at most 15 columns
    widths = [ln.count("|") - 1 for ln in md.splitlines() if ln.startswith("|")]
    assert max(widths) <= 15, max(widths)
    # and beside them what its text says
    paper = _table_rows(md, "method")
    assert paper["PSO"]["mean err % (paper's text)"] == "1.95"
    assert paper["GA"]["mean abs err % (from Table 1)"] == "1.80"
    assert "do not all agree with its own table" in md
    assert "geometry is a reconstruction" in md
    for name in ("random-search", TINY, BROKEN):
        assert name in rows and name in errors, f"no row for {name}"


def test_report_numbers_equal_the_runs(study, report):
    path, md = report
    runs = [r for r in study.runs() if r.optimizer == "random-search"]
    assert [r.seed for r in runs] == SEEDS
    solvers = _table_rows(md, "optimizer")
    med, iqr = _median_iqr(solvers["random-search"]["best_f median (IQR)"])
    best = np.array([r.best_f for r in runs])
    q1, q2, q3 = np.quantile(best, [0.25, 0.5, 0.75])
    assert med == pytest.approx(q2, rel=5e-4) and iqr == pytest.approx(q3 - q1, rel=5e-3)
    # updated frequencies and errors from the model at each run's best point
    problem = make_problem("paper")
    corr = [problem.correlation(r.best_x) for r in runs]
    mean_err = np.median([np.mean(np.abs(c.error_pct)) for c in corr])
    cell = _median_iqr(solvers["random-search"]["mean abs err % median (IQR)"])[0]
    assert cell == pytest.approx(mean_err, abs=0.005)
    table = _table_rows(md, "model | f1")
    f2 = np.median([c.model_hz[1] for c in corr])
    assert _median_iqr(table["random-search"]["f2"])[0] == pytest.approx(f2, abs=0.005)
    # summary.json carries the same numbers unrounded
    summary = json.loads((path.parent / "summary.json").read_text())[0]["solvers"]["random-search"]
    assert summary["best_f"]["median"] == q2
    assert summary["mean_abs_error_pct"]["median"] == pytest.approx(mean_err, rel=1e-12)
    assert summary["n_evals"]["median"] == BUDGET


def test_failed_runs_are_counted_and_listed(report):
    _, md = report
    solvers = _table_rows(md, "optimizer")
    assert solvers[BROKEN]["failed"] == str(len(SEEDS))
    assert solvers["random-search"]["failed"] == "0"
    assert "### Failed runs" in md and "RuntimeError: boom after 20 evaluations" in md


def _png_size(path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path} is not a PNG"
    assert data[12:16] == b"IHDR"
    return struct.unpack(">II", data[16:24])


def test_figures_exist_and_are_real_pngs(report):
    path, md = report
    names = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", md)
    assert {n.split("_")[0] for n in names} == {"convergence", "ecdf", "errors", "overhead", "parameters", "modes",
                                                 "mac"}
    for name in names:
        fig = path.parent / name
        w, h = _png_size(fig)
        assert 600 <= w <= 2000 and 350 <= h <= 1500, (name, w, h)
        assert fig.stat().st_size > 15_000, f"{name} is suspiciously small"


def test_curves_and_ecdf_agree_with_the_runs(study):
    runs = study.runs()
    (g,) = summarize(runs)
    rs = [r for r in runs if r.optimizer == TINY]
    s = g.solver(TINY)
    # the median curve ends on the median best value
    assert s.curve.median[-1] == pytest.approx(np.median([r.best_f for r in rs]), rel=1e-12)
    # ... and at every sampled evaluation count on the median of each run's best so far
    for i in range(0, len(g.grid), 17):
        n = int(g.grid[i])
        assert s.curve.median[i] == pytest.approx(np.median([r.best_at(n) for r in rs]), rel=1e-12), n
    # ECDF at the end: the fraction of (run, target) pairs with best_f <= target
    reached = np.mean([[r.best_f <= t for t in g.targets] for r in rs])
    assert s.ecdf[-1] == pytest.approx(reached, abs=1e-12)
    assert np.all(np.diff(s.ecdf) >= 0)
    # targets run from the worst first value to the best found, log-spaced
    assert g.targets[0] == pytest.approx(max(r.trace[0][1] for r in runs if r.trace))
    assert g.targets[-1] == pytest.approx(min(r.best_f for r in runs if r.trace))


def test_cli_report_with_ioh_and_a_clear_error_for_a_missing_store(study, tmp_path, capsys):
    out = tmp_path / "rep"
    assert cli.main(["report", str(study.path), "--out", str(out), "--ioh", "--coco"]) == 0
    assert "report written to" in capsys.readouterr().out
    assert (out / "report.md").exists() and (out / "ioh" / "femu-ioh.json").exists()
    # COCO data (tests/test_coco.py reads it with cocopp): one .info per function of each optimizer
    assert sorted(p.name for p in (out / "coco" / "random-search").glob("*.info")) == ["femuexp_f1.info"]
    assert cli.main(["report", str(tmp_path / "nowhere"), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "nowhere" in err and "no such store" in err


# -- IOHprofiler --------------------------------------------------------------------------
def test_ioh_export_round_trips(study, tmp_path):
    runs = study.runs()
    out = export_runs(study, tmp_path / "ioh")
    back = read_ioh(out)
    assert len(back) == len(runs)
    terms = ioh_terms("paper")  # raw_y = (J - f_opt) / scale, f_opt the paper's best known J
    p = make_problem("paper")
    gap = p.evaluate(p.x0)[0] - PAPER_F_OPT
    assert terms.f_opt == PAPER_F_OPT and terms.scale / 10 < gap <= terms.scale == 10.0 ** round(np.log10(terms.scale))
    by_key = {(r.algorithm, r.attributes["seed"]): r for r in back}
    for run in runs:
        r = by_key[(run.optimizer, run.seed)]
        assert r.function_name == PREFIX + "paper" and r.dimension == 12
        assert r.function_id == FUNCTION_IDS["paper"] == 20001 and r.instance == 1
        assert r.function_id > 24                        # clear of BBOB's function ids 1-24
        assert r.evals == run.n_evals
        assert terms.objective(r.best_y) == pytest.approx(run.best_f, rel=1e-9)
        assert r.best_y == pytest.approx((run.best_f - PAPER_F_OPT) / terms.scale, rel=1e-9)
        # the logged points are the trace's improvements, then ioh's last-evaluation line
        imp = improvements(run)
        np.testing.assert_array_equal(r.points[: len(imp), 0], [k for k, _ in imp])
        # at full precision, not ioh's 10 fixed decimals
        np.testing.assert_allclose(r.points[: len(imp), 1], terms.raw([f for _, f in imp]), rtol=1e-15, atol=0)
        assert r.points[-1, 0] == run.n_evals
    meta = json.loads(next((out / "random-search").glob("IOHprofiler_*.json")).read_text())
    assert meta["maximization"] is False and meta["algorithm"]["name"] == "random-search"
    assert [run["seed"] for run in meta["scenarios"][0]["runs"]] == SEEDS
    # best x in the declared search space [0, 1]: (x - xl) / (xu - xl)
    rs = {r.seed: r for r in runs if r.optimizer == "random-search"}
    for entry in meta["scenarios"][0]["runs"]:
        x = np.asarray(entry["best"]["x"])
        assert np.all((x >= 0) & (x <= 1))
        np.testing.assert_allclose(x, terms.unit(rs[entry["seed"]].best_x), atol=1e-6)


def test_ioh_export_keeps_a_precision_of_1e_14_that_ten_decimals_would_round_to_0(study, tmp_path):
    import dataclasses

    run = study.runs()[0]
    terms = ioh_terms("paper")
    tiny = PAPER_F_OPT + 1.2345678901234e-14 * terms.scale
    trace = [list(t) for t in run.trace if t[1] > tiny] + [[run.n_evals, tiny]]
    close = dataclasses.replace(run, trace=trace, best_f=tiny)
    out = export_runs([close], tmp_path / "ioh")
    (r,) = read_ioh(out)
    assert r.points[-1, 1] == pytest.approx(terms.raw(tiny), rel=1e-15) and r.points[-1, 1] > 1e-14
    dat = next(out.rglob("*.dat")).read_text()
    assert dat.splitlines()[0].split() == ["evaluations", "raw_y"]     # ioh's columns, no extra one
    meta = json.loads(next(out.rglob("IOHprofiler_*.json")).read_text())
    assert meta["attributes"] == ["evaluations", "raw_y"]


def test_ioh_check_catches_a_changed_file(study, tmp_path):
    out = export_runs(study, tmp_path / "ioh")
    dat = next((out / "random-search").rglob("*.dat"))
    lines = dat.read_text().splitlines()
    e, y = lines[1].split()
    lines[1] = f"{e} {float(y) * 0.5:.10f}"
    dat.write_text("\n".join(lines) + "\n")
    from femu.reports.ioh import algorithm_names
    with pytest.raises(RuntimeError, match="reads back as"):
        check_export(out, algorithm_names(study.runs()))


def test_ioh_export_skips_runs_without_evaluations_and_refuses_foreign_dirs(study, tmp_path):
    from adapters.harness import RunResult

    empty = RunResult(optimizer="random-search", problem="hframe:paper", seed=9, budget=BUDGET, status="failed",
                      error="died before its first evaluation")
    out = export_runs(study.runs()[:2] + [empty], tmp_path / "ioh")
    marker = json.loads((out / "femu-ioh.json").read_text())
    assert marker["skipped"] == [{"optimizer": "random-search", "variant": "paper", "seed": 9, "status": "failed"}]
    assert len(read_ioh(out)) == 2
    export_runs(study.runs()[:1], out)  # a previous export is replaced
    assert len(read_ioh(out)) == 1
    foreign = tmp_path / "mine"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("keep me")
    with pytest.raises(ValueError, match="not a femu IOH export"):
        export_runs(study.runs(), foreign)
    assert (foreign / "notes.txt").read_text() == "keep me"


def test_live_ioh_logging_matches_the_replayed_export(tmp_path):
    result = run_logged("random-search", "paper", 250, 3, tmp_path / "live")
    export_runs([result], tmp_path / "replay")
    (live,) = read_ioh(tmp_path / "live")
    (replay,) = read_ioh(tmp_path / "replay")
    assert (live.function_id, live.function_name, live.evals) == (replay.function_id, replay.function_name, 250)
    assert live.best_y == pytest.approx(replay.best_y, rel=1e-12)
    assert ioh_terms("paper").objective(live.best_y) == pytest.approx(result.best_f, rel=1e-12)
    # every improvement the harness recorded is what ioh saw live; only the last line differs:
    # live logging writes that evaluation's raw value, the replay its best-so-far
    np.testing.assert_array_equal(live.points[:-1], replay.points[:-1])
    assert live.points[-1, 0] == replay.points[-1, 0] == 250
    assert replay.points[-1, 1] == pytest.approx(replay.best_y, abs=1e-10)
    assert live.points[-1, 1] >= replay.points[-1, 1] - 1e-10
    assert math.isclose(live.attributes["seed"], 3)


def test_a_study_of_variants_gets_the_benchmark_statistics(study, report, capsys):
    # not a suite study: the statistics are there all the same (`femu report --json`)
    capsys.readouterr()
    assert cli.main(["report", str(study.path), "--json"]) == 0
    s = json.loads(capsys.readouterr().out)
    (p,) = s["problems"]
    assert p["id"] == "paper" and p["f_opt"] == PAPER_F_OPT and p["f_opt_kind"] == "certified"
    assert p["targets"][0] == pytest.approx(100 * p["target_scale"])
    # one problem: no comparison on problems as blocks, said; per-problem tests on 3 pairs
    assert s["comparisons"] == {} and "at least 2 common problems" in s["not_compared"]
    pairs = s["per_problem"]["final"]["pairs"]
    assert {frozenset((q["a"], q["b"])) for q in pairs} == {frozenset(("random-search", BROKEN)),
                                                            frozenset(("random-search", TINY)), frozenset((BROKEN, TINY))}
    # the broken solver never reaches a target past its 20 evaluations: its aggregate area is the smallest
    area = s["aggregate"]["area"]
    assert set(area) == {"random-search", BROKEN, TINY} and area[BROKEN] == min(area.values())
    assert {q["tolerance"] for q in s["profiles"]} == {1e-1, 1e-3, 1e-5, 1e-7}
    assert s["design"]["mannwhitneyu"] == pytest.approx(0.1)            # 3 seeds: 2 / C(6, 3)
    # the Markdown report links the benchmark report, which draws the aggregate and the profiles
    path, md = report
    assert "[benchmark.md](benchmark.md)" in md
    bench = (path.parent / "benchmark.md").read_text()
    assert "![aggregated ECDF](aggregate_ecdf.png)" in bench and "![profiles](profiles.png)" in bench
    assert (path.parent / "aggregate_ecdf.png").stat().st_size > 5000
