"""`femu import` of OpenSeesPy scripts and `femu export --to opensees`
(fe_problem/model/opensees.py): the frequencies OpenSees computes for a script that calls
openseespy directly are the imported model's."""

from __future__ import annotations

import runpy
import subprocess
import sys
import textwrap

import numpy as np
import openseespy.opensees as ops
import pytest

import fe_problem as fp
from fe_problem.model import load_model

N_MODES = 8

# A space frame with an asymmetric section (Iy 4.4 times Iz) and skew vecxz, lumped mass with
# rotary inertia at the free nodes, a Timoshenko member with consistent mass whose J = Iy + Iz
# (femu's torsional inertia rho (Iy + Iz) is then OpenSees' rho J), and a zeroLength spring to
# a fixed node (a spring to ground).
SPACE = """
import openseespy.opensees as ops

ops.wipe()
ops.model('basic', '-ndm', 3, '-ndf', 6)
for tag, xyz in {1: (0, 0, 0), 2: (0, 0, 1.5), 3: (1.2, 0, 1.5), 4: (1.2, 0.9, 1.7), 5: (1.2, 0.9, 1.7)}.items():
    ops.node(tag, *xyz)
ops.node(6, 2.0, 0.9, 1.7)
ops.fix(1, 1, 1, 1, 1, 1, 1)
ops.fix(5, 1, 1, 1, 1, 1, 1)
for tag, m, i in ((2, 4.0, 0.02), (3, 2.5, 0.015), (4, 3.0, 0.01), (6, 1.5, 0.012)):
    ops.mass(tag, m, m, m, i, i, i)
E, G, rho = 2.0e11, 7.75e10, 7850.0
A, Iy, Iz, J = 1.2e-3, 3.1e-6, 0.7e-6, 4.0e-8
ops.geomTransf('Linear', 1, 1.0, 0.3, 0.0)
ops.geomTransf('Linear', 2, 0.0, 0.6, 0.8)
ops.geomTransf('Linear', 3, 0.2, -0.4, 1.0)
ops.element('elasticBeamColumn', 1, 1, 2, A, E, G, J, Iy, Iz, 1, '-mass', rho * A)
ops.element('elasticBeamColumn', 2, 2, 3, A, E, G, J, Iy, Iz, 2, '-mass', rho * A)
ops.element('elasticBeamColumn', 3, 3, 4, A, E, G, J, Iy, Iz, 3, '-mass', rho * A)
A2, Iy2, Iz2 = 4.0e-3, 2.0e-6, 5.0e-6
ops.element('ElasticTimoshenkoBeam', 4, 4, 6, E, G, A2, Iy2 + Iz2, Iy2, Iz2, 0.8 * A2, 0.8 * A2, 3,
            '-mass', rho * A2, '-cMass')
ops.uniaxialMaterial('Elastic', 1, 3.0e5)
ops.element('zeroLength', 5, 5, 4, '-mat', 1, '-dir', 2)
"""

# A planar portal, Euler-Bernoulli with consistent mass and a Timoshenko beam, a rotational
# spring to ground at a pinned foot.
PLANAR = """
import openseespy.opensees as ops

ops.wipe()
ops.model('basic', '-ndm', 2, '-ndf', 3)
for tag, xy in {1: (0, 0), 2: (0, 1.0), 3: (1.5, 1.0), 4: (1.5, 0), 5: (1.5, 0)}.items():
    ops.node(tag, *xy)
ops.fix(1, 1, 1, 1)
ops.fix(4, 1, 1, 0)
ops.fix(5, 1, 1, 1)
ops.mass(3, 2.0, 2.0, 0.0)
ops.geomTransf('Linear', 1)
ops.element('elasticBeamColumn', 1, 1, 2, 1.2e-3, 2.0e11, 3.1e-6, 1, '-mass', 7850 * 1.2e-3, '-cMass')
ops.element('ElasticTimoshenkoBeam', 2, 2, 3, 2.0e11, 7.7e10, 6.0e-3, 2.0e-5, 5.0e-3, 1, '-mass', 7850 * 6.0e-3,
            '-cMass')
ops.element('elasticBeamColumn', 3, 3, 4, 1.2e-3, 2.0e11, 3.1e-6, 1, '-mass', 7850 * 1.2e-3, '-cMass')
ops.uniaxialMaterial('Elastic', 7, 4.0e4)
ops.element('zeroLength', 4, 5, 4, '-mat', 7, '-dir', 3)
"""


def femu(*args):
    p = subprocess.run([sys.executable, "-m", "femu", *map(str, args)], capture_output=True, text=True, timeout=120)
    return p.returncode, p.stdout, p.stderr.replace("Process 0 Terminating\n", "")


def opensees_frequencies(script, n):
    """OpenSees' own frequencies of the model the script builds."""
    runpy.run_path(str(script))
    w = np.array(ops.eigen("-fullGenLapack", n))
    ops.wipe()
    return np.sqrt(np.abs(w)) / (2 * np.pi)  # abs: a free-free model's rigid-body modes, ~0


@pytest.mark.parametrize("text, dimension, mass", [(SPACE, 3, "mixed"), (PLANAR, 2, "consistent")],
                         ids=["space", "planar"])
