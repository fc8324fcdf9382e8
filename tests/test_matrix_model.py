"""Models given as matrices (fe_problem/matrix_model, docs/matrix-model.md).

(a) A planar frame with lumped masses at its translations only (every rotation massless), its
    stiffness written out here from the textbook: the matrix model's frequencies against
    OpenSeesPy's of the same structure (node masses on x and y, none on rz) and against an
    exact static condensation of the massless DOFs written here with dense numpy.
(b) The shipped 3-D frame (`frame3d`) as a frame model and as a matrix model, one stiffness
    matrix per parameter group assembled by an independent code in this file (textbook 12 x 12
    Euler-Bernoulli matrices, the project's element and assembly code not used): the same
    frequencies, the same UpdatingProblem objective and the same least-squares estimates.
(c) Every malformed manifest is one line naming the manifest, the term and the problem, in
    the library and through `python -m femu model` (exit 2, one line on stderr).
(d) The matrix file types (.mtx, .mat, .npz sparse and dense, .op4) read the same matrix.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import openseespy.opensees as ops
import pytest
import scipy.io
import scipy.linalg
import scipy.sparse as sp

import adapters
import fe_problem as fp
from fe_problem.matrix_model import MatrixModelError
from fe_problem.modal_data import ModalData, load_modal_data, save_modal_data
from fe_problem.shipped import SHIPPED_DIR

FORMAT = "femu.matrix-model/1"
ENV = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[1]), "OPENBLAS_NUM_THREADS": "1"}


def write_manifest(folder: Path, stiffness, mass, dofs, name="test", file="model.json") -> Path:
    """A manifest in `folder` whose terms are (name, matrix, extra keys) written as .npz files."""
    def terms(entries):
        out = []
        for tname, a, extra in entries:
            sp.save_npz(folder / f"{tname}.npz", sp.csr_matrix(a))
            out.append({"name": tname, "file": f"{tname}.npz", **extra})
        return out
    path = folder / file
    path.write_text(json.dumps({"format": FORMAT, "name": name, "dofs": dofs, "stiffness": terms(stiffness),
                                "mass": terms(mass)}))
    return path


# --- (a) a planar frame with massless rotations, against OpenSees -------------------------

def planar_frame(bays=2, storeys=3, width=5.0, height=3.2, split=2):
    """Nodes (id -> (x, y)), members (id, i, j), fixed base node ids of a regular frame whose
    members are split in `split` parts."""
    nodes, members, nid = {}, [], 0
    grid = {}
    for s in range(storeys + 1):
        for b in range(bays + 1):
            nid += 1
            nodes[nid] = (b * width, s * height)
            grid[b, s] = nid
    base = [grid[b, 0] for b in range(bays + 1)]
    lines = [(grid[b, s], grid[b, s + 1]) for b in range(bays + 1) for s in range(storeys)]
    lines += [(grid[b, s], grid[b + 1, s]) for s in range(1, storeys + 1) for b in range(bays)]
    for i, j in lines:
        prev = i
        for k in range(1, split + 1):
            if k < split:
                nid += 1
                xi, yi = nodes[i]
                xj, yj = nodes[j]
                nodes[nid] = (xi + (xj - xi) * k / split, yi + (yj - yi) * k / split)
                nxt = nid
            else:
                nxt = j
            members.append((len(members) + 1, prev, nxt))
            prev = nxt
    return nodes, members, base


E, A_COL, I_COL = 2.1e11, 7.8e-3, 1.2e-4


def planar_matrices(nodes, members, base, mass_kg):
    """K of the frame (textbook 6 x 6 Euler-Bernoulli frame element, rotated, summed) and the
    lumped M (mass_kg on x and y of every free node, nothing on rz), on the free DOFs; their
    labels [node, direction]."""
    labels = [(n, d) for n in nodes if n not in base for d in ("x", "y", "rz")]
    row = {lab: i for i, lab in enumerate(labels)}
    n = len(labels)
    k = np.zeros((n, n))
    for _, i, j in members:
        (xi, yi), (xj, yj) = nodes[i], nodes[j]
        length = np.hypot(xj - xi, yj - yi)
        c, s = (xj - xi) / length, (yj - yi) / length
        a, b = E * A_COL / length, E * I_COL / length**3
        kl = np.array([[a, 0, 0, -a, 0, 0],
                       [0, 12 * b, 6 * b * length, 0, -12 * b, 6 * b * length],
                       [0, 6 * b * length, 4 * b * length**2, 0, -6 * b * length, 2 * b * length**2],
                       [-a, 0, 0, a, 0, 0],
                       [0, -12 * b, -6 * b * length, 0, 12 * b, -6 * b * length],
                       [0, 6 * b * length, 2 * b * length**2, 0, -6 * b * length, 4 * b * length**2]])
        r = np.array([[c, s, 0], [-s, c, 0], [0, 0, 1.0]])
        t = scipy.linalg.block_diag(r, r)
        kg = t.T @ kl @ t
        dofs = [row.get((nd, d), -1) for nd in (i, j) for d in ("x", "y", "rz")]
        for p, dp in enumerate(dofs):
            for q, dq in enumerate(dofs):
                if dp >= 0 and dq >= 0:
                    k[dp, dq] += kg[p, q]
    m = np.diag([mass_kg if d != "rz" else 0.0 for _, d in labels])
    return k, m, labels


def opensees_planar(nodes, members, base, mass_kg, n_modes):
    """The same frame in OpenSees: elasticBeamColumn elements without element mass, node masses
    on x and y only; its default (ARPACK) eigen solver."""
    ops.wipe()
    ops.model("basic", "-ndm", 2, "-ndf", 3)
    for nid, (x, y) in nodes.items():
        ops.node(nid, x, y)
        if nid in base:
            ops.fix(nid, 1, 1, 1)
        else:
            ops.mass(nid, mass_kg, mass_kg, 0.0)
    ops.geomTransf("Linear", 1)
    for eid, i, j in members:
        ops.element("elasticBeamColumn", eid, i, j, A_COL, E, I_COL, 1)
    lam = np.array(ops.eigen("-genBandArpack", n_modes))
    ops.wipe()
    return np.sqrt(lam) / (2 * np.pi)


def condensed_hz(k, m, n_modes):
    """Exact static condensation of the massless DOFs (dense): the reference computation."""
    a = np.flatnonzero(np.diag(m) > 0)
    b = np.flatnonzero(np.diag(m) == 0)
    kc = k[np.ix_(a, a)] - k[np.ix_(a, b)] @ np.linalg.solve(k[np.ix_(b, b)], k[np.ix_(b, a)])
    lam = scipy.linalg.eigh(kc, m[np.ix_(a, a)], eigvals_only=True)[:n_modes]
    return np.sqrt(lam) / (2 * np.pi)


@pytest.fixture(scope="module")
def planar_case(tmp_path_factory):
    folder = tmp_path_factory.mktemp("planar")
    nodes, members, base = planar_frame()
    k, m, labels = planar_matrices(nodes, members, base, 1500.0)
    path = write_manifest(folder, [("frame", k, {"lower": 0.5, "upper": 2.0})], [("lumped", m, {})],
                          [list(lab) for lab in labels], name="planar")
    return nodes, members, base, k, m, labels, path


def test_massless_rotations_give_opensees_frequencies(planar_case):
    """A third of the DOFs have no mass: the matrix model's 8 lowest frequencies are OpenSees'
    and the exact condensation's to 1e-8, with no fake mass anywhere."""
    nodes, members, base, k, m, labels, path = planar_case
    model = fp.load_matrix_model(path)
    system = fp.MatrixSystem(model)
    assert system.n_massless == sum(d == "rz" for _, d in labels) == len(labels) // 3
    assert system.n_elastic == len(labels) - system.n_massless and system.n_rigid == 0
    res = fp.modal_analysis(path, 8)
    ref = opensees_planar(nodes, members, base, 1500.0, 8)
    np.testing.assert_allclose(res.frequencies_hz, ref, rtol=1e-8, atol=0)
    np.testing.assert_allclose(res.frequencies_hz, condensed_hz(k, m, 8), rtol=1e-10, atol=0)
    # mass-normalised on the singular M, and an eigenvector of the pencil
    phi = res.shapes
    np.testing.assert_allclose(phi.T @ m @ phi, np.eye(8), atol=1e-10)
    lam = (2 * np.pi * res.frequencies_hz) ** 2
    resid = k @ phi - m @ phi * lam
    assert np.abs(resid).max() < 1e-7 * np.abs(k @ phi).max()


