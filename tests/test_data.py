"""Measured modal data: the JSON contract (docs/modal-data-format.md), UFF dataset 55,
the shipped paper dataset and the synthetic measurement generator."""

import copy
import json
import re

import numpy as np
import pytest

import fe_problem as fp
from fe_problem.modal_data.uff import read_uff55, write_uff55

VALID = {
    "format": "femu.modal-data/1",
    "model": "hframe",
    "dofs": [[1, "x"], [2, "x"], [11, "y"]],
    "modes": [
        {"frequency_hz": 53.9, "shape": [0.12, -0.4, 1.0]},
        {"frequency_hz": 117.3, "shape": None},
    ],
    "meta": {"source": "a test"},
}
UFF_RTOL = 5e-6  # dataset 55 stores 6 significant figures (format 6E13.5)


def write_json(tmp_path, obj, name="data.json"):
    path = tmp_path / name
    path.write_text(obj if isinstance(obj, str) else json.dumps(obj))
    return path


def assert_refused(path, *fragments):
    """The file is refused with a DataFileError naming the file and every fragment."""
    with pytest.raises(fp.DataFileError) as err:
        fp.load_modal_data(path)
    msg = str(err.value)
    assert str(path) in msg, msg
    for frag in fragments:
        assert frag in msg, msg
    return msg


def mutated(change):
    d = copy.deepcopy(VALID)
    change(d)
    return d


# -- the JSON contract ----------------------------------------------------------------

def test_valid_file_loads_as_written(tmp_path):
    data = fp.load_modal_data(write_json(tmp_path, VALID))
    assert data.model == "hframe" and data.dofs == ((1, "x"), (2, "x"), (11, "y"))
    np.testing.assert_array_equal(data.frequencies_hz, [53.9, 117.3])
    np.testing.assert_array_equal(data.shapes[:, 0], [0.12, -0.4, 1.0])
    assert np.isnan(data.shapes[:, 1]).all()
    assert data.has_shape.tolist() == [True, False]
    assert data.meta == {"source": "a test"}


@pytest.mark.parametrize("field", ["format", "model", "dofs", "modes"])
def test_missing_field(tmp_path, field):
    assert_refused(write_json(tmp_path, mutated(lambda d: d.pop(field))), f"missing field '{field}'")


def test_missing_frequency(tmp_path):
    bad = mutated(lambda d: d["modes"][1].pop("frequency_hz"))
    assert_refused(write_json(tmp_path, bad), "'modes'[1]", "frequency_hz")


@pytest.mark.parametrize("fmt", ["femu.modal-data/2", "femu.modal-data", "", 1])
def test_wrong_format_string(tmp_path, fmt):
    bad = mutated(lambda d: d.__setitem__("format", fmt))
    assert_refused(write_json(tmp_path, bad), "'format'", "femu.modal-data/1")


@pytest.mark.parametrize("shape, told", [([0.1, 0.2], "got 2"), ([0.1, 0.2, 0.3, 0.4], "got 4"),
                                         ("0.1 0.2 0.3", "got str")])
def test_shape_of_the_wrong_length(tmp_path, shape, told):
    bad = mutated(lambda d: d["modes"][0].__setitem__("shape", shape))
    assert_refused(write_json(tmp_path, bad), "'modes'[0].shape", "needs 3", told)


def test_nan_in_a_shape(tmp_path):
    text = json.dumps(VALID).replace("-0.4", "NaN")
    assert_refused(write_json(tmp_path, text), "'modes'[0].shape[1]", "nan")


def test_nan_frequency(tmp_path):
    text = json.dumps(VALID).replace("117.3", "NaN")
    assert_refused(write_json(tmp_path, text), "'modes'[1].frequency_hz", "nan")


def test_all_zero_shape(tmp_path):
    bad = mutated(lambda d: d["modes"][0].__setitem__("shape", [0, 0.0, 0]))
    assert_refused(write_json(tmp_path, bad), "'modes'[0].shape", "all zeros")


@pytest.mark.parametrize("f", [-53.9, 0, 0.0, True, "53.9"])
def test_non_positive_or_non_numeric_frequency(tmp_path, f):
    bad = mutated(lambda d: d["modes"][0].__setitem__("frequency_hz", f))
    assert_refused(write_json(tmp_path, bad), "'modes'[0].frequency_hz", "> 0")


