"""What a system built after another reuses from it, checked against the full computation it
replaces (the caches emptied, everything computed afresh), bit for bit:

- `element_matrices`: the elements a recent model holds as the same objects on the same nodes,
  sections and materials are copied, the rest computed (an element's matrices do not depend on
  which others are computed with it);
- `beam2d.to_global`: each distinct (local matrix, rotation) transformed once;
- `DofMap.of`: one map for the copies that keep a model's nodes, elements and supports;
- `sparse._pattern` and CHOLMOD's analysis: a kept pattern's entries looked up, not sorted anew,
  and its analysis reused;
- `AffineModel.nodal_rows`: kept with the DOF map;
- `elements.base.coordinates`: the last model's coordinates, for the same nodes and layout.

No tolerance: each reuse is the same arithmetic on the same numbers, so any difference at all
is a fault (the planar fingerprint, benchmarks/planar_fingerprint.py, holds the same)."""

import dataclasses

import numpy as np
import pytest

import fe_problem as fp
from fe_problem import elements as elements_mod
from fe_problem import sparse as sparse_mod
from fe_problem import terms as terms_mod
from fe_problem.dofs import SPACE_FRAME
from fe_problem.elements import base as base_mod
from fe_problem.elements import beam2d, element_blocks, element_matrices, formulation, formulations
from fe_problem.model import Spring, release_element_end


def _forget():
    elements_mod._KEPT.clear()
    terms_mod._MAPS.clear()
    sparse_mod._PATTERNS.clear()
    sparse_mod._ANALYSES.clear()
    base_mod._KEPT_COORDINATES = None


def _direct(model):
    """Every element's matrices straight from its formulation, one group per formulation."""
    k_dof = 2 * model.layout.per_node
    k, m = np.zeros((len(model.elements), k_dof, k_dof)), np.zeros((len(model.elements), k_dof, k_dof))
    for name in dict.fromkeys(e.formulation for e in model.elements):
        rows = [i for i, e in enumerate(model.elements) if e.formulation == name]
        form = formulation(name, model.layout)
        els = [model.elements[i] for i in rows]
        k[rows], m[rows] = form.stiffness(model, els), form.mass(model, els)
    return k, m


def _bits(a, b):
    return a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes()


@pytest.fixture(scope="module")
def planar():
    """A split 3-bay 5-storey frame with a cracked element: over 200 free DOFs (sparse path)."""
    m = fp.split_elements(fp.regular_frame(3, 5, floor_mass_kg=400.0), 3)
    return m.replace(elements=tuple(dataclasses.replace(e, crack_position=0.3, crack_stiffness=2e7) if e.id == 9
                                    else e for e in m.elements))


@pytest.fixture(scope="module")
def space():
    return fp.split_elements(fp.regular_frame_3d(2, 1, 2), 2)


def _copies(model):
    """Copies of `model` a diagnosis builds: a spring added, an end released, a modulus, a
    section changed under its name, the Timoshenko form."""
    e = model.elements[4]
    node = model.supports[0].node
    free = next(n for n in model.node_ids if n != node)
    sec = e.section
    thick = dataclasses.replace(model.sections[sec], area_m2=1.5 * model.sections[sec].area_m2)
    out = {
        "a spring": model.replace(springs=model.springs + (Spring(901, (free, "x"), None, 1e6),)),
        "an end released": release_element_end(model, e.id, e.node_j, 1e7,
                                                None if model.layout.dimension == 2 else ("rz",)),
        "a modulus": model.with_element_moduli({e.id: 0.8 * model.element_modulus_pa(e.id)}),
        "a section": model.replace(sections={**model.sections, sec: thick}),
    }
    if "timoshenko" in formulations(model.layout):
        out["timoshenko"] = fp.with_formulation(model, "timoshenko")
    return out


@pytest.mark.parametrize("which", ["planar", "space"])
def test_element_matrices_of_copies_are_computed_afresh_bit_for_bit(which, request):
    model = request.getfixturevalue(which)
    _forget()
    for name, copy in _copies(model).items():
        element_matrices(model)            # the model's matrices kept: the copy reuses what it shares
        k, m = element_matrices(copy)
        k_full, m_full = _direct(copy)
        assert _bits(k, k_full) and _bits(m, m_full), name
        assert not k.flags.writeable      # shared: read-only
    _forget()


