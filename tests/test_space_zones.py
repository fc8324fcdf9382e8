"""Weak zones on space elements and end releases on skew members (issue 24), each against
OpenSeesPy (tests/test_beam3d.py `opensees_modes`), which builds the same structure its own way.

A weak zone (`weak_zone` with `about`) is checked against OpenSees' member split into three
elasticBeamColumn segments, the middle one with the reduced Iy, Iz or both over the zone. Our
element keeps the uniform beam's consistent mass (the zone changes its stiffness only), where
the split member distributes the same mass over its segments: to test the stiffness to 1e-8,
the zoned member is given the least density a model file allows (1e-3 kg/m^3, in both codes;
the rest of the frame carries its steel's mass), so that the two mass discretisations of that
member differ by less than 1e-8 in frequency.

A release about a local axis of a skew member (along no global axis) is checked against
OpenSees with the whole structure turned rigidly so that the released member's local axes are
OpenSees' global ones: there the release is OpenSees' own, a second node tied by ``equalDOF``
and ``zeroLength`` springs in the global rotations (fixed supports, isotropic lumped masses and
frequencies do not change under the turn; the shapes are turned back).
"""

from __future__ import annotations

import contextlib
import dataclasses
import io
import json
import os
import pathlib
import subprocess
import sys
import tempfile

import numpy as np
import pytest

import fe_problem as fp
from fe_problem.terms import release_axis
from femu.cli import main

from test_beam3d import STEEL_BEAM, STEEL_COL, Frame, mac_diagonal, opensees_modes, opensees_modes_fresh, portal
from test_frame3d import _diagnose_cli, cut_member, frame_of, measured, model_file
from test_opensees import assert_agrees_with_opensees

N_MODES = 10
LIGHT = 1e-3  # kg/m^3: the least density a model file allows (validate.RANGES)


# --- the weak-zone element ------------------------------------------------------------------------

def split_member(frame: Frame, eid: int, start: float, end: float, ratio: float, about) -> Frame:
    """`frame` with member `eid` cut at `start` and `end` (fractions of its length from its first
    node) into three members, the middle one's Iy (about "ry"), Iz ("rz") times `ratio`."""
    return cut_member(frame, eid, start, end, lambda p: dataclasses.replace(
        p, Iy=p.Iy * (ratio if "ry" in about else 1.0), Iz=p.Iz * (ratio if "rz" in about else 1.0)))


def _light(frame: Frame, eid: int) -> Frame:
    return Frame(frame.nodes, [(e, i, j, dataclasses.replace(p, rho=LIGHT) if e == eid else p, v)
                               for e, i, j, p, v in frame.members], frame.fixed, frame.masses)


def _zoned_file(frame: Frame, eid: int, zone: dict, tmp_path) -> fp.FrameModel:
    """`frame` written as a 3-D model file whose element `eid` carries `zone`, loaded."""
    path = tmp_path / "zoned.model.json"
    d = json.loads(open(model_file(frame, "euler-bernoulli", path)).read())
    next(e for e in d["elements"] if e["id"] == eid)["weak_zone"] = zone
    path.write_text(json.dumps(d))
    return fp.load_model(path)


@pytest.mark.parametrize("about", [["ry"], ["rz"], ["ry", "rz"]], ids=["ry", "rz", "both"])
@pytest.mark.parametrize("eid", [3, 5], ids=["skew-column", "beam"])
def test_weak_zone_element_matches_opensees_split_member(eid, about, tmp_path):
    """The portal of test_beam3d with a weak zone (0.3 to 0.45 of the member, 20 % of its
    bending stiffness about local y, local z or both) in a column with a skew vecxz (member 3)
    or a beam (member 5): frequencies to 1e-8 and MAC 1 against OpenSees' split member."""
    frame = _light(portal(), eid)
    model = _zoned_file(frame, eid, {"start": 0.3, "end": 0.45, "modulus_ratio": 0.2, "about": about}, tmp_path)
    assert model.element(eid).weak_zone == (0.3, 0.45, 0.2) and model.element(eid).weak_zone_about == tuple(about)
    ours = fp.modal_analysis(model, N_MODES)
    f_os, s_os = opensees_modes(split_member(frame, eid, 0.3, 0.45, 0.2, about), False, N_MODES)
    np.testing.assert_allclose(ours.frequencies_hz, f_os, rtol=1e-8, atol=0)
    assert mac_diagonal(ours.shapes, s_os[: 6 * len(frame.nodes)]).min() > 1 - 1e-10
    # the zone matters: the frame's modes move
    nominal = fp.modal_analysis(_zoned_file(frame, eid, {"start": 0.3, "end": 0.45, "modulus_ratio": 1.0,
                                                         "about": about}, tmp_path), N_MODES).frequencies_hz
    assert np.max(np.abs(ours.frequencies_hz / nominal - 1.0)) > 1e-3