def test_unsorted_frequencies(tmp_path):
    bad = mutated(lambda d: d["modes"].reverse())
    assert_refused(write_json(tmp_path, bad), "'modes'", "ascend", "53.9")


def test_unknown_node(tmp_path):
    bad = mutated(lambda d: d["dofs"].__setitem__(2, [14, "y"]))
    assert_refused(write_json(tmp_path, bad), "'dofs'[2]", "node 14", "hframe")


@pytest.mark.parametrize("direction", ["z", "X", "rx", 2])
def test_unknown_direction(tmp_path, direction):
    bad = mutated(lambda d: d["dofs"].__setitem__(1, [2, direction]))
    assert_refused(write_json(tmp_path, bad), "'dofs'[1]", "direction")


@pytest.mark.parametrize("dof", [[1], [1, "x", 0], ["1", "x"], [True, "x"], "1x"])
def test_malformed_dof(tmp_path, dof):
    bad = mutated(lambda d: d["dofs"].__setitem__(0, dof))
    assert_refused(write_json(tmp_path, bad), "'dofs'[0]", "[node id, direction]")


def test_duplicate_dof(tmp_path):
    bad = mutated(lambda d: d["dofs"].__setitem__(1, [1, "x"]))
    assert_refused(write_json(tmp_path, bad), "'dofs'", "twice")


def test_empty_modes_and_dofs(tmp_path):
    assert_refused(write_json(tmp_path, mutated(lambda d: d.__setitem__("modes", []))), "'modes'", "non-empty")
    assert_refused(write_json(tmp_path, mutated(lambda d: d.__setitem__("dofs", []))), "'dofs'", "non-empty")


def test_unknown_model(tmp_path):
    bad = mutated(lambda d: d.__setitem__("model", "no-such-frame"))
    assert_refused(write_json(tmp_path, bad), "'model'", "no-such-frame", "hframe")


def test_bad_json(tmp_path):
    text = json.dumps(VALID)[:-5]
    assert_refused(write_json(tmp_path, text), "not valid JSON")


def test_not_an_object(tmp_path):
    assert_refused(write_json(tmp_path, [VALID]), "JSON object")


@pytest.mark.parametrize("meta", [[], "free text", 3])
def test_meta_not_an_object(tmp_path, meta):
    bad = mutated(lambda d: d.__setitem__("meta", meta))
    assert_refused(write_json(tmp_path, bad), "'meta'", "object")


def test_meta_is_optional_and_kept(tmp_path):
    no_meta = fp.load_modal_data(write_json(tmp_path, mutated(lambda d: d.pop("meta"))))
    assert no_meta.meta == {}
    rich = mutated(lambda d: d.__setitem__("meta", {"rig": {"bands": 4}, "notes": [1, "two"]}))
    out = fp.save_modal_data(fp.load_modal_data(write_json(tmp_path, rich, "rich.json")), tmp_path / "again.json")
    assert json.loads(out.read_text())["meta"] == rich["meta"]


def test_model_path_relative_to_the_data_file(tmp_path):
    model_dir = tmp_path / "models"
    model_dir.mkdir()
    fp.save_model(fp.load_model("hframe").replace(name="myframe"), model_dir / "myframe.json")
    data = fp.load_modal_data(write_json(tmp_path, mutated(lambda d: d.__setitem__("model", "models/myframe.json"))))
    assert data.load_model().name == "myframe"


def test_missing_data_file_names_shipped_datasets(tmp_path):
    with pytest.raises(FileNotFoundError, match=r"nowhere\.json.*paper"):
        fp.load_modal_data(tmp_path / "nowhere.json")


def test_json_round_trip_is_exact(tmp_path):
    data = fp.synthetic_measurement("hframe", 6, freq_noise=0.003, shape_noise=0.02, seed=4)
    again = fp.load_modal_data(fp.save_modal_data(data, tmp_path / "s.json"))
    assert again.dofs == data.dofs and again.model == data.model and again.meta == data.meta
    np.testing.assert_array_equal(again.frequencies_hz, data.frequencies_hz)
    np.testing.assert_array_equal(again.shapes, data.shapes)


# -- the shipped paper dataset ---------------------------------------------------------

