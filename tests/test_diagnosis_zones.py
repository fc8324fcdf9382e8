"""What the diagnosis fits is what it writes: the weak-zone stiffness loss (a crack's candidate)
and the spring to ground equal their extensions as model files, and the extended model of a
several-cause answer reproduces the final fit's chi^2. A suspension mode counts; a soft
support is placed at its node. Truths are built unlike the candidates (diagnosis_cases.py)."""

import numpy as np
import pytest

import fe_problem as fp
from diagnosis_cases import BUILDING, HFRAME, Case, crack_truth, diagnose_through_cli, soft_support_truth
from fe_problem.assembly import AffineModel
from fe_problem.diagnosis.candidates import Setting, all_candidates, solve
from fe_problem.diagnosis.fit import profiled
from fe_problem.diagnosis.residuals import Observations
from fe_problem.diagnosis.zones import zone_places


@pytest.fixture(scope="module")
def setting():
    return Setting(HFRAME, HFRAME.measured_dofs, 14)


def _modes(model, st):
    hz, sh = solve(AffineModel(model), np.zeros((1, 0)), st.coords, st.n_modes)
    return hz[0], sh[0]


@pytest.mark.parametrize("kind", ["stiffness_loss", "boundary_stiffness"])
def test_a_candidate_is_exactly_its_extension(setting, kind, tmp_path):
    """forward(a) is the modes of the model file extend(a) writes, for every size (zero: the model)."""
    cands = [c for c in all_candidates(setting, [kind]) if kind != "stiffness_loss" or "zone" in c.label]
    nominal_hz, _ = _modes(HFRAME, setting)
    for c in cands[::9]:
        sizes = np.array([0.0, 0.1 * c.upper, 0.9 * c.upper]) if kind == "stiffness_loss" else np.array([0.0, 0.05, 3.0])
        hz, shapes = c.forward(sizes)
        assert np.allclose(hz[0], nominal_hz, rtol=1e-12)
        for k, a in enumerate(sizes):
            model = fp.load_model(fp.save_model(c.extend(a), tmp_path / f"ext-{kind}.model.json")) if k else c.extend(a)
            ref_hz, ref_shapes = _modes(model, setting)
            order = np.argsort(hz[k])  # a spring's suspension mode is listed last (see boundary_stiffness)
            assert np.allclose(hz[k][order], ref_hz, rtol=1e-9), (c.label, a)
            assert np.allclose(np.abs(shapes[k][:, order]), np.abs(ref_shapes), atol=1e-8 * np.abs(ref_shapes).max())


@pytest.mark.parametrize("kind", ["added_mass", "distributed_mass", "joint_flexibility", "stiffness_loss",
                                  "stiffness_gain", "boundary_stiffness", "shear_deformation"])
def test_every_candidate_is_its_extension_on_a_model_with_floor_masses(kind):
    """On a user's building whose floor nodes carry lumped masses (a mass parameter is the node's
    whole lumped mass: the candidate must add to it), every kind's forward(a) is the modes of
    extend(a). The added mass at a floor node once replaced the floor's mass in the fit and
    added to it in the extension."""
    st = Setting(BUILDING, BUILDING.measured_dofs, 10)
    cands = all_candidates(st, [kind])
    assert cands
    for c in cands[:: max(len(cands) // 4, 1)]:
        sizes = np.array([0.05, 0.5]) * c.upper
        hz, shapes = c.forward(sizes)
        for k, a in enumerate(sizes):
            ref_hz, ref_shapes = _modes(c.extend(a), st)
            order = np.argsort(hz[k])
            assert np.allclose(hz[k][order], ref_hz, rtol=1e-9), (c.label, a, hz[k][order], ref_hz)
            assert np.allclose(np.abs(shapes[k][:, order]), np.abs(ref_shapes), atol=1e-7 * np.abs(ref_shapes).max())


def test_zones_stay_inside_the_element_and_away_from_its_ends():
    for e in HFRAME.elements:
        places = zone_places(HFRAME, e.id)
        assert len(places) == 7
        for start, end in places:
            assert 0.0 < start < end < 1.0 and end - start <= 0.2 + 1e-12
            assert 0.15 <= 0.5 * (start + end) <= 0.85


def test_a_spring_candidate_keeps_the_suspension_mode(setting):
    """On the free H-frame a spring to ground makes one rigid-body mode a suspension mode: the
    candidate's lowest frequency is that mode, as in the extended model, never dropped."""
    c = next(c for c in all_candidates(setting, ["boundary_stiffness"]) if c.location == {"node": 9, "direction": "x"})
    hz, _ = c.forward(np.array([0.05]))
    ext_hz, _ = _modes(c.extend(0.05), setting)
    assert hz[0, -1] < 0.5 * _modes(HFRAME, setting)[0][0]  # listed last, every other mode keeps its index
    assert np.allclose(np.sort(hz[0]), ext_hz, rtol=1e-9)


def test_the_extended_model_reproduces_the_final_fit():
    """A crack and a far mass: both named, and the written model (calibrated, both causes, the
    crack as a weak zone in its element) gives the final fit's chi^2 to 1e-8."""
    data = fp.synthetic_measurement(fp.add_mass(crack_truth(5, 0.6, 2e4), 10, 0.05), 8, freq_noise=0.002,
                                    shape_noise=0.02, seed=5, model_name="hframe")
    diag = fp.diagnose("hframe", data)
    assert {(c.kind, str(c.location)) for c in diag.causes} == {("added_mass", "{'node': 10}"),
                                                                ("stiffness_loss", "{'element': 5}")}
    assert diag.adequate is True
    model = diag.extended_model
    assert model.element(5).weak_zone is not None and 0.4 < sum(model.element(5).weak_zone[:2]) / 2 < 0.8
    assert sum(m.mass_kg for m in model.masses if m.node == 10) == pytest.approx(0.05, rel=0.2)
    hz, sh = solve(AffineModel(model), np.zeros((1, 0)), data.dofs, 14)
    f = profiled(Observations.of(data), hz[0], sh[0])
    assert f.chi2 == pytest.approx(diag.verdict.chi2, rel=1e-8)
    assert f.s == pytest.approx(1.0, abs=1e-9)


@pytest.mark.parametrize("node,direction,stiffness,seed", [(9, "x", 2e4, 41), (13, "y", 5e4, 42)])
def test_a_soft_support_is_placed_at_its_node(tmp_path, node, direction, stiffness, seed):
    """The frame hung on a rubber rod: the measured suspension mode has no partner in the free
    model, and the spring to ground that brings one is named at its node and direction (sizes
    moving an elastic frequency by 3.2 % and 2.1 %, inside the class's 1.5-6 %)."""
    case = Case("boundary_stiffness", {"node": node}, 0.0, soft_support_truth(node, direction, stiffness), seed)
    a = diagnose_through_cli(case, tmp_path)
    assert a["residuals"]["unpaired_modes"] == [1]
    named = [(c["kind"], c["location"]) for c in a["causes"] if c["identifiable"]]
    assert named == [("boundary_stiffness", {"node": node, "direction": direction})], a["causes"]
    assert a["adequate"] is True
