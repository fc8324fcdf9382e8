"""The problem suite (fe_problem.suite) and `femu suite`, through the public API and the CLI."""

import json

import numpy as np
import pytest

import fe_problem as fp
from fe_problem import suite as fs
from femu.cli import main


def test_ids_are_stable_and_parse_as_family_dimension_instance():
    ids = fp.suite_ids()
    # 126 planar ids, then the space-frame families (tests/test_suite3d.py pins the planar 126)
    assert ids == fp.suite_ids() and len(ids) == len(set(ids)) == 156
    assert ids[0] == "paper/12/1"
    for i in ids:
        family, dim, inst = i.split("/")
        assert family in fs.FAMILIES and int(dim) in fs.FAMILIES[family].dimensions and int(inst) >= 1
    dims = sorted({int(i.split("/")[1]) for i in ids if i.startswith("hframe-freq/")})
    assert dims == [12, 24, 48, 96, 192]
    assert sorted({int(i.split("/")[1]) for i in ids if i.startswith("frame-shape/")}) == [12, 24, 48, 96, 192]
    # an instance is a function of its id alone: pinned, since a change would silently change problems
    assert fs.id_seed("hframe-freq/12/1", "truth") == 6628707864742086067
    assert fp.suite_problem("hframe-freq/12/1").truth[:3] == pytest.approx([78760991311.45547, 72687743503.40878,
                                                                           79241417387.72], rel=1e-15)


def test_truths_are_pinned_by_the_id():
    a, b = fp.suite_problem("hframe-freq/12/2"), fp.suite_problem("hframe-freq/12/2")
    assert np.array_equal(a.truth, b.truth)
    assert not np.array_equal(a.truth, fp.suite_problem("hframe-freq/12/3").truth)
    assert np.all((a.truth >= a.xl) & (a.truth <= a.xu))


def test_select_suite_by_prefix_of_whole_parts():
    assert fp.select_suite("paper") == ["paper/12/1"]
    assert fp.select_suite("hframe-freq/48") == [f"hframe-freq/48/{k}" for k in range(1, 6)]
    # a family prefix is whole: hframe-freq does not select hframe-freq-noisy
    sel = fp.select_suite("hframe-freq")
    assert len(sel) == 25 and all(i.startswith("hframe-freq/") for i in sel)
    assert fp.select_suite("frame-shape/12/3, paper") == ["paper/12/1", "frame-shape/12/3"]
    assert fp.select_suite(["paper", "paper/12"]) == ["paper/12/1"]
    with pytest.raises(ValueError, match="'hframe-freq/13' matches no problem"):
        fp.select_suite("hframe-freq/13")
    with pytest.raises(ValueError, match="empty suite selection"):
        fp.select_suite(" , ")
    with pytest.raises(ValueError, match="unknown suite problem 'paper/12/2'"):
        fp.suite_problem("paper/12/2")


@pytest.mark.parametrize("pid", ["hframe-freq/12/1", "hframe-freq/12/4", "hframe-shape/12/2", "hframe-shape/24/5",
                                 "frame-shape/12/1", "frame-shape/24/3"])
def test_noise_free_instances_have_f_opt_zero_at_their_truth(pid):
    p = fp.suite_problem(pid)
    assert isinstance(p, fp.UpdatingProblem) and p.f_opt == 0.0 and p.f_opt_kind == "exact"
    assert p.name == pid and p.n_evals == 0
    j = p.evaluate(p.truth)[0]
    if p.shape_weight == 0:
        # frequencies only: the squared relative errors of frequencies equal to round-off
        assert 0.0 <= j < 1e-20
    else:
        # 1 - MAC of two identical shapes computes to 0 within a few 1e-16, clamped at 0: J >= 0
        assert 0.0 <= j < 1e-14
    assert p.evaluate(p.x0)[0] > 1e-6            # the initial model is not the truth
    near = np.clip(p.truth * (1 + 1e-4), p.xl, p.xu)
    assert p.evaluate(near)[0] > abs(j)


def test_noisy_instances_have_a_certified_minimum_below_the_truths_J(monkeypatch):
    from fe_problem.certify import certify_minimum

    q = fp.suite_problem("hframe-freq-noisy/12/3")
    assert q.shape_weight == 0 and q.f_opt_kind == "certified" and q.f_opt == 0.0
    assert 0 < q.f_opt_precision < fs.ZERO_BELOW and q.n_evals == 0
    assert q.evaluate(q.truth)[0] > 1e-6                 # the truth does not fit noisy data
    stored = fs.certificates()["hframe-freq-noisy/12/3"]
    c = certify_minimum(q, starts=stored["starts"] - 2, seed=0, truth=q.truth, max_nfev=stored["max_nfev"])
    assert c.f_min < fs.ZERO_BELOW and max(c.ends) == pytest.approx(max(stored["ends"]), rel=1e-6)
    assert float(np.sum(q.least_squares(c.x).residuals ** 2)) < fs.ZERO_BELOW   # J's frequency part at x
    p = fp.suite_problem("hframe-shape-noisy/12/3")
    j_truth = float(p.evaluate(p.truth)[0])
    assert p.f_opt_kind == "certified" and 0 < p.f_opt < 0.95 * j_truth
    assert fs.suite_entry("hframe-shape-noisy/12/3").f_opt == p.f_opt          # stored: known before building
    X = np.random.default_rng(0).uniform(p.xl, p.xu, (200, 12))
    assert np.all(p.evaluate(X) >= p.f_opt - p.f_opt_precision)
    # an instance not certified falls back to J(truth), an upper bound, and says so
    monkeypatch.setattr(fs, "certificates", lambda: {})
    r = fp.suite_problem("hframe-shape-noisy/12/3")
    assert r.f_opt_kind == "reference" and r.f_opt == j_truth and r.f_opt_precision is None