def test_paper_dataset():
    data = fp.load_modal_data("paper")
    np.testing.assert_array_equal(data.frequencies_hz, [53.9, 117.3, 208.4, 254.0, 445.1])
    assert data.model == "hframe" and not data.has_shape.any()
    assert data.dofs == fp.load_model("hframe").measured_dofs
    table = fp.paper_table()
    assert table["measured_hz"] == [53.9, 117.3, 208.4, 254.0, 445.1]
    assert table["initial_hz"] == [56.2, 127.1, 228.4, 263.4, 452.4]
    assert table["updated_hz"]["PSO"] == [53.9, 117.8, 208.5, 253.8, 438.5]
    assert table["mean_error_pct_text"]["PSO"] == 1.95


# -- UFF dataset 55 ----------------------------------------------------------------------

def _by_dof(data):
    return {d: data.shapes[i] for i, d in enumerate(data.dofs)}


def test_json_to_uff_to_json_round_trip(tmp_path):
    data = fp.synthetic_measurement("hframe", 8, freq_noise=0.002, shape_noise=0.03, seed=11)
    fp.save_modal_data(data, tmp_path / "m.json")
    uff = fp.save_modal_data(fp.load_modal_data(tmp_path / "m.json"), tmp_path / "m.uff")
    back = fp.load_modal_data(uff)
    assert back.model == "hframe" and back.meta == {"source": "synthetic"}
    assert set(back.dofs) == set(data.dofs)
    np.testing.assert_allclose(back.frequencies_hz, data.frequencies_hz, rtol=UFF_RTOL, atol=0)
    ours, theirs = _by_dof(back), _by_dof(data)
    for dof in data.dofs:
        np.testing.assert_allclose(ours[dof], theirs[dof], rtol=UFF_RTOL, atol=0)
    # and back to JSON: a valid file that loads the same again
    again = fp.load_modal_data(fp.save_modal_data(back, tmp_path / "again.json"))
    np.testing.assert_array_equal(again.shapes, back.shapes)


def test_uff_to_json_to_uff_is_byte_identical(tmp_path):
    data = fp.synthetic_measurement("hframe", 5, shape_noise=0.01, seed=2)
    first = write_uff55(data, tmp_path / "a.uff")
    via_json = fp.save_modal_data(read_uff55(first), tmp_path / "a.json")
    second = write_uff55(fp.load_modal_data(via_json), tmp_path / "b.uff")
    assert first.read_text() == second.read_text()


def test_uff_layout_is_standard_dataset_55(tmp_path):
    data = fp.synthetic_measurement("hframe", 3, seed=0, dofs=[(3, "x"), (3, "rz"), (11, "y")])
    lines = write_uff55(data, tmp_path / "s.unv").read_text().splitlines()
    starts = [i for i, line in enumerate(lines) if line.strip() == "55"]
    assert len(starts) == 3  # one dataset per mode
    head = lines[starts[0]:starts[0] + 12]
    assert head[1].rstrip() == "model: hframe"
    assert head[6].split() == ["1", "2", "3", "8", "2", "6"]  # structural, normal mode, 6 DOF, real
    assert head[7].split() == ["2", "4", "1", "1"]  # load case 1, mode 1
    assert float(head[8].split()[0]) == pytest.approx(data.frequencies_hz[0], rel=UFF_RTOL)
    assert head[9].strip() == "3"
    x, y, z, rx, ry, rz = map(float, head[10].split())
    assert (y, z, rx, ry) == (0.0, 0.0, 0.0, 0.0) and x != 0 and rz != 0


def test_frequency_only_modes_are_refused_by_uff(tmp_path):
    with pytest.raises(fp.DataFileError, match=r"p\.uff.*mode\(s\) 1 \(53\.9 Hz\).*no measured shape.*JSON"):
        fp.save_modal_data(fp.load_modal_data("paper"), tmp_path / "p.uff")
    assert not (tmp_path / "p.uff").exists()
    mixed = fp.load_modal_data(write_json(tmp_path, VALID))
    with pytest.raises(fp.DataFileError, match=r"mode\(s\) 2 \(117\.3 Hz\)"):
        write_uff55(mixed, tmp_path / "mixed.uff")
    kept = read_uff55(write_uff55(mixed.subset(np.flatnonzero(mixed.has_shape)), tmp_path / "kept.uff"))
    np.testing.assert_array_equal(kept.frequencies_hz, [53.9])


