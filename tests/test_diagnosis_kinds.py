"""The kind registry (fe_problem/diagnosis/kinds/): the typed key, the spec, a new kind as one
module and one registry line."""

from __future__ import annotations

import pytest

from fe_problem.diagnosis import kinds
from fe_problem.diagnosis.kinds import CandidateKey, KindSpec


@pytest.mark.parametrize("label", ["stiffness_loss@element=3", "stiffness_loss@element=3(zone 0.30 ry)",
                                   "shear_deformation", "joint_flexibility@node=2,element=5,rotation=ry",
                                   "node_position@node=4(+x)", "boundary_stiffness@node=3,direction=x",
                                   "every_member_sparse@members=[1, 2, 12]"])
def test_key_label_round_trip(label):
    key = CandidateKey.parse(label)
    assert key.label() == label
    assert CandidateKey.of(key.kind, key.location, key.profile) == key
    assert hash(key) == hash(CandidateKey.parse(label))


def test_key_is_typed_and_frozen():
    key = CandidateKey.of("stiffness_loss", {"element": 3}, "zone 0.30")
    assert key.where == (("element", 3),) and key.get("element") == 3 and key.get("node") is None
    assert key.place == CandidateKey("stiffness_loss", (("element", 3),))
    assert key.place.label() == "stiffness_loss@element=3"
    assert key != CandidateKey.of("stiffness_loss", {"element": 4}, "zone 0.30")
    with pytest.raises(AttributeError):
        key.kind = "added_mass"  # type: ignore[misc]
    with pytest.raises(ValueError, match="not name=value"):
        CandidateKey.parse("stiffness_loss@element")


def test_register_rejects_a_duplicate_and_a_bad_family():
    spec = KindSpec("toy_duplicate", "local", ("element",))
    kinds.register(spec)
    try:
        with pytest.raises(ValueError, match="registered already"):
            kinds.register(spec)
        assert kinds.spec_of("toy_duplicate") is spec
        assert kinds.spec_of(CandidateKey("toy_duplicate", (("element", 1),))) is spec
    finally:
        kinds.unregister("toy_duplicate")
    with pytest.raises(ValueError, match="family"):
        KindSpec("toy_bad", "nonsense", ())