def test_a_sections_dict_changed_in_place_is_not_taken_for_the_same(planar):
    """A frozen model's sections dict can still be changed in place: the kept matrices are
    taken only while it holds the same values."""
    _forget()
    model = planar.replace(sections=dict(planar.sections))
    element_matrices(model)
    name = model.elements[0].section
    model.sections[name] = dataclasses.replace(model.sections[name], area_m2=2.0 * model.sections[name].area_m2)
    k, m = element_matrices(model)
    k_full, m_full = _direct(model)
    assert _bits(k, k_full) and _bits(m, m_full)
    _forget()


def test_a_subset_of_elements_has_the_matrices_of_the_whole(planar):
    """The property the reuse rests on, on every size of subset: computing some elements alone
    gives what computing them with all the others gives."""
    k_all, m_all = _direct(planar)
    form = formulation("euler-bernoulli", planar.layout)
    rng = np.random.default_rng(3)
    for size in (1, 2, 3, 7, 15, 16, 17, 40):
        rows = np.sort(rng.choice(len(planar.elements), size, replace=False))
        els = [planar.elements[r] for r in rows]
        assert _bits(form.stiffness(planar, els), k_all[rows]) and _bits(form.mass(planar, els), m_all[rows])


def test_to_global_of_repeated_elements_is_the_plain_product():
    """Many repeated (a, T) pairs and some distinct ones, signed zeros among them: the same bytes
    as the einsum over the whole stack."""
    rng = np.random.default_rng(5)
    a = rng.standard_normal((6, 6, 6))
    a[1, 2, 3] = -0.0
    angle = rng.uniform(0, np.pi, 6)
    pick, turn = rng.integers(0, 6, 200), rng.integers(0, 6, 200)  # a and T repeat independently
    local, t = a[pick], beam2d.rotation(np.cos(angle), np.sin(angle))[turn]
    local[7] = rng.standard_normal((6, 6))  # one of its own
    plain = np.einsum("eki,ekl,elj->eij", t, local, t)
    assert _bits(beam2d.to_global(local, t), plain)
    few = slice(0, beam2d.DISTINCT_MIN - 1)
    assert _bits(beam2d.to_global(local[few], t[few]), plain[few])


def test_to_global_groups_by_bits_not_by_hash(monkeypatch):
    """Every pair hashed alike (a zero multiplier): the grouping check finds the pairs differ
    and the stack is transformed whole, the same bytes."""
    rng = np.random.default_rng(6)
    local = rng.standard_normal((40, 6, 6))
    angle = rng.uniform(0, np.pi, 40)
    t = beam2d.rotation(np.cos(angle), np.sin(angle))
    monkeypatch.setattr(beam2d, "_MIX", np.zeros_like(beam2d._MIX))
    assert _bits(beam2d.to_global(local, t), np.einsum("eki,ekl,elj->eij", t, local, t))


def test_a_dof_map_is_shared_only_by_copies_with_the_same_nodes_elements_and_supports(planar):
    _forget()
    base = terms_mod.DofMap.of(planar)
    copies = _copies(planar)
    assert terms_mod.DofMap.of(copies["a section"]) is base
    assert terms_mod.DofMap.of(copies["a spring"]) is base
    released = terms_mod.DofMap.of(copies["an end released"])
    assert released is not base and released.n_total == base.n_total + 1
    _forget()
    fresh = terms_mod.DofMap._build(copies["a section"])[0]
    assert _bits(fresh.element_dofs, base.element_dofs) and _bits(fresh.free, base.free)


def _same_map(a, b):
    assert (a.n_nodal, a.n_total) == (b.n_nodal, b.n_total)
    assert _bits(a.element_dofs, b.element_dofs) and _bits(a.free, b.free)
    assert a.node_dofs.keys() == b.node_dofs.keys() and all(_bits(a.node_dofs[k], b.node_dofs[k]) for k in a.node_dofs)
    assert (a.hinges, a.hinge_stiffness, a.relative) == (b.hinges, b.hinge_stiffness, b.relative)
    assert a.extended.keys() == b.extended.keys()


