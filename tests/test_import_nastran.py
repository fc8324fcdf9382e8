"""`femu import` and `femu export` of Nastran decks (fe_problem/model/nastran.py).

The reference for the decks' physics is OpenSeesPy: the same structure built by calling
openseespy directly, with the textbook conventions of both programs written out here (a
CBAR's element z = x cross v, plane 1 its x-y plane, I1 resisting bending in it; OpenSees'
vecxz lies in the element's x-z plane and Iz resists bending in its x-y plane). The decks are
written by pyNastran's own writer (BDF.add_* then write_bdf), not by the project's.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import openseespy.opensees as ops
import pytest

import fe_problem as fp
from fe_problem.model import load_model, save_model
from fe_problem.model.nastran import _new_bdf, read_bdf

N_MODES = 8


def femu(*args, cwd=None):
    """`python -m femu ARGS`: (exit code, stdout, stderr)."""
    p = subprocess.run([sys.executable, "-m", "femu", *map(str, args)], capture_output=True, text=True, cwd=cwd,
                       timeout=120)
    return p.returncode, p.stdout, p.stderr.replace("Process 0 Terminating\n", "")


def frequencies(model, n=N_MODES):
    return fp.modal_analysis(model, n).frequencies_hz


@pytest.mark.parametrize("name", ["hframe", "frame3d"])
def test_shipped_models_exported_and_imported_back(tmp_path, name):
    code, out, err = femu("export", name, "--to", "bdf", "--out", tmp_path / "m.bdf")
    assert code == 0, err
    code, out, err = femu("import", tmp_path / "m.bdf", "--out", tmp_path / "m.json")
    assert code == 0, err
    assert "consistent mass, from nastran (SI)" in out
    back, model = load_model(tmp_path / "m.json"), load_model(name)
    assert back.layout == model.layout and len(back.elements) == len(model.elements)
    np.testing.assert_allclose(frequencies(back, 10), frequencies(model, 10), rtol=1e-10, atol=0)
    assert back.meta["import"]["path"] == str((tmp_path / "m.bdf").resolve())


# -- a space frame with an asymmetric section, by pyNastran's writer and by openseespy -------
E, NU, RHO = 2.0e11, 0.29, 7850.0
G = E / (2 * (1 + NU))
A, I1, I2, J = 1.2e-3, 3.1e-6, 0.7e-6, 4.0e-8  # I1 (plane 1) 4.4 times I2
NODES = {1: (0.0, 0.0, 0.0), 2: (0.0, 0.0, 1.5), 3: (1.2, 0.0, 1.5), 4: (1.2, 0.9, 1.7), 5: (2.0, 0.9, 1.7)}
# (eid, ga, gb, v or None, g0 or None)
BARS = [(1, 1, 2, (1.0, 0.3, 0.0), None), (2, 2, 3, None, 4), (3, 3, 4, (0.2, -0.4, 1.0), None),
        (4, 4, 5, (0.0, 1.0, 0.3), None)]
CONM2 = {2: (4.0, 0.02), 3: (2.5, 0.015), 4: (3.0, 0.01), 5: (1.5, 0.012)}  # node: (kg, kg m^2)
K_SPRING = 3.0e5  # a CELAS2 to ground at node 5, y


def _pynastran_deck(path):
    """The frame by pyNastran's own writer: lumped mass (no COUPMASS), rotary inertia at every free node."""
    bdf = _new_bdf()
    for nid, xyz in NODES.items():
        bdf.add_grid(nid, list(xyz))
    bdf.add_mat1(1, E, None, NU, rho=RHO)
    bdf.add_pbar(1, 1, A=A, i1=I1, i2=I2, j=J)
    for eid, ga, gb, v, g0 in BARS:
        bdf.add_cbar(eid, 1, [ga, gb], list(v) if v else None, g0)
    for k, (nid, (m, i)) in enumerate(CONM2.items()):
        bdf.add_conm2(100 + k, nid, m, I=[i, 0.0, i, 0.0, 0.0, i])
    bdf.add_celas2(200, K_SPRING, [5, 0], 2, 0)
    bdf.add_spc1(7, "123456", [1])
    bdf.write_bdf(str(path))


