"""The kind registry (fe_problem/diagnosis/kinds/): the typed key, the spec, a new kind as one
module and one registry line."""

from __future__ import annotations

import ast
import importlib
import sys
from pathlib import Path

import numpy as np
import pytest

import fe_problem as fp
from fe_problem.diagnosis import candidates, group_free, kinds, plausibility, sparse_class
from fe_problem.diagnosis.groups import distributed_candidates
from fe_problem.diagnosis.kinds import CandidateKey, KindSpec
from fe_problem.diagnosis.modelform import model_form_candidates
from fe_problem.diagnosis.core import score_classes
from fe_problem.diagnosis.setting import Setting
from fe_problem.diagnosis.steps import calibrate, screen_and_fit
from fe_problem.model import add_mass
from fe_problem.model.generate import regular_frame


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


# == a new kind: one module and one registry line ===========================================

TOY_KIND = '''
"""A toy kind for the test: a lumped mass of a kg at a node, each size a model of its own."""
import numpy as np

from fe_problem.diagnosis.kinds import KindSpec
from fe_problem.diagnosis.setting import Candidate, solve_model
from fe_problem.model import add_mass
from fe_problem.model.generate import regular_frame


def generate(st):
    for node in st.model.node_ids[:3]:
        def forward(a, node=node):
            out = [solve_model(add_mass(st.model, node, float(v)), st) for v in np.atleast_1d(a)]
            return np.concatenate([o[0] for o in out]), np.concatenate([o[1] for o in out])

        yield Candidate("toy_point_mass", {"node": node}, 50.0, np.array([0.0, 1.0, 10.0, 50.0]), forward,
                        lambda a, s: {"mass_kg": a}, lambda a, node=node: add_mass(st.model, node, a), step=0.5)


def variants(st, cand):
    return 3


def check(model, loc, estimate):
    return "too heavy" if estimate.get("mass_kg", 0.0) > 20.0 else None


SPEC = KindSpec("toy_point_mass", "local", ("node",), generate, variants=variants, check=check)
'''


@pytest.fixture
def toy_kind(tmp_path, monkeypatch):
    """The toy kind's module written to a file of its own and registered by one line."""
    (tmp_path / "toy_point_mass_kind.py").write_text(TOY_KIND)
    monkeypatch.syspath_prepend(str(tmp_path))
    module = importlib.import_module("toy_point_mass_kind")
    kinds.register(module.SPEC)  # the one registry line
    yield module.SPEC
    kinds.unregister(module.SPEC.name)
    sys.modules.pop("toy_point_mass_kind", None)


def test_a_new_kind_is_one_module_and_one_registry_line(toy_kind):
    """A kind written as one module and registered by one line is built by `all_candidates`,
    labelled by its key, charged by its spec (`kinds.label_variants`), bounded by its spec
    (`plausibility.check`), and its candidates' modes are those of the model it names
    (`fp.modal_analysis` of the model with the mass added, solved on its own)."""
    model = fp.load_model("hframe")
    coords = tuple((n, d) for n in (4, 5, 8) for d in ("x", "y"))
    st = Setting(model, coords, 4)
    cands = kinds.all_candidates(st, ["toy_point_mass"])
    assert [c.label for c in cands] == [f"toy_point_mass@node={n}" for n in model.node_ids[:3]]
    assert all(kinds.spec_of(c.key) is toy_kind for c in cands)
    assert "toy_point_mass" not in kinds.default_kinds()  # not `default`: only when asked for
    assert kinds.label_variants(st, cands[0]) == 3
    assert plausibility.check(model, "toy_point_mass", {"node": 1}, {"mass_kg": 30.0}) == "too heavy"
    assert plausibility.check(model, "toy_point_mass", {"node": 1}, {"mass_kg": 5.0}) is None
    hz, _ = cands[1].forward(np.array([0.0, 10.0]))
    want = fp.modal_analysis(add_mass(model, model.node_ids[1], 10.0), 4).frequencies_hz
    assert np.allclose(hz[1], want, rtol=1e-9)
    assert np.all(hz[1] <= hz[0] + 1e-12) and np.any(hz[1] < hz[0] - 1e-6)  # a mass lowers the modes


