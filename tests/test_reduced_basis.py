"""The shared reduced basis of the diagnosis's candidate searches (fe_problem/diagnosis/reduced.py),
checked against full sparse solves of each candidate's own system (`Candidate.forward`: the
model edited and assembled, solved by ARPACK), and the fits that use it against fits without it.

The data hide a crack built differently from every candidate: the element split in two and
joined by a rotational spring (`split_element`)."""

import dataclasses

import numpy as np
import pytest

import fe_problem as fp
from fe_problem.assembly import solver_path
from fe_problem.diagnosis.candidates import all_candidates, reduced_linear
from fe_problem.diagnosis.core import calibrate
from fe_problem.diagnosis.fit import CHECK_FACTOR, chi2_batch, class_promises, fit, look_along, promise
from fe_problem.diagnosis.groups import distributed_candidates
from fe_problem.diagnosis.reduced import SharedBasis

#: Frequencies of the reduced solve against the full one, relative: over each candidate's whole
#: grid (to a mass of half the model's at one node, a modulus down to 0.1 of its value; measured
#: at most 3e-7, a mass), and for a change of stiffness (a modulus, a weak zone, a spring) up to
#: half its upper size (measured at most 2e-9). The basis serves the fit's search only; its
#: answer is solved in full (`fit.fit`).
FREQ_RTOL_GRID, FREQ_RTOL_STIFFNESS = 1e-6, 1e-8


@pytest.fixture(scope="module")
def case():
    """The cracked frame's calibration (`cracked_calibration`) and its candidates."""
    cal = cracked_calibration()
    return cal, all_candidates(cal.setting)


def cracked_calibration():
    """A 2-bay 8-storey frame, each member in three elements (sparse path), measured with a
    crack at the middle of element 20 (a rotational spring of half the element's E I / L): its
    calibration."""
    model = fp.split_elements(fp.regular_frame(2, 8, floor_mass_kg=2000.0), 3).replace(name="frame2x8")
    e = model.element(20)
    ei_l = model.element_modulus_pa(20) * model.sections[e.section].inertia_m4 / model.element_length_m(20)
    truth = fp.split_element(model, 20, 0.5, 0.5 * ei_l)
    data = fp.synthetic_measurement(truth, 8, freq_noise=0.002, shape_noise=0.02, model_name=model.name, seed=1)
    cal = calibrate(model, data, 0.002, 0.02)
    assert solver_path(len(cal.setting.local.dofmap.free)) == "sparse"
    return cal


def _one(cands, kind, profile="uniform", **where):
    return next(c for c in cands if c.kind == kind and c.meta.get("profile", "uniform").startswith(profile)
                and all(c.location.get(k) == v for k, v in where.items()))


@pytest.mark.parametrize("kind,profile,where", [
    ("stiffness_loss", "uniform", {"element": 20}),         # a member's loss
    ("stiffness_loss", "zone", {"element": 20}),            # a crack: a weak zone, nonlinear in a
    ("stiffness_loss", "zone", {"element": 1}),             # a crack at a column's foot
    ("stiffness_gain", "uniform", {"element": 41}),
    ("added_mass", "uniform", {"node": 30}),
    ("distributed_mass", "uniform", {"element": 50}),
    ("boundary_stiffness", "uniform", {"node": 12, "direction": "x"}),  # a support's spring
])
def test_reduced_frequencies_agree_with_full_sparse_solves(case, kind, profile, where):
    cal, cands = case
    c = _one(cands, kind, profile, **where)
    reduced = c.reduced()
    assert reduced is not None
    a = np.asarray(c.grid, dtype=float)
    hz_full, sh_full = c.forward(a)
    hz, sh = reduced(a)
    assert hz.shape == hz_full.shape and sh.shape == sh_full.shape
    np.testing.assert_allclose(hz, hz_full, rtol=FREQ_RTOL_GRID, atol=0.0)
    if "mass" not in kind:
        half = a <= 0.5 * c.upper
        np.testing.assert_allclose(hz[half], hz_full[half], rtol=FREQ_RTOL_STIFFNESS, atol=0.0)
    # shapes are first order in the basis' error (frequencies second): held to 1e-4 of the largest entry
    np.testing.assert_allclose(sh, sh_full, atol=1e-4 * np.abs(sh_full).max())