def test_script_imports_to_opensees_frequencies(tmp_path, text, dimension, mass):
    script = tmp_path / "frame.py"
    script.write_text(textwrap.dedent(text))
    code, out, err = femu("import", script, "--out", tmp_path / "frame.json")
    assert code == 0, err
    model = load_model(tmp_path / "frame.json")
    assert model.layout.dimension == dimension and model.meta["import"]["mass"] == mass
    assert len(model.springs) == 1 and model.springs[0].dof_b is None  # to ground
    n = 6 if dimension == 2 else N_MODES
    np.testing.assert_allclose(fp.modal_analysis(model, n).frequencies_hz, opensees_frequencies(script, n),
                               rtol=1e-8, atol=0)


# The most common OpenSees model: lumped mass (no -cMass) and node masses in the translations
# only, so every rotation is massless; a pinned foot leaves one more.
LUMPED = """
import openseespy.opensees as ops

ops.wipe()
ops.model('basic', '-ndm', 2, '-ndf', 3)
nodes = {1: (0, 0), 2: (0, 1.0), 3: (0, 2.0), 4: (1.5, 2.0), 5: (1.5, 1.0), 6: (1.5, 0), 7: (0.75, 2.0)}
for tag, xy in nodes.items():
    ops.node(tag, *xy)
ops.fix(1, 1, 1, 1)
ops.fix(6, 1, 1, 0)
for tag, m in ((2, 3.0), (3, 2.0), (4, 2.5), (5, 1.5), (7, 1.0)):
    ops.mass(tag, m, m, 0.0)
ops.geomTransf('Linear', 1)
A, E, I = 1.2e-3, 2.0e11, 3.1e-6
for k, (i, j) in enumerate([(1, 2), (2, 3), (3, 7), (7, 4), (4, 5), (5, 6)], 1):
    ops.element('elasticBeamColumn', k, i, j, A, E, I, 1, '-mass', 7850 * A)
"""


def test_translational_node_masses_import_to_opensees_frequencies(tmp_path):
    """Rotations without mass are solved exactly on both paths (condensed on the dense one,
    shift-invert with the singular M on the sparse one): OpenSees' frequencies to 1e-8, from
    its -fullGenLapack (its default ArpackSolver cannot factor this M)."""
    script = tmp_path / "lumped.py"
    script.write_text(textwrap.dedent(LUMPED))
    code, out, err = femu("import", script, "--out", tmp_path / "lumped.json")
    assert code == 0 and err == "", err
    model = load_model(tmp_path / "lumped.json")
    assert model.meta["import"]["mass"] == "lumped" and all(m.inertia_kg_m2 == 0.0 for m in model.masses)
    expected = opensees_frequencies(script, N_MODES)
    for solver in ("dense", "sparse"):
        np.testing.assert_allclose(fp.modal_analysis(model, N_MODES, solver=solver).frequencies_hz, expected,
                                   rtol=1e-8, atol=0, err_msg=solver)
    code, out, err = femu("model", tmp_path / "lumped.json", "--modes", 3)
    assert code == 0 and err == "", err
    assert f"{expected[0]:.3f}" in out and f"{expected[2]:.3f}" in out


@pytest.mark.parametrize("name", ["hframe", "frame3d"])
def test_shipped_models_exported_and_imported_back(tmp_path, name):
    code, out, err = femu("export", name, "--to", "opensees", "--out", tmp_path / "m.py")
    assert code == 0, err
    code, out, err = femu("import", tmp_path / "m.py", "--out", tmp_path / "m.json")
    assert code == 0, err
    model = load_model(name)
    f = fp.modal_analysis(model, 10).frequencies_hz
    np.testing.assert_allclose(fp.modal_analysis(load_model(tmp_path / "m.json"), 10).frequencies_hz, f,
                               rtol=1e-10, atol=0)
    # the script OpenSees runs has the model's frequencies too (after the rigid-body modes)
    n_rigid = 3 if name == "hframe" else 0
    np.testing.assert_allclose(opensees_frequencies(tmp_path / "m.py", 10 + n_rigid)[n_rigid:], f, rtol=1e-8)


@pytest.mark.parametrize("body, said", [
    ("ops.element('truss', 1, 1, 2, 1.0e-3, 1)", "truss"),
    ("ops.element('elasticBeamColumn', 1, 1, 2, 1e-3, 2e11, 1e-6, 1)", "no -mass"),
    ("ops.equalDOF(1, 2, 1)", "equalDOF"),
    ("raise RuntimeError('boom')", "line 8: the script failed: RuntimeError: boom"),
])
def test_what_cannot_be_read_is_refused_by_name(tmp_path, body, said):
    script = tmp_path / "bad.py"
    script.write_text("import openseespy.opensees as ops\nops.wipe()\nops.model('basic', '-ndm', 2, '-ndf', 3)\n"
                      "ops.node(1, 0.0, 0.0)\nops.node(2, 1.0, 0.0)\nops.uniaxialMaterial('Elastic', 1, 2e11)\n"
                      "ops.geomTransf('Linear', 1)\n" + body + "\n")
    code, out, err = femu("import", script, "--out", tmp_path / "m.json")
    assert code == 2 and len(err.strip().splitlines()) == 1 and str(script) in err and said in err, err
