"""The COCO export (`femu report --coco`) read by COCO's own post-processing, cocopp: it
finds every run, and its ERT (computed by cocopp from the files) is the report's."""

import json
import math
import warnings

import numpy as np
import pytest

from fe_problem.jsonutil import dumps
from fe_problem.safe_files import write_text
from femu.cli import main
from femu.reports.benchmark import benchmark_statistics
from femu.reports.coco import SUITE, cocopp_testbed, export_coco, function_ids, tdat_evaluations
from femu.studies.store import Store

PROBLEMS = ("hframe-freq/12/1", "hframe-freq/12/4", "paper")
SOLVERS = ("cma-es", "random-search")
SEEDS, BUDGET = 3, 200


@pytest.fixture(scope="module")
def exported(tmp_path_factory):
    """A study's store and OUT with OUT/coco and OUT/stats.json (the report's numbers; its
    figures, slow, are made by the CLI test in test_report.py)."""
    root = tmp_path_factory.mktemp("coco")
    store, out = root / "store", root / "report"
    assert main(["study", "--suite", ",".join(PROBLEMS), "--optimizers", ",".join(SOLVERS), "--seeds",
                 f"0-{SEEDS - 1}", "--budget", str(BUDGET), "--store", str(store), "--workers", "0",
                 "--no-progress"]) == 0
    runs = Store(store).runs()
    export_coco(runs, out / "coco")
    write_text(out / "stats.json", dumps(benchmark_statistics(runs)))
    return store, out


@pytest.fixture(scope="module")
def cocopp_result(exported, tmp_path_factory):
    """cocopp.main on the exported folders (tables only: the figures take half a minute)."""
    cocopp_testbed()
    import cocopp

    _, out = exported
    folders = [str(out / "coco" / s) for s in SOLVERS]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # cocopp's look-ups of its online archives, offline here
        return cocopp.main(["-o", str(tmp_path_factory.mktemp("ppdata")), "--tab-only", "--no-svg", *folders])


def test_cocopp_reads_every_run(exported, cocopp_result):
    store, _ = exported
    runs = Store(store).runs()
    sets = {(alg, ds.funcId, ds.dim): ds for (alg, _), dsl in cocopp_result.items() for ds in dsl}
    assert {(a, f) for a, f, _ in sets} == {(s, function_ids()[fam]) for s in SOLVERS
                                             for fam in ("hframe-freq", "paper")}
    for (alg, fid, dim), ds in sets.items():
        mine = [r for r in runs if r.optimizer == alg and function_ids()[r.variant.split("/")[0]] == fid]
        assert ds.suite_name == SUITE and dim == 12
        assert ds.nbRuns() == len(mine) == SEEDS * (2 if fid == 11 else 1)
        assert sorted(ds.instancenumbers) == sorted(int(r.variant.split("/")[2]) for r in mine)
        np.testing.assert_array_equal(ds.maxevals, BUDGET)


def test_cocopp_ert_is_the_reports(exported, cocopp_result):
    _, out = exported
    stats = json.loads((out / "stats.json").read_text())
    ert = stats["ert"]["ert"]
    assert stats["ert"]["levels"] == pytest.approx([10 ** (-k / 5) for k in range(51)], rel=1e-15)
    # COCO's targets 1e2 ... 1e-8 on f - Fopt (f = J / target scale) are the report's levels
    # (1e2 times them), written as cocopp writes its own (10^(i/5)): a target a rounding below
    # cocopp's would be looked up as the next, harder one
    targets = [float(np.power(10, (10 - k) / 5)) for k in range(51)]
    checked = 0
    for (alg, _), dsl in cocopp_result.items():
        for ds in dsl:
            family = next(f for f, i in function_ids().items() if i == ds.funcId)
            ours = ert[alg][f"{family}/{ds.dim}"]
            coco = ds.detERT(targets)
            assert len(coco) == len(ours) == 51
            for k, (a, b) in enumerate(zip(coco, ours)):
                b = math.inf if b is None else b
                assert (a == b == math.inf) or a == pytest.approx(b, rel=1e-12), (alg, family, k, a, b)
            checked += sum(math.isfinite(a) for a in coco)
    assert checked > 20  # the comparison is not all at inf


def test_the_files_as_coco_writes_them(exported):
    _, out = exported
    folder = out / "coco" / "cma-es"
    info = (folder / "femuexp_f11.info").read_text().splitlines()
    assert info[0].startswith(f"suite = '{SUITE}', funcId = 11, DIM = 12, Precision = 1.000e-08, algId = 'cma-es'")
    assert info[1].startswith("%") and info[2].startswith("data_f11/femuexp_f11_DIM12.dat, ")
    assert sorted(e.split(":")[0] for e in info[2].split(", ")[1:]) == ["1"] * SEEDS + ["4"] * SEEDS
    dat = (folder / "data_f11" / "femuexp_f11_DIM12.dat").read_text().splitlines()
    assert sum(ln.startswith("%") for ln in dat) == 2 * SEEDS
    tdat = (folder / "data_f11" / "femuexp_f11_DIM12.tdat").read_text().splitlines()
    first = [ln.split() for ln in tdat[1:] if not ln.startswith("%")]
    assert [int(c[0]) for c in first[:len(tdat_evaluations(BUDGET))]] == tdat_evaluations(BUDGET).tolist()
    # 10^(i/20) steps: 1, 2, 3, ... then every 12 % or so, and the last evaluation
    assert tdat_evaluations(BUDGET)[:4].tolist() == [1, 2, 3, 4] and tdat_evaluations(BUDGET)[-1] == BUDGET
    marker = json.loads((out / "coco" / "femu-coco.json").read_text())
    assert marker["problems"]["hframe-freq/12/4"] == {"function_id": 11, "instance": 4, "f_opt": 0.0, "scale": 1e-4}


def test_coco_needs_out_and_keeps_a_foreign_directory(exported, capsys, tmp_path):
    store, _ = exported
    assert main(["report", str(store), "--json", "--coco"]) == 2
    assert "--coco writes to OUT/coco and needs --out DIR" in capsys.readouterr().err
    (tmp_path / "notes.txt").write_text("keep me")
    with pytest.raises(ValueError, match="not a femu COCO export"):
        export_coco(Store(store).runs(), tmp_path)
    assert (tmp_path / "notes.txt").read_text() == "keep me"