def _opensees_frequencies():
    """The same frame in OpenSees (lumped mass: elasticBeamColumn -mass rho A, no -cMass)."""
    ops.wipe()
    ops.model("basic", "-ndm", 3, "-ndf", 6)
    for nid, xyz in NODES.items():
        ops.node(nid, *xyz)
    ops.node(99, *NODES[5])
    ops.fix(1, 1, 1, 1, 1, 1, 1)
    ops.fix(99, 1, 1, 1, 1, 1, 1)
    for nid, (m, i) in CONM2.items():
        ops.mass(nid, m, m, m, i, i, i)
    for eid, ga, gb, v, g0 in BARS:
        x = np.subtract(NODES[gb], NODES[ga])
        v = np.subtract(NODES[g0], NODES[ga]) if g0 else np.asarray(v)
        vecxz = np.cross(x, v)  # Nastran's element z: in OpenSees' x-z plane
        ops.geomTransf("Linear", eid, *vecxz)
        # Nastran I1 resists bending in plane 1 (element x-y): OpenSees' Iz; I2: Iy
        ops.element("elasticBeamColumn", eid, ga, gb, A, E, G, J, I2, I1, eid, "-mass", RHO * A)
    ops.uniaxialMaterial("Elastic", 1, K_SPRING)
    ops.element("zeroLength", 300, 99, 5, "-mat", 1, "-dir", 2)
    w = np.array(ops.eigen("-fullGenLapack", N_MODES))
    ops.wipe()
    return np.sqrt(w) / (2 * np.pi)


@pytest.fixture(scope="module")
def reference():
    return _opensees_frequencies()


def test_pynastran_deck_matches_opensees(tmp_path, reference):
    _pynastran_deck(tmp_path / "frame.bdf")
    code, out, err = femu("import", tmp_path / "frame.bdf", "--out", tmp_path / "frame.json")
    assert code == 0, err
    assert "space frame, lumped mass" in out
    model = load_model(tmp_path / "frame.json")
    assert {e.formulation for e in model.elements} == {"euler-bernoulli-lumped"}
    assert model.meta["import"]["mass"] == "lumped"
    np.testing.assert_allclose(frequencies(model), reference, rtol=1e-8, atol=0)
    # the sections' axes matter: I1 and I2 swapped is another structure
    swapped = model.replace(sections={k: s.__class__(s.area_m2, iy_m4=s.iz_m4, iz_m4=s.iy_m4, j_m4=s.j_m4)
                                      for k, s in model.sections.items()})
    assert np.max(np.abs(frequencies(swapped) / reference - 1)) > 1e-2


def test_consistent_mass_planar_deck_matches_opensees(tmp_path):
    """COUPMASS: a planar portal (GRID PS 345) with consistent mass, against OpenSees 2-D -cMass;
    its beam's plane 2 is the frame's plane (v normal to it), so I2 is the in-plane inertia."""
    bdf = _new_bdf()
    pts = {1: (0.0, 0.0), 2: (0.0, 1.0), 3: (1.5, 1.0), 4: (1.5, 0.0)}
    for nid, (x, y) in pts.items():
        bdf.add_grid(nid, [x, y, 0.0], ps="345")
    bdf.add_param("COUPMASS", [1])
    bdf.add_mat1(1, E, None, NU, rho=RHO)
    bdf.add_pbar(1, 1, A=A, i1=I1, i2=I2, j=J)
    bdf.add_cbar(1, 1, [1, 2], [1.0, 0.0, 0.0], None)  # plane 1 in the frame's plane: I1
    bdf.add_cbar(2, 1, [2, 3], [0.0, 0.0, 1.0], None)  # plane 1 normal to it: I2 in the plane
    bdf.add_cbar(3, 1, [3, 4], [1.0, 0.0, 0.0], None)
    bdf.add_conm2(10, 3, 2.0)
    bdf.add_spc1(1, "123456", [1, 4])
    bdf.write_bdf(str(tmp_path / "portal.bdf"))
    model = read_bdf(tmp_path / "portal.bdf")
    assert model.layout.dimension == 2 and model.meta["import"]["mass"] == "consistent"
    ops.wipe()
    ops.model("basic", "-ndm", 2, "-ndf", 3)
    for nid, (x, y) in pts.items():
        ops.node(nid, x, y)
    ops.fix(1, 1, 1, 1)
    ops.fix(4, 1, 1, 1)
    ops.mass(3, 2.0, 2.0, 0.0)
    ops.geomTransf("Linear", 1)
    for eid, (i, j), inertia in ((1, (1, 2), I1), (2, (2, 3), I2), (3, (3, 4), I1)):
        ops.element("elasticBeamColumn", eid, i, j, A, E, inertia, 1, "-mass", RHO * A, "-cMass")
    w = np.array(ops.eigen("-fullGenLapack", 6))
    ops.wipe()
    np.testing.assert_allclose(frequencies(model, 6), np.sqrt(w) / (2 * np.pi), rtol=1e-8, atol=0)


