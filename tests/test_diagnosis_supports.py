"""Support conditions as model-form classes (diagnosis/supports.py; issues 19 and 24).

The candidates are checked against independent routes: the members' stiffness at a support
against the closed forms of a beam's end (4 E I / L, E A / L, 12 E I / L^3, G J / L); a support
released onto a rotational spring against the same base built as the column's end released
(a hinge DOF of the element, tied by a spring) and, on the shipped space frame, against OpenSees
(a zeroLength spring between the fixed base and the column); a pinned base held by a spring
against the fixed base with a released column end; the held rotation's first-order term
against the assembled models' difference.

The diagnosis end to end (`femu diagnose` and `diagnose()`), the truths built independently of
the candidate (the planar one by the reference FE of diagnosis_cases.py with the column's end
released; the space one by OpenSees with the base's rotations unfixed, or a zeroLength spring):
a base that is really pinned or sprung is answered as a support condition (the best class by
evidence is the answer: the cause, the extended model and the verdict are its, and the warning
says so); a correct model gets no support alarm (no-effect data, and data with a real mass
elsewhere).
"""

from __future__ import annotations

import json

import numpy as np
import pytest

import diagnosis_cases as dc
import fe_problem as fp
from fe_problem.diagnosis import diagnose
from fe_problem.diagnosis.core import calibrate
from fe_problem.diagnosis.modelform import model_form_candidates
from fe_problem.diagnosis.supports import member_stiffness, support_candidates
from fe_problem.jsonutil import dumps
from femu.cli import main

PORTAL = dc.PORTAL
AL = PORTAL.materials["aluminium"]
BAR = PORTAL.sections["bar"]


def _setting(model, truth=None, seed=1):
    data = fp.synthetic_measurement(truth or model, 8, dofs=model.measured_dofs, seed=seed, model_name=model.name)
    return calibrate(model, data, 0.002, 0.02).setting


def _hz(model, n):
    return fp.modal_analysis(model, n).frequencies_hz


def _candidate(st, node, direction, mode):
    return next(c for c in support_candidates(st) if c.location == {"node": node, "direction": direction}
                and c.meta["profile"] == mode)


# -- the candidates against independent routes ------------------------------------------------

def test_member_stiffness_at_a_support_is_the_beams_end_stiffness():
    st = _setting(PORTAL)
    e, length = AL.youngs_modulus_pa, 0.15  # the portal's column elements: vertical, 0.15 m
    ei = e * BAR.inertia_m4
    assert member_stiffness(PORTAL, st.local, 1, "rz") == pytest.approx(4 * ei / length, rel=1e-12)
    assert member_stiffness(PORTAL, st.local, 1, "y") == pytest.approx(e * BAR.area_m2 / length, rel=1e-12)
    assert member_stiffness(PORTAL, st.local, 1, "x") == pytest.approx(12 * ei / length**3, rel=1e-12)
    # the space frame's base: a vertical column, bending about both axes, torsion about z
    m3 = fp.load_model("frame3d")
    col, length = m3.sections["column"], m3.element_length_m(1)
    steel = m3.materials["steel"]
    st3 = _setting(m3)
    got = {d: member_stiffness(m3, st3.local, 1, d) for d in ("x", "y", "z", "rx", "ry", "rz")}
    bending = sorted(4 * steel.youngs_modulus_pa * i / length for i in (col.iy_m4, col.iz_m4))
    np.testing.assert_allclose(sorted([got["rx"], got["ry"]]), bending, rtol=1e-12)
    assert got["rz"] == pytest.approx(steel.shear_modulus_pa * col.j_m4 / length, rel=1e-12)
    assert got["z"] == pytest.approx(steel.youngs_modulus_pa * col.area_m2 / length, rel=1e-12)


def test_every_support_direction_is_a_candidate_on_planar_and_space_models():
    st = _setting(PORTAL)
    forms = model_form_candidates(st)
    sup = [c for c in forms if c.kind == "support_condition"]
    assert sorted((c.location["node"], c.location["direction"]) for c in sup) == \
        sorted((n, d) for n in (1, 13) for d in ("x", "y", "rz"))
    assert all(c.meta["profile"] == "released" for c in sup)
    # a pinned base: its rotation can be held; a space frame: every direction and the rotations together
    pinned = fp.regular_frame(1, 2, base="pinned")
    held = [c for c in support_candidates(_setting(pinned)) if c.meta["profile"] == "held"]
    assert sorted(c.location["node"] for c in held) == [1, 2] and {c.location["direction"] for c in held} == {"rz"}
    m3 = fp.load_model("frame3d")
    sup3 = model_form_candidates(_setting(m3))
    assert {c.kind for c in sup3} == {"support_condition"}  # geometry classes are planar only
    assert len(sup3) == 9 * 7 and sum(c.location["direction"] == "rx+ry+rz" for c in sup3) == 9