def test_tiny_model_with_massless_dofs_solved_densely(tmp_path):
    """Below ARPACK's size the dense path solves the pencil (M, K - sigma M): still exact."""
    n = 6
    k = sp.diags([2 * np.ones(n), -np.ones(n - 1), -np.ones(n - 1)], [0, 1, -1]).toarray() * 1e4
    m = np.diag([1.0, 0, 2.0, 0, 1.5, 0])
    path = write_manifest(tmp_path, [("k", k, {})], [("m", m, {})], n)
    res = fp.modal_analysis(path, 3)
    np.testing.assert_allclose(res.frequencies_hz, condensed_hz(k, m, 3), rtol=1e-12)
    assert fp.MatrixSystem(fp.load_matrix_model(path)).n_elastic == 3


def test_free_structure_rigid_modes_dropped(tmp_path):
    """A free-free chain: its rigid-body translation is counted and dropped, as for a frame."""
    n = 40
    k = sp.diags([2 * np.ones(n), -np.ones(n - 1), -np.ones(n - 1)], [0, 1, -1]).tolil()
    k[0, 0] = k[n - 1, n - 1] = 1.0
    m = np.diag(np.where(np.arange(n) % 2 == 0, 1.0, 0.0))
    path = write_manifest(tmp_path, [("k", k.toarray() * 1e4, {})], [("m", m, {})], n)
    system = fp.MatrixSystem(fp.load_matrix_model(path))
    assert system.n_rigid == 1
    res = fp.modal_analysis(path, 4)
    kd = k.toarray() * 1e4
    np.testing.assert_allclose(res.frequencies_hz, condensed_hz(kd, m, 5)[1:], rtol=1e-9)