def _uff_text(tmp_path):
    """A valid 2-mode UFF file as text (nodes 1, 5, 11)."""
    data = fp.synthetic_measurement("hframe", 2, seed=0, dofs=[(1, "x"), (5, "y"), (11, "y")])
    return write_uff55(data, tmp_path / "base.uff").read_text()


def _rewrite(tmp_path, text, name="bad.uff"):
    path = tmp_path / name
    path.write_text(text)
    return path


def _replace_record(text, record, new, dataset=1):
    """Replace record `record` (1-based, as in the UFF 55 spec) of the dataset-th dataset."""
    lines = text.splitlines()
    starts = [i for i, line in enumerate(lines) if line.strip() == "55"]
    lines[starts[dataset - 1] + record] = new
    return "\n".join(lines) + "\n"


def test_uff_not_dataset_55(tmp_path):
    text = _uff_text(tmp_path).replace("    55    ", "    58    ")
    assert_refused(_rewrite(tmp_path, text), "no dataset 55", "58")


def test_uff_not_a_uff_file(tmp_path):
    assert_refused(_rewrite(tmp_path, "this is\nnot a universal file\n"), "not a UFF file")


def test_uff_not_normal_modes(tmp_path):
    text = _replace_record(_uff_text(tmp_path), 6, "%10i" * 6 % (1, 3, 3, 8, 2, 6))
    assert_refused(_rewrite(tmp_path, text), "dataset 55 #1", "analysis type 3", "normal mode")


def test_uff_complex_data(tmp_path):
    # 3 complex translations per node: each record 10 of 6 numbers reads as 3 complex values
    text = _replace_record(_uff_text(tmp_path), 6, "%10i" * 6 % (1, 2, 2, 8, 5, 3))
    assert_refused(_rewrite(tmp_path, text), "dataset 55 #1", "data type 5", "real")


def test_uff_out_of_plane_direction(tmp_path):
    text = _uff_text(tmp_path)
    lines = text.splitlines()
    i = next(k for k, line in enumerate(lines) if line.strip() == "5")  # node 5's record 10 follows
    values = lines[i + 1].split()
    values[2] = "1.00000e-01"  # z
    lines[i + 1] = "".join(f"{float(v):13.5e}" for v in values)
    assert_refused(_rewrite(tmp_path, "\n".join(lines) + "\n"), "dataset 55 #1", "node 5", "non-zero z")


def test_uff_inconsistent_nodes_across_modes(tmp_path):
    text = _uff_text(tmp_path)
    starts = [m.start() for m in re.finditer(r"(?m)^        11$", text)]
    text = text[:starts[1]] + "        12" + text[starts[1] + 10:]  # mode 2 lists node 12 for 11
    msg = assert_refused(_rewrite(tmp_path, text), "dataset 55 #2", "inconsistent nodes")
    assert "[1, 5, 11]" in msg and "[1, 5, 12]" in msg


def test_uff_without_model_name(tmp_path):
    text = _uff_text(tmp_path).replace("model: hframe", "NONE         ")
    with pytest.raises(fp.DataFileError, match=r"bad\.uff.*ID line 1.*model"):
        read_uff55(_rewrite(tmp_path, text))
    # the caller may say which model the data belong to
    assert read_uff55(tmp_path / "bad.uff", model="hframe").model == "hframe"


def test_uff_unknown_node_in_the_model(tmp_path):
    data = fp.ModalData("hframe", ((1, "x"), (40, "y")), np.array([50.0]), np.array([[1.0], [0.5]]))
    path = write_uff55(data, tmp_path / "n.uff")
    assert_refused(path, "node 40", "hframe")


def test_uff_zero_frequency(tmp_path):
    text = _replace_record(_uff_text(tmp_path), 8, "%13.5e" * 4 % (0.0, 0.0, 0.0, 0.0), dataset=2)
    assert_refused(_rewrite(tmp_path, text), "dataset 55 #2", "frequency", "> 0")


# -- synthetic measurements ------------------------------------------------------------