@pytest.mark.parametrize("ratio", [0.0, 0.05, 1.0, 20.0])
def test_a_released_base_rotation_is_the_column_end_on_a_spring(ratio):
    # the candidate frees the support's rz and ties the node to ground by a spring; the truth ties
    # the column's own end to the fixed node by a spring (a hinge DOF of the element): one physics
    st = _setting(PORTAL)
    cand = _candidate(st, 13, "rz", "released")
    k_members = member_stiffness(PORTAL, st.local, 13, "rz")
    a = 1.0 / (1.0 + ratio)  # k = k_members (1 - a) / a
    hz, _ = cand.forward(np.array([a]))
    truth = fp.release_element_end(PORTAL, 12, 13, ratio * k_members)
    np.testing.assert_allclose(hz[0], _hz(truth, hz.shape[1]), rtol=1e-9)
    est = cand.estimate(a, 1.0)
    assert est["rotational_stiffness_nm_per_rad"] == pytest.approx(ratio * k_members, rel=1e-12, abs=1e-9)
    assert est["fixity"] == pytest.approx(ratio / (1 + ratio), rel=1e-12)
    assert est["condition"] == {0.0: "pinned", 0.05: "spring", 1.0: "spring", 20.0: "spring"}[ratio]
    assert cand.extend(a).supports[-1] == fp.model.Support(13, ("x", "y"))
    np.testing.assert_allclose(_hz(cand.extend(a), hz.shape[1]), hz[0], rtol=1e-9)
    # a = 0: the model as it is
    np.testing.assert_array_equal(cand.forward(np.array([0.0]))[0][0], _hz(PORTAL, hz.shape[1]))


def test_a_released_translation_is_the_node_on_a_spring_to_a_grounded_twin():
    # the truth: the support no longer holds x at node 1, which is tied by a model spring to a new
    # grounded node (diagnosis_cases.springs_truth), not by a spring parameter to ground
    from fe_problem.diagnosis import plausibility

    st = _setting(PORTAL)
    cand = _candidate(st, 1, "x", "released")
    k_members = member_stiffness(PORTAL, st.local, 1, "x")
    for ratio in (0.3, 4.0):
        a = 1.0 / (1.0 + ratio)
        hz, _ = cand.forward(np.array([a]))
        unheld = PORTAL.replace(supports=(fp.model.Support(1, ("y", "rz")), PORTAL.supports[1]))
        truth = dc.springs_truth(unheld, [(1, "x")], [ratio * k_members])
        np.testing.assert_allclose(hz[0], _hz(truth, hz.shape[1]), rtol=1e-9)
        est = cand.estimate(a, 1.0)
        assert est["stiffness_n_per_m"] == pytest.approx(ratio * k_members, rel=1e-12)
        assert plausibility.check(PORTAL, cand.kind, cand.location, est) is None
    # a translation is released no further than a spring of k_members / 999; below 1 % it is flagged
    assert cand.upper == pytest.approx(0.999)
    est = cand.estimate(cand.upper, 1.0)
    assert est["condition"] == "free" and est["stiffness_ratio"] == pytest.approx(1 / 999)
    why = plausibility.check(PORTAL, cand.kind, cand.location, est)
    assert why is not None and "node 1" in why and "hardly there" in why
    # a rotation released as far is a pinned support: plausible
    rot = _candidate(st, 1, "rz", "released")
    assert plausibility.check(PORTAL, rot.kind, rot.location, rot.estimate(1.0, 1.0)) is None


@pytest.mark.parametrize("ratio", [0.1, 3.0])
def test_a_held_pinned_base_is_the_fixed_base_with_a_sprung_column_end(ratio):
    pinned, fixed = fp.regular_frame(1, 2, base="pinned"), fp.regular_frame(1, 2, base="fixed")
    st = _setting(pinned)
    cand = _candidate(st, 1, "rz", "held")
    k_members = member_stiffness(pinned, st.local, 1, "rz")
    a = ratio / (1.0 + ratio)  # k = k_members a / (1 - a)
    hz, _ = cand.forward(np.array([a, 1.0]))
    column = next(e.id for e in fixed.elements if 1 in (e.node_i, e.node_j))
    truth_fixed = fixed.replace(supports=(fixed.supports[0], pinned.supports[1]))  # node 2 stays pinned
    np.testing.assert_allclose(hz[0], _hz(fp.release_element_end(truth_fixed, column, 1, ratio * k_members),
                                          hz.shape[1]), rtol=1e-9)
    np.testing.assert_allclose(hz[1], _hz(truth_fixed, hz.shape[1]), rtol=1e-12)
    assert cand.estimate(1.0, 1.0)["condition"] == "fixed"