# --- (b) the shipped 3-D frame as a frame model and as a matrix model ------------------------

GROUPS = {  # parameter name -> which members (by the file's own data)
    "columns_low": lambda z0, z1, dx, dy: dx == dy == 0 and max(z0, z1) <= 7.0 + 1e-9,
    "columns_high": lambda z0, z1, dx, dy: dx == dy == 0 and max(z0, z1) > 7.0 + 1e-9,
    "beams_x": lambda z0, z1, dx, dy: z0 == z1 and dx != 0,
    "beams_y": lambda z0, z1, dx, dy: z0 == z1 and dy != 0,
}
NAMES6 = ("x", "y", "z", "rx", "ry", "rz")


def independent_frame3d():
    """frame3d read as plain JSON and assembled here: one stiffness per group of GROUPS and the
    mass (consistent Euler-Bernoulli element mass with torsional inertia rho (Iy + Iz), the
    docs/model-format.md convention, plus the nodes' lumped masses on x, y, z), on the free
    DOFs; the element ids of each group; the labels."""
    d = json.loads((SHIPPED_DIR / "frame3d.model.json").read_text())
    xyz = {n["id"]: np.array([n["x"], n["y"], n["z"]]) for n in d["nodes"]}
    fixed = {(s["node"], dr) for s in d["supports"] for dr in s["directions"]}
    labels = [(n, dr) for n in xyz for dr in NAMES6 if (n, dr) not in fixed]
    row = {lab: i for i, lab in enumerate(labels)}
    n = len(labels)
    ks = {g: np.zeros((n, n)) for g in GROUPS}
    members = {g: [] for g in GROUPS}
    mass = np.zeros((n, n))
    for e in d["elements"]:
        i, j = e["nodes"]
        mat, sec = d["materials"][e["material"]], d["sections"][e["section"]]
        vec = xyz[j] - xyz[i]
        length = np.linalg.norm(vec)
        group = [g for g, rule in GROUPS.items() if rule(xyz[i][2], xyz[j][2], abs(vec[0]), abs(vec[1]))]
        assert len(group) == 1, e
        members[group[0]].append(e["id"])
        ex = vec / length
        ey = np.cross(np.array(e["orientation"], float), ex)
        ey /= np.linalg.norm(ey)
        ez = np.cross(ex, ey)
        r = np.array([ex, ey, ez])
        t = scipy.linalg.block_diag(r, r, r, r)
        el, g_, a = mat["youngs_modulus_pa"], mat["shear_modulus_pa"], sec["area_m2"]
        iy, iz, jt = sec["iy_m4"], sec["iz_m4"], sec["j_m4"]
        L = length
        k = np.zeros((12, 12))
        k[0, 0] = k[6, 6] = el * a / L
        k[0, 6] = k[6, 0] = -el * a / L
        k[3, 3] = k[9, 9] = g_ * jt / L
        k[3, 9] = k[9, 3] = -g_ * jt / L
        bz = el * iz
        for (p, q), v in {(1, 1): 12 * bz / L**3, (1, 5): 6 * bz / L**2, (1, 7): -12 * bz / L**3,
                          (1, 11): 6 * bz / L**2, (5, 5): 4 * bz / L, (5, 7): -6 * bz / L**2, (5, 11): 2 * bz / L,
                          (7, 7): 12 * bz / L**3, (7, 11): -6 * bz / L**2, (11, 11): 4 * bz / L}.items():
            k[p, q] = k[q, p] = v
        by = el * iy
        for (p, q), v in {(2, 2): 12 * by / L**3, (2, 4): -6 * by / L**2, (2, 8): -12 * by / L**3,
                          (2, 10): -6 * by / L**2, (4, 4): 4 * by / L, (4, 8): 6 * by / L**2, (4, 10): 2 * by / L,
                          (8, 8): 12 * by / L**3, (8, 10): 6 * by / L**2, (10, 10): 4 * by / L}.items():
            k[p, q] = k[q, p] = v
        rho_a = mat["density_kg_m3"] * a
        m = np.zeros((12, 12))
        c = rho_a * L / 420.0
        for (p, q), v in {(0, 0): 140, (0, 6): 70, (6, 6): 140,
                          (1, 1): 156, (1, 5): 22 * L, (1, 7): 54, (1, 11): -13 * L, (5, 5): 4 * L * L,
                          (5, 7): 13 * L, (5, 11): -3 * L * L, (7, 7): 156, (7, 11): -22 * L, (11, 11): 4 * L * L,
                          (2, 2): 156, (2, 4): -22 * L, (2, 8): 54, (2, 10): 13 * L, (4, 4): 4 * L * L,
                          (4, 8): -13 * L, (4, 10): -3 * L * L, (8, 8): 156, (8, 10): 22 * L, (10, 10): 4 * L * L}.items():
            m[p, q] = m[q, p] = c * v
        ip = mat["density_kg_m3"] * (iy + iz) * L / 6.0
        m[3, 3] = m[9, 9] = 2 * ip
        m[3, 9] = m[9, 3] = ip
        kg, mg = t.T @ k @ t, t.T @ m @ t
        dofs = np.array([row.get((nd, dr), -1) for nd in (i, j) for dr in NAMES6])
        keep = dofs >= 0
        ks[group[0]][np.ix_(dofs[keep], dofs[keep])] += kg[np.ix_(keep, keep)]
        mass[np.ix_(dofs[keep], dofs[keep])] += mg[np.ix_(keep, keep)]
    for lm in d["masses"]:
        for dr in ("x", "y", "z"):
            if (lm["node"], dr) in row:
                mass[row[lm["node"], dr], row[lm["node"], dr]] += lm["mass_kg"]
    return ks, mass, members, labels, d["materials"]["steel"]["youngs_modulus_pa"]


