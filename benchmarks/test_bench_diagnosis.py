"""One diagnosis of an 8-mode, 15-coordinate data file (goal: under 10 s on 2 cores).

The data hide a crack (a rotational spring of 3e4 N m/rad at 0.3 of element 7); the same
data every run. The benchmark checks the answer too, so a fast wrong diagnosis cannot pass.
"""

from __future__ import annotations

import pytest

import fe_problem as fp


@pytest.fixture(scope="module")
def crack_data(tmp_path_factory):
    truth = fp.crack_element(fp.load_model("hframe"), 7, 0.3, 3e4)
    data = fp.synthetic_measurement(truth, 8, freq_noise=0.002, shape_noise=0.02, seed=11, model_name="hframe")
    return fp.save_modal_data(data, tmp_path_factory.mktemp("diag") / "crack.json")


def test_diagnosis_of_8_modes_15_coordinates(benchmark, crack_data):
    benchmark.group = "diagnosis"
    result = benchmark.pedantic(fp.diagnose, args=("hframe", str(crack_data)), rounds=5, iterations=1)
    assert result.cause.kind == "stiffness_loss" and result.cause.location == {"element": 7}
    benchmark.extra_info["goal_s"] = 10.0


def test_sparse_class_of_two_softer_members(benchmark):
    """The "every member" sparse class alone (sparse_class.fit_sparse: Gauss-Newton + ARD, refit,
    pruning) on data of the H-frame with members 2 and 9 of lower section inertia; beside the
    diagnosis above, its share of a diagnosis. Checks the members it localises."""
    import dataclasses

    from fe_problem.diagnosis.core import calibrate
    from fe_problem.diagnosis.sparse_class import fit_sparse

    model = fp.load_model("hframe")
    truth = model
    for e, f in ((2, 0.7), (9, 0.8)):
        sec = dataclasses.replace(truth.sections[truth.element(e).section],
                                  inertia_m4=f * truth.sections[truth.element(e).section].inertia_m4)
        truth = truth.replace(sections={**truth.sections, f"soft{e}": sec}, elements=tuple(
            dataclasses.replace(x, section=f"soft{e}") if x.id == e else x for x in truth.elements))
    data = fp.synthetic_measurement(truth, 8, dofs=model.measured_dofs, freq_noise=0.002, shape_noise=0.02, seed=1,
                                    model_name="hframe")
    cal = calibrate(model, data, 0.002, 0.02)
    benchmark.group = "diagnosis"
    sf = benchmark.pedantic(fit_sparse, args=(cal.setting, cal.obs, cal.base.pairing), rounds=5, iterations=1)
    assert sf.members == (2, 9)


@pytest.fixture(scope="module")
def shear_frame_gradient():
    """A four-storey shear frame (tests/test_diagnosis_spread.py's: 0.25 m storeys, one 0.3 m bay,
    the H-frame's bar as columns, floors 3 times as deep, 0.2 kg per floor node, x at one node of
    each floor) and 4 modes of it with storey stiffnesses 0.71, 0.81, 0.91, 1.47 of nominal."""
    from fe_problem.model import Section

    h = fp.load_model("hframe")
    bar = h.sections["bar"]
    model = fp.regular_frame(1, 4, 0.3, 0.25, column=bar, beam=Section(3 * bar.area_m2, 27 * bar.inertia_m4),
                             material=h.materials["aluminium"], floor_mass_kg=0.2, name="shear4")
    model = model.replace(measured_dofs=tuple((n.id, "x") for n in model.nodes if n.x == 0.0 and n.y > 0.0))
    ratios = (0.71, 0.81, 0.91, 1.47)
    storey = {e.id: int(0.5 * (model.node(e.node_i).y + model.node(e.node_j).y) // 0.25) for e in model.elements
              if model.node(e.node_i).x == model.node(e.node_j).x}
    truth = model.with_element_moduli({e: ratios[k] * model.element_modulus_pa(e) for e, k in storey.items()})
    data = fp.synthetic_measurement(truth, 4, dofs=model.measured_dofs, freq_noise=0.002, shape_noise=0.02, seed=0,
                                    model_name="shear4")
    return model, data


def test_diagnosis_of_a_four_storey_shear_frame(benchmark, shear_frame_gradient):
    """The whole diagnosis of the shear frame's storey gradient (4 modes at 4 floors); checks that
    "every storey free" is first by evidence."""
    benchmark.group = "diagnosis storeys"
    result = benchmark.pedantic(fp.diagnose, args=shear_frame_gradient, rounds=3, iterations=1)
    assert result.evidence.classes[0].label.startswith("every_storey_free@")


def test_every_storey_free_of_a_shear_frame(benchmark, shear_frame_gradient):
    """The class "every storey free" alone (group_free.fit_storeys: bounded least squares of 3
    storeys' stiffness), beside the whole diagnosis above: its share of a diagnosis."""
    from fe_problem.diagnosis.core import calibrate
    from fe_problem.diagnosis.group_free import fit_storeys

    model, data = shear_frame_gradient
    cal = calibrate(model, data, 0.002, 0.02)
    benchmark.group = "diagnosis storeys"
    sf = benchmark.pedantic(fit_storeys, args=(cal.setting, cal.obs, cal.base.pairing), rounds=5, iterations=1)
    assert abs(sf.estimate()["storey_ratio"][0] / 0.71 - 1.0) < 0.05