def test_units_mm_n_t(tmp_path, reference):
    """The frame in mm, N, tonne: the same model in SI."""
    bdf = _new_bdf()
    for nid, xyz in NODES.items():
        bdf.add_grid(nid, [c * 1e3 for c in xyz])
    bdf.add_mat1(1, E * 1e-6, None, NU, rho=RHO * 1e-12)
    bdf.add_pbar(1, 1, A=A * 1e6, i1=I1 * 1e12, i2=I2 * 1e12, j=J * 1e12)
    for eid, ga, gb, v, g0 in BARS:
        bdf.add_cbar(eid, 1, [ga, gb], list(v) if v else None, g0)
    for k, (nid, (m, i)) in enumerate(CONM2.items()):
        bdf.add_conm2(100 + k, nid, m * 1e-3, I=[i * 1e3, 0.0, i * 1e3, 0.0, 0.0, i * 1e3])
    bdf.add_celas2(200, K_SPRING * 1e-3, [5, 0], 2, 0)
    bdf.add_spc1(7, "123456", [1])
    bdf.write_bdf(str(tmp_path / "mm.bdf"), size=16, is_double=True)
    model = read_bdf(tmp_path / "mm.bdf", units="mm-N-t")
    assert model.meta["import"]["units"] == "mm-N-t"
    np.testing.assert_allclose(frequencies(model), reference, rtol=1e-8, atol=0)


# -- malformed decks -------------------------------------------------------------------------
GOOD = """SOL 103
CEND
SPC = 1
BEGIN BULK
PARAM,COUPMASS,1
GRID    1               0.      0.      0.
GRID    2               1.      0.      0.
CBAR    1       1       1       2       0.      1.      0.
PBAR    1       1       .001    2.-6    1.-6    3.-6
MAT1    1       2.+11           .3      7850.
SPC1    1       123456  1
ENDDATA
"""
BAD = {
    "missing": (GOOD.replace("CBAR    1       1       1       2 ", "CBAR    1       1       1         "),
                "line 8: CBAR 1", "gb"),
    "duplicate": (GOOD.replace("GRID    2               1.      0.      0.\n",
                               "GRID    2               1.      0.      0.\nGRID    2               2.      0.      0.\n"),
                  "line 8: GRID 2", "a second GRID"),
    "nomaterial": (GOOD.replace("MAT1    1 ", "MAT1    7 "), "line 9: PBAR 1", "MAT1 1 is not defined"),
    "nocoord": (GOOD.replace("GRID    2       ", "GRID    2       5"), "line 7: GRID 2",
                "coordinate system 5 is not defined"),
    "shell": (GOOD.replace("ENDDATA", "CQUAD4  9       1       1       2       2       1\nENDDATA"),
              "CQUAD4 x1", "matrices"),
}


@pytest.mark.parametrize("case", sorted(BAD))
def test_malformed_decks_are_refused_in_one_line(tmp_path, case):
    text, where, what = BAD[case]
    deck = tmp_path / f"{case}.bdf"
    deck.write_text(text)
    code, out, err = femu("import", deck, "--out", tmp_path / "m.json")
    assert code == 2 and out == ""
    assert len(err.strip().splitlines()) == 1, err
    assert str(deck) in err and where in err and what in err, err
    assert not (tmp_path / "m.json").exists()


def test_good_deck_of_the_malformed_ones_reads(tmp_path):
    (tmp_path / "good.bdf").write_text(GOOD)
    code, out, err = femu("import", tmp_path / "good.bdf", "--out", tmp_path / "m.json")
    assert code == 0, err