def test_a_zone_about_one_axis_leaves_the_other_plane_alone():
    """A zone about local y changes only the x-z bending plane of the element's local stiffness
    (the x-y plane, axial and torsion entries are the uniform beam's), and a zone of ratio 1 is
    the uniform element."""
    from fe_problem.elements import beam3d

    one = np.ones(1)
    args = (np.array([2.5]), np.array([3e-3]), np.array([4e-6]), np.array([1e-6]), np.array([2e-7]))
    plain = beam3d.local_stiffness(*args, np.zeros(1), np.zeros(1))
    zoned = beam3d.zone_stiffness(*args, np.array([0.2]), np.array([0.5]), 0.3 * one, one)
    changed = np.argwhere(np.abs(zoned - plain)[0] > 1e-12 * np.abs(plain).max())
    assert set(changed.ravel()) <= set(beam3d.PLANE_XZ) and len(changed) > 0
    np.testing.assert_allclose(beam3d.zone_stiffness(*args, np.array([0.2]), np.array([0.5]), one, one), plain,
                               rtol=0, atol=1e-12 * np.abs(plain).max())


def test_space_weak_zone_round_trips_and_reads_the_old_form(tmp_path):
    """A space model's zone is written with "about" and read back the same; a file without
    "about" (the form written before it) weakens both bending planes."""
    model = fp.load_model("frame3d")
    from fe_problem.diagnosis import zones
    zoned = zones.with_zone(model, 2, 0.2, 0.35, 0.4, "ry")
    path = fp.save_model(zoned, tmp_path / "z.model.json")
    d = json.loads(path.read_text())
    zone = next(e for e in d["elements"] if e["id"] == 2)["weak_zone"]
    assert zone == {"start": 0.2, "end": 0.35, "modulus_ratio": 0.4, "about": ["ry"]}
    again = fp.load_model(path)
    assert again.element(2).weak_zone == (0.2, 0.35, 0.4) and again.element(2).weak_zone_about == ("ry",)
    np.testing.assert_array_equal(fp.modal_analysis(again, 6).frequencies_hz,
                                  fp.modal_analysis(zoned, 6).frequencies_hz)
    del zone["about"]
    path.write_text(json.dumps(d))
    assert fp.load_model(path).element(2).weak_zone_about == ("ry", "rz")


def test_bad_space_zone_is_one_line(tmp_path, capsys):
    """A bad "about" is one line naming the file, the element and the field, exit 2."""
    model = fp.load_model("frame3d")
    from fe_problem.diagnosis import zones
    path = fp.save_model(zones.with_zone(model, 2, 0.2, 0.35, 0.4, "ry"), tmp_path / "z.model.json")
    d = json.loads(path.read_text())
    zone = next(e for e in d["elements"] if e["id"] == 2)["weak_zone"]
    for bad, words in ((["rx"], ["element 2", "'about'", "['ry', 'rz']"]), (["ry", "ry"], ["element 2", "each once"]),
                       ("ry", ["elements[1]", "'about'", "list"])):
        zone["about"] = bad
        path.write_text(json.dumps(d))
        capsys.readouterr()
        assert main(["model", str(path)]) == 2
        err = capsys.readouterr().err.strip()
        assert "\n" not in err and "Traceback" not in err and str(path) in err, err
        assert all(w in err for w in words), (words, err)


