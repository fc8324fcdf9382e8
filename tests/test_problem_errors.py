"""UpdatingProblem refuses bad input with a message that says what and where."""

import json
import re

import numpy as np
import pytest

import fe_problem as fp


@pytest.fixture(scope="module")
def problem():
    return fp.UpdatingProblem()


@pytest.fixture(scope="module")
def measured():
    """Synthetic data with shapes, from the nominal H-frame."""
    return fp.synthetic_measurement("hframe", 6, shape_noise=0.01, seed=0)


# -- the point(s) to evaluate --------------------------------------------------------------

@pytest.mark.parametrize("X, shape", [(np.full(11, 7e10), "(11,)"), (np.full((4, 13), 7e10), "(4, 13)"),
                                      (np.full((2, 12, 1), 7e10), "(2, 12, 1)"), (7e10, "()")])
def test_x_of_wrong_shape(problem, X, shape):
    with pytest.raises(ValueError, match=r"^X must have shape \(12,\) or \(n, 12\), got " + re.escape(shape)):
        problem.evaluate(X)


def test_x_not_numbers(problem):
    with pytest.raises(ValueError, match=r"^X must be an array of numbers"):
        problem.evaluate([[7e10] * 12, ["E"] * 12])


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_x_not_finite_names_the_entry(problem, bad):
    X = np.full((3, 12), 7e10)
    X[1, 4] = bad
    with pytest.raises(ValueError, match=r"^X\[1, 4\] is -?(nan|inf): every value must be finite"):
        problem.evaluate(X)


def test_x_outside_bounds_names_index_parameter_and_bounds(problem):
    X = np.full((3, 12), 7e10)
    X[2, 5] = 8.5e10
    with pytest.raises(ValueError, match=r"^X\[2, 5\] = 8\.5e\+10 \(E6\) is outside its bounds \[6e\+10, 8e\+10\]"):
        problem.evaluate(X)
    X[2, 5] = 5.9e10
    with pytest.raises(ValueError, match=r"X\[2, 5\] = 5\.9e\+10 \(E6\).*\[6e\+10, 8e\+10\]"):
        problem.evaluate(X)


def test_refused_points_are_not_counted(problem):
    before = problem.n_evals
    with pytest.raises(ValueError):
        problem.evaluate(np.full((5, 12), 9e10))
    assert problem.n_evals == before
    problem.evaluate(np.full((2, 12), 8e10))  # the bounds themselves are inside
    assert problem.n_evals == before + 2


def test_single_point_methods_name_x(problem):
    with pytest.raises(ValueError, match=r"^x must have shape \(12,\)"):
        problem.correlation(np.ones(3))
    with pytest.raises(ValueError, match=r"^x\[0, 0\] = 5e\+10 \(E1\) is outside"):
        problem.modal(np.full(12, 5e10))
    with pytest.raises(ValueError, match="least_squares takes one point, got 2"):
        problem.least_squares(np.full((2, 12), 7e10))


# -- the data and the model ----------------------------------------------------------------

def test_data_file_for_another_model(tmp_path):
    # measured on a frame with a crack node (14) that the H-frame does not have, but filed
    # as belonging to 'hframe'
    truth = fp.split_element(fp.load_model("hframe"), 4, 0.37, 3e4)
    data = fp.synthetic_measurement(truth, 6, dofs=[(1, "x"), (14, "x"), (5, "y")], seed=0, model_name="hframe")
    path = fp.save_modal_data(data, tmp_path / "other.json")
    with pytest.raises(fp.DataFileError, match=re.escape(str(path)) + r": field 'dofs'\[1\]: node 14 is not in "
                                                                      r"model 'hframe'"):
        fp.UpdatingProblem(data=str(path))
    # in memory, and against an explicitly given model
    with pytest.raises(fp.DataFileError, match=r"'dofs'\[1\]: node 14 is not in model 'hframe'"):
        fp.UpdatingProblem(model="hframe", data=data)
    # the model it was measured on is fine
    assert fp.UpdatingProblem(model=truth, data=data).n_var == 13


def test_data_naming_a_model_that_does_not_exist(tmp_path):
    path = tmp_path / "lost.json"
    path.write_text(json.dumps({"format": "femu.modal-data/1", "model": "models/gone.json", "dofs": [[1, "x"]],
                                "modes": [{"frequency_hz": 50.0, "shape": None}]}))
    with pytest.raises(fp.DataFileError, match=r"lost\.json: field 'model': .*gone\.json"):
        fp.UpdatingProblem(data=str(path))


