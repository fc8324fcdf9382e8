"""More damaged files, one exception type per file kind: model files (ModelFileError), modal
data (DataFileError), FRF files (FRFFileError), run records (StoreError). Each case is refused by
the library with that type and by the CLI with exit code 2 and one stderr line naming the file
and what is wrong, or read with a warning naming what was lost. Never a traceback, never a
hang on a device or a pipe, never a silently shorter file.

The files are made here from files the project writes (the H-frame model, a cracked H-frame's
8-mode data, a synthetic FRF set), each with one damage."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import fe_problem as fp
from fe_problem.identification.frf_io import write_csv, write_npz, write_uff58
from fe_problem.model.io import model_to_dict
from femu.cli import main
from femu.studies.store import StoreError

BIG = int("9" * 400)


def _one_error_line(capsys, argv, *says) -> str:
    """Run `femu argv`: exit 2, one stderr line containing every fragment of `says`."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert all(s in err for s in says), err
    return err


# -- model files --------------------------------------------------------------------------------
def _model(d):
    d["nodes"].append({"id": 99, "x": 2.0, "y": 2.0})


MODEL_DAMAGE = {  # name: (edit of the H-frame's dict or raw text, fragment of the message)
    "name a number": (lambda d: d.__setitem__("name", 5), "field 'name' must be a non-empty string, got 5"),
    "name empty": (lambda d: d.__setitem__("name", " "), "field 'name' must be a non-empty string"),
    "coordinates 1e-300": (lambda d: [n.update(x=n["x"] * 1e-300, y=n["y"] * 1e-300) for n in d["nodes"]],
                           "is below the 1e-06 m an element may have"),
    "an element 1 nm long": (lambda d: d["nodes"][1].update(x=d["nodes"][0]["x"] + 1e-9, y=d["nodes"][0]["y"]),
                             "element 1: length 1e-09 m (nodes 1 and 2)"),
    "every DOF supported": (lambda d: d.__setitem__("supports", [{"node": n["id"], "directions": ["x", "y", "rz"]}
                                                                 for n in d["nodes"]]),
                            "every DOF is supported, so the model has no mode"),
    "support direction z": (lambda d: d.__setitem__("supports", [{"node": 1, "directions": ["z"]}]),
                            "support at node 1: unknown direction 'z'"),
    "support at node 99": (lambda d: d.__setitem__("supports", [{"node": 99, "directions": ["x"]}]),
                           "support at unknown node 99"),
    "directions a dict": (lambda d: d.__setitem__("supports", [{"node": 1, "directions": {"x": 1}}]),
                          "field 'directions' must be a list"),
    "node x NaN": (lambda d: d["nodes"][0].__setitem__("x", float("nan")), "nodes[0] field 'x': must be a finite"),
    "node y Infinity": (lambda d: d["nodes"][2].__setitem__("y", float("inf")), "nodes[2] field 'y'"),
    "node id 1.5": (lambda d: d["nodes"][0].__setitem__("id", 1.5), "nodes[0] field 'id': must be an integer id"),
    "node id true": (lambda d: d["nodes"][0].__setitem__("id", True), "must be an integer id, got True"),
    "node id a string": (lambda d: d["nodes"][0].__setitem__("id", "1"), "must be an integer id, got '1'"),
    "a node twice": (lambda d: d["nodes"].append(dict(d["nodes"][0])), "'nodes' has duplicate ids [1]"),
    "an element twice": (lambda d: d["elements"].append(dict(d["elements"][0])), "'elements' has duplicate ids [1]"),
    "element to node 99": (lambda d: d["elements"][0].__setitem__("nodes", [1, 99]), "unknown node 99"),
    "element from a node to itself": (lambda d: d["elements"][0].__setitem__("nodes", [1, 1]), "both ends at node 1"),
    "no nodes": (lambda d: d.__setitem__("nodes", []), "'nodes' is empty"),
    "no elements": (lambda d: d.__setitem__("elements", []), "'elements' is empty"),
    "format femu.model/9": (lambda d: d.__setitem__("format", "femu.model/9"), "field 'format' must be"),
    "poisson 0.7": (lambda d: d["materials"]["aluminium"].__setitem__("poisson_ratio", 0.7), "'poisson_ratio'"),
    "E negative": (lambda d: d["materials"]["aluminium"].__setitem__("youngs_modulus_pa", -7e10), "must be a finite"),
    "E a string": (lambda d: d["materials"]["aluminium"].__setitem__("youngs_modulus_pa", "7e10"), "got '7e10'"),
    "formulation magic": (lambda d: d["elements"][0].__setitem__("formulation", "magic"), "'formulation' must be"),
    "release negative": (lambda d: d["elements"][0].__setitem__("release_i", -1.0), "'release_i': must be"),
    "mass negative": (lambda d: d.__setitem__("masses", [{"node": 1, "mass_kg": -1.0}]), "'mass_kg': must be"),
    "mass 1e300 kg": (lambda d: d.__setitem__("masses", [{"node": 1, "mass_kg": 1e300}]), "outside the physical"),
    "measured DOF at node 99": (lambda d: d.__setitem__("measured_dofs", [[99, "x"]]), "measured_dofs[0]: unknown"),
    "measured DOF twice": (lambda d: d.__setitem__("measured_dofs", [[1, "x"], [1, "x"]]), "lists a DOF twice"),
    "excitation at node 99": (lambda d: d.__setitem__("excitation", [99, "x"]), "excitation: unknown node 99"),
    "sections a list": (lambda d: d.__setitem__("sections", []), "field 'sections' must be an object"),
    "unknown material": (lambda d: d["elements"][0].__setitem__("material", "steel"), "unknown material 'steel'"),
    "coordinates 1e200": (lambda d: [n.update(x=n["x"] * 1e200) for n in d["nodes"]], "within +-1e+06"),
    "a key twice": ("DUPKEY", "key 'nodes' is given twice in one object"),
    "null": ("null", "expected an object, got NoneType"),
    "empty file": ("", "not valid JSON"),
    "NaN literal": ("NANLIT", "nodes[0] field 'x': must be a finite number, got nan"),
}