def test_the_held_rotations_first_order_term_is_the_assembled_difference():
    pinned = fp.regular_frame(1, 2, base="pinned")
    st = _setting(pinned)
    cand = _candidate(st, 2, "rz", "held")
    term = cand.term()
    h = 1e-6
    k0 = fp.AffineModel(cand.extend(0.0), solver="dense").k0
    system = fp.AffineModel(cand.extend(h), solver="dense")
    pos = np.full(system.dofmap.n_total, -1)
    pos[system.dofmap.free] = np.arange(system.n_free)
    dk = np.zeros_like(k0)
    rows = pos[term.dofs]
    dk[np.ix_(rows, rows)] = term.dk
    np.testing.assert_allclose(dk, (system.k0 - k0) / h, rtol=1e-5, atol=1e-9 * np.abs(k0).max())
    assert np.abs(term.dk).max() > 0


@pytest.mark.parametrize("model_name, node, direction", [("portal", 1, "rz"), ("portal", 13, "x"),
                                                         ("portal", 1, "y"), ("frame3d", 5, "rx+ry+rz")])
def test_the_released_supports_reaction_term_is_the_exact_first_order_change(model_name, node, direction):
    # the first-order eigenvalue and shape changes the sparse path screens with (screening.py, from
    # the reaction term) against the exact modes of the candidate at a small size, differenced
    from fe_problem.diagnosis.screening import first_order_modes

    model = PORTAL if model_name == "portal" else fp.load_model("frame3d")
    st = _setting(model)
    cand = _candidate(st, node, direction, "released")
    n = 6
    lam0, phi0, dlam, dshape = first_order_modes(fp.AffineModel(model), st.coords, n, [cand.term()])
    h = 1e-5  # a spring 1e5 times the members': smaller steps drown in the stiff system's rounding
    hz, sh = cand.forward(np.array([0.0, h]))
    lam = (2 * np.pi * hz[:, :n]) ** 2
    np.testing.assert_allclose(lam[0], lam0, rtol=1e-10)
    np.testing.assert_allclose(dlam[0], (lam[1] - lam[0]) / h, rtol=1e-3, atol=1e-6 * lam0.max())
    assert np.abs(dlam[0]).max() > 1e-3 * lam0.max()  # the support carries these modes: a real change
    signs = np.sign(np.sum(sh[1, :, :n] * sh[0, :, :n], axis=0))  # the solver's sign of each shape
    np.testing.assert_allclose(dshape[0], (sh[1, :, :n] * signs - sh[0, :, :n]) / h,
                               rtol=0, atol=5e-3 * np.abs(dshape[0]).max())


def _opensees_frame3d(fixed=None, releases=None, n_modes=8, seed=7, freq_noise=0.001, shape_noise=0.01,
                      shapes_out=False):
    """The shipped space frame solved by OpenSees with base supports `fixed` {node: 6 ints} and
    column-end `releases` (test_beam3d.opensees_modes: a zeroLength spring per released global
    rotation 4-6), measured at the model's DOFs with seeded noise."""
    from test_beam3d import Frame, opensees_modes
    from test_frame3d import frame_of, measured

    model = fp.load_model("frame3d")
    frame = frame_of(model)
    fx = dict(frame.fixed)
    fx.update(fixed or {})
    f, shapes = opensees_modes(Frame(frame.nodes, frame.members, fx, frame.masses), False, n_modes, releases=releases)
    if shapes_out:
        return f, shapes
    return measured(model, list(frame.nodes), f, shapes, seed, freq_noise, shape_noise,
                    meta={"source": "OpenSeesPy", "freq_noise": freq_noise, "shape_noise": shape_noise})


def test_space_base_released_in_its_rotations_matches_opensees_zero_length_springs():
    m3 = fp.load_model("frame3d")
    st = _setting(m3)
    cand = _candidate(st, 5, "rx+ry+rz", "released")
    a = 0.6
    hz, _ = cand.forward(np.array([a, 1.0]))
    k = {d: member_stiffness(m3, st.local, 5, d) * (1 - a) / a for d in ("rx", "ry", "rz")}
    f_os, _ = _opensees_frame3d(releases={(5, 5): {4: k["rx"], 5: k["ry"], 6: k["rz"]}}, n_modes=hz.shape[1],
                                shapes_out=True)
    np.testing.assert_allclose(hz[0], f_os, rtol=1e-8)
    pinned_os, _ = _opensees_frame3d(fixed={5: (1, 1, 1, 0, 0, 0)}, n_modes=hz.shape[1], shapes_out=True)
    np.testing.assert_allclose(hz[1], pinned_os, rtol=1e-8)
    assert cand.estimate(1.0, 1.0)["condition"] == "pinned"