@pytest.mark.parametrize("which", ["planar", "space"])
def test_a_dof_map_built_from_a_kept_one_is_the_one_built_alone(which, request):
    """A copy on the same nodes (an end released, a modulus, a support freed, two ends
    released one after the other) takes the kept map's node DOFs and the ends of the elements
    it shares: the map built with nothing kept, field by field."""
    model = request.getfixturevalue(which)
    copies = _copies(model)
    sup = model.supports[0]
    copies["a support freed"] = model.replace(supports=(dataclasses.replace(sup, directions=sup.directions[:1]),)
                                              + model.supports[1:])
    e = model.elements[7]
    copies["two ends released"] = release_element_end(copies["an end released"], e.id, e.node_i, 3e6,
                                                      None if model.layout.dimension == 2 else ("ry",))
    for name, copy in copies.items():
        _forget()
        terms_mod.DofMap.of(model)
        terms_mod.DofMap.of(copies["an end released"])
        kept = terms_mod.DofMap.of(copy)
        _same_map(kept, terms_mod.DofMap._build(copy)[0])
    _forget()


@pytest.mark.parametrize("which", ["planar", "space"])
def test_a_system_built_after_others_is_the_one_built_alone(which, request):
    """Systems of a model's copies built one after another (the pattern, its analysis, the DOF
    map and the element matrices reused), each against itself built with the caches emptied:
    K, M, the zero-energy count and the modes, bit for bit."""
    model = request.getfixturevalue(which)
    e = model.elements[2]
    e0 = model.element_modulus_pa(e.id)
    builds = {"model": lambda: fp.AffineModel(model),
              "a modulus parameter": lambda: fp.AffineModel(model, (fp.Parameter("modulus", (e.id,), 0.1 * e0, e0, e0),))}
    for name, copy in _copies(model).items():
        builds[name] = lambda copy=copy: fp.AffineModel(copy)
    _forget()
    after = {name: build() for name, build in builds.items()}
    coords = tuple((n, "x") for n in model.node_ids[1::3])
    for name, build in builds.items():
        _forget()
        alone = build()
        s = after[name]
        assert s.path == "sparse"
        theta = s.x0[None, :]
        assert _bits(s.stiffness(theta)[0].toarray(), alone.stiffness(theta)[0].toarray()), name
        assert _bits(s.mass(theta)[0].toarray(), alone.mass(theta)[0].toarray()), name
        assert s.n_rigid == alone.n_rigid
        lam, phi = s.eigen(theta, 6, vectors=True)
        lam_alone, phi_alone = alone.eigen(theta, 6, vectors=True)
        assert _bits(lam, lam_alone) and _bits(phi, phi_alone), name
        rows = s.nodal_rows(coords)
        assert _bits(rows, alone.nodal_rows(coords)) and _bits(s.nodal_rows(coords), rows)
    _forget()


def test_a_pattern_is_reused_only_when_its_entries_are_exactly_filled():
    sparse_mod._PATTERNS.clear()
    keys = np.array([0, 5, 5, 12, 3, 0])
    (lin, rows, cols, indptr), slot = sparse_mod._pattern(keys, 4)
    (lin2, *_), slot2 = sparse_mod._pattern(keys[::-1].copy(), 4)
    assert lin2 is lin and _bits(lin[slot2], keys[::-1].copy())
    for other in (np.array([0, 5, 12]), np.array([0, 5, 12, 3, 7])):  # one entry short, one more
        (lin3, *_), slot3 = sparse_mod._pattern(other, 4)
        expect, inverse = np.unique(other, return_inverse=True)
        assert lin3 is not lin and _bits(lin3, expect) and _bits(slot3, inverse.ravel())
    sparse_mod._PATTERNS.clear()