@pytest.fixture(scope="module")
def hframe():
    return model_to_dict(fp.load_model("hframe"))


@pytest.mark.parametrize("name", list(MODEL_DAMAGE))
def test_a_damaged_model_file_is_a_model_file_error_and_one_line(hframe, tmp_path, capsys, name):
    edit, says = MODEL_DAMAGE[name]
    f = tmp_path / "bad.model.json"
    if callable(edit):
        d = json.loads(json.dumps(hframe))
        edit(d)
        f.write_text(json.dumps(d))
    else:
        text = json.dumps(hframe)
        text = {"DUPKEY": text[:-1] + ', "nodes": []}', "NANLIT": text.replace('"x": 0.0', '"x": NaN', 1)}.get(edit, edit)
        f.write_text(text)
    with pytest.raises(fp.ModelFileError, match=str(f)):
        fp.modal_analysis(fp.load_model(f))
    _one_error_line(capsys, ["model", str(f)], str(f), says)


def test_a_byte_order_mark_is_read_as_utf8(hframe, tmp_path):
    f = tmp_path / "bom.model.json"
    f.write_bytes(b"\xef\xbb\xbf" + json.dumps(hframe).encode())
    assert fp.load_model(f) == fp.load_model("hframe")


def test_a_pipe_or_a_device_is_refused_without_reading_it(tmp_path, capsys):
    fifo = tmp_path / "pipe.model.json"
    os.mkfifo(fifo)  # opening it would wait for a writer forever
    for path in (fifo, Path("/dev/zero")):  # /dev/zero would never end
        with pytest.raises(fp.ModelFileError, match="not a regular file"):
            fp.load_model(path)
        _one_error_line(capsys, ["model", str(path)], f"{path}: not a regular file")


def test_a_json_file_above_the_size_limit_is_refused_unread(tmp_path, capsys):
    from fe_problem.jsonutil import MAX_JSON_BYTES

    f = tmp_path / "huge.model.json"
    with open(f, "wb") as fh:
        fh.truncate(MAX_JSON_BYTES + 1)  # sparse: nothing written
    _one_error_line(capsys, ["model", str(f)], f"{f}: larger than the {MAX_JSON_BYTES} bytes")