LOW, HIGH = 0.6, 1.5
#: the true multipliers: near enough to 1 that the modes keep their order from x0 (the pairing,
#: made at x0, stays right: further away, the close sway modes 2 and 3 swap and J(truth) > 0)
TRUTH = np.array([1.08, 0.93, 0.96, 1.06])


@pytest.fixture(scope="module")
def frame3d_pair(tmp_path_factory):
    """frame3d's two problems (frame model in Pa, matrix model in multipliers) on the same
    synthetic data: 8 modes at its 72 measured DOFs from the frame model at TRUTH."""
    folder = tmp_path_factory.mktemp("frame3d")
    ks, mass, members, labels, e0 = independent_frame3d()
    path = write_manifest(folder, [(g, ks[g], {"lower": LOW, "upper": HIGH}) for g in GROUPS],
                          [("mass", mass, {})], [list(lab) for lab in labels], name="frame3d-matrices")
    frame = fp.load_model("frame3d")
    params = tuple(fp.Parameter("modulus", tuple(members[g]), LOW * e0, HIGH * e0, e0, name=g) for g in GROUPS)
    data = fp.synthetic_measurement(frame, 8, parameters=params, theta=TRUTH * e0, seed=3)
    frame_problem = fp.UpdatingProblem(frame, data, parameters=params, shape_weight=1.0, solver="sparse")
    matrix_problem = fp.UpdatingProblem(path, data, shape_weight=1.0)
    return frame_problem, matrix_problem, e0, path, data


def test_frame3d_matrix_model_same_frequencies_and_objective(frame3d_pair):
    frame_problem, matrix_problem, e0, _, _ = frame3d_pair
    assert matrix_problem.parameter_names == tuple(GROUPS)
    f_frame = frame_problem.modal(n_modes=12).frequencies_hz
    f_matrix = matrix_problem.modal(n_modes=12).frequencies_hz
    np.testing.assert_allclose(f_matrix, f_frame, rtol=1e-8, atol=0)
    X = np.random.default_rng(0).uniform(LOW, HIGH, (5, 4))
    j_frame = frame_problem.evaluate(X * e0)
    j_matrix = matrix_problem.evaluate(X)
    np.testing.assert_allclose(j_matrix, j_frame, rtol=1e-8, atol=1e-14)
    # the frequency rows' analytic Jacobian: d r / d mu = e0 d r / d E (the shape rows are forward
    # differences of step 1e-6 over ARPACK's vectors: they agree to that step's noise only)
    a, b = frame_problem.least_squares(X[0] * e0), matrix_problem.least_squares(X[0])
    np.testing.assert_allclose(b.residuals, a.residuals, rtol=1e-7, atol=1e-12)
    m = matrix_problem.data.n_modes
    np.testing.assert_allclose(b.jacobian[:m], a.jacobian[:m] * e0, rtol=1e-8, atol=0)
    np.testing.assert_allclose(b.jacobian[m:], a.jacobian[m:] * e0, rtol=0, atol=1e-3 * np.abs(b.jacobian).max())


def test_frame3d_least_squares_updates_agree(frame3d_pair):
    """The sensitivity method (least squares on the analytic sensitivities) from the same start
    on both problems: the same estimates to 1e-6, the truth recovered."""
    frame_problem, matrix_problem, e0, _, _ = frame3d_pair
    run_frame = adapters.run("sensitivity", frame_problem, 120, 0)
    run_matrix = adapters.run("sensitivity", matrix_problem, 120, 0)
    assert run_frame.status == run_matrix.status == "ok", (run_frame.error, run_matrix.error)
    np.testing.assert_allclose(np.array(run_matrix.best_x), np.array(run_frame.best_x) / e0, rtol=1e-6)
    np.testing.assert_allclose(run_matrix.best_x, TRUTH, rtol=1e-6)
    assert run_matrix.best_f < 1e-12


