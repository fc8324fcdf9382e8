"""Data checks before the diagnosis (datachecks.py) and plausibility of estimates (plausibility.py).

Faults are made the way they happen in a test, by editing the measured data (a channel's row of
the shape matrix negated, two rows exchanged, two modes' shape columns exchanged, a mode
repeated), on synthetic measurements of truths built by the reference constructions of
diagnosis_cases.py (a crack as a rotational spring inside an element, a mass with rotary
inertia, ...), never by the candidate code. Null data and data with a structural effect must
raise no data fault.
"""

import dataclasses

import numpy as np
import pytest

import fe_problem as fp
from diagnosis_cases import HFRAME, Case, cases, crack_truth, diagnose_through_cli
from fe_problem.diagnosis import plausibility
from fe_problem.diagnosis.core import calibrate, data_checks


def _checks(model, data):
    return data_checks(calibrate(model, data, 0.002, 0.02))


def _data(truth=HFRAME, seed=3):
    return fp.synthetic_measurement(truth, 8, dofs=HFRAME.measured_dofs, freq_noise=0.002, shape_noise=0.02,
                                    seed=seed, model_name="hframe")


def _with_shapes(data, shapes, freqs=None):
    return dataclasses.replace(data, shapes=shapes, frequencies_hz=data.frequencies_hz if freqs is None else freqs,
                               frequency_std_hz=None, shape_std=None)  # synthetic data state no deviations


CRACKED = crack_truth(3, 0.4, 3e4)


@pytest.mark.parametrize("truth", [HFRAME, CRACKED], ids=["no effect", "crack"])
@pytest.mark.parametrize("channel", [(1, "x"), (5, "x"), (10, "x"), (12, "y")])
def test_a_reversed_channel_is_named(truth, channel):
    data = _data(truth)
    c = data.dofs.index(channel)
    shapes = data.shapes.copy()
    shapes[c] *= -1.0
    found = _checks(HFRAME, _with_shapes(data, shapes))
    assert [(x.kind, x.where) for x in found] == [("channel_polarity", {"channels": [list(channel)]})]
    assert len(found[0].evidence["modes"]) >= 2
    assert f"{channel[0]}{channel[1]}" in found[0].text


@pytest.mark.parametrize("truth", [HFRAME, CRACKED], ids=["no effect", "crack"])
@pytest.mark.parametrize("pair", [((1, "x"), (6, "x")), ((5, "x"), (12, "y")), ((9, "x"), (4, "x"))])
def test_two_swapped_channels_are_named(truth, pair):
    data = _data(truth)
    a, b = (data.dofs.index(p) for p in pair)
    shapes = data.shapes.copy()
    shapes[[a, b]] = shapes[[b, a]]
    found = _checks(HFRAME, _with_shapes(data, shapes))
    assert [x.kind for x in found] == ["channel_swap"], [x.text for x in found]
    assert sorted(map(tuple, found[0].where["channels"])) == sorted(pair)
    assert all(after > before for before, after in zip(found[0].evidence["mac_as_given"],
                                                        found[0].evidence["mac_corrected"]))


@pytest.mark.parametrize("truth", [HFRAME, CRACKED], ids=["no effect", "crack"])
def test_exchanged_mode_shapes_and_a_duplicate_are_named(truth):
    data = _data(truth)
    shapes = data.shapes.copy()
    shapes[:, [1, 3]] = shapes[:, [3, 1]]
    found = _checks(HFRAME, _with_shapes(data, shapes))
    assert [(x.kind, x.where) for x in found] == [("mode_order", {"modes": [2, 4]})]
    rng = np.random.default_rng(5)
    dup = data.shapes[:, 2] * (1.0 + 0.01 * rng.standard_normal(data.shapes.shape[0]))
    freqs = np.insert(data.frequencies_hz, 3, data.frequencies_hz[2] * 1.008)
    found = _checks(HFRAME, _with_shapes(data, np.insert(data.shapes, 3, dup, axis=1), freqs))
    assert [(x.kind, x.where) for x in found] == [("duplicate_mode", {"modes": [3, 4]})]