def test_a_model_of_30000_nodes_is_refused_by_size_on_the_dense_path_not_left_to_run(tmp_path, capsys):
    """Loading, validation and the size check are linear in the nodes (they were quadratic: a
    hang). The dense path refuses it by its size; the automatic choice takes the sparse path
    (which solves it: `femu model` on it takes seconds, tests/test_cli_model_scale.py)."""
    n = 30_000
    d = {"format": "femu.model/1", "name": "long",
         "nodes": [{"id": i + 1, "x": 0.01 * i, "y": 0.0} for i in range(n)],
         "elements": [{"id": i + 1, "nodes": [i + 1, i + 2], "section": "s", "material": "m"} for i in range(n - 1)],
         "sections": {"s": {"area_m2": 1e-4, "inertia_m4": 1e-9}},
         "materials": {"m": {"youngs_modulus_pa": 7e10, "density_kg_m3": 2700, "poisson_ratio": 0.33}}}
    f = tmp_path / "long.model.json"
    f.write_text(json.dumps(d))
    model = fp.load_model(f)
    with pytest.raises(fp.ModelFileError, match=f"{f}: 30000 nodes, 90000 DOFs and 0 parameters need about"):
        fp.modal_analysis(model, solver="dense")
    _one_error_line(capsys, ["model", str(f), "--solver", "dense"], "GiB limit")
    assert fp.assembly.solver_path(model.n_dof) == "sparse" and fp.AffineModel(model).path == "sparse"


def test_a_model_above_the_sparse_limit_is_refused_by_size(tmp_path, capsys, monkeypatch):
    """The sparse path is bounded too (fe_problem.assembly.MAX_SPARSE_DOFS, 250,000 free DOFs):
    shown here with the limit lowered, on the 8-bay 20-storey frame `femu model` makes."""
    f = tmp_path / "frame.model.json"
    assert main(["model", "--frame", "8x20", "--save", str(f)]) == 0
    capsys.readouterr()
    monkeypatch.setattr(fp.assembly, "MAX_SPARSE_DOFS", 400)
    with pytest.raises(fp.ModelFileError, match=r"frame.model.json: 189 nodes, 540 free DOFs: more than the 400"):
        fp.modal_analysis(fp.load_model(f))
    _one_error_line(capsys, ["model", str(f)], "fe_problem.assembly.MAX_SPARSE_DOFS")


# -- modal data -----------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def crack(tmp_path_factory):
    d = tmp_path_factory.mktemp("crack")
    truth = fp.crack_element(fp.load_model("hframe"), 7, 0.3, 3e4)
    data = fp.synthetic_measurement(truth, n_modes=8, freq_noise=0.002, shape_noise=0.02, seed=1, model_name="hframe")
    fp.save_modal_data(data, d / "crack.json")
    fp.save_modal_data(data, d / "crack.uff")
    return d


DATA_DAMAGE = {
    "frequency 1e300 Hz": (lambda d: d["modes"][7].__setitem__("frequency_hz", 1e300),
                           "modes'[7].frequency_hz: 1e+300 Hz is outside the range"),
    "frequency 1e-300 Hz": (lambda d: d["modes"][0].__setitem__("frequency_hz", 1e-300), "outside the range"),
    "10001 modes": (lambda d: d.__setitem__("modes", [{"frequency_hz": 1.0 + k} for k in range(10_001)]),
                    "10001 modes are more than the 10000"),
    "a node of 400 digits": (lambda d: d["dofs"].__setitem__(0, [BIG, "x"]), "node an integer of 400 digits"),
    "a direction as a list": (lambda d: d["dofs"].__setitem__(0, [1, ["x"]]), "unknown direction ['x']"),
    "modes an object": (lambda d: d.__setitem__("modes", {}), "field 'modes' must be a non-empty list"),
    "a mode a number": (lambda d: d["modes"].__setitem__(0, 5), "modes'[0]: missing 'frequency_hz'"),
    "model a number": (lambda d: d.__setitem__("model", 5), "field 'model' must be a model name or a path"),
    "model the root directory": (lambda d: d.__setitem__("model", "/"), "field 'model': /: is a directory"),
    "model a pipe": (lambda d: d.__setitem__("model", "PIPE"), "field 'model'", "not a regular file"),
    "model a disconnected frame": (lambda d: d.__setitem__("model", "DISC"), "node 99 is connected to no element"),
    "frequencies descending": (lambda d: d["modes"].reverse(), "frequencies must ascend"),
    "a key twice": ("DUPKEY", "key 'format' is given twice"),
}