def test_the_basis_holds_the_calibrated_model_exactly(case):
    cal, cands = case
    c = _one(cands, "stiffness_loss", "uniform", element=20)
    hz, sh = c.reduced()(np.zeros(1))
    np.testing.assert_allclose(hz[0], cal.hz0, rtol=1e-12)
    np.testing.assert_allclose(sh[0], cal.sh0, atol=1e-10 * np.abs(cal.sh0).max())


def test_the_ritz_shapes_are_the_signed_products_at_the_coordinates(case):
    """`SharedBasis._pairs` forms v y as (y^T v^T)^T, mode by mode in memory: its shapes are
    `signed(v @ y)` at the measured rows, written out here, to rounding (bit for bit with the
    OpenBLAS of this project's venv), for batches of one and six, with the joint's extra row of
    y ignored; and exactly for the calibrated modes themselves (y selects them: products with 0
    and 1), whose largest entries a symmetric frame ties in sign."""
    from fe_problem.solver import signed, take_rows

    cal, _ = case
    basis = cal.setting.basis
    v, k = basis.phi, basis.n_modes
    rng = np.random.default_rng(2)
    for b in (1, 6):
        y = rng.standard_normal((b, v.shape[1] + 1, k))
        _, sh = basis._pairs(v, np.ones((b, k)), y)
        ref = take_rows(signed(v @ y[:, :v.shape[1]]), basis.rows)
        np.testing.assert_allclose(sh, ref, rtol=0, atol=1e-14 * np.abs(ref).max())
    pick = np.zeros((1, v.shape[1], k))
    pick[0, np.arange(k), np.arange(k)] = 1.0
    hz, sh = basis._pairs(v, basis.lam[None, :k], pick)
    np.testing.assert_array_equal(sh[0], take_rows(signed(v[None, :, :k]), basis.rows)[0])
    np.testing.assert_array_equal(hz[0], fp.modal.frequencies_hz(basis.lam[:k]))


def _counted(c):
    """The candidate with its own (full) forward counting the sizes it solves."""
    n = [0]

    def forward(a):
        n[0] += len(np.atleast_1d(a))
        return c.forward(a)
    return dataclasses.replace(c, forward=forward), n


@pytest.mark.parametrize("kind,profile,where", [
    ("stiffness_loss", "zone 0.50", {"element": 20}),
    ("stiffness_loss", "uniform", {"element": 20}),
    ("added_mass", "uniform", {"node": 30}),
])
def test_a_fit_with_the_basis_is_the_full_fit(case, kind, profile, where):
    """The fit's search runs on the basis (fewer full solves than the grid has sizes), its answer
    is solved with the candidate's own system: chi^2 and scale are the full model's at its a,
    and a moves from the fit without the basis by less than the search's own tolerance
    (xatol = 1e-4 of the bracket's upper end)."""
    cal, cands = case
    c = _one(cands, kind, profile, **where)
    assert_fit_is_the_full_fit(cal, c, len(c.grid) - 1)