def test_a_parameter_at_the_models_value_takes_the_models_count_and_shift(planar, monkeypatch):
    """`AffineModel(model, params, like=system)`: a modulus, density or mass parameter at the
    model's own value is the model at x0, so the model's zero-energy count and shift are taken
    and the count's eigen-solve is not made. Against the system built without `like` (its own
    count): the same count, the shift to 1e-12 relative (K and M at x0 are the same sums in
    another order), and the frequencies at sizes across the parameter's range to 1e-10 relative
    (the sparse path's accuracy requirement, sparse.ARPACK_TOL), the shapes to 1e-8 of their
    largest entry. A parameter away from the model's value does not match: the own count."""
    e = planar.elements[5]
    e0, rho0 = planar.element_modulus_pa(e.id), planar.materials[e.material].density_kg_m3
    node = planar.masses[0].node
    m0 = sum(lm.mass_kg for lm in planar.masses if lm.node == node)
    model_system = fp.AffineModel(planar)
    cases = [(fp.Parameter("modulus", (e.id,), 1e-3 * e0, e0, e0), [0.3 * e0, 0.9 * e0]),
             (fp.Parameter("density", (e.id,), 0.0, 3 * rho0, rho0), [0.5 * rho0, 2.5 * rho0]),
             (fp.Parameter("mass", (node,), 0.0, m0 + 5e3, m0), [m0 + 100.0, m0 + 4e3])]
    for par, sizes in cases:
        own = fp.AffineModel(planar, (par,))
        with monkeypatch.context() as patch:
            patch.setattr(sparse_mod.SparseModalSolver, "_lowest", lambda *a: pytest.fail("count solved"))
            taken = fp.AffineModel(planar, (par,), like=model_system)
        assert taken._solver.sigma == model_system._solver.sigma
        assert taken.n_rigid == own.n_rigid and taken.n_elastic == own.n_elastic
        assert abs(taken._solver.sigma - own._solver.sigma) <= 1e-12 * abs(own._solver.sigma)
        theta = np.array(sizes + [par.initial])[:, None]
        lam, phi = taken.eigen(theta, 8, vectors=True)
        lam_own, phi_own = own.eigen(theta, 8, vectors=True)
        np.testing.assert_allclose(lam, lam_own, rtol=1e-10, atol=0)
        assert np.abs(phi - phi_own).max() <= 1e-8 * np.abs(phi_own).max()
    away = fp.Parameter("modulus", (e.id,), 1e-3 * e0, e0, 0.5 * e0)
    assert fp.AffineModel(planar, (away,), like=model_system)._solver.sigma == \
        fp.AffineModel(planar, (away,))._solver.sigma


def test_element_blocks_of_some_rows_are_those_of_the_whole_model(planar):
    """The one helper that computes element matrices from their formulations (element_matrices
    and an edited system's blocks both call it): a mix of formulations, rows in any order, bit
    for bit the matrices computed per formulation over the whole model."""
    model = planar.replace(elements=tuple(dataclasses.replace(e, formulation="timoshenko") if e.id % 3 == 0 and e.id != 9 else e
                                          for e in planar.elements))
    k_all, m_all = _direct(model)
    rows = [17, 3, 0, 9, 30, 4]
    k, m = element_blocks(model, rows)
    assert _bits(k, k_all[rows]) and _bits(m, m_all[rows])
    _forget()
    k, m = element_matrices(model)
    assert _bits(k, k_all) and _bits(m, m_all)
    _forget()


def test_to_global_of_any_transformation_is_the_plain_product():
    """Transformations that agree in their first row (the cos, sin of `rotation`) but not
    elsewhere are different pairs: the same bytes as the einsum over the whole stack."""
    rng = np.random.default_rng(8)
    n = 3 * beam2d.DISTINCT_MIN
    local = np.repeat(rng.standard_normal((1, 6, 6)), n, axis=0)
    t = np.repeat(beam2d.rotation(np.array([0.6]), np.array([0.8])), n, axis=0)
    t[1::2, 3:, 3:] = rng.standard_normal((3, 3))  # half the stack: another lower block
    t[2::4, 2, 2] = 2.0
    assert _bits(beam2d.to_global(local, t), np.einsum("eki,ekl,elj->eij", t, local, t))


def test_nodal_rows_of_a_generator_then_of_a_list():
    """DOFs given as a generator (read once) and then as a list: each nodal DOF's row is the
    free DOF of that name, both times."""
    _forget()
    system = fp.AffineModel(fp.regular_frame(2, 2), solver="dense")
    names = system._dof_names()
    nodes = [4, 5, 6]
    for dofs in (((n, "x") for n in nodes), [(n, "x") for n in nodes]):
        rows = system.nodal_rows(dofs)
        assert [names[r] for r in rows] == [f"node {n} x" for n in nodes]
    _forget()