def test_updated_matrix_model_written_and_read_back(frame3d_pair, tmp_path):
    _, matrix_problem, _, path, _ = frame3d_pair
    x = np.array([1.1, 0.95, 1.2, 0.8])
    updated = matrix_problem.updated_model(x)
    assert [t.initial for t in updated.stiffness] == list(x)
    assert isinstance(updated, fp.MatrixModel)
    out = fp.save_matrix_model(updated, tmp_path / "updated.json")
    back = fp.load_any_model(out)
    assert [t.initial for t in back.stiffness] == list(x)
    assert [(t.lower, t.upper) for t in back.stiffness] == [(LOW, HIGH)] * 4
    np.testing.assert_allclose(fp.modal_analysis(back, 6).frequencies_hz,
                               matrix_problem.modal(x, 6).frequencies_hz, rtol=1e-12)
    (tmp_path / "copy").mkdir()
    copied = fp.save_matrix_model(updated, tmp_path / "copy" / "m.json", copy_files=True)
    assert sorted(p.name for p in copied.parent.iterdir()) == sorted(["m.json", *(f"{g}.npz" for g in GROUPS),
                                                                      "mass.npz"])
    np.testing.assert_allclose(fp.modal_analysis(copied, 6).frequencies_hz,
                               matrix_problem.modal(x, 6).frequencies_hz, rtol=1e-12)


def test_modal_data_files_for_matrix_models(frame3d_pair, tmp_path):
    """A data file names the manifest: labels as [node, direction]; a counted model's data give
    row numbers. `load_modal_data` loads and checks the model, `UpdatingProblem(data=...)`
    takes it from there."""
    _, matrix_problem, _, path, data = frame3d_pair
    labelled = ModalData(os.path.relpath(path, tmp_path), data.dofs, data.frequencies_hz, data.shapes)
    save_modal_data(labelled, tmp_path / "data.json")
    problem = fp.UpdatingProblem(data=str(tmp_path / "data.json"), shape_weight=1.0)
    assert isinstance(problem.model, fp.MatrixModel)
    np.testing.assert_allclose(problem.evaluate(TRUTH), 0.0, atol=1e-20)
    # the same model with a count of DOFs, the data by row number
    doc = json.loads(Path(path).read_text())
    model = fp.load_matrix_model(path)
    rows = [model.row_of(d) + 1 for d in data.dofs]
    doc["dofs"] = len(doc["dofs"])
    for t in doc["stiffness"] + doc["mass"]:
        t["file"] = str(Path(path).parent / t["file"])
    (tmp_path / "counted.json").write_text(json.dumps(doc))
    counted = ModalData("counted.json", tuple(rows), data.frequencies_hz, data.shapes)
    save_modal_data(counted, tmp_path / "rows.json")
    assert json.loads((tmp_path / "rows.json").read_text())["dofs"][:3] == rows[:3]
    problem = fp.UpdatingProblem(data=str(tmp_path / "rows.json"), shape_weight=1.0)
    np.testing.assert_allclose(problem.evaluate(np.array([TRUTH, TRUTH * 1.01])),
                               matrix_problem.evaluate(np.array([TRUTH, TRUTH * 1.01])), rtol=1e-10, atol=1e-20)
    # a data file that names labels for a counted model, or a row beyond it: one line each
    bad = ModalData("counted.json", data.dofs, data.frequencies_hz, data.shapes)
    save_modal_data(bad, tmp_path / "bad.json")
    with pytest.raises(ValueError, match=r"bad.json: field 'dofs'\[0\]: model .* numbers its DOFs 1\.\.\d+"):
        load_modal_data(tmp_path / "bad.json")
    beyond = ModalData("counted.json", (1, 10**6), data.frequencies_hz, data.shapes[:2])
    save_modal_data(beyond, tmp_path / "beyond.json")
    with pytest.raises(ValueError, match=r"beyond.json: field 'dofs'\[1\]: model .* has no row 1000000"):
        load_modal_data(tmp_path / "beyond.json")


def test_femu_model_prints_a_matrix_models_modes(frame3d_pair):
    frame_problem, _, _, path, _ = frame3d_pair
    out = subprocess.run([sys.executable, "-m", "femu", "model", str(path), "--modes", "5"], capture_output=True,
                         text=True, env=ENV, timeout=120)
    assert out.returncode == 0, out.stderr
    n = frame_problem.system.n_free
    assert "model frame3d-matrices" in out.stdout and f"given as matrices: {n} DOFs" in out.stdout
    assert "columns_low [0.6, 1.5]" in out.stdout
    rows = [line.split() for line in out.stdout.splitlines() if line.strip()[:1].isdigit() and len(line.split()) == 2]
    printed = np.array([float(r[1]) for r in rows])
    np.testing.assert_allclose(printed, frame_problem.modal(n_modes=5).frequencies_hz, atol=6e-4)
    js = subprocess.run([sys.executable, "-m", "femu", "model", str(path), "--modes", "3", "--json"],
                        capture_output=True, text=True, env=ENV, timeout=120)
    summary = json.loads(js.stdout)
    assert summary["n_dofs"] == n and summary["n_massless_dofs"] == 0 and summary["kind"] == "matrix"
    np.testing.assert_allclose(summary["frequencies_hz"], frame_problem.modal(n_modes=3).frequencies_hz, rtol=1e-8)