def assert_fit_is_the_full_fit(cal, c, most_full: int) -> None:
    """`fit` of candidate `c` takes the reduced path (1 to `most_full` full solves), its chi^2 and
    scale are the full model's at its a, and a and chi^2 are those of the fit without the basis
    (a within the search's xatol, 1e-4 of the bracket's upper end; chi^2 within 1e-6)."""
    c, n_full = _counted(c)
    with_basis = fit(cal.obs, c)
    assert 0 < n_full[0] <= most_full  # the reduced path was taken
    without = fit(cal.obs, dataclasses.replace(c, reduced=None))
    assert with_basis.a > 0.0 and with_basis.chi2 < cal.base.chi2
    full_at_a = chi2_batch(cal.obs, c, np.array([with_basis.a]))[0]
    assert with_basis.chi2 == full_at_a.chi2 and with_basis.s == full_at_a.s
    grid = np.asarray(c.grid)
    bracket_top = grid[grid > max(with_basis.a, without.a)].min()
    assert abs(with_basis.a - without.a) < 1e-4 * bracket_top  # the search's xatol
    assert abs(with_basis.chi2 - without.chi2) <= 1e-6 * without.chi2


@pytest.mark.parametrize("kind,profile,where", [
    ("stiffness_loss", "zone 0.50", {"element": 20}),
    ("stiffness_loss", "uniform", {"element": 20}),
    ("added_mass", "uniform", {"node": 30}),
])
def test_look_along_with_the_basis_is_the_full_look(case, kind, profile, where):
    """`look_along` searches its sizes on the basis (fewer full solves than sizes) and promises
    the full model's chi^2 drop at the size the full solves of every size pick."""
    cal, cands = case
    c, n_full = _counted(_one(cands, kind, profile, **where))
    sizes = np.asarray(c.grid)[1::3]
    drop, a = look_along(cal.obs, c, cal.base)
    assert 0 < n_full[0] < len(sizes)
    full = chi2_batch(cal.obs, c, sizes, pairing=cal.base.pairing)
    best = min(full, key=lambda f: f.chi2)
    assert a == best.a and drop > 0.0
    np.testing.assert_allclose(drop, cal.base.chi2 - best.chi2, rtol=1e-10)


def test_groups_and_trends_are_fitted_on_their_spread_basis_to_the_full_fit(case):
    """A group's or a trend's change is not held by the shared basis (reduced.py: frequencies
    off by up to 9.6e-2): none has a reduced forward. Its fit searches on its own spread basis
    (`Candidate.reduced_screen`, `fit._search_forward`) and one batch of full solves confirms
    it: the classes the diagnosis fits (the 8 `class_promises` keeps) and every trend take that
    path with at most 6 full solves (the grid has 16 sizes; solved in full, 20 to 34 with the
    scalar search), the chi^2 and scale are the full model's at its a, and a and chi^2 are those
    of the fit solved in full (a within the search's xatol, 1e-4 of the bracket's upper end, as
    a local candidate's; chi^2 within 1e-6 relative)."""
    cal, _ = case
    groups = distributed_candidates(cal.setting)
    assert {d.kind for d in groups} >= {"group_stiffness_loss", "group_stiffness_gain", "stiffness_trend"}
    assert all(d.reduced is None for d in groups)
    promises = class_promises(cal.obs, groups, cal.base, 8)
    chosen = [i for i, _ in _kept(promises, 8)] + [i for i, d in enumerate(groups) if d.kind == "stiffness_trend"]
    for i in dict.fromkeys(chosen):
        c, n_full = _counted(groups[i])
        with_basis = fit(cal.obs, c, promises[i][1])
        assert 0 < n_full[0] <= 6, (c.label, n_full[0])
        without = fit(cal.obs, dataclasses.replace(c, reduced_screen=None), promises[i][1])
        assert n_full[0] - 6 > len(c.grid)  # the fit without the basis solved the grid and its search
        full_at_a = chi2_batch(cal.obs, c, np.array([with_basis.a]))[0]
        assert with_basis.chi2 == full_at_a.chi2 and with_basis.s == full_at_a.s
        assert_same_fit(c, with_basis, without)


