"""The diagnosis answers the tests cache by content (tests/diagnosis_cases.py): a second run on
unchanged code reads the answer `femu diagnose` gave; any change of the code or of the files the
command reads is another key, and FEMU_TEST_CACHE=0 turns the cache off."""

from __future__ import annotations

import json

import diagnosis_cases as dc
from diagnosis_cases import HFRAME, Case, crack_truth, diagnose_through_cli


def test_a_cached_answer_is_the_commands_answer_in_the_new_directory(tmp_path, monkeypatch):
    case = Case("stiffness_loss", {"element": 7}, 3.0, crack_truth(7, 0.4, 3e4), 11)
    for d in "a":
        (tmp_path / d).mkdir()
    first = diagnose_through_cli(case, tmp_path / "a")
    args = ["diagnose", str(tmp_path / "b" / "case-stiffness_loss-11.json"), "--json"]
    (tmp_path / "b").mkdir()
    dc.fp.save_modal_data(case.data("hframe"), tmp_path / "b" / "case-stiffness_loss-11.json")
    key = dc._cache_path(tmp_path / "b", args)
    assert key.exists() and str(tmp_path / "a") not in key.read_text()  # stored without its directory
    second = diagnose_through_cli(case, tmp_path / "b")  # read from the cache
    as_b = json.loads(json.dumps(first).replace(str(tmp_path / "a"), str(tmp_path / "b")))
    assert second == as_b  # (a record names no directory today; if one did, it would be the new one)
    monkeypatch.setenv("FEMU_TEST_CACHE", "0")
    assert dc._cache_path(tmp_path / "b", args) is None  # off: diagnose_through_cli runs the command


def test_the_key_follows_the_contents_and_the_code(tmp_path, monkeypatch):
    data = tmp_path / "d.json"
    data.write_text("{}")
    k1 = dc._cache_path(tmp_path, ["diagnose", str(data), "--json"])
    data.write_text("{ }")
    k2 = dc._cache_path(tmp_path, ["diagnose", str(data), "--json"])
    k3 = dc._cache_path(tmp_path, ["diagnose", str(data), "--json", "--shape-noise", "0.03"])
    monkeypatch.setattr(dc, "_CODE", ["another code"])
    k4 = dc._cache_path(tmp_path, ["diagnose", str(data), "--json", "--shape-noise", "0.03"])
    assert len({k1, k2, k3, k4}) == 4