def test_no_data_fault_on_null_data_nor_on_structural_effects():
    """Every null class and every class with a structural effect (a different seed from the
    README's tables), data as measured: no data check fires."""
    plan = {"stiffness_loss": 4, "added_mass": 3, "joint_flexibility": 3, "shear_deformation": 2, "none": 4,
            "global": 4, "two_effects": 2, "soft_support": 2, "spread_mass": 2, "stiffer_member": 2, "sparse": 2,
            "sparse_none": 4, "portal": 2, "portal_none": 2, "cantilever": 2, "cantilever_none": 2, "building": 3,
            "building_none": 2}
    fired = []
    for case in cases(seed=99, plan=plan):
        model = case.nominal or HFRAME
        found = _checks(model, case.data(model.name))
        fired += [(case.cls or case.kind, x.text) for x in found]
    assert fired == []


def test_frequencies_only_data_get_no_shape_checks():
    assert _checks(HFRAME, _data().without_shapes()) == ()


def test_swapped_channels_through_the_cli(tmp_path, capsys):
    """`femu diagnose --json` names the fault in `data_checks`; the text names it and the
    channels and says the diagnosis left them out of its fit (issue 38; `--keep-faulty` fits them:
    tests/test_diagnosis_faults.py)."""
    from femu.cli import main

    data = _data()
    a, b = data.dofs.index((1, "x")), data.dofs.index((6, "x"))
    shapes = data.shapes.copy()
    shapes[[a, b]] = shapes[[b, a]]
    record = diagnose_through_cli(Case("none", None, 0.0, HFRAME, 3), tmp_path)  # the clean data: no check
    assert record["data_checks"] == []
    path = fp.save_modal_data(_with_shapes(data, shapes), tmp_path / "swapped.json")
    assert main(["diagnose", str(path)]) == 0
    text = capsys.readouterr().out
    assert "DATA CHECKS: 1 fault(s)" in text and "channels 1x and 6x look swapped" in text
    line = next(x for x in text.splitlines() if "left out of its fit: channels" in x)
    assert "1x" in line and "6x" in line
    assert main(["diagnose", str(path), "--json"]) == 0
    import json

    record = json.loads(capsys.readouterr().out)
    assert [c["kind"] for c in record["data_checks"]] == ["channel_swap"]
    assert sorted(record["data_checks"][0]["where"]["channels"]) == [[1, "x"], [6, "x"]]
    assert any("left out of its fit channels" in w for w in record["warnings"])
    assert sorted(record["left_out"]["channels"]) == [[1, "x"], [6, "x"]] and record["answer"]["decisive"] is False