def assert_same_fit(c, with_basis, without) -> None:
    """a within the search's xatol (1e-4 of the bracket's upper end: the grid's first size above
    both, or its last) and chi^2 within 1e-6 relative."""
    grid = np.asarray(c.grid)
    above = grid[grid > max(with_basis.a, without.a)]
    hi = above.min() if above.size else grid[-1]
    assert abs(with_basis.a - without.a) < 1e-4 * hi, (c.label, with_basis.a, without.a)
    assert abs(with_basis.chi2 - without.chi2) <= 1e-6 * without.chi2, (c.label, with_basis.chi2, without.chi2)


def storey_loss_calibration(storey: int, ratio: float):
    """The 2 x 8 frame of `cracked_calibration` (sparse path) measured with the columns of one
    storey (the vertical elements whose midpoint lies between its floors, 3 m apart) at `ratio`
    of their modulus, each element's own modulus set in the model (`Element.youngs_modulus_pa`),
    not by a candidate: its calibration."""
    model = fp.split_elements(fp.regular_frame(2, 8, floor_mass_kg=2000.0), 3).replace(name="frame2x8")
    columns = set()
    for e in model.elements:
        i, j = model.node(e.node_i), model.node(e.node_j)
        if i.x == j.x and 3.0 * (storey - 1) < 0.5 * (i.y + j.y) < 3.0 * storey:
            columns.add(e.id)
    assert len(columns) == 9  # three columns, each in three elements
    elements = tuple(dataclasses.replace(e, youngs_modulus_pa=ratio * model.materials[e.material].youngs_modulus_pa)
                     if e.id in columns else e for e in model.elements)
    truth = model.replace(elements=elements)
    data = fp.synthetic_measurement(truth, 8, freq_noise=0.002, shape_noise=0.02, model_name=model.name, seed=1)
    cal = calibrate(model, data, 0.002, 0.02)
    assert solver_path(len(cal.setting.local.dofmap.free)) == "sparse"
    return cal


@pytest.mark.parametrize("storey", [1, 4])
def test_a_storey_losing_most_of_its_stiffness_is_fitted_on_its_spread_basis_to_the_full_fit(storey):
    """Where the spread basis is weakest (its error grows with a): a storey's columns at 0.2 of
    their modulus, a loss of 0.8 of the class's largest 0.9. The storey's loss fitted with its
    spread basis (`fit._search_forward`) is the fit solved in full (`assert_same_fit`; today the
    basis's search is confirmed, with 5 full solves against 24), and it finds the loss (a within
    0.01 of 0.8)."""
    cal = storey_loss_calibration(storey, 0.2)
    c = next(g for g in distributed_candidates(cal.setting) if g.label == f"group_stiffness_loss@group=storey{storey}")
    with_basis = fit(cal.obs, c)
    without = fit(cal.obs, dataclasses.replace(c, reduced_screen=None))
    assert abs(without.a - 0.8) < 0.01, without.a
    assert_same_fit(c, with_basis, without)


#: The spread basis (`SharedBasis.spread`) against full solves at the sizes the classes are ranked
#: on (the screen's step and the look along's sizes, to 0.42 of the largest), in the modes the
#: ranking pairs (the calibrated model's pairing, held): frequencies relative (measured at most
#: 1.7e-5 on this frame, a quadratic trend over the height at its largest look; the unpaired
#: modes above are held worse, to 1.3e-2, and enter nothing), chi^2 absolute (measured at most
#: 0.56, the same trend, where chi^2 is 1.7e4).
SPREAD_FREQ_RTOL, SPREAD_CHI2_ATOL = 1e-4, 1.0