# -- the diagnosis end to end --------------------------------------------------------------

def _support_named(record: dict, node: int) -> bool:
    """The record names a support condition at `node` as its answer: the best class by evidence,
    the answer (family model_form) and the cause are that class, the model-form warning says it is
    the answer, and the extended model is the one with that support."""
    best = record["evidence"]["classes"][0]
    at = f"support_condition@node={node},"
    warned = any(w.startswith("model form: " + at) and "it is the answer" in w for w in record["warnings"])
    answer = record["answer"]
    answered = (record["cause"]["kind"] == "support_condition" and record["cause"]["location"]["node"] == node
                and record["cause"]["label"] == best["label"] == answer["label"] and answer["family"] == "model_form")
    return best["label"].startswith(at) and warned and answered and at in record["extended_model"]["name"]


def _cli(tmp_path, capsys, data: fp.ModalData, model=None) -> dict:
    """`femu diagnose DATA --json` (with the model file written and passed, as a user does)."""
    argv = [] if model is None else ["--model", str(fp.save_model(model, tmp_path / f"{model.name}.model.json"))]
    path = tmp_path / "measured.modal.json"
    fp.save_modal_data(data, path)
    assert main(["diagnose", str(path), "--json", *argv]) == 0
    return json.loads(capsys.readouterr().out)


@pytest.mark.parametrize("node, column, seed", [(1, 1, 3), (13, 12, 8)])
def test_femu_diagnose_names_a_sprung_planar_base(node, column, seed, tmp_path, capsys):
    """A portal whose base at `node` is a rotational spring (the column's end released onto it, a
    random stiffness sized to move a frequency by 2-5 %): `femu diagnose` ranks the support
    condition at that node first by evidence and says so, its stiffness within 20 % of the
    truth's; no confident answer without that flag."""
    rng = np.random.default_rng(seed)
    k_members = 4 * AL.youngs_modulus_pa * BAR.inertia_m4 / 0.15
    target = float(rng.uniform(2.0, 5.0))
    truth = dc._sized(lambda k: fp.release_element_end(PORTAL, column, node, k), target, 0.05 * k_members,
                      1e3 * k_members, PORTAL)
    k_true = truth.element(column).release_i if column == 1 else truth.element(column).release_j
    data = fp.synthetic_measurement(truth, 8, dofs=PORTAL.measured_dofs, freq_noise=dc.FREQ_NOISE,
                                    shape_noise=dc.SHAPE_NOISE, seed=seed, model_name="portal.model.json")
    record = _cli(tmp_path, capsys, data, PORTAL)
    assert _support_named(record, node), (record["warnings"], record["evidence"]["classes"][:3])
    best = record["evidence"]["classes"][0]
    assert best["estimate"]["condition"] == "spring"
    assert best["estimate"]["rotational_stiffness_nm_per_rad"] == pytest.approx(k_true, rel=0.2)


@pytest.mark.parametrize("node, column, seed", [(1, 1, 1), (13, 12, 4)])
def test_diagnose_answers_a_pinned_planar_base(node, column, seed):
    """A portal base really pinned (the reference FE: its column's end released with no spring,
    the support itself kept; a 25 % shift of the first mode): the support at that node released in
    rz, pinned, is first by evidence and it is the answer, decisively, adequate. The local search
    stops after its first cause (a loss at the column's foot; without the early stop it went on to
    four causes, 32 s of CPU against 2.7 s, adequate: a confident wrong answer), and a warning says
    why."""
    truth = fp.release_element_end(PORTAL, column, node, 0.0)
    data = fp.synthetic_measurement(truth, 8, dofs=PORTAL.measured_dofs, freq_noise=dc.FREQ_NOISE,
                                    shape_noise=dc.SHAPE_NOISE, seed=seed, model_name=PORTAL.name)
    record = json.loads(dumps(diagnose(PORTAL, data)))
    assert _support_named(record, node), (record["warnings"], record["evidence"]["classes"][:3])
    best = record["evidence"]["classes"][0]
    assert best["label"] == f"support_condition@node={node},direction=rz(released)"
    assert best["estimate"]["condition"] == "pinned" and best["estimate"]["fixity"] < 0.01
    assert record["answer"]["decisive"] and record["answer"]["estimate"]["condition"] == "pinned"
    assert record["adequate"] and best["label"] in record["goodness_of_fit"]["explanation"]
    assert len(record["causes"]) == 1 and record["causes"][0]["kind"] != "support_condition"
    assert any(w.startswith("the local search stopped after its first cause: the model-form class "
                            + best["label"]) for w in record["warnings"])