def test_every_kind_the_diagnosis_builds_is_registered_with_its_place():
    """Every candidate the diagnosis builds on a planar frame (the local search's, the model-form
    and the distributed classes') is of a registered kind, with its spec's family and place keys;
    the class kinds of many members are registered too."""
    model = regular_frame(2, 3, base="pinned")
    coords = tuple((n, d) for n in model.node_ids[3:9] for d in ("x", "y"))
    st = Setting(model, coords, 4)
    built = ([(c, "local") for c in kinds.all_candidates(st)] + [(c, "model_form") for c in model_form_candidates(st)]
             + [(c, "distributed") for c in distributed_candidates(st)])
    assert {c.kind for c, _ in built} >= {"stiffness_loss", "added_mass", "joint_flexibility", "member_depth",
                                         "node_position", "support_condition", "group_stiffness_loss",
                                         "stiffness_trend"}
    for c, family in built:
        spec = kinds.spec_of(c.key)
        assert spec is not None, c.label
        assert spec.family == family, (c.label, spec.family)
        assert set(c.location or {}) <= set(spec.place), (c.label, spec.place)
        assert CandidateKey.parse(c.label) == c.key
    for kind in (sparse_class.KIND, group_free.KIND, group_free.PAIR_KIND, *group_free.PARTITIONS):
        assert kinds.spec_of(kind) is not None, kind
    assert set(kinds.default_kinds()) == set(candidates.DEFAULT_KINDS)


# == structure: no import cycle, no branch on the dimension ================================

DIAGNOSIS = Path(__file__).resolve().parents[1] / "fe_problem" / "diagnosis"
PACKAGE = "fe_problem.diagnosis"


def _modules() -> dict[str, Path]:
    out = {}
    for path in sorted(DIAGNOSIS.rglob("*.py")):
        parts = path.relative_to(DIAGNOSIS).with_suffix("").parts
        name = ".".join((PACKAGE,) + (parts[:-1] if parts[-1] == "__init__" else parts))
        out[name] = path
    return out


def _resolve(module: str, is_package: bool, level: int, target: str | None) -> str:
    base = module.split(".") if is_package else module.split(".")[:-1]
    base = base[:len(base) - (level - 1)]
    return ".".join(base + ([target] if target else []))


def _edges(modules: dict[str, Path]) -> dict[str, set[str]]:
    """module -> the diagnosis modules its module-level imports run (a submodule imported runs
    the packages above it too, except those above the importing module itself)."""
    edges = {}
    for name, path in modules.items():
        is_package = path.name == "__init__.py"
        out = set()
        for node in ast.parse(path.read_text()).body:
            if not isinstance(node, ast.ImportFrom) or node.level == 0:
                continue
            base = _resolve(name, is_package, node.level, node.module)
            targets = [f"{base}.{a.name}" if f"{base}.{a.name}" in modules else base for a in node.names]
            for t in targets:
                parts = t.split(".")
                for k in range(len(PACKAGE.split(".")) + 1, len(parts) + 1):
                    p = ".".join(parts[:k])
                    if p in modules and p != name and not name.startswith(p + "."):
                        out.add(p)
        edges[name] = out
    return edges


def test_the_diagnosis_modules_import_each_other_without_a_cycle():
    """The module-level imports among the diagnosis's modules (kinds/ included) form no cycle, and
    no function imports a diagnosis module (an import cycle hidden inside a function)."""
    modules = _modules()
    edges = _edges(modules)
    state: dict[str, int] = {}

    def visit(m, stack):
        state[m] = 1
        for n in sorted(edges[m]):
            assert state.get(n) != 1, "import cycle: " + " -> ".join(stack + [m, n])
            if n not in state:
                visit(n, stack + [m])
        state[m] = 2

    for m in modules:
        if m not in state:
            visit(m, [])
    hidden = []
    for name, path in modules.items():
        for fn in ast.walk(ast.parse(path.read_text())):
            if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                hidden += [f"{name}.{fn.name}" for node in ast.walk(fn)
                           if isinstance(node, ast.ImportFrom) and (node.level > 0 or (node.module or "")
                                                                    .startswith(PACKAGE))]
    assert not hidden, hidden
    below = {f"{PACKAGE}.picks", f"{PACKAGE}.steps", f"{PACKAGE}.joint"}
    assert edges[f"{PACKAGE}.rounds"] >= below, edges[f"{PACKAGE}.rounds"]


