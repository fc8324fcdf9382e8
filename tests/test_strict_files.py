"""Strict schemas: a key a model or modal-data file does not define is refused with the file, the
path to the key and the closest known key; meaningless entries are refused or named
(fe_problem/jsonutil.check_keys, model/io.py, modal_data/json_format.py; docs/bad-input.md)."""

import copy
import json

import pytest

import fe_problem as fp
from fe_problem.modal_data.json_format import modal_data_to_dict
from fe_problem.model.io import KEYS, model_to_dict
from femu.cli import main

MODEL_CASES = [  # (edit of the H-frame's file, what the one error line says)
    (lambda d: d.update(suports=d.pop("supports")), ": unknown key 'suports'; did you mean 'supports'?"),
    (lambda d: d["elements"][0].update(releas_i=0.0), ": elements[0]: unknown key 'releas_i'; did you mean 'release_i'?"),
    (lambda d: d["nodes"][2].update(z=0.5), ": node 3 field 'z': a planar model's nodes lie in the x-y plane"),
    (lambda d: d["masses"].append({"node": 5, "mass_kg": 0.1, "inertia_kgm2": 1e-4}),
     ": masses[0]: unknown key 'inertia_kgm2'; did you mean 'inertia_kg_m2'?"),
    (lambda d: d["springs"].append({"id": 9, "dofs": [[5, "x"], [5, "x"]], "stiffness": 1e3}),
     ": spring 9 joins DOF [5, 'x'] to itself"),
    (lambda d: d["sections"][next(iter(d["sections"]))].update(inertia_m=1.0),
     "']: unknown key 'inertia_m'; did you mean 'inertia_m4'?"),
    (lambda d: d["materials"][next(iter(d["materials"]))].update(density=2700),
     "']: unknown key 'density'; did you mean 'density_kg_m3'?"),
    (lambda d: d["supports"].append({"node": 1, "direction": ["x"]}), ": supports[0]: unknown key 'direction'; "
                                                                     "did you mean 'directions'?"),
    (lambda d: d.update(colour="red"), ": unknown key 'colour'; the known keys are"),
]


