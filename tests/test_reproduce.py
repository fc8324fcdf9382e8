"""`femu reproduce`: every available optimizer on the paper's problem, one budget, a report."""

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from femu import cli
from adapters.registry import BUILTINS, available
from femu.reproduce import solvers
from femu.studies.store import Store
from adapters.variants import make_problem

FEMU = str(Path(sys.executable).with_name("femu"))
ARGS = ["reproduce", "--seeds", "2", "--budget", "200", "--workers", "2", "--json"]


@pytest.fixture(scope="module")
def reproduced(tmp_path_factory):
    out = tmp_path_factory.mktemp("repro") / "out"
    proc = subprocess.run([FEMU, *ARGS, "--out", str(out)], capture_output=True, text=True, timeout=600,
                          stdin=subprocess.DEVNULL)
    assert proc.returncode == 0, proc.stderr
    return out, json.loads(proc.stdout), proc.stderr


def test_json_schema_with_every_available_solver(reproduced):
    out, res, err = reproduced
    assert res["budget"] == 200 and res["seeds"] == 2 and res["variant"] == "paper"
    names, left_out = solvers(200)
    assert set(names) | set(left_out) == set(available())
    assert set(BUILTINS) <= set(res["solvers"]), f"built-ins left out: {left_out}"
    assert list(res["solvers"]) == names
    for name, s in res["solvers"].items():
        assert s["status"] == "ok", (name, s["statuses"])
        assert s["n_runs"] == 2 and s["n_evals"] == 200
        assert len(s["frequencies_hz"]) == 5 and all(40 < f < 500 for f in s["frequencies_hz"]), name
        assert 0 < s["mean_abs_error_pct"] < res["initial_mean_abs_error_pct"], name
        assert s["best_f"] > 0 and s["wall_s"] > 0 and s["cpu_s"] >= 0 and s["fe_s"] > 0
        q1, q3 = s["best_f_q1_q3"]
        assert q1 <= s["best_f"] <= q3
    assert res["measured_hz"] == [53.9, 117.3, 208.4, 254.0, 445.1]
    assert res["paper"]["mean_abs_error_pct_from_table"]["PSO"] == pytest.approx(0.4077, abs=1e-3)
    assert Path(res["report"]) == out / "report.md" and (out / "report.md").exists()
    assert f"femu study: {2 * len(names)} runs" in err and f"{2 * len(names)} ok, 0 failed" in err


def test_json_numbers_are_medians_over_the_stored_seeds(reproduced):
    out, res, _ = reproduced
    runs = Store(out / "store").runs()
    problem = make_problem("paper")
    for name, s in res["solvers"].items():
        rs = [r for r in runs if r.optimizer == name and r.budget == 200]
        assert sorted(r.seed for r in rs) == [0, 1]
        assert s["best_f"] == np.median([r.best_f for r in rs])
        assert s["wall_s"] == pytest.approx(np.median([r.wall_s for r in rs]), rel=1e-12)
        corr = [problem.correlation(r.best_x) for r in rs]
        assert s["mean_abs_error_pct"] == pytest.approx(np.median([np.mean(np.abs(c.error_pct)) for c in corr]),
                                                        rel=1e-12)
        np.testing.assert_allclose(s["frequencies_hz"], np.median([c.model_hz for c in corr], axis=0), rtol=1e-12)
        best = min(rs, key=lambda r: r.best_f)  # the updated moduli of the best run
        assert s["best_run"] == {"seed": best.seed, "best_f": best.best_f, "x": list(best.best_x)}


def test_resumes_from_the_store_and_prints_a_table(reproduced, capsys):
    out, res, _ = reproduced
    before = {p.name: p.stat().st_mtime_ns for p in (out / "store" / "runs").glob("*.json")}
    assert cli.main(["reproduce", "--seeds", "2", "--budget", "200", "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert f"0 new, {len(before)} kept" in captured.err
    assert {p.name: p.stat().st_mtime_ns for p in (out / "store" / "runs").glob("*.json")} == before
    text = captured.out
    for name, s in res["solvers"].items():
        line = next(ln for ln in text.splitlines() if ln.startswith(name + " "))
        assert f"{s['mean_abs_error_pct']:.2f}" in line and f"{s['best_f']:.3e}" in line
    assert "paper PSO (Table 1)" in text and "0.41" in text


def test_bad_arguments_are_named(capsys, tmp_path):
    assert cli.main(["reproduce", "--seeds", "0", "--out", str(tmp_path)]) == 2
    assert "--seeds" in capsys.readouterr().err
    assert cli.main(["reproduce", "--budget", "0", "--out", str(tmp_path)]) == 2
    assert "--budget" in capsys.readouterr().err
    assert not (tmp_path / "store").exists()