def test_diagnose_names_a_pinned_space_base_from_opensees(tmp_path, capsys):
    """The shipped space frame with its corner column base (node 1) pinned in OpenSees (rotations
    unfixed): `femu diagnose` ranks the support at node 1 released in its rotations, pinned, first
    by evidence, and says so."""
    record = _cli(tmp_path, capsys, _opensees_frame3d(fixed={1: (1, 1, 1, 0, 0, 0)}, seed=5))
    assert _support_named(record, 1), (record["warnings"], record["evidence"]["classes"][:3])
    best = record["evidence"]["classes"][0]
    assert best["label"] == "support_condition@node=1,direction=rx+ry+rz(released)"
    assert best["estimate"]["condition"] == "pinned" and best["n_parameters"] == 1


def test_diagnose_names_another_pinned_space_base_from_opensees():
    """The same with an edge column's base (node 8) pinned, other noise, through `diagnose()` with
    one round (`max_causes=1`, as the planar pinned case)."""
    record = json.loads(dumps(diagnose(fp.load_model("frame3d"), _opensees_frame3d(fixed={8: (1, 1, 1, 0, 0, 0)},
                                                                                  seed=9), max_causes=1)))
    assert _support_named(record, 8), (record["warnings"], record["evidence"]["classes"][:3])
    best = record["evidence"]["classes"][0]
    assert best["label"] == "support_condition@node=8,direction=rx+ry+rz(released)"
    assert best["estimate"]["condition"] == "pinned"
    assert record["cause"]["kind"] == "support_condition" and record["answer"]["decisive"]


def test_diagnose_names_a_sprung_space_base_from_opensees():
    """The centre column's base (node 5) on rotational springs (OpenSees zeroLength, half of the
    column's own end stiffness about each axis): the support at node 5 is first by evidence, its
    fixity near 1/3."""
    m3 = fp.load_model("frame3d")
    st = _setting(m3)
    k = {d: 0.5 * member_stiffness(m3, st.local, 5, d) for d in ("rx", "ry", "rz")}
    data = _opensees_frame3d(releases={(5, 5): {4: k["rx"], 5: k["ry"], 6: k["rz"]}}, seed=11)
    record = json.loads(dumps(diagnose(m3, data)))
    assert _support_named(record, 5), (record["warnings"], record["evidence"]["classes"][:3])
    assert record["evidence"]["classes"][0]["estimate"]["fixity"] == pytest.approx(1 / 3, abs=0.1)


@pytest.mark.parametrize("seed", [2, 5])
def test_no_support_alarm_on_a_correct_model(seed):
    """No-effect data of the portal (the reference FE, noise only), and data with a real lumped
    mass (with rotary inertia) at a beam node: no cause at a support, no support warning, and no
    support class first by evidence."""
    for truth in (PORTAL, fp.add_mass(PORTAL, 7, 0.08, inertia_kg_m2=0.08 * 0.02**2 / 6)):
        data = fp.synthetic_measurement(truth, 8, dofs=PORTAL.measured_dofs, freq_noise=dc.FREQ_NOISE,
                                        shape_noise=dc.SHAPE_NOISE, seed=seed, model_name=PORTAL.name)
        d = diagnose(PORTAL, data)
        assert not any("support_condition" in w for w in d.warnings), d.warnings
        assert d.cause.kind != "support_condition"
        assert not d.evidence.classes[0].label.startswith("support_condition"), d.evidence.classes[:2]
        if truth is not PORTAL:
            assert (d.cause.kind, d.cause.location) == ("added_mass", {"node": 7}), d.cause


@pytest.mark.parametrize("seed", [3, 4])
def test_no_support_alarm_on_the_correct_space_frame(seed):
    """No-effect data of the shipped space frame from OpenSees (its own supports, noise only): no
    support cause, no support warning, no support class first by evidence."""
    d = diagnose(fp.load_model("frame3d"), _opensees_frame3d(seed=seed))
    assert not any("support_condition" in w for w in d.warnings), d.warnings
    assert d.cause.kind != "support_condition"
    assert not d.evidence.classes[0].label.startswith("support_condition"), d.evidence.classes[:2]