# --- a hidden weak zone found by `femu diagnose` --------------------------------------------------

#: Measured at every floor node: the sways x, y and the rotations rx, ry (rotation sensors).
#: The shipped file's x and y alone cannot tell a column's one-plane weak zone from the same
#: zone in the other columns of its frame line: in the frame's sway and torsion modes those
#: columns act alike (same lever arm about the centre); e.g. column 2's zone about rz tied with
#: columns 5 and 8 (chi^2 within 1), column 5's about ry with columns 4 and 6.
DIRECTIONS = ("x", "y", "rx", "ry")


def opensees_zone_data(element_id: int, start: float, end: float, ratio: float, about: str,
                       seed: int = 11, n_modes: int = 12, freq_noise: float = 0.001,
                       shape_noise: float = 0.01, directions=DIRECTIONS) -> fp.ModalData:
    """Measured modes of the shipped frame3d with element `element_id` split by OpenSees at `start`
    and `end`, its bending stiffness about `about` times `ratio` between them; `directions` at
    every floor node, seeded noise (frequencies relative, shapes a fraction of each mode's largest)."""
    model = fp.load_model("frame3d")
    model = model.replace(measured_dofs=tuple((n, d) for n, _ in model.measured_dofs[::2] for d in directions))
    frame = split_member(frame_of(model), element_id, start, end, ratio, (about,))
    f, shapes = opensees_modes_fresh(frame, False, n_modes)  # the same in any process
    return measured(model, list(frame.nodes), f, shapes, seed, freq_noise, shape_noise,
                    meta={"source": "OpenSeesPy", "freq_noise": freq_noise, "shape_noise": shape_noise})


def _diagnose_json(data: fp.ModalData, path: pathlib.Path) -> dict:
    """`femu diagnose FILE --json` on `data` written to `path`, as a user runs it: its record."""
    fp.save_modal_data(data, path)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["diagnose", str(path), "--json"]) == 0
    return json.loads(out.getvalue())


@pytest.fixture(scope="module")
def corner_record(tmp_path_factory):
    """`corner_record(about)`: the `femu diagnose --json` record of the corner column's zone about
    `about` (`opensees_zone_data(1, 0.2, 0.3, 0.1, about)`), each diagnosed once for the module: the
    test of its answer and (rz) the test of its last digits read the same record (a space-frame
    diagnosis is the costly part of both)."""
    directory = tmp_path_factory.mktemp("corner")
    records = {}

    def record(about: str) -> dict:
        if about not in records:
            records[about] = _diagnose_json(opensees_zone_data(1, 0.2, 0.3, 0.1, about),
                                            directory / f"corner-{about}.modal.json")
        return records[about]

    return record


def _truth_in_a_process(out, before: str) -> tuple[np.ndarray, np.ndarray]:
    """The corner-column rz truth (`opensees_zone_data`) made in a new Python process that first
    runs `before` (Python source)."""
    code = (f"import sys\nimport numpy as np\nimport fe_problem as fp\n{before}\n"
            "from test_space_zones import opensees_zone_data\n"
            "d = opensees_zone_data(1, 0.2, 0.3, 0.1, 'rz')\n"
            "np.savez(sys.argv[1], f=d.frequencies_hz, shapes=d.shapes)\n")
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(pathlib.Path(__file__).parent), *sys.path]))
    subprocess.run([sys.executable, "-c", code, str(out)], env=env, check=True, capture_output=True)
    with np.load(out) as d:
        return d["f"], d["shapes"]


def test_truth_does_not_depend_on_what_ran_before(tmp_path):
    """The measured modes `opensees_zone_data` makes are bit for bit the same in a process that
    ran nothing before and in one that ran a modal analysis of the H-frame first (as pytest does
    when tests/test_diagnosis_answer.py comes before this module). Made in the calling process,
    OpenSees' modes differed by 3e-14 in frequency, 1e-13 in shape and in the sign of 7 of the 12
    modes; the signs made the noise drawn on those modes another draw (test_frame3d.measured now
    fixes each mode's sign first), and `femu diagnose` of the corner-column rz data then answered
    "undetermined" instead of the zone in that column's frame line (the diagnosis of one data
    file is the same record after any other: checked)."""
    alone = _truth_in_a_process(tmp_path / "alone.npz", "")
    after = _truth_in_a_process(tmp_path / "after.npz", "fp.modal_analysis(fp.load_model('hframe'), 8)")
    assert np.array_equal(alone[0], after[0]) and np.array_equal(alone[1], after[1])