@pytest.mark.parametrize("name", list(DATA_DAMAGE))
def test_a_damaged_data_file_is_a_data_file_error_and_one_line(crack, hframe, tmp_path, capsys, name):
    edit, *says = DATA_DAMAGE[name]
    f = tmp_path / "bad.json"
    text = (crack / "crack.json").read_text()
    if edit == "DUPKEY":
        f.write_text('{"format": "x", ' + text.lstrip()[1:])
    else:
        d = json.loads(text)
        edit(d)
        if d["model"] == "PIPE":
            os.mkfifo(tmp_path / "pipe.model.json")
            d["model"] = "pipe.model.json"
        if d["model"] == "DISC":
            loose = json.loads(json.dumps(hframe))
            _model(loose)
            (tmp_path / "loose.model.json").write_text(json.dumps(loose))
            d["model"] = "loose.model.json"
        f.write_text(json.dumps(d))
    with pytest.raises(fp.DataFileError, match=str(f)):
        fp.load_modal_data(f).load_model()
    _one_error_line(capsys, ["diagnose", str(f)], str(f), *says)


def test_a_geometry_dataset_among_the_modes_is_named_not_lost(crack, tmp_path, capsys):
    lines = (crack / "crack.uff").read_text().split("\n")
    heads = [i + 1 for i, line in enumerate(lines) if line.strip() == "-1"][::2]
    bad = tmp_path / "d15.uff"  # the 5th mode's type 55 damaged into 15 (nodes): read past, with a warning
    bad.write_text("\n".join(line.replace("55", "15") if i == heads[4] else line for i, line in enumerate(lines)))
    with pytest.warns(UserWarning, match=r"ignored 1 dataset\(s\) of type\(s\) \[15\] among the 7 datasets 55"):
        assert fp.load_modal_data(bad).n_modes == 7
    nan = tmp_path / "nan.uff"  # a value that is no number: the dataset and the line where it opens
    nan.write_text("\n".join(line.replace(line.split()[0], "NaN", 1) if i == heads[1] + 9 else line
                             for i, line in enumerate(lines)))
    _one_error_line(capsys, ["diagnose", str(nan)], f"{nan}: dataset 55 #2 (line {heads[1]})")


# -- FRF files ------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def frf(tmp_path_factory):
    d = tmp_path_factory.mktemp("frf")
    s = fp.synthetic_frf(fp.load_model("hframe"), band_hz=(5, 400), resolution_hz=0.5)
    write_uff58(s, d / "good.uff")
    write_npz(s, d / "good.npz")
    write_csv(s, d / "good.csv")
    return d