def test_paper_problem_is_the_published_one_with_its_best_known_value():
    p = fp.suite_problem("paper/12/1")
    ref = fp.UpdatingProblem("hframe", "paper")
    X = np.random.default_rng(0).uniform(p.xl, p.xu, (5, 12))
    assert np.array_equal(p.evaluate(X), ref.evaluate(X))
    assert p.f_opt == fs.PAPER_F_OPT and p.f_opt_kind == "certified" and "suite_fopt.py" in p.f_opt_how
    assert p.f_opt_precision == pytest.approx(1e-10 * fs.PAPER_F_OPT) and p.target_scale == fs.TARGET_SCALE["paper"]
    assert p.truth is None
    assert np.all(p.evaluate(X) > p.f_opt)


def test_every_dimension_is_listed_without_building_and_the_structures_scale():
    for pid in fp.select_suite("hframe-freq") + fp.select_suite("frame-shape"):
        e = fs.suite_entry(pid)
        assert e.n_var == int(pid.split("/")[1])
    for parts in (1, 2, 4, 8, 16):
        m = fs.split_hframe(parts)
        assert len(m.elements) == 12 * parts and len(fp.element_moduli(m)) == 12 * parts
        assert m.total_mass_kg() == pytest.approx(fp.load_model("hframe").total_mass_kg())
    for storeys in (4, 64):
        m = fs.storey_frame(storeys)
        assert len(m.elements) == 3 * storeys and len(m.measured_dofs) == 4 * storeys
    assert fs.suite_entry("hframe-shape/192/1").n_dof == 3 * (13 + 12 * 15)


@pytest.mark.parametrize("pid", ["hframe-shape/12/1", "frame-shape/96/1"])
def test_a_point_evaluates_at_dimensions_12_and_96(pid):
    p = fp.suite_problem(pid)
    n = int(pid.split("/")[1])
    assert p.n_var == n
    X = np.random.default_rng(1).uniform(p.xl, p.xu, (3, n))
    j = p.evaluate(X)
    assert j.shape == (3,) and np.all(np.isfinite(j)) and np.all(j > 0) and p.n_evals == 3
    assert abs(p.evaluate(p.truth)[0]) < 1e-14


def test_femu_suite_lists_every_problem(capsys):
    assert main(["suite", "--json"]) == 0
    rows = json.loads(capsys.readouterr().out)
    assert [r["id"] for r in rows] == list(fp.suite_ids())
    paper = rows[0]
    assert paper["n_var"] == 12 and paper["n_dof"] == 39 and paper["f_opt"] == fs.PAPER_F_OPT
    assert {"exact", "certified"} <= {r["f_opt_kind"] for r in rows} <= {"exact", "certified", "reference"}
    assert all(r["f_opt"] is None for r in rows if r["f_opt_kind"] == "reference")
    assert all(r["f_opt"] is not None and r["f_opt_precision"] is not None for r in rows
               if r["f_opt_kind"] == "certified")
    assert main(["suite", "frame-shape/12"]) == 0
    out = capsys.readouterr().out
    assert "frame-shape/12/5" in out and "5 problems" in out and "exact:" in out


def test_femu_suite_build_fills_noisy_references_and_bad_specs_fail_in_one_line(capsys):
    assert main(["suite", "hframe-freq-noisy/12/1", "--build", "--json"]) == 0
    (row,) = json.loads(capsys.readouterr().out)
    assert row["f_opt"] == fp.suite_problem("hframe-freq-noisy/12/1").f_opt
    assert main(["suite", "nope"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("femu suite: error: suite selection 'nope' matches no problem") and "\n" not in err


def test_j_cannot_go_negative_where_1_minus_mac_rounds_below_0():
    p = fp.suite_problem("frame-shape/12/2")
    raw = 1.0 - p.correlation(p.truth).mac              # 1 - MAC as computed: rounds below 0 here
    assert np.nanmin(raw) < 0                           # (their sum's sign depends on the BLAS kernel)
    j = p.evaluate(np.vstack([p.truth, p.truth]))
    assert np.all(j >= 0.0) and np.all(j < 1e-14)


def test_the_reference_solve_certifies_the_papers_f_opt_within_its_precision():
    from fe_problem.certify import certify_minimum

    p = fp.suite_problem("paper/12/1")
    c = certify_minimum(p, starts=3, seed=0)
    # independent of benchmarks/suite_fopt.py's sensitivity and CMA-ES runs: the same minimum
    assert abs(c.f_min - fs.PAPER_F_OPT) <= fs.PAPER_F_OPT_PRECISION
    # the starts end together, within J's own rounding noise there (an ulp-level spread: 6.5e-18
    # with one BLAS kernel, below 5.4e-18 with another)
    assert len(c.ends) == 4 and max(c.ends) - min(c.ends) <= c.noise
    assert float(p.evaluate(c.x)[0]) == pytest.approx(c.f_min, rel=1e-14)