def test_the_spread_basis_agrees_with_full_solves_where_the_classes_are_ranked(case):
    """Every group and trend class of the frame: the reduced screen's frequencies (the paired
    modes) and chi^2 at the step and the look along's sizes against the class's own system
    solved in full."""
    cal, _ = case
    groups = distributed_candidates(cal.setting)
    worst_f = worst_c = 0.0
    for c in groups:
        sizes = np.concatenate([[c.step], c.grid[1::3]])
        reduced = c.reduced_screen()
        hz, sh = reduced(sizes)
        hz_full, sh_full = c.forward(sizes)
        paired = cal.base.pairing[cal.base.pairing >= 0]
        worst_f = max(worst_f, float(np.max(np.abs(hz[:, paired] / hz_full[:, paired] - 1.0))))
        approx = [f.chi2 for f in chi2_batch(cal.obs, c, sizes, pairing=cal.base.pairing, forward=reduced)]
        exact = [f.chi2 for f in chi2_batch(cal.obs, c, sizes, pairing=cal.base.pairing)]
        worst_c = max(worst_c, float(np.max(np.abs(np.subtract(approx, exact)))))
    assert len(groups) > 20
    assert worst_f < SPREAD_FREQ_RTOL and worst_c < SPREAD_CHI2_ATOL, (worst_f, worst_c)


def _kept(promises, n_keep):
    order = sorted(range(len(promises)), key=lambda i: -promises[i][0])[:n_keep]
    return [(i, promises[i]) for i in order]


@pytest.mark.parametrize("n_keep", [3, 8])
def test_the_classes_kept_are_those_of_full_solves(case, n_keep):
    """`class_promises` ranks on the spread basis and solves the best in full: the classes kept,
    their order and their promises (chi^2 drop, size) are those of every class solved in full,
    bit for bit, and it solved fewer than all in full."""
    cal, _ = case
    groups = distributed_candidates(cal.setting)
    full = [promise(cal.obs, c, cal.base) for c in groups]
    got = class_promises(cal.obs, groups, cal.base, n_keep)
    assert _kept(got, n_keep) == _kept(full, n_keep)
    assert sum(g == f for g, f in zip(got, full)) < len(groups)  # the others only ranked on the basis
    assert len(groups) > CHECK_FACTOR * n_keep


def test_a_misleading_reduced_screen_falls_back_to_full_solves(case):
    """A reduced screen that answers for other classes (each class given the basis of the class two
    places on: another group's loss for a loss, a gain for a gain; finite everywhere) ranks other
    classes first; the full solves of those it checks disagree with it, so every promise is
    solved in full: the same list as without a basis, bit for bit."""
    cal, _ = case
    groups = distributed_candidates(cal.setting)
    shifted = [dataclasses.replace(c, reduced_screen=groups[(k + 2) % len(groups)].reduced_screen)
               for k, c in enumerate(groups)]
    full = [promise(cal.obs, c, cal.base) for c in groups]
    misled = []
    for c in shifted:
        sizes = np.concatenate([[c.step], c.grid[1::3]])
        fits = chi2_batch(cal.obs, c, sizes, pairing=cal.base.pairing, forward=c.reduced_screen())
        assert all(np.isfinite(f.chi2) for f in fits)
        misled.append((cal.base.chi2 - min(f.chi2 for f in fits), 0.0))
    assert [i for i, _ in _kept(misled, 8)] != [i for i, _ in _kept(full, 8)]
    assert class_promises(cal.obs, shifted, cal.base, 8) == full


def _truncated(cal, c):
    """`c` with a reduced forward on a deliberately truncated basis: the calibrated model's
    modes alone, without the static corrections of the change."""
    basis = SharedBasis.__new__(SharedBasis)
    basis.__dict__.update(cal.setting.basis.__dict__)
    basis._basis = lambda r: basis.phi
    return dataclasses.replace(c, reduced=reduced_linear(type("S", (), {"basis": basis})(), c.term))


@pytest.mark.parametrize("kind,where", [("stiffness_loss", {"element": 20}), ("stiffness_loss", {"element": 57}),
                                        ("stiffness_gain", {"element": 89})])