def test_synthetic_same_seed_identical_other_seed_differs():
    kw = dict(n_modes=8, freq_noise=0.005, shape_noise=0.05)
    a, b = fp.synthetic_measurement("hframe", seed=7, **kw), fp.synthetic_measurement("hframe", seed=7, **kw)
    c = fp.synthetic_measurement("hframe", seed=8, **kw)
    np.testing.assert_array_equal(a.frequencies_hz, b.frequencies_hz)
    np.testing.assert_array_equal(a.shapes, b.shapes)
    assert not np.any(a.frequencies_hz == c.frequencies_hz)
    assert not np.any(a.shapes == c.shapes)
    assert a.dofs == fp.load_model("hframe").measured_dofs and a.model == "hframe"


def test_synthetic_frequency_noise_statistics():
    model = fp.load_model("hframe")
    exact = fp.modal_analysis(model, 10).frequencies_hz
    rel = np.array([fp.synthetic_measurement(model, 10, freq_noise=0.01, seed=s, with_shapes=False)
                    .frequencies_hz / exact - 1.0 for s in range(60)])
    # 600 draws of N(0, 0.01): the sample std lies within 0.01 +- 1.2e-3 and the mean within
    # +- 1.6e-3 (4 standard errors each)
    assert abs(rel.std() - 0.01) < 1.2e-3
    assert abs(rel.mean()) < 1.6e-3
    # each mode is noisy, none is left exact or swapped
    assert np.all(np.abs(rel).max(axis=0) > 1e-3) and np.abs(rel).max() < 0.05
    # no noise, no change
    quiet = fp.synthetic_measurement("hframe", 10, seed=3)
    np.testing.assert_array_equal(quiet.frequencies_hz, exact)


def test_synthetic_shape_noise_statistics():
    model = fp.load_model("hframe")
    exact = fp.modal_analysis(model, 8).at(model.measured_dofs)
    peak = np.abs(exact).max(axis=0)
    noise = np.array([fp.synthetic_measurement(model, 8, shape_noise=0.05, seed=s, random_sign_scale=False)
                      .shapes - exact for s in range(20)])
    rel = noise / peak  # per-entry noise in units of the mode's largest entry: 20 x 15 x 8 draws
    # 4 standard errors: std within 0.05 +- 0.003, mean within +- 0.004
    assert abs(rel.std() - 0.05) < 0.003
    assert abs(rel.mean()) < 0.004


def test_random_sign_and_scale_leave_mac_unchanged():
    model = fp.load_model("hframe")
    exact = fp.modal_analysis(model, 8).at(model.measured_dofs)
    data = fp.synthetic_measurement(model, 8, seed=5)
    np.testing.assert_allclose(np.diag(fp.mac(data.shapes, exact)), 1.0, rtol=0, atol=1e-12)
    scale = np.sum(data.shapes * exact, axis=0) / np.sum(exact * exact, axis=0)
    np.testing.assert_allclose(data.shapes, exact * scale, rtol=1e-12, atol=1e-15)
    # the sign and scale really were randomised: both signs, scales spread over [0.1, 10]
    assert (scale > 0).any() and (scale < 0).any()
    assert np.all((np.abs(scale) >= 0.1) & (np.abs(scale) <= 10.0))
    assert np.abs(scale).max() / np.abs(scale).min() > 3.0
    # and the correlation the project computes is blind to them
    rep = fp.UpdatingProblem(data=data).correlation()
    np.testing.assert_allclose(rep.mac, 1.0, atol=1e-12)
    np.testing.assert_allclose(rep.comac, 1.0, atol=1e-12)


def test_truth_with_hidden_crack_shows_in_nominal_correlation():
    nominal = fp.load_model("hframe")
    truth = fp.split_element(nominal, 4, 0.37, 3e4)  # a crack high on the left upright
    kw = dict(n_modes=8, freq_noise=0.001, shape_noise=0.01, seed=1)
    cracked = fp.synthetic_measurement(truth, model_name="hframe", **kw)
    control = fp.synthetic_measurement(nominal, **kw)
    assert cracked.model == "hframe" and cracked.dofs == nominal.measured_dofs
    rep = fp.UpdatingProblem(data=cracked, weights="unit").correlation()
    ref = fp.UpdatingProblem(data=control, weights="unit").correlation()
    # the control differs from the nominal model by its noise only
    assert np.abs(ref.error_pct).max() < 0.5 and ref.mac.min() > 0.999
    # the crack softens the frame: the nominal model is too stiff, clearly above the noise
    assert np.abs(rep.error_pct).max() > 3.0
    assert np.sum(rep.error_pct > 0.2) >= 3
    assert rep.mac.min() < 0.98
