"""Two rules of a user's own problem (issue 35's left-alones): `update.json`'s `model_sha256` of a
matrix model covers its matrix files, as a study's problem source does (`user_problem.model_hash`);
a study's problem source names the user's files relative to itself, so that a store moved with
those files keeps its problem, and a missing file is one line saying where it was looked for."""

from __future__ import annotations

import json
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

from fe_problem.modal_data import ModalData, save_modal_data
from fe_problem.user_problem import file_hash, model_hash, problem_from_source, source_from_dict

sys.path.insert(0, str(Path(__file__).resolve().parent))
from matrix_cases import Frame, measured, truth  # noqa: E402


def _user_files(folder: Path):
    """A three-storey matrix model (textbook elements, tests/matrix_cases.py) and data of it with its
    second storey softer."""
    fr = Frame(storeys=3, bays=0)
    path = fr.write(folder)
    k, m = truth(fr, soft=(2, 0, 0.8))
    d = measured(fr, path, k, m, [(n, "x") for n in fr.free], n_modes=3, seed=1)
    # the data name their model relative to themselves, as a user's files beside each other do
    data = save_modal_data(ModalData("frame.json", d.dofs, d.frequencies_hz, d.shapes), folder / "measured.json")
    return fr, path, data


def test_update_json_hashes_a_matrix_models_files(tmp_path):
    from femu.update import update

    fr, path, data = _user_files(tmp_path)
    record = update(path, data, tmp_path / "out", budget=12, progress=False).record
    assert record["model_sha256"] == model_hash(path) != file_hash(path)
    assert record["data_sha256"] == file_hash(data)
    before = record["model_sha256"]
    sp.save_npz(tmp_path / "storey2.npz", sp.csr_matrix(1.01 * fr.storey_matrix(2)))  # a matrix changed, not the manifest
    assert model_hash(path) != before


def test_a_moved_store_keeps_its_user_problem(tmp_path):
    from femu.studies.store import Store
    from femu.studies.study import user_source

    old = tmp_path / "project"
    (old / "model").mkdir(parents=True)
    fr, path, data = _user_files(old / "model")
    variant = user_source(Store(old / "store"), path, data)
    source = Path(variant.split(":", 1)[1])
    text = source.read_text()
    assert str(tmp_path) not in text  # no absolute path: the files relative to the source file
    assert json.loads(text)["model"] == "../../model/frame.json"
    new = tmp_path / "moved"
    shutil.move(str(old), str(new))
    moved = new / source.relative_to(old)
    src = source_from_dict(json.loads(moved.read_text()), str(moved))
    assert src.model == str((new / "model" / "frame.json").resolve())
    problem = problem_from_source(src)
    first = problem.evaluate(problem.x0[None])
    assert np.isfinite(first).all()
    # the store moved without the files: one line naming where the model was looked for
    alone = tmp_path / "alone"
    shutil.move(str(new / "store"), str(alone))
    lonely = alone / moved.relative_to(new / "store")
    with pytest.raises(ValueError, match=r"frame\.json: the model file of this study's problem is not there"):
        problem_from_source(source_from_dict(json.loads(lonely.read_text()), str(lonely)))
    # the variant itself holds the source's absolute path (run records carry it): a moved store's
    # variant is one line naming the source and where its files and hashes are recorded
    from adapters.variants import make_problem

    with pytest.raises(ValueError, match=r"its problem source .* is not there .*problem_source names the model"):
        make_problem(variant)

