"""Issue 39: blind instances. A plugin that knows the public suite problem of an id (its truth
is fixed by the id alone, so anyone can rebuild it) submits that truth: on the public instance
(`femu study --no-blind`) it reaches J ~ 0; on the blind instance (the default with --suite)
it gains nothing, while an honest optimizer runs and is verified beside it. The blind truths
are checked from outside the study: rebuilt here from the store's secret by a second,
separately written derivation of the key."""

from __future__ import annotations

import hashlib
import hmac
import json
import os
import shutil
import stat
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from fe_problem.suite import suite_problem
from femu.studies.store import Store

PID = "hframe-freq/12/1"
NOISY = "hframe-freq-noisy/12/1"
BUDGET = 40

CHEAT = '''
import numpy as np

TRUTH = {truth!r}


class SubmitsThePublicTruth:
    """Submits the truth of the public instance of {pid} (rebuilt from its id beforehand)."""

    name = "submits-the-public-truth"

    def min_budget(self, n_var, **options):
        return 1

    def minimize(self, objective, bounds, budget, rng):
        x = np.clip(np.array(TRUTH, dtype=float), bounds[0], bounds[1])
        while True:
            objective(x[None])
'''


def _femu(plugins: Path, *args) -> subprocess.CompletedProcess:
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(plugins), os.environ.get("PYTHONPATH", "")]))
    return subprocess.run([sys.executable, "-m", "femu", *args], env=env, capture_output=True, text=True,
                          timeout=600)


def _runs(store: Path) -> dict:
    return {(r.optimizer, r.variant): r for r in Store(store).runs()}


def _key(secret: bytes, pid: str) -> str:
    """The instance key, derived again here (femu.studies.blind.instance_key's definition)."""
    return hmac.new(secret, f"femu-blind-instance:{pid}".encode(), hashlib.sha256).hexdigest()


@pytest.fixture(scope="module")
def studies(tmp_path_factory):
    """The cheat and random-search on PID: blind (the default) and public (--no-blind), by the CLI."""
    root = tmp_path_factory.mktemp("blind")
    plugins = root / "plugins"
    plugins.mkdir()
    public = suite_problem(PID)
    (plugins / "public_truth.py").write_text(CHEAT.format(truth=public.truth.tolist(), pid=PID))
    cheat = "public_truth:SubmitsThePublicTruth"
    common = ["--optimizers", f"{cheat},random-search", "--seeds", "0", "--budget", str(BUDGET), "--workers", "0",
              "--no-progress"]
    done = {}
    for name, flags in (("blind", ["--suite", f"{PID},{NOISY}"]), ("public", ["--suite", PID, "--no-blind"])):
        proc = _femu(plugins, "study", *common, "--store", str(root / name), *flags)
        assert proc.returncode == 0, proc.stderr
        done[name] = _runs(root / name)
    return root, plugins, cheat, done


def test_the_public_truth_solves_the_public_instance_and_gains_nothing_on_the_blind_one(studies):
    _, _, cheat, done = studies
    on_public, on_blind = done["public"][(cheat, PID)], done["blind"][(cheat, PID)]
    assert on_public.status == on_blind.status == "ok" and on_public.verified and on_blind.verified
    assert not on_public.blind and on_blind.blind
    assert on_public.best_f < 1e-20  # the attack works where the instance is public
    honest = done["blind"][("random-search", PID)]
    assert honest.status == "ok" and honest.verified and honest.n_evals == BUDGET and honest.blind
    # on the blind instance the public truth is no better than an honest random search's 40 points
    assert on_blind.best_f > 1e-6 and on_blind.best_f > 0.1 * honest.best_f, (on_blind.best_f, honest.best_f)


def test_the_blind_instance_is_the_stores_secret_s_and_its_f_opt_is_exact(studies):
    root, _, cheat, done = studies
    secret_file = root / "blind" / ".blind"
    assert stat.S_IMODE(secret_file.stat().st_mode) == 0o600 and len(secret_file.read_bytes()) == 32
    mine = suite_problem(PID, blind=_key(secret_file.read_bytes(), PID))
    public = suite_problem(PID)
    assert not np.allclose(mine.truth, public.truth)
    assert np.all((mine.truth >= mine.xl) & (mine.truth <= mine.xu))
    assert float(mine.evaluate(mine.truth)[0]) < 1e-20  # the data are the truth's: f_opt = 0 exactly
    r = done["blind"][(cheat, PID)]
    assert (r.f_opt, r.f_opt_kind, r.f_opt_precision) == (0.0, "exact", 0.0)
    # the record's value is J at the submitted point of this very instance, evaluated again here
    assert r.best_f == pytest.approx(float(mine.evaluate(np.array(r.best_x))[0]), rel=1e-9)
    assert r.f_start == pytest.approx(float(mine.evaluate(mine.x0)[0]), rel=1e-12)