# -- lumped mass with rotations (and released ends) that carry no mass -----------------------
def _opensees_space(rotary: bool, pin_end_of_bar3: bool) -> np.ndarray:
    """The space frame of `_opensees_frequencies`, its node masses with or without rotary
    inertia, and with `pin_end_of_bar3` bar 3's end at node 4 pinned (every rotation released:
    a node of its own tied to node 4 by equalDOF in the translations) and node 5 clamped (else
    bar 4 would spin about its axis, massless and unstrained); OpenSees' -fullGenLapack, which
    takes a singular mass matrix (its default ArpackSolver fails to build a factorisation)."""
    ops.wipe()
    ops.model("basic", "-ndm", 3, "-ndf", 6)
    for nid, xyz in NODES.items():
        ops.node(nid, *xyz)
    ops.node(99, *NODES[5])
    ops.node(44, *NODES[4])
    ops.fix(1, 1, 1, 1, 1, 1, 1)
    ops.fix(99, 1, 1, 1, 1, 1, 1)
    if pin_end_of_bar3:
        ops.equalDOF(4, 44, 1, 2, 3)
        ops.fix(5, 1, 1, 1, 1, 1, 1)
    else:
        ops.fix(44, 1, 1, 1, 1, 1, 1)
    for nid, (m, i) in CONM2.items():
        ops.mass(nid, m, m, m, *([i] * 3 if rotary else [0.0] * 3))
    for eid, ga, gb, v, g0 in BARS:
        x = np.subtract(NODES[gb], NODES[ga])
        v = np.subtract(NODES[g0], NODES[ga]) if g0 else np.asarray(v)
        ops.geomTransf("Linear", eid, *np.cross(x, v))
        end = 44 if (eid == 3 and pin_end_of_bar3) else gb
        ops.element("elasticBeamColumn", eid, ga, end, A, E, G, J, I2, I1, eid, "-mass", RHO * A)
    ops.uniaxialMaterial("Elastic", 1, K_SPRING)
    ops.element("zeroLength", 300, 99, 5, "-mat", 1, "-dir", 2)
    w = np.array(ops.eigen("-fullGenLapack", N_MODES))
    ops.wipe()
    return np.sqrt(w) / (2 * np.pi)


@pytest.mark.parametrize("pinned", [False, True], ids=["rigid", "pinned"])
def test_lumped_deck_without_rotary_inertia_matches_opensees(tmp_path, pinned):
    """Nastran's default (lumped mass, no COUPMASS) with CONM2s that have no inertia: every
    rotation is massless, and with bar 3's end B pinned (PB 456, node 5 clamped) so is its released end; the
    import solves them exactly (condensed on the dense path, shift-invert with the singular M
    on the sparse path): OpenSees' frequencies to 1e-8 on both."""
    bdf = _new_bdf()
    for nid, xyz in NODES.items():
        bdf.add_grid(nid, list(xyz))
    bdf.add_mat1(1, E, None, NU, rho=RHO)
    bdf.add_pbar(1, 1, A=A, i1=I1, i2=I2, j=J)
    for eid, ga, gb, v, g0 in BARS:
        bdf.add_cbar(eid, 1, [ga, gb], list(v) if v else None, g0, pb="456" if (pinned and eid == 3) else "")
    for k, (nid, (m, _)) in enumerate(CONM2.items()):
        bdf.add_conm2(100 + k, nid, m)
    bdf.add_celas2(200, K_SPRING, [5, 0], 2, 0)
    bdf.add_spc1(7, "123456", [1, 5] if pinned else [1])
    bdf.write_bdf(str(tmp_path / "frame.bdf"))
    code, out, err = femu("import", tmp_path / "frame.bdf", "--out", tmp_path / "frame.json")
    assert code == 0 and err == "", err
    assert "space frame, lumped mass" in out
    model = load_model(tmp_path / "frame.json")
    assert all(m.inertia_kg_m2 == 0.0 for m in model.masses)
    assert any(model.end_releases(e)[1] for e in model.elements) == pinned
    expected = _opensees_space(rotary=False, pin_end_of_bar3=pinned)
    for solver in ("dense", "sparse"):
        got = fp.modal_analysis(model, N_MODES, solver=solver).frequencies_hz
        np.testing.assert_allclose(got, expected, rtol=1e-8, atol=0, err_msg=solver)
    # the massless rotations matter: with the CONM2s' inertias it is another structure
    assert np.max(np.abs(_opensees_space(rotary=True, pin_end_of_bar3=pinned) / expected - 1)) > 1e-3


