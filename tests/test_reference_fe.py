"""The from-scratch per-sample baseline (benchmarks/reference_fe.py) against the fast path.

The baseline shares no FE code with fe_problem (its element matrices are written out from
the textbook, its assembly is a plain loop, its eigen-solve is scipy's generalised one), so
agreement to round-off verifies UpdatingProblem.evaluate from the outside.
"""

import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
import pytest

import fe_problem
from adapters.variants import make_problem

_PATH = Path(__file__).resolve().parents[1] / "benchmarks" / "reference_fe.py"


def _load_reference():
    # benchmarks/ is not a package; load the file itself (registered first: dataclasses need it).
    name = "femu_benchmarks_reference_fe"
    if name not in sys.modules:
        spec = importlib.util.spec_from_file_location(name, _PATH)
        module = importlib.util.module_from_spec(spec)
        sys.modules[name] = module
        spec.loader.exec_module(module)
    return sys.modules[name]


ref = _load_reference()

#: hframe.md's nominal elastic frequencies (Hz), modes 1-10, given to three decimals.
NOMINAL_HZ = [56.287, 127.217, 228.388, 263.523, 452.854, 658.509, 1043.033, 1248.947, 1442.207, 1813.389]


@pytest.fixture(scope="module")
def reference():
    return ref.ReferenceObjective()


def test_reference_objective_equals_updating_problem(reference):
    problem = make_problem("paper")
    rng = np.random.default_rng(11)
    X = np.vstack([rng.uniform(problem.xl, problem.xu, size=(60, problem.n_var)),
                   problem.xl, problem.xu, problem.x0])
    expected = problem.evaluate(X)
    np.testing.assert_allclose(reference.evaluate(X), expected, rtol=1e-9, atol=0)
    # The points are spread: the check is not made on nearly equal values only.
    assert expected.max() > 3 * expected.min()


def test_reference_pairing_and_gamma_weights(reference):
    problem = make_problem("paper")
    np.testing.assert_array_equal(reference.model_index, problem.model_index)
    np.testing.assert_allclose(reference.initial_hz, problem.initial_hz, rtol=1e-11)
    np.testing.assert_allclose(reference.weights, problem.weights, rtol=1e-9)
    # At the nominal moduli each term is gamma_i * gamma_i (eq. 4 with its own weights).
    assert reference.evaluate(reference.x0)[0] == pytest.approx(np.sum(reference.weights**2), rel=1e-12)


def test_reference_reproduces_published_nominal_frequencies():
    frame = ref.load_frame()
    f = ref.elastic_frequencies_hz(frame, frame.modulus_pa, 10)
    np.testing.assert_allclose(f, NOMINAL_HZ, atol=1.5e-3)  # hframe.md's three decimals


def test_reference_matrices_have_the_rigid_body_modes_and_the_mass():
    frame = ref.load_frame()
    k, m = ref.assemble(frame, frame.modulus_pa)
    np.testing.assert_allclose(k, k.T, atol=0)
    np.testing.assert_allclose(m, m.T, atol=0)
    n_nodes = frame.xy.shape[0]
    tx = np.tile([1.0, 0.0, 0.0], n_nodes)
    ty = np.tile([0.0, 1.0, 0.0], n_nodes)
    # small rotation about the origin: u = -y th, v = x th, rz = th
    rot = np.column_stack([-frame.xy[:, 1], frame.xy[:, 0], np.ones(n_nodes)]).ravel()
    for mode in (tx, ty, rot):
        assert np.abs(k @ mode).max() < 1e-6 * np.abs(k).max()
    # 1.772 kg in hframe.md; exactly sum(rho A L) for a translation of the consistent mass
    lengths = np.hypot(*(frame.xy[frame.ends[:, 1]] - frame.xy[frame.ends[:, 0]]).T)
    total = np.sum(frame.density_kg_m3 * frame.area_m2 * lengths)
    assert tx @ m @ tx == pytest.approx(total, rel=1e-12)
    assert ty @ m @ ty == pytest.approx(total, rel=1e-12)
    assert total == pytest.approx(1.772, abs=5e-4)
    lam = np.sort(np.linalg.eigvals(np.linalg.solve(m, k)).real)
    assert np.all(np.abs(lam[:ref.N_RIGID]) < 1e-9 * lam[-1]) and lam[ref.N_RIGID] > 1e3


def test_reference_rejects_what_it_does_not_model(reference, tmp_path):
    with pytest.raises(ValueError, match=r"X must have shape \(12,\) or \(n, 12\)"):
        reference.evaluate(np.ones((3, 11)))
    with pytest.raises(ValueError, match=r"moduli_pa must have shape \(12,\)"):
        ref.assemble(reference.frame, np.ones(5))
    doc = json.loads((Path(fe_problem.__file__).parent / "shipped" / "hframe.model.json").read_text())
    doc["supports"] = [{"node": 1, "directions": ["x", "y"]}]
    path = tmp_path / "supported.model.json"
    path.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match=r"supported\.model\.json: the reference baseline models no supports"):
        ref.load_frame(path)