# --- (c) malformed manifests -----------------------------------------------------------------

def _good(folder: Path) -> dict:
    n = 4
    k = sp.diags([2 * np.ones(n), -np.ones(n - 1), -np.ones(n - 1)], [0, 1, -1]).tocsr() * 1e3
    sp.save_npz(folder / "k.npz", k)
    scipy.io.mmwrite(str(folder / "m.mtx"), sp.identity(n, format="coo"))
    np.savez(folder / "two.npz", a=np.eye(n), b=np.eye(n))
    scipy.io.savemat(str(folder / "mats.mat"), {"K1": k.toarray()})
    (folder / "text.mtx").write_text("this is not a matrix\n")
    np.savez(folder / "cube.npz", np.ones((n, n, 2)))
    np.savez(folder / "nan.npz", np.where(np.eye(n) > 0, np.nan, 0.0))
    asym = k.toarray()
    asym[0, 1] *= 1.001
    np.savez(folder / "asym.npz", asym)
    np.savez(folder / "small.npz", np.eye(n - 1))
    np.savez(folder / "neg.npz", -np.eye(n))
    np.savez(folder / "indef.npz", np.array([[1.0, 2, 0, 0], [2, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]))
    np.savez(folder / "cplx.npz", np.eye(n) * (1 + 1j))
    return {"format": FORMAT, "name": "bad", "dofs": n,
            "stiffness": [{"name": "k", "file": "k.npz", "lower": 0.5, "upper": 2.0}],
            "mass": [{"name": "m", "file": "m.mtx"}]}


def _set(path, value):
    def change(d):
        target = d
        for key in path[:-1]:
            target = target[key]
        if value is _DELETE:
            del target[path[-1]]
        else:
            target[path[-1]] = value
        return d
    return change


_DELETE = object()

BAD = {  # case -> (change, term named in the message or None, problem)
    "format": (_set(["format"], "femu.matrix-model/2"), None, "field 'format' must be"),
    "no mass": (_set(["mass"], _DELETE), None, "missing field 'mass'"),
    "empty stiffness": (_set(["stiffness"], []), None, "field 'stiffness' must be a non-empty list"),
    "dofs zero": (_set(["dofs"], 0), None, "field 'dofs': a count must be in"),
    "dofs direction": (_set(["dofs"], [[1, "x"], [1, "q"], [2, "x"], [2, "y"]]), None, "unknown direction 'q'"),
    "dofs twice": (_set(["dofs"], [[1, "x"], [1, "y"], [1, "x"], [2, "y"]]), None, "is listed twice"),
    "unknown key": (_set(["stiffnes"], []), None, "unknown key 'stiffnes'"),
    "term key": (_set(["stiffness", 0, "uper"], 2.0), None, "unknown key 'uper'"),
    "duplicate name": (_set(["mass", 0, "name"], "k"), "k", "the name 'k' is used twice"),
    "one bound": (_set(["stiffness", 0, "upper"], _DELETE), "k", "give both 'lower' and 'upper'"),
    "bounds order": (_set(["stiffness", 0, "lower"], 3.0), "k", "needs lower < upper"),
    "initial outside": (_set(["stiffness", 0, "initial"], 5.0), "k", "'initial' 5 is outside [0.5, 2]"),
    "initial text": (_set(["stiffness", 0, "initial"], "1"), "k", "field 'initial' must be a finite number"),
    "missing file": (_set(["mass", 0, "file"], "nowhere.mtx"), "m", "does not exist"),
    "file type": (_set(["mass", 0, "file"], "m.txt"), "m", "unknown type '.txt'"),
    "not a matrix file": (_set(["mass", 0, "file"], "text.mtx"), "m", "is not a readable .mtx matrix"),
    "mat without variable": (_set(["stiffness", 0, "file"], "mats.mat"), "k", "a .mat file needs 'variable'"),
    "missing variable": (lambda d: _set(["stiffness", 0, "variable"], "K2")(_set(["stiffness", 0, "file"], "mats.mat")(d)),
                         "k", "has no variable 'K2' (it has K1)"),
    "several arrays": (_set(["mass", 0, "file"], "two.npz"), "m", "holds several arrays (a, b)"),
    "three dimensions": (_set(["mass", 0, "file"], "cube.npz"), "m", "not a matrix (an array of 3 dimension(s)"),
    "nan": (_set(["mass", 0, "file"], "nan.npz"), "m", "is nan: every entry must be finite"),
    "not symmetric": (_set(["stiffness", 0, "file"], "asym.npz"), "k", "not symmetric"),
    "wrong size": (_set(["mass", 0, "file"], "small.npz"), "m", "size 3 x 3, the model has 4 DOFs"),
    "complex": (_set(["mass", 0, "file"], "cplx.npz"), "m", "complex entries"),
    "negative mass": (_set(["mass", 0, "file"], "neg.npz"), "m", "M (term 'm') at the initial values is not "
                                                                  "positive semi-definite: diagonal entry 1"),
    "indefinite mass": (_set(["mass", 0, "file"], "indef.npz"), "m", "is not positive semi-definite (an eigenvalue"),
}


@pytest.mark.parametrize("case", list(BAD))
def test_malformed_manifest_one_line(tmp_path, case):
    change, term, problem = BAD[case]
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(change(_good(tmp_path))))
    with pytest.raises(MatrixModelError) as info:
        fp.load_any_model(path)
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith(f"{path}: ")
    assert problem in msg
    if term is not None:
        assert f"term {term!r}" in msg