def test_changes_in_the_last_digits_of_the_data_change_no_diagnosis(corner_record, tmp_path):
    """The corner-column rz data, and the same with every frequency and shape entry changed by
    1e-13 of itself in two seeded patterns of signs: the same cause, answer and pinned moduli.
    (Its truth made after a modal analysis of the H-frame once answered "undetermined": its
    frequencies differed by 1e-13, and 7 of its 12 modes had the other sign, so their noise was
    another draw, test_frame3d.test_measured_data_do_not_depend_on_the_solvers_signs; the
    last digits alone change nothing.) The pinned moduli are compared but may be none: the
    sparse path's pinned fit is the MAP with each modulus' box as a prior (issue 19), which pins
    none here (its most moved moduli: beam 17 at z = 0.13, the cracked column 1 at 0.21); the
    unregularised fit it replaced pinned 15, 17, 18 and 58. Its own stability under changes of
    its Jacobian: tests/test_pinned_fit.py. Each through `femu diagnose --json` (the data files
    keep every digit: checked), the unchanged data's record shared with the test of its answer."""
    data = opensees_zone_data(1, 0.2, 0.3, 0.1, "rz")

    def key(r):
        cause, answer = r["cause"], r["answer"]
        return (cause["kind"], cause["label"], cause.get("indistinguishable", []), answer["label"], answer["kind"],
                answer["decisive"], [(p["parameter"], p["bound"]) for p in r["residuals"]["pinned_parameters"]])

    first = key(corner_record("rz"))
    assert first[0] == "stiffness_loss", first
    for seed in (1, 2):
        rng = np.random.default_rng(seed)
        f = data.frequencies_hz * (1.0 + 1e-13 * rng.choice([-1.0, 1.0], data.frequencies_hz.shape))
        shapes = data.shapes * (1.0 + 1e-13 * rng.choice([-1.0, 1.0], data.shapes.shape))
        assert not np.array_equal(f, data.frequencies_hz) and not np.array_equal(shapes, data.shapes)
        path = tmp_path / f"digits-{seed}.modal.json"
        record = _diagnose_json(dataclasses.replace(data, frequencies_hz=f, shapes=shapes), path)
        written = fp.load_modal_data(path)
        assert np.array_equal(written.frequencies_hz, f) and np.array_equal(written.shapes, shapes)
        assert key(record) == first, seed


def test_the_batched_screen_is_the_one_by_one_screen_beside_close_modes():
    """screening.screen_linear_batch (the sparse path's hot path) against screen_linear (one
    candidate, every mode of the baseline) on frame3d's element and joint candidates, with data
    whose paired modes have close unpaired neighbours (the sway pairs): the same (chi^2 drop, a)."""
    from fe_problem.diagnosis.candidates import all_candidates
    from fe_problem.diagnosis.core import calibrate
    from test_diagnosis_modelform_terms import one_by_one_and_batched

    model = fp.load_model("frame3d")
    cal = calibrate(model, opensees_zone_data(1, 0.2, 0.3, 0.1, "ry"), 0.001, 0.01)
    st, base = cal.setting, cal.base
    cands = [c for c in all_candidates(st, ["stiffness_loss", "joint_flexibility"]) if c.term is not None][::7]
    assert len(np.unique(base.pairing[base.pairing >= 0])) < st.n_modes  # unpaired model modes exist
    one, batch = one_by_one_and_batched(cal, cands)
    assert len(cands) > 100 and one[:, 0].max() > 100.0
    np.testing.assert_allclose(batch, one, rtol=1e-9, atol=1e-9 * one[:, 0].max())