def test_a_misleading_reduced_grid_gets_the_full_answer(case, kind, where):
    """On a truncated basis the reduced grid's best size is not the full grid's: the fit and
    the look along the grid are those without a basis, bit for bit."""
    cal, cands = case
    c = _truncated(cal, _one(cands, kind, "uniform", **where))
    grid = np.asarray(c.grid, dtype=float)
    approx = [f.chi2 for f in chi2_batch(cal.obs, c, grid, forward=c.reduced())]
    exact = [f.chi2 for f in chi2_batch(cal.obs, c, grid)]
    assert np.argmin(approx) != np.argmin(exact)  # the reduced grid misleads
    full = fit(cal.obs, dataclasses.replace(c, reduced=None))
    got = fit(cal.obs, c)
    assert (got.a, got.s, got.chi2) == (full.a, full.s, full.chi2)
    assert look_along(cal.obs, c, cal.base) == look_along(cal.obs, dataclasses.replace(c, reduced=None), cal.base)


def test_a_wrong_basis_is_caught_and_the_grid_solved_in_full(case):
    """A reduced forward that answers for another candidate (a mass far away) is refused by the
    grid's full solves: the fit is the full one, bit for bit."""
    cal, cands = case
    c = _one(cands, "stiffness_loss", "zone 0.50", element=20)
    other = _one(cands, "added_mass", "uniform", node=30).reduced
    wrong = dataclasses.replace(c, reduced=other)
    full = fit(cal.obs, dataclasses.replace(c, reduced=None))
    got = fit(cal.obs, wrong)
    assert (got.a, got.s, got.chi2) == (full.a, full.s, full.chi2)


@pytest.mark.parametrize("kind,profile,where", [
    ("stiffness_loss", "zone 0.50", {"element": 20}),       # a model built per size
    ("stiffness_loss", "uniform", {"element": 20}),          # one system, a modulus per size
    ("added_mass", "uniform", {"node": 30}),
])
def test_a_size_asked_again_is_the_size_solved_afresh(case, kind, profile, where):
    """`Candidate.forward` keeps the sizes it solved (candidates._Remembered): a size asked again,
    alone or in another batch, in another order, is bit for bit what a fresh candidate's own
    system gives for that size solved alone."""
    cal, _ = case
    c = _one(all_candidates(cal.setting), kind, profile, **where)
    sizes = np.asarray(c.grid, dtype=float)[[2, 5, 9, 12]]
    first = c.forward(sizes)
    solved = []
    solve = c.forward.solve
    c.forward.solve = lambda a: solved.append(len(a)) or solve(a)
    again = c.forward(np.array([sizes[3], sizes[1], 0.5 * (sizes[0] + sizes[1]), sizes[1]]))
    fresh = _one(all_candidates(cal.setting), kind, profile, **where)
    alone = [fresh.forward(np.array([v])) for v in (sizes[3], sizes[1], 0.5 * (sizes[0] + sizes[1]))]
    for k, want in enumerate((alone[0], alone[1], alone[2], alone[1])):
        assert np.array_equal(again[0][k], want[0][0]) and np.array_equal(again[1][k], want[1][0])
    assert np.array_equal(first[0][3], again[0][0]) and np.array_equal(first[1][1], again[1][1])
    assert solved == [1]  # only the new size was solved


@pytest.mark.parametrize("kind,profile,where", [
    ("stiffness_loss", "uniform", {"element": 20}),
    ("stiffness_gain", "uniform", {"element": 41}),
    ("added_mass", "uniform", {"node": 30}),
    ("joint_flexibility", "uniform", {}),
])
def test_a_candidate_found_by_its_label_is_the_listed_one(case, kind, profile, where):
    """The rounds rebuild a candidate by its label (`rounds._candidate_on`, which stops at the
    first match of `iter_candidates`): the same candidate `all_candidates` lists, its modes bit
    for bit."""
    from fe_problem.diagnosis.rounds import _candidate_on
    cal, cands = case
    listed = _one(cands, kind, profile, **where)
    found = _candidate_on(cal.setting.model, cal.setting, listed.key)
    assert found.label == listed.label and found.upper == listed.upper and found.step == listed.step
    assert np.array_equal(found.grid, listed.grid)
    a = np.asarray(listed.grid, dtype=float)[[3, 8]]
    for got, want in zip(found.forward(a), listed.forward(a)):
        assert np.array_equal(got, want)