def test_planar_lumped_deck_pinned_foot_and_hinge_matches_opensees(tmp_path):
    """A planar portal (GRID PS 345), lumped mass, one CONM2 without inertia, a pinned foot
    (SPC 12: its rotation free and massless) and a hinge at the girder's end A (PA 6), the
    default deck convention through the command line, against OpenSees 2-D lumped mass with
    the hinge as a node tied by equalDOF."""
    bdf = _new_bdf()
    pts = {1: (0.0, 0.0), 2: (0.0, 1.0), 3: (1.5, 1.0), 4: (1.5, 0.0)}
    for nid, (x, y) in pts.items():
        bdf.add_grid(nid, [x, y, 0.0], ps="345")
    bdf.add_mat1(1, E, None, NU, rho=RHO)
    bdf.add_pbar(1, 1, A=A, i1=I1, i2=I2, j=J)
    bdf.add_cbar(1, 1, [1, 2], [1.0, 0.0, 0.0], None)
    bdf.add_cbar(2, 1, [2, 3], [0.0, 1.0, 0.0], None, pa="6")  # I1 in the plane, hinge at node 2
    bdf.add_cbar(3, 1, [3, 4], [1.0, 0.0, 0.0], None)
    bdf.add_conm2(10, 3, 2.0)
    bdf.add_spc1(1, "123456", [1])
    bdf.add_spc1(1, "12", [4])
    bdf.write_bdf(str(tmp_path / "portal.bdf"))
    code, out, err = femu("import", tmp_path / "portal.bdf", "--out", tmp_path / "portal.json")
    assert code == 0 and err == "", err
    assert "planar frame, lumped mass" in out
    model = load_model(tmp_path / "portal.json")
    assert model.meta["import"]["mass"] == "lumped" and model.end_releases(model.element(2))[0]
    ops.wipe()
    ops.model("basic", "-ndm", 2, "-ndf", 3)
    for nid, (x, y) in pts.items():
        ops.node(nid, x, y)
    ops.node(22, *pts[2])
    ops.fix(1, 1, 1, 1)
    ops.fix(4, 1, 1, 0)
    ops.equalDOF(2, 22, 1, 2)
    ops.mass(3, 2.0, 2.0, 0.0)
    ops.geomTransf("Linear", 1)
    for eid, (i, j) in ((1, (1, 2)), (2, (22, 3)), (3, (3, 4))):
        ops.element("elasticBeamColumn", eid, i, j, A, E, I1, 1, "-mass", RHO * A)
    w = np.array(ops.eigen("-fullGenLapack", 4))  # 4 massed DOFs: the translations of nodes 2 and 3
    ops.wipe()
    expected = np.sqrt(w) / (2 * np.pi)
    for solver in ("dense", "sparse"):
        np.testing.assert_allclose(fp.modal_analysis(model, 4, solver=solver).frequencies_hz, expected,
                                   rtol=1e-8, atol=0, err_msg=solver)
        with pytest.raises(ValueError, match="only 4 elastic modes"):  # no more modes than massed DOFs
            fp.modal_analysis(model, 5, solver=solver)