def test_good_manifest_of_the_malformed_cases_loads(tmp_path):
    path = tmp_path / "good.json"
    path.write_text(json.dumps(_good(tmp_path)))
    model = fp.load_any_model(path)
    assert model.n_dof == 4 and [p.name for p in model.parameters] == ["k"]


@pytest.mark.parametrize("case", list(BAD))
def test_malformed_manifest_through_femu_model(tmp_path, capsys, case):
    """`femu model bad.json`: exit 2, one line on stderr naming the manifest, the term, the problem."""
    from femu.cli import main

    change, term, problem = BAD[case]
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(change(_good(tmp_path))))
    assert main(["model", str(path)]) == 2
    out, err = capsys.readouterr()
    lines = err.strip().splitlines()
    assert out == "" and len(lines) == 1 and str(path) in lines[0] and problem in lines[0], err
    if term is not None:
        assert f"term {term!r}" in lines[0]


@pytest.mark.parametrize("case", ["not symmetric", "missing variable"])
def test_malformed_manifest_through_python_m_femu(tmp_path, case):
    change, term, problem = BAD[case]
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(change(_good(tmp_path))))
    out = subprocess.run([sys.executable, "-m", "femu", "model", str(path)], capture_output=True, text=True,
                         env=ENV, timeout=120)
    assert out.returncode == 2 and out.stdout == ""
    lines = out.stderr.strip().splitlines()
    assert len(lines) == 1 and str(path) in lines[0] and problem in lines[0], out.stderr
    if term is not None:
        assert f"term {term!r}" in lines[0]


# --- (d) the matrix file types ----------------------------------------------------------------

def test_file_types_read_the_same_matrix(tmp_path):
    from pyNastran.op2.result_objects.matrix import Matrix
    from pyNastran.op4.op4 import OP4

    n = 9
    a = sp.random(n, n, density=0.3, random_state=5, format="csr")
    a = (a + a.T + sp.identity(n) * 5).tocsr()
    dense = a.toarray()
    scipy.io.mmwrite(str(tmp_path / "a.mtx"), a)
    scipy.io.mmwrite(str(tmp_path / "dense.mtx"), dense)
    scipy.io.savemat(str(tmp_path / "a.mat"), {"A": a, "D": dense})
    sp.save_npz(tmp_path / "a.npz", a)
    np.savez(tmp_path / "arrays.npz", A=dense, other=np.zeros(3))
    np.savez(tmp_path / "single.npz", dense)
    OP4().write_op4(str(tmp_path / "a.op4"), {"KAA": Matrix("KAA", 6, a.tocoo()), "MAA": Matrix("MAA", 6, dense)},
                    precision="double", is_binary=False)
    terms = [("mtx", "a.mtx", None), ("mtxdense", "dense.mtx", None), ("mat", "a.mat", "A"), ("matdense", "a.mat", "D"),
             ("npz", "a.npz", None), ("npzvar", "arrays.npz", "A"), ("npzone", "single.npz", None),
             ("op4", "a.op4", "KAA"), ("op4dense", "a.op4", "MAA")]
    doc = {"format": FORMAT, "name": "types", "dofs": n,
           "stiffness": [{"name": t, "file": f, **({"variable": v} if v else {})} for t, f, v in terms],
           "mass": [{"name": "m", "file": "a.npz"}]}
    (tmp_path / "types.json").write_text(json.dumps(doc))
    model = fp.load_matrix_model(tmp_path / "types.json")
    for t in model.stiffness:
        np.testing.assert_array_equal(t.matrix.toarray(), dense, err_msg=t.name)
    assert {t.name: t.variable for t in model.stiffness}["op4"] == "KAA"


def test_matrix_model_rejects_the_dense_path(planar_case):
    with pytest.raises(ValueError, match="a matrix model is solved on the sparse path"):
        fp.MatrixSystem(fp.load_matrix_model(planar_case[-1]), solver="dense")