def test_a_size_that_is_not_a_number_is_solved_not_looked_up():
    """A NaN size is no dictionary key (hash(nan) is per object since Python 3.10): the kept
    sizes (`candidates._Remembered`) pass a batch holding one to the solve as it is, which gives
    its rows (NaN for the NaN size), instead of failing on a key it just stored."""
    from fe_problem.diagnosis.candidates import _Remembered

    calls = []

    def forward(a):
        calls.append(np.array(a))
        return np.outer(a, [1.0, 2.0]), np.zeros((len(a), 2, 3))

    kept = _Remembered(forward)
    hz, shapes = kept(np.array([0.5, np.nan]))
    assert hz.shape == (2, 2) and shapes.shape == (2, 2, 3)
    assert np.array_equal(hz[0], [0.5, 1.0]) and np.isnan(hz[1]).all()
    assert len(calls) == 1 and np.array_equal(calls[0], [0.5, np.nan], equal_nan=True)


def test_which_candidates_bring_an_unpaired_mode_is_the_same_on_the_basis_as_in_full(case):
    """`fit.brings` (which candidates a round fits for a measured mode that pairs with nothing,
    rounds._next_cause) runs on the shared basis on the sparse path: the same answer as solving
    each candidate's grid in full. The data's first mode as if measured without a shape and 28 %
    below the calibrated model (outside the 30 % pairing window): a candidate that lowers it
    enough (a heavy mass, a loss) brings it; most do not."""
    import dataclasses

    from fe_problem.diagnosis.fit import brings, profiled

    cal, cands = case
    obs = cal.obs_all
    hz, shapes, has_shape = obs.frequencies_hz.copy(), obs.shapes.copy(), obs.has_shape.copy()
    hz[0], shapes[:, 0], has_shape[0] = 0.72 * cal.hz0[0], np.nan, False
    obs = dataclasses.replace(obs, frequencies_hz=hz, shapes=shapes, has_shape=has_shape)
    unpaired = np.flatnonzero(profiled(obs, cal.hz0, cal.sh0).pairing < 0)
    assert list(unpaired) == [0]
    sample = cands[::len(cands) // 60]
    on_basis = [brings(obs, c, unpaired) for c in sample]
    in_full = [any(bool((f.pairing[unpaired] >= 0).any()) for f in chi2_batch(obs, c, c.grid)) for c in sample]
    assert on_basis == in_full
    assert 0 < sum(in_full) < len(sample)
    assert any(b and c.reduced is not None for b, c in zip(on_basis, sample)), "no bringing candidate on the basis"


def test_the_models_own_system_is_built_once_and_solves_as_a_fresh_one(case, monkeypatch):
    """`Setting.system` (the calibration's system, kept for the first-order screen's baseline and the
    shared basis) and `Setting.modes0` (its modes, for the calibration and every candidate's size
    a = 0) give what a system built afresh gives, bit for bit; the screen's baseline is made once
    per model and pairing (`Setting.baselines`) and the screen from it is the screen from a fresh
    system and baseline."""
    from fe_problem.diagnosis import screening
    from fe_problem.diagnosis.candidates import Setting, solve

    cal, cands = case
    st = cal.setting
    fresh_st = Setting(st.model, st.coords, st.n_modes)  # nothing kept: builds its own
    kept = solve(st.system, np.zeros((1, 0)), st.coords, st.n_modes)
    fresh = solve(fp.AffineModel(st.model), np.zeros((1, 0)), st.coords, st.n_modes)
    np.testing.assert_array_equal(kept[0], fresh[0])
    np.testing.assert_array_equal(kept[1], fresh[1])
    np.testing.assert_array_equal(kept[0][0], cal.hz0)
    mine = st.modes0  # the model's modes solved once (`Setting.modes0`), each caller its own copy
    mine[0][:] = 0.0
    np.testing.assert_array_equal(st.modes0[0], fresh[0])
    np.testing.assert_array_equal(st.modes0[1], fresh[1])
    # a = 0 of a candidate whose size 0 is the unextended model: from the kept system
    for c in (next(x for x in cands if x.kind == "joint_flexibility"),
              next(x for x in cands if x.kind == "shear_deformation"),
              next(x for x in cands if x.kind == "boundary_stiffness")):
        hz0, sh0 = c.forward(np.zeros(1))
        np.testing.assert_array_equal(hz0[0], fresh[0][0])
        np.testing.assert_array_equal(sh0[0], fresh[1][0])
    termed = [c for c in cands if c.term is not None][::7]
    real, made = screening.baseline, []
    monkeypatch.setattr(screening, "baseline", lambda *a, **k: made.append(1) or real(*a, **k))
    once = screening.screen_all(cal.obs, cal.base, st.model, st.coords, st.n_modes, termed, fresh_st)
    again = screening.screen_all(cal.obs, cal.base, st.model, st.coords, st.n_modes, termed, fresh_st)
    assert len(made) == 1 and len(fresh_st.baselines) == 1  # the second screen made none
    from_scratch = screening.screen_all(cal.obs, cal.base, st.model, st.coords, st.n_modes, termed)
    assert len(made) == 2
    on_the_calibration = screening.screen_all(cal.obs, cal.base, st.model, st.coords, st.n_modes, termed, st)
    assert len(termed) > 50 and max(d for d, _ in once) > 0.0
    for other in (again, from_scratch, on_the_calibration):
        np.testing.assert_array_equal(np.array(other, dtype=float), np.array(once, dtype=float))


def test_shear_sizes_on_the_kept_timoshenko_copy_are_the_models_built_afresh(case):
    """The shear candidate's sizes are built on one Timoshenko copy of the model: the modes are
    those of the model built from scratch at each size (its formulation and sections edited)."""
    import dataclasses as dc

    from fe_problem.diagnosis.candidates import solve_model
    from fe_problem.model import with_formulation

    cal, cands = case
    st = cal.setting
    c = next(x for x in cands if x.kind == "shear_deformation")
    sizes = np.array([0.5, 3.0])
    hz, sh = c.forward(sizes)
    for k, a in enumerate(sizes):
        model = with_formulation(st.model, "timoshenko")
        model = model.replace(sections={n: dc.replace(v, shear_coefficient=v.shear_coefficient / a)
                                        for n, v in st.model.sections.items()})
        hz_ref, sh_ref = solve_model(model, st)
        np.testing.assert_array_equal(hz[k], hz_ref[0])
        np.testing.assert_array_equal(sh[k], sh_ref[0])
    assert np.abs(hz[1] - cal.hz0).max() > 1e-3 * cal.hz0.min()  # the sizes do change the modes


def test_the_model_form_screen_takes_the_first_screens_baseline_then_drops_it(case, monkeypatch):
    """The first screen and the model-form screen of the calibrated model share one baseline (one
    eigen-solve and one bordered factorisation per paired mode); after the model-form screen,
    its last use, the baseline's adjoint blocks are let go."""
    from fe_problem.diagnosis import screening
    from fe_problem.diagnosis.core import model_form_fits, screen_candidates

    cal, cands = case
    cal.setting.baselines.clear()
    real, made = screening.baseline, []
    monkeypatch.setattr(screening, "baseline", lambda *a, **k: made.append(1) or real(*a, **k))
    screen_candidates(cal, [c for c in cands if c.term is not None][:40])
    assert len(made) == 1 and len(cal.setting.baselines) == 1
    forms = model_form_fits(cal)
    assert len(made) == 1 and cal.setting.baselines == {} and len(forms) > 0