# -- an updated model written back like its deck ---------------------------------------------
def test_updated_model_written_like_its_deck(tmp_path):
    _pynastran_deck(tmp_path / "frame.bdf")
    code, _, err = femu("import", tmp_path / "frame.bdf", "--out", tmp_path / "frame.json")
    assert code == 0, err
    model = load_model(tmp_path / "frame.json")
    (sec_name,) = model.sections
    sec = model.sections[sec_name]
    updated = model.with_element_moduli({1: 1.8e11, 2: 1.8e11, 3: 1.8e11, 4: 1.8e11}).replace(
        sections={sec_name: sec.__class__(sec.area_m2 * 1.1, iy_m4=sec.iy_m4, iz_m4=sec.iz_m4 * 0.9, j_m4=sec.j_m4)},
        masses=tuple(m.__class__(m.node, m.mass_kg * 1.5, m.inertia_kg_m2) if m.node == 3 else m
                     for m in model.masses),
        springs=tuple(s.__class__(s.id, s.dof_a, s.dof_b, 2.0e5) for s in model.springs))
    save_model(updated, tmp_path / "updated.json")
    code, out, err = femu("export", tmp_path / "updated.json", "--to", "bdf", "--like", "source",
                          "--out", tmp_path / "updated.bdf")
    assert code == 0, err
    old, new = _new_bdf(), _new_bdf()
    old.read_bdf(str(tmp_path / "frame.bdf"), xref=False)
    new.read_bdf(str(tmp_path / "updated.bdf"), xref=False)
    assert new.materials[1].e == pytest.approx(1.8e11, rel=1e-15)
    assert new.materials[1].g == pytest.approx(old.materials[1].g * 0.9, rel=1e-14)
    assert new.properties[1].A == pytest.approx(A * 1.1, rel=1e-15)
    assert new.properties[1].i1 == pytest.approx(I1 * 0.9, rel=1e-15)
    assert new.properties[1].i2 == old.properties[1].i2 and new.properties[1].j == old.properties[1].j
    assert new.masses[101].mass == pytest.approx(2.5 * 1.5, rel=1e-15)
    assert new.elements[200].k == pytest.approx(2.0e5, rel=1e-15)
    # every other card as it was
    for table in ("nodes", "elements", "masses", "properties", "materials"):
        a, b = getattr(old, table), getattr(new, table)
        assert set(a) == set(b)
        changed = {"elements": {200}, "masses": {101}, "properties": {1}, "materials": {1}}.get(table, set())
        for key in set(a) - changed:
            assert a[key].raw_fields() == b[key].raw_fields(), (table, key)
    assert {k: [c.raw_fields() for c in v] for k, v in old.spcs.items()} == \
        {k: [c.raw_fields() for c in v] for k, v in new.spcs.items()}
    # and the deck read back is the updated model
    np.testing.assert_allclose(frequencies(read_bdf(tmp_path / "updated.bdf")), frequencies(updated), rtol=1e-10)


def test_element_moduli_that_split_a_material_get_their_own_cards(tmp_path):
    _pynastran_deck(tmp_path / "frame.bdf")
    model = read_bdf(tmp_path / "frame.bdf")
    updated = model.with_element_moduli({2: 1.5e11})
    from fe_problem.model.nastran import write_like
    write_like(updated, tmp_path / "frame.bdf", tmp_path / "split.bdf")
    new = _new_bdf()
    new.read_bdf(str(tmp_path / "split.bdf"), xref=False)
    assert new.materials[1].e == E and new.materials[2].e == pytest.approx(1.5e11, rel=1e-15)
    assert new.properties[new.elements[2].pid].mid == 2 and new.elements[1].pid == 1
    np.testing.assert_allclose(frequencies(read_bdf(tmp_path / "split.bdf")), frequencies(updated), rtol=1e-10)