@pytest.mark.parametrize("edit,says", MODEL_CASES, ids=[s.split("'")[1] for _, s in MODEL_CASES])
def test_femu_model_refuses_an_unknown_key_naming_file_path_and_suggestion(tmp_path, capsys, edit, says):
    d = copy.deepcopy(model_to_dict(fp.load_model("hframe")))
    edit(d)
    f = tmp_path / "m.model.json"
    f.write_text(json.dumps(d))
    assert main(["model", str(f)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert err.startswith(f"femu model: error: {f}") and says in err, err


def test_every_key_the_format_documents_is_known():
    """The docs' 3-D example (shared/formats/model-3d.md) and every field the writer emits are keys
    the reader knows: a file the project writes is always read back."""
    written = model_to_dict(fp.load_model("hframe"))
    assert set(written) <= set(KEYS["model"])
    for e in written["elements"]:
        assert set(e) <= set(KEYS["element"])
    for n in written["nodes"]:
        assert set(n) <= set(KEYS["node"])
    three_d = {"format": "femu.model/1", "name": "frame3d", "dimension": 3,
               "materials": {"steel": {"youngs_modulus_pa": 2.0e11, "shear_modulus_pa": 7.69e10,
                                       "density_kg_m3": 7850}},
               "sections": {"col": {"area_m2": 1.133e-3, "iy_m4": 1.97e-6, "iz_m4": 0.664e-6, "j_m4": 8.01e-9}},
               "nodes": [{"id": 1, "x": 0.0, "y": 0.0, "z": 0.0}, {"id": 10, "x": 0.0, "y": 0.0, "z": 0.9}],
               "elements": [{"id": 1, "nodes": [1, 10], "section": "col", "material": "steel",
                             "orientation": [1, 0, 0]}],
               "masses": [{"node": 10, "mass_kg": 88.9}],
               "supports": [{"node": 1, "directions": ["x", "y", "z", "rx", "ry", "rz"]}],
               "measured_dofs": [[10, "x"], [10, "y"]]}
    assert set(three_d) <= set(KEYS["model"])
    for table, kind in (("nodes", "node"), ("elements", "element"), ("masses", "mass"), ("supports", "support")):
        assert all(set(item) <= set(KEYS[kind]) for item in three_d[table]), table
    for table in ("materials", "sections"):
        assert all(set(v) <= set(KEYS[table]) for v in three_d[table].values()), table


DATA_CASES = [
    (lambda d: d["modes"][0].update(shapes=d["modes"][0].pop("shape")),
     "field 'modes'[0]: unknown key 'shapes'; did you mean 'shape'?"),
    (lambda d: d.update(dof=d.pop("dofs")), "unknown key 'dof'; did you mean 'dofs'?"),
    (lambda d: d.update(metadata={}), "unknown key 'metadata'; did you mean 'meta'?"),
    (lambda d: d["modes"][1].update(frequency=d["modes"][1]["frequency_hz"]),
     "field 'modes'[1]: unknown key 'frequency'; did you mean 'frequency_hz'?"),
]


@pytest.mark.parametrize("edit,says", DATA_CASES, ids=[s.split("'")[1] for _, s in DATA_CASES])
def test_femu_diagnose_refuses_an_unknown_key_in_modal_data(tmp_path, capsys, edit, says):
    d = modal_data_to_dict(fp.synthetic_measurement("hframe", n_modes=4, seed=0, model_name="hframe"))
    edit(d)
    f = tmp_path / "d.json"
    f.write_text(json.dumps(d))
    assert main(["diagnose", str(f), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err and str(f) in err and says in err, err


def test_a_mode_given_twice_is_named(tmp_path):
    d = modal_data_to_dict(fp.synthetic_measurement("hframe", n_modes=4, seed=0, model_name="hframe"))
    d["modes"].insert(2, copy.deepcopy(d["modes"][2]))
    f = tmp_path / "d.json"
    f.write_text(json.dumps(d))
    with pytest.warns(UserWarning, match=r"field 'modes'\[2\] and \[3\] are the same mode given twice"):
        fp.load_modal_data(f)


# -- run records and study.json (femu/studies/store.py RECORD_KEYS, manifest.py STUDY_KEYS) ----------
def _rename(key, new):
    return lambda d: d.update({new: d.pop(key)})


RECORD_CASES = [  # (edit of a stored run record, what the one error line says)
    (_rename("best_f", "best_fx"), "unknown key 'best_fx'; did you mean 'best_f'?"),
    (_rename("n_evals", "n_eval"), "unknown key 'n_eval'; did you mean 'n_evals'?"),
    (_rename("status", "stauts"), "unknown key 'stauts'; did you mean 'status'?"),
    (_rename("verified", "verifed"), "unknown key 'verifed'; did you mean 'verified'?"),
    (_rename("effective_options", "effective_option"),
     "unknown key 'effective_option'; did you mean 'effective_options'?"),
    (lambda d: d["capabilities"].update(batchs=d["capabilities"].pop("batch")),
     "unknown key 'capabilities.batchs'; did you mean 'batch'?"),
    (lambda d: d.update(comment="rerun by hand"), "unknown key 'comment'; the known keys are best_f, best_x, blind, budget"),
]


def _copy(random_search_store, tmp_path):
    import shutil

    s = tmp_path / "store"
    shutil.copytree(random_search_store, s)
    return s, sorted((s / "runs").glob("*.json"))[0]


def _one_line(capsys, argv, *says):
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err, err
    assert all(s in err for s in says), err


@pytest.mark.parametrize("edit,says", RECORD_CASES, ids=[s.split("'")[1] for _, s in RECORD_CASES])
def test_results_and_report_refuse_an_unknown_key_in_a_run_record(random_search_store, tmp_path, capsys, edit, says):
    s, f = _copy(random_search_store, tmp_path)
    d = json.loads(f.read_text())
    edit(d)
    f.write_text(json.dumps(d))
    capsys.readouterr()
    for argv in (["results", str(s)], ["results", str(s), "--json"], ["report", str(s), "--out", str(tmp_path / "r")]):
        _one_line(capsys, argv, f"femu {argv[0]}: error: {f}: not a readable run record ({says}",
                  "correct or remove that key")
    assert not (tmp_path / "r").exists()
    assert main(["results", str(s), "--skip-invalid"]) == 0  # the other run, with the damaged one named
    out, err = capsys.readouterr()
    assert out.strip().endswith("1 runs in " + str(s)) and err.count("warning: left out") == 1 and str(f) in err


def test_a_record_written_before_the_newer_fields_is_still_read(random_search_store, tmp_path, capsys):
    """A record of format femu.run/1 with the fields of RunResult's first version (before
    fe_cpu_s, opt_cpu_s, n_jacobians, x0, versions, f_opt, verified, output and the plugin
    description):
    read as written, the missing fields at their defaults; the report says it is unverified."""
    s, f = _copy(random_search_store, tmp_path)
    d = json.loads(f.read_text())
    old = {k: d[k] for k in ("optimizer", "problem", "seed", "budget", "options", "n_evals", "best_f", "best_x",
                             "trace", "wall_s", "cpu_s", "fe_s", "status", "error", "variant", "host", "format")}
    f.write_text(json.dumps(old))
    capsys.readouterr()
    assert main(["results", str(s), "--json"]) == 0
    runs = json.loads(capsys.readouterr().out)
    back = next(r for r in runs if r["seed"] == d["seed"])
    assert {k: back[k] for k in old} == old and back["verified"] is False and back["capabilities"] == {}
    assert main(["report", str(s), "--out", str(tmp_path / "r")]) == 0
    assert "1 run of `random-search` is **unverified**" in (tmp_path / "r" / "report.md").read_text()


def test_every_key_a_study_writes_is_a_key_the_reader_knows(random_search_store):
    from femu.studies.manifest import REQUEST_KEYS, STUDY_KEYS
    from femu.studies.store import RECORD_KEYS

    for f in (random_search_store / "runs").glob("*.json"):
        assert set(json.loads(f.read_text())) == set(RECORD_KEYS)
    manifest = json.loads((random_search_store / "study.json").read_text())
    assert set(manifest) == set(STUDY_KEYS) and set(REQUEST_KEYS) == set(STUDY_KEYS) - {"format", "history"}


STUDY_CASES = [  # (edit of study.json, what the one error line says)
    (_rename("seeds", "seedz"), "unknown key 'seedz'; did you mean 'seeds'?"),
    (_rename("time_limit_s", "time_limit"), "unknown key 'time_limit'; did you mean 'time_limit_s'?"),
    (lambda d: d.update(workers=2), "unknown key 'workers'; the known keys are blind, budget, executor, format"),
    (lambda d: d["history"].append({**{k: v for k, v in d.items() if k not in ("format", "history")}, "budgett": 3}),
     "unknown key 'history[0].budgett'; did you mean 'budget'?"),
]


@pytest.mark.parametrize("edit,says", STUDY_CASES, ids=[s.split("'")[1] for _, s in STUDY_CASES])
def test_femu_study_refuses_an_unknown_key_in_study_json_and_touches_nothing(random_search_store, tmp_path, capsys, edit,
                                                                         says):
    s, _ = _copy(random_search_store, tmp_path)
    f = s / "study.json"
    d = json.loads(f.read_text())
    edit(d)
    f.write_text(json.dumps(d))
    before = {p: p.read_bytes() for p in s.rglob("*") if p.is_file()}
    capsys.readouterr()
    _one_line(capsys, ["study", "--optimizers", "random-search", "--seeds", "0-2", "--budget", "10", "--store", str(s),
                       "--workers", "0", "--no-progress"],
              f"femu study: error: {f}: not a study manifest ({says}", "delete or repair study.json")
    assert {p: p.read_bytes() for p in s.rglob("*") if p.is_file()} == before


def test_a_workers_unknown_capability_flag_never_reaches_a_record():
    """The worker is the plugin's process: what it says about itself is kept only in the record's
    documented shape, so a patched description cannot make the record one the reader refuses."""
    from adapters.harness import RunResult
    from adapters.sandbox import _description
    from femu.studies.store import check_record, run_key

    said = _description({"capabilities": {"anytime": True, "evil": True, "batch": "yes"}, "distribution": "x" * 300})
    assert said["capabilities"] == {"anytime": True} and said["distribution"] is None
    record = RunResult(optimizer="p", problem="hframe", seed=0, budget=1, verified=True, **said).to_dict()
    assert check_record(record, run_key("paper", "p", 1, 0)) is None
    record["capabilities"]["evil"] = True  # as it would be stored without the cut
    assert check_record(record, run_key("paper", "p", 1, 0)).startswith("unknown key 'capabilities.evil'")