def test_diagnose_keeps_a_zone_in_its_bending_plane_and_frame_line(tmp_path, capsys):
    """An edge column of the shipped space frame (element 6, at x = 12 m) with a weak zone from
    0.2 to 0.3 of its length keeping 10 % of its bending stiffness about local z (sway in y),
    built by OpenSees (the column split in three), 12 modes at x, y, rx, ry of every floor node
    with 0.1 % / 1 % noise: `femu diagnose` names a weak zone about rz, and the column up to its
    frame line (the columns at x = 12, elements 3, 6, 9, which these data cannot tell apart:
    the diagnosis says so and names no other place)."""
    record = _diagnose_cli(tmp_path, capsys, opensees_zone_data(6, 0.2, 0.3, 0.1, "rz"))
    cause = record["cause"]
    assert cause["kind"] == "stiffness_loss", cause
    tied = cause.get("indistinguishable") or [cause["label"]]
    assert all(label.startswith("stiffness_loss@element=") and label.endswith(" rz)") for label in tied), tied
    columns = {int(label.split("=")[1].split("(")[0]) for label in tied}
    assert 6 in columns and columns <= {3, 6, 9}, tied


@pytest.mark.parametrize("about, line", [("ry", {1, 2, 3}), ("rz", {1, 4, 7})], ids=["ry", "rz"])
def test_diagnose_finds_a_corner_columns_zone_in_its_plane_and_frame_line(about, line, corner_record):
    """A corner column of the shipped space frame (element 1, at x = y = 0) with a weak zone from
    0.2 to 0.3 of its length keeping 10 % of its bending stiffness about local y (sway in x) or
    local z (sway in y), built by OpenSees (the column split in three), 12 modes at x, y, rx, ry
    of every floor node with 0.1 % / 1 % noise: `femu diagnose` names a weak zone in that bending
    plane, the column among the ground-storey columns of its frame line in that plane (y = 0:
    elements 1, 2, 3; x = 0: elements 1, 4, 7), and names no joint: the corner columns of a line
    are mirror images in a doubly symmetric frame, so the answer may be another of them only as
    not decisive. Before `core.look_at_clipped` the true zone (fitted chi^2 422, the best of all)
    screened 15th to first order and was not fitted: `femu diagnose` named a joint of element 2."""
    record = corner_record(about)
    cause, answer = record["cause"], record["answer"]
    assert cause["kind"] == "stiffness_loss" and answer["kind"] == "stiffness_loss", (cause, answer)
    tied = cause.get("indistinguishable") or [cause["label"]]
    assert all(label.startswith("stiffness_loss@element=") and label.endswith(f" {about})") for label in tied), tied
    columns = {int(label.split("=")[1].split("(")[0]) for label in tied}
    assert 1 in columns and columns <= line, tied
    assert answer["label"].endswith(f" {about})"), answer
    if not answer["label"].startswith("stiffness_loss@element=1("):
        assert not answer["decisive"] and answer["runner_up"]["label"].endswith(f" {about})"), answer
        assert int(answer["runner_up"]["label"].split("=")[1].split("(")[0]) in line, answer


# --- end releases on skew members -----------------------------------------------------------------

def turned(frame: Frame, r: np.ndarray) -> Frame:
    """`frame` turned rigidly by the rotation `r` (3, 3): nodes and vecxz r @ v."""
    return Frame({n: tuple(r @ np.asarray(p, dtype=float)) for n, p in frame.nodes.items()},
                 [(e, i, j, p, tuple(r @ np.asarray(v, dtype=float))) for e, i, j, p, v in frame.members],
                 frame.fixed, frame.masses)


def opensees_turned(model: fp.FrameModel, element_id: int, releases: dict, n_modes: int = N_MODES):
    """The modes of `model` with end `releases` ({node: {local rotation: N m/rad}}) of element
    `element_id` in OpenSees, built turned so that the element's local axes are the global ones
    (its local rx, ry, rz: OpenSees' DOFs 4, 5, 6); frequencies, and shapes turned back (6 rows
    per node of the model, its order)."""
    r = model.local_axes(element_id)
    assert all(s.directions == model.layout.names for s in model.supports)  # fixed supports turn with it
    dof = {"rx": 4, "ry": 5, "rz": 6}
    rel = {(element_id, node): {dof[k]: v for k, v in spec.items()} for node, spec in releases.items()}
    f, shapes = opensees_modes(turned(frame_of(model, releases_allowed=True), r), False, n_modes + 6, releases=rel)
    keep = np.flatnonzero(np.isfinite(f))[:n_modes]  # a massless released end: OpenSees' infinite eigenvalues
    s = shapes[:, keep].reshape(len(model.nodes), 2, 3, len(keep))
    back = np.einsum("ab,nkam->nkbm", r, s)  # global = r^T turned
    return f[keep], back.reshape(6 * len(model.nodes), len(keep))