def test_parameter_subset_and_fixed_terms(planar_case, tmp_path):
    """A term without bounds is fixed at its `initial`; a subset of parameters by name leaves the
    others at theirs: K(2) as a parameter equals K fixed at initial 2."""
    _, _, _, k, m, labels, path = planar_case
    fixed = write_manifest(tmp_path, [("frame", k, {"initial": 2.0})], [("lumped", m, {})],
                           [list(lab) for lab in labels])
    a = fp.modal_analysis(fixed, 4).frequencies_hz
    system = fp.MatrixSystem(fp.load_matrix_model(path), parameters=["frame"])
    lam, _ = system.eigen(np.array([[2.0]]), 4)
    np.testing.assert_allclose(np.sqrt(lam[0]) / (2 * np.pi), a, rtol=1e-12)
    np.testing.assert_allclose(a, condensed_hz(2 * k, m, 4), rtol=1e-10)
    with pytest.raises(MatrixModelError, match="'mass' is not a parameter of the model"):
        fp.MatrixSystem(fp.load_matrix_model(path), parameters=["mass"])


def test_op4_without_pynastran_names_the_extra(tmp_path, monkeypatch):
    """Without pyNastran a .op4 term is one line naming the 'import' extra."""
    np.savez(tmp_path / "k.npz", np.eye(3))
    (tmp_path / "m.op4").write_text("not read\n")
    doc = {"format": FORMAT, "dofs": 3, "stiffness": [{"name": "k", "file": "k.npz"}],
           "mass": [{"name": "m", "file": "m.op4", "variable": "MAA"}]}
    (tmp_path / "x.json").write_text(json.dumps(doc))
    monkeypatch.setitem(sys.modules, "pyNastran.op4.op4", None)
    with pytest.raises(MatrixModelError, match=r"x.json: term 'm' \(mass\[0\]\): reading a .op4 file needs the "
                                               r"'import' extra: pip install 'femu-bench\[import\]'"):
        fp.load_matrix_model(tmp_path / "x.json")


def test_row_number_data_refused_as_uff(tmp_path):
    data = ModalData("m.json", (1, 2, 3), np.array([1.0, 2.0]), np.ones((3, 2)))
    with pytest.raises(ValueError, match=r"d.uff: the DOFs are row numbers of a model given as matrices; UFF dataset "
                                         r"55 holds \[node, direction\] coordinates: write JSON instead"):
        save_modal_data(data, tmp_path / "d.uff")


def test_diagnose_of_a_matrix_model_names_a_dof_it_lacks_in_one_line(frame3d_pair, tmp_path, capsys):
    """`femu diagnose` takes a matrix model (tests/test_diagnosis_matrix.py); data at a DOF its
    manifest does not label: one line naming the data file, the field and the DOF, before the work."""
    from femu.cli import main

    _, _, _, path, data = frame3d_pair
    dofs = ((999, "x"),) + tuple(data.dofs[1:])
    save_modal_data(ModalData(str(path), dofs, data.frequencies_hz, data.shapes), tmp_path / "d.json")
    assert main(["diagnose", str(tmp_path / "d.json")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "d.json" in err[0] and "no DOF [999, 'x']" in err[0], err


def test_synthetic_measurement_of_a_matrix_model(planar_case):
    """Synthetic data of a matrix model at other multipliers: named by the manifest's path, the
    problem built from them alone finds those multipliers at J = 0."""
    _, _, _, k, m, labels, path = planar_case
    dofs = [lab for lab in labels if lab[1] == "x"][:6]
    data = fp.synthetic_measurement(path, 5, dofs=dofs, parameters=("frame",), theta=np.array([1.3]), seed=2)
    assert data.model == str(path) and data.dofs == tuple(dofs)
    np.testing.assert_allclose(data.frequencies_hz, condensed_hz(1.3 * k, m, 5), rtol=1e-10)
    problem = fp.UpdatingProblem(data=data, shape_weight=1.0)
    assert problem.evaluate(np.array([1.3]))[0] < 1e-20 < problem.evaluate(np.array([1.2]))[0]


def test_femu_model_save_writes_the_manifest(planar_case, tmp_path, capsys):
    from femu.cli import main

    path = planar_case[-1]
    assert main(["model", str(path), "--modes", "3", "--json", "--save", str(tmp_path / "saved.json")]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["saved"] == str(tmp_path / "saved.json") and summary["n_massless_dofs"] == len(planar_case[5]) // 3
    again = fp.load_any_model(tmp_path / "saved.json")
    assert again.dofs == fp.load_matrix_model(path).dofs
    np.testing.assert_allclose(fp.modal_analysis(again, 3).frequencies_hz, summary["frequencies_hz"], rtol=1e-12)


def test_row_numbers_for_a_frame_model_refused(tmp_path):
    doc = {"format": "femu.modal-data/1", "model": "hframe", "dofs": [1, 2],
           "modes": [{"frequency_hz": 50.0, "shape": [1.0, 0.5]}]}
    (tmp_path / "rows.json").write_text(json.dumps(doc))
    with pytest.raises(ValueError, match=r"rows.json: field 'dofs': row numbers are for a model given as matrices"):
        load_modal_data(tmp_path / "rows.json")
    doc["dofs"] = [1, [2, "x"]]
    (tmp_path / "mixed.json").write_text(json.dumps(doc))
    with pytest.raises(ValueError, match=r"mixed.json: field 'dofs'\[1\]: expected a row number >= 1 \(as entry 0 is\)"):
        load_modal_data(tmp_path / "mixed.json")
