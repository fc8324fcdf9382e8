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