def braced_portal() -> fp.FrameModel:
    """test_beam3d's portal with a tube brace from a base corner (node 1) to the far top corner
    (node 23): a member along no global axis, its vecxz skew too."""
    frame = portal()
    tube = dataclasses.replace(STEEL_BEAM, A=1.2e-3, Iy=1.5e-6, Iz=1.5e-6, J=3.0e-6)
    frame = Frame(frame.nodes, frame.members + [(200, 1, 23, tube, (0.3, -0.2, 0.9))], frame.fixed, frame.masses)
    with tempfile.TemporaryDirectory() as tmp:
        return fp.load_model(model_file(frame, "euler-bernoulli", pathlib.Path(tmp) / "braced.model.json"))


def _released(model: fp.FrameModel, eid: int, i=(), j=()) -> fp.FrameModel:
    return model.replace(elements=tuple(dataclasses.replace(e, releases_i=tuple(i), releases_j=tuple(j))
                                        if e.id == eid else e for e in model.elements))


def test_skew_brace_released_about_its_local_axes_matches_opensees():
    """The braced portal's brace pinned about both bending axes at its base and tied at its top
    by springs in torsion and both bending planes (its local axes along no global axis):
    frequencies to 1e-8, MAC 1, against OpenSees on the dense and the sparse path."""
    model = braced_portal()
    assert all(release_axis(model, model.element(200), r) is not None for r in ("rx", "ry", "rz"))
    released = _released(model, 200, i=(("ry", 0.0), ("rz", 0.0)), j=(("rx", 2e4), ("ry", 1e5), ("rz", 4e5)))
    ours = fp.modal_analysis(released, N_MODES)
    f_os, s_os = opensees_turned(released, 200, {1: {"ry": 0.0, "rz": 0.0}, 23: {"rx": 2e4, "ry": 1e5, "rz": 4e5}})
    np.testing.assert_allclose(ours.frequencies_hz, f_os, rtol=1e-8, atol=0)
    assert mac_diagonal(ours.shapes, s_os).min() > 1 - 1e-10
    sparse = fp.modal_analysis(released, N_MODES, solver="sparse")
    np.testing.assert_allclose(sparse.frequencies_hz, f_os, rtol=1e-8, atol=0)
    rigid = fp.modal_analysis(model, N_MODES).frequencies_hz
    assert np.max(np.abs(ours.frequencies_hz / rigid - 1.0)) > 1e-3  # the releases matter


def gable() -> fp.FrameModel:
    """A gable frame in the x-z plane, modelled in 3-D: two 4 m columns, two rafters rising
    1.5 m over 5 m to the ridge (node 5), fixed bases, masses at the eaves and the ridge."""
    d = {"format": "femu.model/1", "name": "gable", "dimension": 3,
         "materials": {"steel": {"youngs_modulus_pa": 2.1e11, "shear_modulus_pa": 8.1e10, "density_kg_m3": 7850}},
         "sections": {"col": {"area_m2": 5.4e-3, "iy_m4": 5.8e-5, "iz_m4": 4.0e-6, "j_m4": 2.0e-7},
                      "raf": {"area_m2": 4.0e-3, "iy_m4": 3.9e-5, "iz_m4": 2.0e-6, "j_m4": 1.2e-7}},
         "nodes": [{"id": 1, "x": 0.0, "y": 0.0, "z": 0.0}, {"id": 2, "x": 10.0, "y": 0.0, "z": 0.0},
                   {"id": 3, "x": 0.0, "y": 0.0, "z": 4.0}, {"id": 4, "x": 10.0, "y": 0.0, "z": 4.0},
                   {"id": 5, "x": 5.0, "y": 0.0, "z": 5.5}],
         "elements": [{"id": 1, "nodes": [1, 3], "section": "col", "material": "steel", "orientation": [1, 0, 0]},
                      {"id": 2, "nodes": [2, 4], "section": "col", "material": "steel", "orientation": [1, 0, 0]},
                      {"id": 3, "nodes": [3, 5], "section": "raf", "material": "steel", "orientation": [-0.3, 0, 1]},
                      {"id": 4, "nodes": [5, 4], "section": "raf", "material": "steel", "orientation": [0.3, 0, 1]}],
         "masses": [{"node": 3, "mass_kg": 400.0}, {"node": 4, "mass_kg": 400.0}, {"node": 5, "mass_kg": 250.0}],
         "supports": [{"node": n, "directions": ["x", "y", "z", "rx", "ry", "rz"]} for n in (1, 2)]}
    return fp.model.model_from_dict(d, "gable.model.json")