def test_no_diagnosis_file_branches_on_the_dimension():
    """The diagnosis asks the layout (`DofLayout.planar`) and the element formulation
    (`zone_planes`, `supports_weak_zone`, ...) and never the dimension itself: no `.dimension`, no
    count of the layout's hinges."""
    found = []
    for name, path in _modules().items():
        tree = ast.parse(path.read_text())
        compared = {id(x) for c in ast.walk(tree) if isinstance(c, ast.Compare) for x in [c.left, *c.comparators]}
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and node.attr == "dimension":
                found.append(f"{name}:{node.lineno}")
            if (isinstance(node, ast.Call) and getattr(node.func, "id", None) == "len" and node.args
                    and isinstance(node.args[0], ast.Attribute)
                    and node.args[0].attr in ("hinges", "translations", "rotations") and id(node) in compared):
                found.append(f"{name}:{node.lineno}")
    assert not found, found


# == every kind is reached through the registry ==============================================

@pytest.fixture(scope="module")
def hframe_crack():
    """The H-frame with element 3's modulus at 0.8 of its model, four modes measured at its
    measured DOFs with little noise."""
    model = fp.load_model("hframe")
    truth = model.with_element_moduli({3: 0.8 * model.element_modulus_pa(3)})
    data = fp.synthetic_measurement(truth, 5, dofs=model.measured_dofs, freq_noise=0.002, shape_noise=0.02,
                                    seed=1, model_name=model.name)
    return model, data


def test_unregistering_a_kind_removes_its_candidates_from_a_diagnosis(hframe_crack, monkeypatch):
    """A local kind (added_mass), a model-form kind (node_position), a distributed class kind
    (stiffness_trend) and two classes fitted as a whole (every_member_sparse, adjacent_members_free:
    both in this frame's evidence table when registered) unregistered: the diagnosis's screen (`screen_and_fit`) has no candidate
    of them and its evidence table (`score_classes`) no class of them, while the kinds still
    registered are there (the registry is how every kind is reached, not a builder named in core)."""
    model, data = hframe_crack
    st = Setting(model, tuple(data.dofs), 6)
    before = ({c.kind for c in kinds.all_candidates(st)}
              | {c.kind for c in kinds.class_candidates(st, "model_form")}
              | {c.kind for c in kinds.class_candidates(st, "distributed")})
    gone = {"added_mass", "node_position", "stiffness_trend"}
    assert gone <= before  # each builds candidates on this frame while registered
    fitted_whole = {"every_member_sparse", "adjacent_members_free"}  # scored on this frame while registered
    assert all(kinds.KINDS[k].fit is not None for k in fitted_whole)
    for kind in gone | fitted_whole:
        monkeypatch.delitem(kinds.KINDS, kind)
    assert not gone & {c.kind for c in model_form_candidates(st) + kinds.class_candidates(st, "distributed")}
    cal = calibrate(model, data, 0.002, 0.02)
    found = screen_and_fit(cal, None, 4)  # the diagnosis's screen (core.screen_and_fit)
    screened = {c.kind for c in found.candidates}
    assert not gone & screened
    assert {"stiffness_loss", "joint_flexibility"} <= screened
    scored = score_classes(cal, found, None)
    assert not any(c.label.split("@")[0] in gone | fitted_whole for c in scored.evidence.classes)
    assert scored.sparse is None
    assert any(c.family == "distributed" for c in scored.evidence.classes)  # the groups still are


TOY_CLASS = '''
"""A toy distributed class kind: every member of the frame's first two elements' section... here:
every vertical member's modulus times (1 - a), one parameter (the test's one-file class kind)."""
import numpy as np

from fe_problem.diagnosis.kinds import KindSpec
from fe_problem.diagnosis.setting import Candidate, solve_model


def _vertical(model):
    out = []
    for e in model.elements:
        a, b = model.node(e.node_i), model.node(e.node_j)
        if abs(a.x - b.x) < 1e-9:
            out.append(e.id)
    return out


def generate(st):
    model = st.model
    ids = _vertical(model)
    e0 = {e: model.element_modulus_pa(e) for e in ids}

    def build(a):
        return model.with_element_moduli({e: v * (1.0 - a) for e, v in e0.items()})

    def forward(a):
        out = [solve_model(build(float(v)), st) for v in np.atleast_1d(a)]
        return np.concatenate([o[0] for o in out]), np.concatenate([o[1] for o in out])

    yield Candidate("toy_columns_loss", {"group": "columns"}, 0.9, 0.9 * np.linspace(0.0, 1.0, 19), forward,
                    lambda a, s: {"size": a, "modulus_ratio": 1.0 - a}, build, step=0.01)


SPEC = KindSpec("toy_columns_loss", "distributed", ("group",), generate, doc="every column softer")
'''


