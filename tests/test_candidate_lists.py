"""The candidates `all_candidates` builds: the same list, in the same order, with the same sizes,
as before their construction was made cheap (shared grids, each zone's forward and each system
made on first use, the collector paused; candidates.py). The reference is the list main's
fcf98d6 built, written by this file's own code with that tree first on the path:

    PYTHONPATH=<fcf98d6's tree> python tests/test_candidate_lists.py tests/candidate_lists_fcf98d6.json.gz

for three models: the shipped H-frame (planar, dense path), the shipped space frame, and a split
3-bay 4-storey frame (sparse path) with an element end released (a joint found before), and
their model-form candidates (`model_form_candidates`). Each candidate is its label and a digest
of its upper bound, step, grid, profile and place."""

import gzip
import hashlib
import importlib.resources
import json
import pathlib
import sys

import numpy as np
import pytest

import fe_problem as fp
from fe_problem.diagnosis.candidates import Setting, all_candidates, iter_candidates
from fe_problem.diagnosis.modelform import model_form_candidates
from fe_problem.model import release_element_end

REFERENCE = pathlib.Path(__file__).with_name("candidate_lists_fcf98d6.json.gz")


def models() -> dict:
    root = importlib.resources.files("fe_problem") / "shipped"
    out = {name: fp.load_model(str(root / f"{name}.model.json")) for name in ("hframe", "frame3d")}
    m = fp.split_elements(fp.regular_frame(3, 4, floor_mass_kg=800.0), 3)
    out["split_frame_with_a_joint"] = release_element_end(m, 40, m.element(40).node_j, 2e6, None).replace(name="split")
    return out


def setting(model) -> Setting:
    coords = tuple(model.measured_dofs) or tuple((n, d) for n in model.node_ids[::3] for d in model.layout.translations)
    return Setting(model, coords, 6)


def listed(candidates) -> list[list[str]]:
    """[label, digest of (upper, step, grid, meta, location)] of each candidate, in order."""
    def digest(c):
        numbers = [c.upper, c.step, np.asarray(c.grid).tolist(), c.meta, c.location]
        return hashlib.sha256(json.dumps(numbers).encode()).hexdigest()[:10]
    return [[c.label, digest(c)] for c in candidates]


@pytest.fixture(scope="module")
def reference() -> dict:
    return json.loads(gzip.decompress(REFERENCE.read_bytes()))


@pytest.mark.parametrize("name", ["hframe", "frame3d", "split_frame_with_a_joint"])
def test_the_same_candidates_in_the_same_order(reference, name):
    model = models()[name]
    got = listed(all_candidates(setting(model)))
    want = reference[name]
    assert len(want) > 100
    for k, (g, w) in enumerate(zip(got, want)):
        assert g == w, f"candidate {k}: {g} against fcf98d6's {w}"
    assert len(got) == len(want)
    # one at a time, as a search for one label builds them
    assert listed(iter_candidates(setting(model))) == want


@pytest.mark.parametrize("name", ["hframe", "frame3d", "split_frame_with_a_joint"])
def test_the_same_model_form_candidates_in_the_same_order(reference, name):
    """The model-form classes at every element and node (modelform.py, supports.py)."""
    got = listed(model_form_candidates(setting(models()[name])))
    want = reference[name + "/model_form"]
    assert len(want) > 5
    for k, (g, w) in enumerate(zip(got, want)):
        assert g == w, f"candidate {k}: {g} against fcf98d6's {w}"
    assert len(got) == len(want)


def test_a_zone_forward_made_on_first_use_is_the_zones_own():
    """A weak zone's forward, made when first called, against `zones.zone_forwards`' for that place."""
    from fe_problem.diagnosis import zones
    model = models()["hframe"]
    st = setting(model)
    cands = [c for c in all_candidates(st, ["stiffness_loss"]) if c.meta["profile"].startswith("zone")][:3]
    assert cands
    for c in cands:
        start, end = c.estimate(0.3, 1.0)["zone_start"], c.estimate(0.3, 1.0)["zone_end"]
        own = next(zones.zone_forwards(model, c.location["element"], st.coords, st.n_modes, {}, [(start, end)]))[2]
        a = np.array([0.0, 0.3, 0.9])
        for x, y in zip(c.forward(a), own(a)):
            np.testing.assert_array_equal(x, y)


def test_the_shared_grids_cannot_be_changed_through_a_candidate():
    c = next(iter_candidates(setting(models()["hframe"]), ["stiffness_gain"]))
    with pytest.raises(ValueError):
        c.grid[1] = 5.0


if __name__ == "__main__":
    out = {name: listed(all_candidates(setting(m))) for name, m in models().items()}
    out.update({name + "/model_form": listed(model_form_candidates(setting(m))) for name, m in models().items()})
    pathlib.Path(sys.argv[1]).write_bytes(gzip.compress(json.dumps(out, separators=(",", ":")).encode(), 9, mtime=0))