def test_inclined_rafter_released_at_the_ridge_matches_opensees():
    """The gable frame's left rafter tied to the ridge by springs about its local y (in-plane
    bending: along the global y) and local z (out-of-plane bending: a skew axis in the x-z
    plane): one release along a global axis and one along none at the same end, frequencies to
    1e-8, MAC 1, against OpenSees."""
    model = gable()
    raf = model.element(3)
    assert release_axis(model, raf, "ry") is None and release_axis(model, raf, "rz") is not None
    released = _released(model, 3, j=(("ry", 3e5), ("rz", 1e5)))
    ours = fp.modal_analysis(released, 8)
    f_os, s_os = opensees_turned(released, 3, {5: {"ry": 3e5, "rz": 1e5}}, 8)
    np.testing.assert_allclose(ours.frequencies_hz, f_os, rtol=1e-8, atol=0)
    assert mac_diagonal(ours.shapes, s_os).min() > 1 - 1e-10
    rigid = fp.modal_analysis(model, 8).frequencies_hz
    assert np.max(np.abs(ours.frequencies_hz / rigid - 1.0)) > 1e-3


def test_planar_inclined_rafter_released_matches_opensees():
    """The same gable as a planar model (x-y plane), its left rafter tied to the ridge by a
    rotational spring, each member in two elements: OpenSees 2-D (tests/test_opensees.py) to
    1e-8 in frequency, MAC 1."""
    d = {"format": "femu.model/1", "name": "gable2d",
         "materials": {"steel": {"youngs_modulus_pa": 2.1e11, "density_kg_m3": 7850}},
         "sections": {"col": {"area_m2": 5.4e-3, "inertia_m4": 5.8e-5}, "raf": {"area_m2": 4.0e-3, "inertia_m4": 3.9e-5}},
         "nodes": [{"id": 1, "x": 0.0, "y": 0.0}, {"id": 2, "x": 10.0, "y": 0.0}, {"id": 3, "x": 0.0, "y": 4.0},
                   {"id": 4, "x": 10.0, "y": 4.0}, {"id": 5, "x": 5.0, "y": 5.5}],
         "elements": [{"id": 1, "nodes": [1, 3], "section": "col", "material": "steel"},
                      {"id": 2, "nodes": [2, 4], "section": "col", "material": "steel"},
                      {"id": 3, "nodes": [3, 5], "section": "raf", "material": "steel", "release_j": 1e5},
                      {"id": 4, "nodes": [5, 4], "section": "raf", "material": "steel"}],
         "masses": [{"node": 3, "mass_kg": 400.0}, {"node": 4, "mass_kg": 400.0}, {"node": 5, "mass_kg": 250.0}],
         "supports": [{"node": n, "directions": ["x", "y", "rz"]} for n in (1, 2)]}
    model = fp.split_elements(fp.model.model_from_dict(d, "gable2d.model.json"), 2)
    assert model.element(3).release_j is None and sum(e.release_j == 1e5 for e in model.elements) == 1
    assert_agrees_with_opensees(model, n_rigid=0)