def test_a_class_kind_in_one_file_is_generated_and_scored(tmp_path, monkeypatch):
    """A distributed class kind written as one module and registered by one line is built by the
    diagnosis (`kinds.class_candidates`), fitted and scored in its evidence table (`score_classes`); on data whose
    truth is that class (every column at 0.85 of its modulus, set in the elements directly) its
    estimate is the truth's ratio and it is the best-scored class."""
    (tmp_path / "toy_columns_kind.py").write_text(TOY_CLASS)
    monkeypatch.syspath_prepend(str(tmp_path))
    module = importlib.import_module("toy_columns_kind")
    kinds.register(module.SPEC)  # the one registry line
    try:
        model = fp.load_model("hframe")
        columns = [e.id for e in model.elements if abs(model.node(e.node_i).x - model.node(e.node_j).x) < 1e-9]
        assert 2 <= len(columns) < len(model.elements)
        truth = model.with_element_moduli({e: 0.85 * model.element_modulus_pa(e) for e in columns})
        data = fp.synthetic_measurement(truth, 5, dofs=model.measured_dofs, freq_noise=0.001, shape_noise=0.01,
                                        seed=2, model_name=model.name)
        cal = calibrate(model, data, 0.001, 0.01)
        assert "toy_columns_loss" in {c.kind for c in kinds.class_candidates(cal.setting, "distributed")}
        scored = score_classes(cal, screen_and_fit(cal, ["stiffness_loss"], 2), None)
        classes = scored.evidence.classes
        row = next(c for c in classes if c.label == "toy_columns_loss@group=columns")
        assert row.family == "distributed"
        assert row.estimate["modulus_ratio"] == pytest.approx(0.85, abs=0.02)
        assert classes[0].label == row.label, [c.label for c in classes[:3]]
    finally:
        kinds.unregister(module.SPEC.name)
        sys.modules.pop("toy_columns_kind", None)


def test_a_kinds_first_order_term_is_its_specs_of_the_key():
    """Where a spec's `term` is a callable (Setting, key), every candidate of its kind carries that
    term of its own key, bit for bit (DOFs, dK/da, dM/da), on a planar and on a space frame: the
    term is declared once, by the kind. The local search's uniform changes, masses and springs have
    one; a weak zone's key gives none (its ends are the generator's)."""
    from fe_problem.model.generate import regular_frame_3d
    planar = regular_frame(2, 2, base="pinned")
    space = regular_frame_3d(1, 1, 1)
    callable_kinds = {k for k, s in kinds.KINDS.items() if callable(s.term)}
    assert {"stiffness_loss", "stiffness_gain", "added_mass", "distributed_mass",
            "boundary_stiffness"} <= callable_kinds
    checked = set()
    for model in (planar, space):
        coords = tuple((n, d) for n in model.node_ids[-4:] for d in ("x", "y"))
        st = Setting(model, coords, 4)
        for c in kinds.all_candidates(st):
            spec = kinds.spec_of(c.key)
            if not callable(spec.term):
                continue
            want = spec.term(st, c.key)
            if want is None:
                assert c.key.profile.startswith("zone"), c.label
                continue
            got = c.term()
            assert np.array_equal(got.dofs, want.dofs) and np.array_equal(got.dk, want.dk), c.label
            assert np.array_equal(got.dm, want.dm), c.label
            checked.add((model.layout.planar, c.kind))
    assert {(p, k) for p in (True, False) for k in ("stiffness_loss", "stiffness_gain", "added_mass",
                                                   "distributed_mass", "boundary_stiffness")} <= checked
