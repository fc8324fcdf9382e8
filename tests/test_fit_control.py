"""The fit control's shortcuts (fe_problem/diagnosis/rounds.py, fit.py) against the computation each
replaces, on the cracked 2 x 8 frame of tests/test_reduced_basis.py (sparse path; the data hide a
crack built as a rotational spring inside an element, not by any candidate)."""

import dataclasses

import numpy as np
import pytest
from scipy.optimize import minimize_scalar

from fe_problem.diagnosis import rounds
from fe_problem.diagnosis.candidates import all_candidates
from fe_problem.diagnosis.fit import _bracket, _refined, bounded_search, chi2_batch, fit

from test_reduced_basis import cracked_calibration


@pytest.fixture(scope="module")
def case():
    cal = cracked_calibration()
    return cal, all_candidates(cal.setting)


@pytest.mark.parametrize("label", ["stiffness_loss@element=20", "joint_flexibility@node=14,element=20",
                                   "added_mass@node=30"])
def test_a_first_round_candidate_asked_again_on_its_model_is_the_one_built_afresh(case, label):
    """While the rounds run (`rounds._listed`), a candidate asked for by its label on the model
    the first round was built on is that round's own object (its solved sizes and its shared
    basis kept), and its fit (the first round's a as the hint, as `_joint_refit` and `_finish`
    refit it) is the fit of the candidate built afresh, bit for bit; a weak zone's label and
    any other model are built afresh, and the list is gone after the rounds."""
    cal, cands = case
    st, model = cal.setting, cal.setting.model
    listed = {c.label: c for c in cands}
    assert label in listed, sorted(k for k in listed if k.startswith(label.split("@")[0]))[:5]
    kind = label.split("@")[0]
    fresh = rounds._candidate_on(model, st, kind, label)
    assert fresh is not listed[label]
    with rounds._listed(model, cands):
        first = fit(cal.obs, listed[label])
        again = rounds._candidate_on(model, st, kind, label)
        assert again is listed[label]
        zone = next(c.label for c in cands if "(zone" in c.label)
        assert rounds._candidate_on(model, st, "stiffness_loss", zone) is not listed[zone]
        other = model.replace(name="copy")
        assert rounds._candidate_on(other, st, kind, label) is not listed[label]
        got = fit(cal.obs, again, first.a)
    assert not rounds._LISTED
    want = fit(cal.obs, fresh, first.a)
    assert (got.a, got.s, got.chi2) == (want.a, want.s, want.chi2)
    assert np.array_equal(got.residuals, want.residuals) and np.array_equal(got.pairing, want.pairing)


def _minima():
    """Functions with a known minimiser c inside a grid's bracket: smooth and convex, steep away
    from it (cosh), skewed (a logarithm's square) and kinked (|x - c|^1.5), on random grids
    (none flat to fourth order: there double precision cannot tell points within xatol apart,
    and no search can find c to xatol; a chi^2 is quadratic about its minimum)."""
    rng = np.random.default_rng(7)
    shapes = [lambda x, c, w: w * (x - c) ** 2 + 1.0, lambda x, c, w: w * (np.cosh(3.0 * (x - c)) - 1.0) + 2.0,
              lambda x, c, w: w * np.log(x / c) ** 2, lambda x, c, w: w * abs(x - c) ** 1.5 - 3.0,
              lambda x, c, w: w * ((x - c) ** 2 + 0.3 * (x - c) ** 4) + 0.5]
    out = []
    while len(out) < 200:
        c, w, g = rng.uniform(0.05, 0.95), rng.uniform(0.2, 50.0), shapes[len(out) % len(shapes)]
        grid = np.sort(np.concatenate([[0.01, 1.0], rng.uniform(0.01, 1.0, 12)]))
        f = (lambda g, c, w: lambda x: float(g(x, c, w)))(g, c, w)
        k = int(np.argmin([f(x) for x in grid]))
        if 0 < k < len(grid) - 1:
            out.append((f, c, grid, k))
    return out


def test_the_search_started_from_the_grid_finds_the_minimum_with_fewer_evaluations():
    """`fit.bounded_search` (Brent's bounded method started from the grid's best point and its
    neighbours) against the known minimiser, with the search's xatol (1e-4 of the bracket's
    upper end, as `fit._bracket` sets it): within the bound Brent's stopping rule gives a
    unimodal function, the final bracket's width 4 tol (tol = sqrt(eps) |x| + xatol / 3), on
    every one of 200 functions, as scipy's bounded method from scratch is, and in fewer
    evaluations in all (measured 17 % fewer on the test script's 300)."""
    evals = {"scipy": 0, "grid": 0}
    for f, c, grid, k in _minima():
        lo, hi = float(grid[k - 1]), float(grid[k + 1])
        xatol = 1e-4 * hi
        n = [0]

        def counted(x):
            n[0] += 1
            return f(x)

        x_scipy = minimize_scalar(counted, bounds=(lo, hi), method="bounded", options={"xatol": xatol}).x
        evals["scipy"], n[0] = evals["scipy"] + n[0], 0
        x = bounded_search(counted, (lo, f(lo)), (float(grid[k]), f(grid[k])), (hi, f(hi)), xatol)
        evals["grid"] += n[0]
        bound = 4.0 * (np.sqrt(2.2e-16) * c + xatol / 3.0)
        assert abs(x - c) <= bound and abs(x_scipy - c) <= bound, (x, x_scipy, c, xatol)
        assert f(x) <= f(grid[k])
    assert evals["grid"] < 0.9 * evals["scipy"], evals


@pytest.mark.parametrize("label", ["stiffness_loss@element=20", "joint_flexibility@node=14,element=20"])
def test_a_reduced_search_started_from_the_grid_is_scipys_search_within_its_tolerance(case, label):
    """On the candidate's reduced forward (the fit's search on the shared basis), the search
    started from the reduced grid ends within xatol of scipy's bounded search from scratch, at
    a chi^2 no higher than the grid's best point's, in no more evaluations."""
    cal, cands = case
    c = next(x for x in cands if x.label == label)
    reduced = c.reduced()
    grid = np.asarray(c.grid, dtype=float)
    on_basis = chi2_batch(cal.obs, c, grid, forward=reduced)
    k = int(np.argmin([f.chi2 for f in on_basis]))
    assert 0 < k < len(grid) - 1
    lo, hi, xatol = _bracket(grid, k)
    n = [0]

    def chi2_at(v):
        n[0] += 1
        return chi2_batch(cal.obs, c, np.array([v]), forward=reduced)[0].chi2

    x_scipy = minimize_scalar(chi2_at, bounds=(lo, hi), method="bounded", options={"xatol": xatol}).x
    n_scipy, n[0] = n[0], 0
    x, at_x = _refined(cal.obs, dataclasses.replace(c, forward=_counting(c, n)), grid, k, reduced, on_basis)
    assert n[0] == 0  # the search ran on the reduced forward only
    n[0] = 0
    x = bounded_search(chi2_at, (lo, on_basis[k - 1].chi2), (float(grid[k]), on_basis[k].chi2),
                       (hi, on_basis[k + 1].chi2), xatol)
    assert n[0] <= n_scipy
    assert abs(x - x_scipy) <= xatol and at_x.chi2 <= on_basis[k].chi2


def _counting(c, n):
    def forward(a):
        n[0] += len(np.atleast_1d(a))
        return c.forward(a)
    return forward