def test_cbeam_pbeam_pbarl_celas1_cmass2_against_opensees(tmp_path):
    """COUPMASS: a CBEAM with a constant PBEAM (J = I1 + I2, so that OpenSees' torsional
    inertia rho J is femu's rho (I1 + I2)), a CBAR with a PBARL ROD (pyNastran's A, I, J), a
    CELAS1 with its PELAS to ground and CMASS2s on a node's three translations."""
    bdf = _new_bdf()
    pts = {1: (0.0, 0.0, 0.0), 2: (0.0, 0.0, 1.0), 3: (1.0, 0.0, 1.0), 4: (2.0, 0.3, 1.0)}
    for nid, xyz in pts.items():
        bdf.add_grid(nid, list(xyz))
    bdf.add_param("COUPMASS", [1])
    bdf.add_mat1(1, E, None, NU, rho=RHO)
    bdf.add_pbeam(1, 1, [0.0], ["C"], [A], [I1], [I2], [0.0], [I1 + I2], k1=0.0, k2=0.0)
    bdf.add_cbeam(1, 1, [1, 2], [1.0, 0.2, 0.0], None)
    bdf.add_cbeam(2, 1, [2, 3], [0.0, 0.3, 1.0], None)
    radius = 0.012
    bdf.add_pbarl(2, 1, "ROD", [radius])
    bdf.add_cbar(3, 2, [3, 4], [0.0, 0.0, 1.0], None)
    bdf.add_pelas(7, 1.0e4)
    bdf.add_celas1(8, 7, [4, 0], 3, 0)
    for k, c in enumerate((1, 2, 3)):
        bdf.add_cmass2(20 + k, 0.5, [4, 0], c, 0)
    bdf.add_spc1(1, "123456", [1])
    bdf.write_bdf(str(tmp_path / "beams.bdf"))
    model = read_bdf(tmp_path / "beams.bdf")
    assert set(model.sections) == {"PBEAM 1", "PBARL 2"}
    ops.wipe()
    ops.model("basic", "-ndm", 3, "-ndf", 6)
    for nid, xyz in pts.items():
        ops.node(nid, *xyz)
    ops.node(9, *pts[4])
    ops.fix(1, 1, 1, 1, 1, 1, 1)
    ops.fix(9, 1, 1, 1, 1, 1, 1)
    ops.mass(4, 0.5, 0.5, 0.5, 0.0, 0.0, 0.0)
    a_rod, i_rod = np.pi * radius**2, np.pi * radius**4 / 4
    for eid, (i, j), v, (a, iy, iz, jt) in ((1, (1, 2), (1.0, 0.2, 0.0), (A, I2, I1, I1 + I2)),
                                            (2, (2, 3), (0.0, 0.3, 1.0), (A, I2, I1, I1 + I2)),
                                            (3, (3, 4), (0.0, 0.0, 1.0), (a_rod, i_rod, i_rod, 2 * i_rod))):
        ops.geomTransf("Linear", eid, *np.cross(np.subtract(pts[j], pts[i]), v))
        ops.element("elasticBeamColumn", eid, i, j, a, E, G, jt, iy, iz, eid, "-mass", RHO * a, "-cMass")
    ops.uniaxialMaterial("Elastic", 1, 1.0e4)
    ops.element("zeroLength", 10, 9, 4, "-mat", 1, "-dir", 3)
    w = np.array(ops.eigen("-fullGenLapack", N_MODES))
    ops.wipe()
    np.testing.assert_allclose(frequencies(model), np.sqrt(w) / (2 * np.pi), rtol=1e-8, atol=0)


def test_crod_along_an_axis_is_a_spring_with_lumped_mass_as_opensees_truss(tmp_path, reference):
    """A CROD along x from the frame's node 5 to a fixed GRID: an axial spring and rho A L / 2 at
    each end, against OpenSees' Truss (lumped mass) on the same frame."""
    _pynastran_deck(tmp_path / "frame.bdf")
    bdf = _new_bdf()
    bdf.read_bdf(str(tmp_path / "frame.bdf"))
    bdf.add_grid(6, [3.0, 0.9, 1.7])
    bdf.add_spc1(7, "123456", [6])
    bdf.add_prod(9, 1, 2.0e-5)
    bdf.add_crod(30, 9, [5, 6])
    bdf.write_bdf(str(tmp_path / "rod.bdf"))
    model = read_bdf(tmp_path / "rod.bdf")
    assert [(s.dof_a, s.dof_b) for s in model.springs if s.id == 30] == [((5, "x"), (6, "x"))]
    ops.wipe()
    ops.model("basic", "-ndm", 3, "-ndf", 6)
    for nid, xyz in {**NODES, 6: (3.0, 0.9, 1.7)}.items():
        ops.node(nid, *xyz)
    ops.node(99, *NODES[5])
    for nid in (1, 6, 99):
        ops.fix(nid, 1, 1, 1, 1, 1, 1)
    for nid, (m, i) in CONM2.items():
        ops.mass(nid, m, m, m, i, i, i)
    for eid, ga, gb, v, g0 in BARS:
        v = np.subtract(NODES[g0], NODES[ga]) if g0 else np.asarray(v)
        ops.geomTransf("Linear", eid, *np.cross(np.subtract(NODES[gb], NODES[ga]), v))
        ops.element("elasticBeamColumn", eid, ga, gb, A, E, G, J, I2, I1, eid, "-mass", RHO * A)
    ops.uniaxialMaterial("Elastic", 1, K_SPRING)
    ops.uniaxialMaterial("Elastic", 2, E)
    ops.element("zeroLength", 300, 99, 5, "-mat", 1, "-dir", 2)
    ops.element("Truss", 301, 5, 6, 2.0e-5, 2, "-rho", RHO * 2.0e-5)
    w = np.array(ops.eigen("-fullGenLapack", N_MODES))
    ops.wipe()
    expected = np.sqrt(w) / (2 * np.pi)
    np.testing.assert_allclose(frequencies(model), expected, rtol=1e-8, atol=0)
    assert np.max(np.abs(expected / reference - 1)) > 1e-3  # the rod changes the frame