def _uff58(frf, tmp_path, damage):
    lines = (frf / "good.uff").read_text().split("\n")
    heads = [i + 1 for i, line in enumerate(lines) if line.strip() == "-1"][::2]
    last = max(i for i, line in enumerate(lines) if line.strip() == "-1")
    out = {"cut in half": lines[: len(lines) // 2], "cut in a line": lines[:300] + [lines[300][:7]],
           "no last delimiter": lines[:last] + lines[last + 1:],
           "type 58 damaged": [ln.replace("58", "5x", 1) if i == heads[3] else ln for i, ln in enumerate(lines)],
           "a value NaN": [ln.replace(ln.split()[0], "NaN", 1) if i == heads[2] + 11 else ln
                           for i, ln in enumerate(lines)]}[damage]
    f = tmp_path / "bad.uff"
    f.write_text("\n".join(out))
    return f


def _npz(frf, tmp_path, damage):
    z = dict(np.load(frf / "good.npz"))
    f = tmp_path / "bad.npz"
    if damage == "not a zip":
        f.write_text("hello")
        return f
    z.update({"real FRF": {"frf": z["frf"].real}, "text nodes": {"response_node": np.array(["a"] * 15)},
              "an object array": {"frf": np.array([object()] * 3, dtype=object)},
              "no reference node": {}, "NaN value": {"frf": np.where(np.arange(z["frf"].size).reshape(z["frf"].shape)
                                                                        == 7, np.nan, z["frf"])}}[damage])
    if damage == "no reference node":
        z.pop("reference_node")
    np.savez(f, **z)
    return f


def _csv(frf, tmp_path, damage):
    lines = (frf / "good.csv").read_text().split("\n")
    hdr = next(i for i, ln in enumerate(lines) if ln.startswith("frequency"))
    f = tmp_path / "bad.csv"
    if damage == "latin-1":
        f.write_bytes("\n".join(lines).replace("# form", "# f\u00e9rm").encode("latin-1"))
        return f
    out = {"header only": lines[: hdr + 1], "model the root": ["# model: /" if ln.startswith("# model") else ln
                                                              for ln in lines],
           "node a word": lines[:hdr] + [lines[hdr].replace("re 1 x,im 1 x", "re one x,im one x")] + lines[hdr + 1:],
           "reference a word": ["# reference: five x" if ln.startswith("# reference") else ln for ln in lines],
           "a ragged row": lines[: hdr + 3] + [lines[hdr + 3].rsplit(",", 3)[0]] + lines[hdr + 4:],
           "1e400": lines[: hdr + 5] + [lines[hdr + 5].replace(lines[hdr + 5].split(",")[1], "1e400", 1)]
           + lines[hdr + 6:]}[damage]
    f.write_text("\n".join(out))
    return f


FRF_DAMAGE = [  # (maker, damage, fragment)
    (_uff58, "cut in half", "is never closed by '    -1'"), (_uff58, "cut in a line", "is never closed"),
    (_uff58, "no last delimiter", "is never closed"), (_uff58, "type 58 damaged", "has no type number (found '5x')"),
    (_uff58, "a value NaN", "dataset 58 #3 (line"),
    (_npz, "not a zip", "not a readable .npz file"), (_npz, "real FRF", "holds real values"),
    (_npz, "text nodes", "array 'response_node' must be a 1-D array of whole numbers"), (_npz, "an object array", "Object arrays cannot be loaded"),
    (_npz, "no reference node", "missing array(s) ['reference_node']"), (_npz, "NaN value", "not a finite number"),
    (_csv, "latin-1", "not UTF-8 text"), (_csv, "header only", "no frequency lines after the header"),
    (_csv, "model the root", "field 'model' '/': /: is a directory"), (_csv, "node a word", "node 'one' is not"),
    (_csv, "reference a word", "bad '# reference: five x'"), (_csv, "a ragged row", "fields, but the header has 31"),
    (_csv, "1e400", "'1e400' is not a finite number"),
]


@pytest.mark.filterwarnings("error::RuntimeWarning")  # the error, not a numpy warning before it
@pytest.mark.parametrize("maker,damage,says", FRF_DAMAGE, ids=[f"{m.__name__[1:]} {d}" for m, d, _ in FRF_DAMAGE])
def test_a_damaged_frf_file_is_an_frf_file_error_and_one_line(frf, tmp_path, capsys, maker, damage, says):
    f = maker(frf, tmp_path, damage)
    with pytest.raises(fp.FRFFileError, match=str(f)):
        fp.identify(fp.read_frf(f))
    _one_error_line(capsys, ["identify", str(f), "--out", str(tmp_path / "out")], str(f), says)
    assert not (tmp_path / "out").exists()


def test_a_directory_as_an_frf_file_is_refused(tmp_path, capsys):
    (tmp_path / "d.npz").mkdir()
    with pytest.raises(fp.FRFFileError, match="not a regular file"):
        fp.read_frf(tmp_path / "d.npz")
    _one_error_line(capsys, ["identify", str(tmp_path / "d.npz")], "d.npz: not a regular file")


# -- run records ----------------------------------------------------------------------------------
RECORD_DAMAGE = {"wall_s": BIG, "trace": [[1, BIG]], "error": 5, "host": [1], "versions": 5, "fe_cpu_s": "x",
                 "opt_cpu_s": -1.0, "x0": [1, 2], "n_jacobians": -1, "f_opt": "zero", "best_x": [None]}


@pytest.mark.parametrize("field,value", list(RECORD_DAMAGE.items()))
def test_a_hand_edited_record_field_is_a_store_error_naming_it(random_search_store, tmp_path, capsys, field, value):
    s = tmp_path / "store"
    shutil.copytree(random_search_store, s)
    f = sorted((s / "runs").glob("*.json"))[0]
    rec = json.loads(f.read_text())
    rec[field] = value
    f.write_text(json.dumps(rec))
    from femu.studies.store import Store

    with pytest.raises(StoreError, match=f"field '{field}'"):
        Store(s).runs()
    capsys.readouterr()
    _one_error_line(capsys, ["results", str(s)], str(f), f"field '{field}'", "delete the file")
    assert main(["results", str(s), "--skip-invalid"]) == 0  # the other run is still reported
    out, err = capsys.readouterr()
    assert "random-search" in out and err.count("warning: left out") == 1 and str(f) in err