def test_a_space_copy_on_a_planar_models_nodes_has_its_own_coordinates():
    """A planar model and its space copy (`replace(layout=...)`) share one nodes tuple: each
    system, and a later copy of the space model, reads coordinates in its own layout (3
    columns for the space model), not the last model's."""
    _forget()
    planar = fp.regular_frame(2, 2)
    sections = {k: dataclasses.replace(s, inertia_m4=None, iy_m4=s.inertia_m4, iz_m4=s.inertia_m4,
                                       j_m4=2 * s.inertia_m4) for k, s in planar.sections.items()}
    space = planar.replace(layout=SPACE_FRAME, sections=sections,
                           elements=tuple(dataclasses.replace(e, orientation=(0.0, 0.0, 1.0)) for e in planar.elements),
                           supports=tuple(dataclasses.replace(s, directions=("x", "y", "z", "rx", "ry", "rz"))
                                          for s in planar.supports), measured_dofs=())
    assert space.nodes is planar.nodes
    built = [fp.AffineModel(m, solver="dense") for m in (space, planar, space.replace(name="copy"))]
    for model, system in zip((space, planar, space), built):
        _forget()
        alone = fp.AffineModel(model, solver="dense")
        assert system.n_rigid == alone.n_rigid
        assert _bits(system.stiffness(system.x0[None, :]), alone.stiffness(alone.x0[None, :]))
    copy = space.replace(name="another copy")
    base_mod.coordinates(planar)
    assert _bits(base_mod.coordinates(copy), np.asarray(space.coordinates))
    _forget()


def test_a_pattern_moved_first_while_another_is_kept_meanwhile(planar):
    """Another thread keeps a pattern between `_pattern`'s read of the kept list and its
    moving the matched pattern first (simulated: the comparison of sizes inserts one): the
    matched pattern ends first, each pattern is kept once, and no more than `_KEEP_PATTERNS`."""
    sparse_mod._PATTERNS.clear()
    a, b, other = np.array([0, 5, 12]), np.array([0, 3, 5, 12]), np.array([1, 6])
    sparse_mod._pattern(b, 4)
    sparse_mod._pattern(a, 4)  # kept: [a, b]
    (other_lin, *_), _ = sparse_mod._pattern(other, 4)
    meanwhile = sparse_mod._PATTERNS.pop(0)
    assert meanwhile[1] is other_lin

    class Meddling(int):
        done = False

        def __ne__(self, m):
            if not Meddling.done:
                Meddling.done = True
                sparse_mod._PATTERNS.insert(0, meanwhile)  # another thread's pattern, kept meanwhile
            return int(self) != m

    (lin, *_), slot = sparse_mod._pattern(b[[3, 0, 2, 1]].copy(), Meddling(4))
    assert Meddling.done and _bits(lin[slot], b[[3, 0, 2, 1]])
    kept = sparse_mod._PATTERNS
    assert kept[0][1] is lin
    assert len(kept) <= sparse_mod._KEEP_PATTERNS and len({id(e) for e in kept}) == len(kept)
    assert any(e is meanwhile for e in kept)
    sparse_mod._PATTERNS.clear()


def test_like_on_another_model_is_not_taken(planar, monkeypatch):
    """`like` built on a copy with a spring added (the same free DOFs, another K) or a support
    freed (other free DOFs, other rigid motions): the system makes its own count, the same as
    without `like`; the solver's own check refuses the other system's matrices too."""
    e = planar.elements[5]
    e0 = planar.element_modulus_pa(e.id)
    par = fp.Parameter("modulus", (e.id,), 1e-3 * e0, e0, e0)
    free = next(n for n in planar.node_ids if n not in {s.node for s in planar.supports})
    sup = planar.supports[0]
    copies = {"a spring": planar.replace(springs=planar.springs + (Spring(901, (free, "x"), None, 1e9),)),
              "a support freed": planar.replace(supports=(dataclasses.replace(sup, directions=("y",)),)
                                                + planar.supports[1:])}
    own = fp.AffineModel(planar, (par,))
    for name, copy in copies.items():
        like = fp.AffineModel(copy)
        assert like.path == "sparse" and not like.parameters
        assert not own._solver._same_at_x0(like._solver, own.x0), name
        counted = []
        lowest = sparse_mod.SparseModalSolver._lowest
        with monkeypatch.context() as patch:
            patch.setattr(sparse_mod.SparseModalSolver, "_lowest",
                          lambda self, *a: counted.append(1) or lowest(self, *a))
            taken = fp.AffineModel(planar, (par,), like=like)
        assert counted, name
        assert taken.n_rigid == own.n_rigid and taken._solver.sigma == own._solver.sigma, name