REFUSED = [
    (lambda b: b.add_conm2(50, 4, 1.0, X=[0.1, 0.0, 0.0]), "CONM2 50", "offset"),
    (lambda b: b.add_conm2(50, 4, 1.0, I=[0.1, 0.0, 0.2, 0.0, 0.0, 0.1]), "CONM2 50", "I11 = I22 = I33"),
    (lambda b: b.add_pbar(1, 1, A=A, i1=I1, i2=I2, i12=1e-7, j=J), "PBAR 1", "I12"),
    (lambda b: b.add_pbar(1, 1, A=A, i1=I1, i2=I2, j=J, nsm=0.5), "PBAR 1", "NSM"),
    (lambda b: b.add_pbar(1, 1, A=A, i1=I1, i2=I2, j=J, k1=0.8, k2=0.6), "PBAR 1", "one shear factor"),
    (lambda b: (b.elements.pop(1), b.add_cbar(1, 1, [1, 2], [1.0, 0.3, 0.0], None, pa=1)), "CBAR 1",
     "rotations only"),
    (lambda b: (b.elements.pop(1), b.add_cbar(1, 1, [1, 2], [1.0, 0.3, 0.0], None, wa=[0.0, 0.1, 0.0])), "CBAR 1",
     "offsets"),
    (lambda b: (b.add_prod(9, 1, 1e-5), b.add_crod(30, 9, [2, 4])), "CROD 30", "no global axis"),
    (lambda b: b.add_cmass2(60, 1.0, [4, 0], 1, 0), "CMASS2 60", "differ between directions"),
    (lambda b: b.add_celas2(61, 1.0, [4, 5], 1, 4), "CELAS2 61", "a translation and a rotation"),
]


@pytest.mark.parametrize("edit, card, said", REFUSED, ids=[r[1] + " " + r[2] for r in REFUSED])
def test_what_a_frame_cannot_hold_is_refused_by_name(tmp_path, edit, card, said):
    bdf = _new_bdf()
    for nid, xyz in NODES.items():
        bdf.add_grid(nid, list(xyz))
    bdf.add_mat1(1, E, None, NU, rho=RHO)
    for eid, ga, gb, v, g0 in BARS:
        bdf.add_cbar(eid, 1, [ga, gb], list(v) if v else None, g0)
    edit(bdf)
    if 1 not in bdf.properties:
        bdf.add_pbar(1, 1, A=A, i1=I1, i2=I2, j=J)
    for k, (nid, (m, i)) in enumerate(CONM2.items()):
        bdf.add_conm2(100 + k, nid, m, I=[i, 0.0, i, 0.0, 0.0, i])
    bdf.add_spc1(7, "123456", [1])
    bdf.write_bdf(str(tmp_path / "bad.bdf"))
    with pytest.raises(ValueError) as err:
        read_bdf(tmp_path / "bad.bdf")
    message = str(err.value)
    assert message.startswith(f"{tmp_path / 'bad.bdf'}: line ") and f": {card}: " in message and said in message, \
        message


def test_without_pynastran_the_command_says_which_extra(tmp_path):
    """In a Python without pyNastran, `femu import` says how to install it, in one line."""
    (tmp_path / "good.bdf").write_text(GOOD)
    code = f"""
import sys
class _Block:
    def find_spec(self, name, path=None, target=None):
        if name.split(".")[0] == "pyNastran":
            raise ModuleNotFoundError(f"No module named {{name!r}}", name=name)
sys.meta_path.insert(0, _Block())
from femu.cli import main
sys.exit(main(["import", {str(tmp_path / "good.bdf")!r}, "--out", {str(tmp_path / "m.json")!r}]))
"""
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    err = p.stderr.replace("Process 0 Terminating\n", "")
    assert p.returncode == 2 and len(err.strip().splitlines()) == 1, err
    assert "needs the 'import' extra: pip install 'femu-bench[import]'" in err and "--no-deps" in err
