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