# == plausibility ==============================================================================
def test_bounds_against_hand_computed_masses_and_stiffnesses():
    """The H-frame's member masses and stiffnesses computed here from the model file's numbers."""
    e = HFRAME.element(3)
    mat, sec = HFRAME.materials[e.material], HFRAME.sections[e.section]
    a, b = HFRAME.node(e.node_i), HFRAME.node(e.node_j)
    length = float(np.hypot(b.x - a.x, b.y - a.y))
    own = mat.density_kg_m3 * sec.area_m2 * length
    total = HFRAME.total_mass_kg()
    assert plausibility.check(HFRAME, "distributed_mass", {"element": 3}, {"mass_kg": 2.0 * own}) is None
    assert "times the member's own" in plausibility.check(HFRAME, "distributed_mass", {"element": 3},
                                                          {"mass_kg": 11.0 * own})
    assert "of the structure" in plausibility.check(HFRAME, "distributed_mass", {"element": 3}, {"mass_kg": 6.0 * own})
    light = HFRAME.replace(materials={k: dataclasses.replace(v, density_kg_m3=v.density_kg_m3 / 100)
                                      for k, v in HFRAME.materials.items()})
    assert "times the member's own" in plausibility.check(light, "distributed_mass", {"element": 3},
                                                          {"mass_kg": 11.0 * own / 100})
    assert plausibility.check(HFRAME, "stiffness_loss", {"element": 3}, {"modulus_ratio": 0.25}) is None
    assert "81" in plausibility.check(HFRAME, "stiffness_loss", {"element": 3}, {"modulus_ratio": 0.19})
    assert plausibility.check(HFRAME, "stiffness_loss", {"element": 3}, {"modulus_ratio": 0.05, "profile": "zone"}) \
        is None
    assert plausibility.check(HFRAME, "stiffness_gain", {"element": 3}, {"modulus_ratio": 3.2}) is not None
    k_axial = mat.youngs_modulus_pa * sec.area_m2 / length
    node = e.node_i
    stiffest = max(HFRAME.materials[x.material].youngs_modulus_pa * HFRAME.sections[x.section].area_m2
                   / HFRAME.element_length_m(x.id) for x in HFRAME.elements if node in (x.node_i, x.node_j))
    assert stiffest >= k_axial
    assert plausibility.check(HFRAME, "boundary_stiffness", {"node": node}, {"stiffness_n_per_m": 50 * stiffest}) is None
    assert "support" in plausibility.check(HFRAME, "boundary_stiffness", {"node": node},
                                           {"stiffness_n_per_m": 200 * stiffest})
    assert "% of the structure" in plausibility.check(HFRAME, "added_mass", {"node": 5}, {"mass_kg": 0.6 * total}) \
        or "times the" in plausibility.check(HFRAME, "added_mass", {"node": 5}, {"mass_kg": 0.6 * total})
    assert plausibility.few_dof_note(3, 2) is None and "2 degree" in plausibility.few_dof_note(2, 2)


def test_frequencies_only_answer_says_it_rests_on_few_degrees_of_freedom():
    """4 frequencies of a cracked H-frame, no shapes: whatever is named, every estimate is within
    the bounds or flagged, and an answer with 1-2 degrees of freedom says so."""
    data = _data(CRACKED).subset([0, 1, 2, 3]).without_shapes()
    diag = fp.diagnose(HFRAME, data)
    record = diag.to_dict()
    for c in record["causes"]:
        if c["estimate"]:
            why = plausibility.check(HFRAME, c["kind"], c["location"], c["estimate"])
            assert c["plausible"] is (why is None)
    if diag.causes:
        assert diag.verdict.dof <= 2
        assert any("degree(s) of freedom" in w for w in diag.warnings)


def test_hypotheses_ranked_by_rank_one_updates_equal_their_corrected_shapes():
    """`_hypothesis_chi2` (every reversal and exchange scored by rank-one updates of the products,
    no corrected shapes built) against `_shape_chi2` of each hypothesis's corrected shapes, built
    one by one: equal to rounding, with close modes, a zero channel and frequency limits."""
    from fe_problem.diagnosis.datachecks import _hypotheses, _hypothesis_chi2, _shape_chi2, _undone

    rng = np.random.default_rng(3)
    n, m, k = 9, 4, 6
    u_a = rng.normal(size=(n, k))
    u_a[:, 2] = u_a[:, 1] + 0.05 * rng.normal(size=n)  # a close pair: partners change with the fault
    u_a /= np.linalg.norm(u_a, axis=0)
    u_m = u_a[:, [0, 1, 3, 4]] + 0.1 * rng.normal(size=(n, m))
    u_m[5] = 0.0
    u_m /= np.linalg.norm(u_m, axis=0)
    ok = rng.random((m, k)) < 0.8
    ok[:, 0] = True
    sigma = 0.02 * np.max(np.abs(u_m), axis=0)
    hyps = list(_hypotheses(n))
    assert len(hyps) == n + n * (n - 1) // 2
    fast = _hypothesis_chi2(u_m, sigma, u_a, ok, hyps)
    exact = np.array([_shape_chi2(_undone(u_m, *h), sigma, u_a, ok)[0].sum() for h in hyps])
    np.testing.assert_allclose(fast, exact, rtol=1e-9)
    assert np.ptp(exact) > 100.0  # the hypotheses differ: the comparison can fail