def test_unknown_data_and_model_names():
    with pytest.raises(FileNotFoundError, match=r"'papers'.*shipped: paper"):
        fp.UpdatingProblem(data="papers")
    with pytest.raises(FileNotFoundError, match=r"'h-frame'.*shipped: frame3d, hframe"):
        fp.UpdatingProblem(model="h-frame")


def test_shape_weight_without_shapes():
    with pytest.raises(ValueError, match=r"shape_weight=0\.5 but .*paper\.modal\.json has no measured shapes"):
        fp.UpdatingProblem(shape_weight=0.5)


@pytest.mark.parametrize("w", [-1.0, np.nan])
def test_negative_shape_weight(measured, w):
    with pytest.raises(ValueError, match=r"shape_weight must be >= 0, got"):
        fp.UpdatingProblem(data=measured, shape_weight=w)


def test_shape_weight_with_shapes_is_accepted(measured):
    p = fp.UpdatingProblem(data=measured, shape_weight=1.0, weights="unit")
    assert p.evaluate(p.x0)[0] > 0.0


@pytest.mark.parametrize("weights", ["gama", "Unit", ""])
def test_unknown_weights_name(weights):
    expected = r"weights must be one of \('gamma', 'unit'\) or an array, got " + repr(weights)
    with pytest.raises(ValueError, match=expected):
        fp.UpdatingProblem(weights=weights)


@pytest.mark.parametrize("weights", [[1.0, 1.0], [1, 1, 1, 1, -1], [1, 1, 1, 1, np.nan]])
def test_bad_weight_arrays(weights):
    with pytest.raises(ValueError, match=r"weights must be 5 finite numbers >= 0"):
        fp.UpdatingProblem(weights=weights)


def test_measured_mode_far_from_every_model_mode():
    data = fp.ModalData("hframe", ((1, "x"),), np.array([56.0, 9000.0]), np.full((1, 2), np.nan), source="lab.json")
    with pytest.raises(ValueError, match=r"lab\.json: measured mode\(s\) \[2\] \(9000\.0 Hz\) pair with no mode of "
                                         r"model 'hframe'"):
        fp.UpdatingProblem(data=data)


def test_measured_shape_matching_no_model_shape(measured):
    # mode 3's shape replaced by one no model mode resembles (a single DOF moving)
    shapes = measured.shapes.copy()
    shapes[:, 2] = 0.0
    shapes[measured.dofs.index((11, "y")), 2] = 1.0
    shapes[measured.dofs.index((1, "x")), 2] = -1.0
    bad = fp.ModalData("hframe", measured.dofs, measured.frequencies_hz, shapes, source="odd.json")
    mm = fp.mac(shapes[:, 2:3], fp.modal_analysis("hframe", 10).at(measured.dofs))
    assert mm.max() < 0.5  # the premise: no model mode pairs by MAC
    with pytest.raises(ValueError, match=r"odd\.json: measured mode\(s\) \[3\] .*no MAC >= 0\.5"):
        fp.UpdatingProblem(data=bad)


def test_too_few_model_modes(problem):
    with pytest.raises(ValueError, match=r"n_model_modes=3 is fewer than the 5 measured modes"):
        fp.UpdatingProblem(n_model_modes=3)


def test_more_measured_modes_than_the_model_has():
    model = fp.load_model("hframe")
    n = fp.AffineModel(model).n_elastic
    f = np.arange(1, n + 2) * 50.0
    data = fp.ModalData("hframe", ((1, "x"),), f, np.full((1, n + 1), np.nan), source="many.json")
    expected = rf"many\.json: {n + 1} measured modes but model 'hframe' has only {n} elastic"
    with pytest.raises(ValueError, match=expected):
        fp.UpdatingProblem(data=data)


def test_no_parameters():
    with pytest.raises(ValueError, match="at least one parameter"):
        fp.UpdatingProblem(parameters=())


def test_parameter_for_a_missing_element():
    bad = (fp.Parameter("modulus", (40,), 6e10, 8e10, 7e10, name="E40"),)
    with pytest.raises(ValueError, match=r"parameter E40: model 'hframe' has no element 40"):
        fp.UpdatingProblem(parameters=bad)
