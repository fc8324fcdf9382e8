"""The IOHprofiler export read by IOHprofiler's own Python reader (iohinspector): one raw_y
scale per function id, no attribute that a reader confuses with a data column, the numbers
the runs hold."""

import json
import warnings

import iohinspector  # the 'test' extra
import numpy as np
import pytest

from fe_problem.suite import TARGET_SCALE
from femu.cli import main
from femu.reports.ioh import ATTRIBUTE, FUNCTION_IDS, export_runs, improvements, read_ioh
from femu.studies.store import Store


# two instances of one function id whose J(x0) lie in different decades (0.01 and 0.001 apart
# from the top target before: the case), and the paper variant
PROBLEMS = ("hframe-freq/12/1", "hframe-freq/12/4", "paper")
SOLVERS = ("cma-es", "random-search")
SEEDS, BUDGET = 2, 200


@pytest.fixture(scope="module")
def store(tmp_path_factory):
    path = tmp_path_factory.mktemp("ioh") / "store"
    assert main(["study", "--suite", ",".join(PROBLEMS), "--optimizers", ",".join(SOLVERS), "--seeds",
                 f"0-{SEEDS - 1}", "--budget", str(BUDGET), "--store", str(path), "--workers", "0",
                 "--no-progress"]) == 0
    return Store(path)


@pytest.fixture(scope="module")
def export(store, tmp_path_factory):
    return export_runs(store, tmp_path_factory.mktemp("export") / "ioh")


def _manager(root):
    """iohinspector's DataManager of the folder ROOT, as a user loads it. It reads every .json
    under the folder: our femu-ioh.json (not an IOHprofiler file) is the one it skips, with a
    warning; any other warning (an attribute renamed, a file it cannot read) fails."""
    dm = iohinspector.DataManager()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        dm.add_folder(str(root))
    others = [str(w.message) for w in caught if "femu-ioh.json" not in str(w.message)]
    assert not others, others
    return dm


def test_one_raw_y_scale_per_function_id(export):
    marker = json.loads((export / "femu-ioh.json").read_text())
    scales = {}
    for pid, p in marker["problems"].items():
        scales.setdefault(p["function_id"], set()).add(p["raw_y_scale"])
    assert all(len(s) == 1 for s in scales.values()), scales
    # the family's top target: 100 x its fixed target scale (fe_problem.suite.TARGET_SCALE)
    assert marker["problems"]["hframe-freq/12/1"]["raw_y_scale"] == 100 * TARGET_SCALE["hframe-freq"]
    assert marker["problems"]["hframe-freq/12/4"]["raw_y_scale"] == 100 * TARGET_SCALE["hframe-freq"]
    assert marker["problems"]["paper/12/1"]["raw_y_scale"] == 100 * TARGET_SCALE["paper"]


def test_iohinspector_reads_every_run_with_its_numbers(store, export):
    dm = _manager(export)
    ov = dm.overview
    assert ov.height == len(store.runs()) == len(PROBLEMS) * len(SOLVERS) * SEEDS
    assert set(ov["function_id"].to_list()) == {FUNCTION_IDS["hframe-freq"], FUNCTION_IDS["paper"]}
    assert ATTRIBUTE in ov.columns and "raw_y_exp_attr" not in ov.columns
    data = dm.load(monotonic=False, include_meta_data=True)
    assert "raw_y_right" not in data.columns and data["raw_y"].dtype.is_float()
    # each run's points, computed here from the stored trace: (J - f_opt) / (100 x TARGET_SCALE)
    runs = {}
    for r in store.runs():
        family = r.variant.split("/")[0]
        instance = int(r.variant.split("/")[2]) if "/" in r.variant else 1
        runs.setdefault((r.optimizer, FUNCTION_IDS[family], instance), []).append(r)
    checked = 0
    for (alg, fid, inst, data_id), block in data.group_by(
            ["algorithm_name", "function_id", "instance", "data_id"], maintain_order=True):
        candidates = runs[(alg, fid, inst)]
        f_opt = candidates[0].f_opt
        scale = 100 * TARGET_SCALE[candidates[0].variant.split("/")[0]]
        got = block.sort("evaluations").select(["evaluations", "raw_y"]).to_numpy()
        # which seed: the one whose improvements these are
        matches = []
        for r in candidates:
            want = [(k, (f - f_opt) / scale) for k, f in improvements(r)]
            if want[-1][0] != r.n_evals:
                want.append((r.n_evals, (r.best_f - f_opt) / scale))
            if got.shape == (len(want), 2) and np.allclose(got, want, rtol=1e-12, atol=0):
                matches.append(r)
        assert len(matches) == 1, (alg, fid, inst, data_id)
        assert block["best_y"][0] == pytest.approx((matches[0].best_f - f_opt) / scale, rel=1e-9)
        assert block["evals"][0] == BUDGET
        checked += 1
    assert checked == len(store.runs())


def test_the_files_are_ioh_analyzers_own(tmp_path):
    # the export writes through ioh's Analyzer: the .json keys and .dat header that IOHanalyzer
    # reads, and nothing else (the full-precision column folded back into raw_y)
    from femu.reports.ioh import run_logged

    run_logged("random-search", "paper", 60, 0, tmp_path)
    meta = json.loads(next(tmp_path.rglob("IOHprofiler_*.json")).read_text())
    for key in ("version", "suite", "function_id", "function_name", "maximization", "algorithm", "attributes",
                "scenarios", "experiment_attributes", "run_attributes"):
        assert key in meta, key
    assert meta["attributes"] == ["evaluations", "raw_y"]
    names = [next(iter(a)) for a in meta["experiment_attributes"]]
    assert names == [ATTRIBUTE] and not set(names) & {"raw_y", "evaluations", "evals", "best_y", "run_id"}
    dat = next(tmp_path.rglob("*.dat")).read_text().splitlines()
    assert dat[0].split() == ["evaluations", "raw_y"]
    (r,) = read_ioh(tmp_path)
    assert _manager(tmp_path).overview["evals"].to_list() == [r.evals] == [60]