def test_a_noisy_blind_instance_is_certified_at_study_time(studies):
    root, _, _, done = studies
    r = done["blind"][("random-search", NOISY)]
    assert r.blind and r.f_opt_kind == "certified" and r.status == "ok"
    mine = suite_problem(NOISY, blind=_key((root / "blind" / ".blind").read_bytes(), NOISY))
    at_truth = float(mine.evaluate(mine.truth)[0])
    # the certified minimum is at most J at the hidden truth, and no run went below it
    assert r.f_opt <= at_truth + r.f_opt_precision and r.best_f >= r.f_opt - r.f_opt_precision
    assert r.f_opt != suite_problem(NOISY).f_opt or r.f_start != suite_problem(NOISY).evaluate(
        suite_problem(NOISY).x0)[0]
    assert json.loads((root / "blind" / ".blind_fopt.json").read_text())[NOISY][:2] == [r.f_opt, r.f_opt_precision]


def test_the_same_secret_and_seed_give_the_same_runs_and_another_store_other_truths(studies, tmp_path):
    from femu.studies.study import run_study

    root, _, _, done = studies
    same, other = tmp_path / "same", tmp_path / "other"
    same.mkdir()
    shutil.copy(root / "blind" / ".blind", same / ".blind")
    for store in (same, other):
        run_study(["random-search"], "0", BUDGET, store, suite=PID, workers=0, progress=False)
    again, before = _runs(same)[("random-search", PID)], done["blind"][("random-search", PID)]
    assert (again.best_f, again.best_x, again.f_start) == (before.best_f, before.best_x, before.f_start)
    elsewhere = _runs(other)[("random-search", PID)]
    assert elsewhere.blind and elsewhere.f_start != before.f_start


def test_a_blind_store_refuses_public_runs_and_the_report_marks_blind_instances(studies, tmp_path):
    root, plugins, cheat, _ = studies
    store = tmp_path / "copy"
    shutil.copytree(root / "blind", store)
    refused = _femu(plugins, "study", "--optimizers", "random-search", "--seeds", "0", "--budget", str(BUDGET),
                    "--workers", "0", "--no-progress", "--store", str(store), "--suite", PID, "--no-blind")
    assert refused.returncode == 2 and "blind" in refused.stderr and refused.stderr.count("\n") == 1, refused.stderr
    report = _femu(plugins, "report", str(store), "--json")  # the numbers of the report (no figures: fast)
    assert report.returncode == 0, report.stderr
    stats = json.loads(report.stdout)
    problems = {p["id"]: p for p in stats["problems"]}
    assert problems[PID]["blind"] and problems[PID]["f_opt"] == 0.0 and problems[PID]["f_opt_kind"] == "exact"
    assert problems[NOISY]["f_opt_kind"] == "certified" and stats["below_f_opt"] == []


def test_the_paper_problem_has_no_blind_instance():
    with pytest.raises(ValueError, match="no blind instance"):
        suite_problem("paper/12/1", blind="k")


def test_a_damaged_blind_secret_is_refused_naming_its_file(tmp_path):
    from femu.studies.store import StoreError
    from femu.studies.study import run_study

    store = tmp_path / "s"
    store.mkdir()
    (store / ".blind").write_bytes(b"short")
    with pytest.raises(StoreError, match=r"\.blind: not this store's blind secret \(32 bytes\)"):
        run_study(["random-search"], "0", BUDGET, store, suite=PID, workers=0, progress=False)
    assert not (store / "runs").exists()


def test_the_best_method_ends_near_a_blind_certified_minimum_and_never_below_it(studies):
    """An independent check of the certificate made at study time: inverse eigensensitivity (the
    best method on these families) on the same blind instance ends within 1e-9 of it, not below."""
    from adapters.harness import run

    root, _, _, done = studies
    r = done["blind"][("random-search", NOISY)]
    p = suite_problem(NOISY, blind=_key((root / "blind" / ".blind").read_bytes(), NOISY),
                      certificate=(r.f_opt, r.f_opt_precision))
    best = run("sensitivity", p, 1000, 0)
    assert best.status == "ok" and best.best_f >= p.f_opt - p.f_opt_precision - 1e-15 * p.f_opt
    assert best.best_f - p.f_opt <= 1e-9 * max(p.f_opt, 1e-3), (best.best_f, p.f_opt)
