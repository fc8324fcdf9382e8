"""Deviations spread over members (issue 19): a storey-wise gradient, a gradient over adjacent
members.

Every truth is built apart from the candidate code: element moduli written into the
model (`with_element_moduli`: model-file entries, the model round-tripped through its file format), the data synthesised from it with the default noise.

- A four-storey shear frame (one bay, stiff floors, floor masses, x measured at one node of each
  floor: 4 modes at 4 floors) with storey stiffnesses 0.71, 0.81, 0.91 and 1.47 of nominal, as
  fitted to laboratory data in the issue: the class "every storey free" (group_free.py) is first
  by evidence with each storey's ratio within 5 % of the truth; the local search never answers
  "top storey only" as adequate.
- The Laplace evidence of that class against an independent Monte Carlo integral (importance
  sampling) of exp(-chi^2 / 2) over its prior, on the real nonlinear chi^2.
- Adjacent members: two H-frame column elements meeting at a joint 0.75 and 0.85 (the rounds
  used to forbid a stiffness change next to one found and named the first with two masses,
  adequate); three consecutive column elements 0.8, 0.85, 0.9.

Two translational springs to ground (`diagnosis_cases.springs_truth`, the issue's "came out as
one, adequate, in 3 of 7"): two cases of seed 19 did not finish within hours. The revisit of a
spring that alone pairs a measured (suspension) mode screened its place to first order, missed
the spring and dropped it; the next round added it again, for ever (`rounds._next_cause` now
fits every candidate that pairs that mode at some size of its grid, `fit.brings`, and `rounds._search` stops when a revisit returns to causes it held).
"""

import dataclasses
import json
import re
from pathlib import Path

import numpy as np
import pytest

import fe_problem as fp
from diagnosis_cases import HFRAME
from fe_problem.diagnosis.core import calibrate
from fe_problem.diagnosis.group_free import KIND, fit_storeys
from fe_problem.diagnosis.sparse_class import HIGH, LOW, log_occam
from fe_problem.model import Section, model_from_dict, model_to_dict

#: Storey stiffness of the laboratory shear frame relative to nominal, base first (issue 19).
STOREY_RATIOS = (0.71, 0.81, 0.91, 1.47)
FREQ_NOISE, SHAPE_NOISE = 0.002, 0.02


def shear_frame() -> fp.FrameModel:
    """A four-storey laboratory shear frame: 0.25 m storeys, one 0.3 m bay, the H-frame's bar as
    columns, floors 3 times as deep, 0.2 kg at each floor node, fixed base; x measured at the
    left node of each floor."""
    bar = HFRAME.sections["bar"]
    m = fp.regular_frame(1, 4, 0.3, 0.25, column=bar, beam=Section(3 * bar.area_m2, 27 * bar.inertia_m4),
                         material=HFRAME.materials["aluminium"], floor_mass_kg=0.2, name="shear4",
                         description="a four-storey shear frame written for the diagnosis tests")
    left = sorted((n for n in m.nodes if n.x == 0.0 and n.y > 0.0), key=lambda n: n.y)
    return m.replace(measured_dofs=tuple((n.id, "x") for n in left))


SHEAR4 = shear_frame()


def _through_file(model: fp.FrameModel) -> fp.FrameModel:
    return model_from_dict(json.loads(json.dumps(model_to_dict(model))), "<truth>")


def storey_truth(model: fp.FrameModel, ratios) -> fp.FrameModel:
    """The columns of storey k (from the base) with their modulus times ratios[k], in the model file."""
    moduli = {}
    for e in model.elements:
        a, b = model.node(e.node_i), model.node(e.node_j)
        if a.x == b.x:
            moduli[e.id] = model.element_modulus_pa(e.id) * ratios[int(0.5 * (a.y + b.y) // 0.25)]
    return _through_file(model.with_element_moduli(moduli))


def _shear_data(seed: int) -> fp.ModalData:
    return fp.synthetic_measurement(storey_truth(SHEAR4, STOREY_RATIOS), 4, dofs=SHEAR4.measured_dofs,
                                    freq_noise=FREQ_NOISE, shape_noise=SHAPE_NOISE, seed=seed, model_name="shear4")


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_storey_gradient_is_every_storey_free_never_top_storey_only(seed):
    diag = fp.diagnose(SHEAR4, _shear_data(seed))
    best = diag.evidence.classes[0]
    assert best.family == "distributed" and best.label.startswith(KIND + "@"), [c.label for c in
                                                                              diag.evidence.classes[:4]]
    assert best.n_parameters == 3  # the top storey's stiffness is the global scale
    ratios = np.array(best.estimate["storey_ratio"])
    assert np.all(np.abs(ratios / np.array(STOREY_RATIOS) - 1.0) < 0.05), ratios
    assert np.all(np.array(best.estimate["storey_ratio_std"]) < 0.05)
    # it beats every one-parameter class (a storey, a trend, a member) by more than a factor of 10
    single = [c for c in diag.evidence.classes if c.n_parameters == 1]
    assert best.log_evidence - max(c.log_evidence for c in single) > np.log(10.0)
    assert any("spread over several members" in w and KIND in w for w in diag.warnings)
    top = {e.id for e in SHEAR4.elements if SHEAR4.node(e.node_i).y >= 0.75 and SHEAR4.node(e.node_j).y >= 0.75}
    top_only = diag.causes and all((c.location or {}).get("element") in top or c.kind == "undetermined"
                                   for c in diag.causes)
    assert not (diag.verdict.adequate and top_only), "top storey only, declared adequate"
    record = diag.to_dict()["evidence"]["classes"][0]
    assert record["label"] == best.label and record["estimate"]["groups"] == ["storey1", "storey2", "storey3",
                                                                              "storey4"]


def test_every_storey_free_evidence_agrees_with_monte_carlo_integration():
    """log of the integral of exp(-(chi^2 - chi^2^) / 2) over the prior box / its volume: the
    class's Laplace factor (Gauss-Newton Hessian, truncation per parameter) within 0.15 of an
    importance-sampling estimate (Gaussian proposal twice as wide as Laplace's, 4,000 draws) on
    the real chi^2 of the shear frame's storey gradient."""
    data = _shear_data(0)
    cal = calibrate(SHEAR4, data, FREQ_NOISE, SHAPE_NOISE)
    sf = fit_storeys(cal.setting, cal.obs, cal.base.pairing)
    theta, jac = sf.fit.theta, sf.fit.jacobian
    laplace = log_occam(theta, jac, len(theta), 1.0)
    cov = 4.0 * np.linalg.inv(jac.T @ jac)  # chi^2 ~ chi^2^ + dtheta^T (2 J^T J) dtheta / 2: cov (J^T J)^-1
    rng = np.random.default_rng(5)
    draws = rng.multivariate_normal(theta, cov, size=4000)
    inside = np.all((draws > LOW) & (draws < HIGH), axis=1)
    chi2 = np.full(len(draws), np.inf)
    chi2[inside] = [f.chi2 for f in sf.params.residuals(cal.obs, draws[inside])]
    diff = draws - theta
    log_q = (-0.5 * np.einsum("ij,jk,ik->i", diff, np.linalg.inv(cov), diff)
             - 0.5 * np.linalg.slogdet(2 * np.pi * cov)[1])
    log_w = -(chi2 - sf.fit.chi2) / 2.0 - log_q
    top = log_w[np.isfinite(log_w)].max()
    monte_carlo = top + np.log(np.mean(np.exp(log_w - top))) - len(theta) * np.log(HIGH - LOW)
    assert laplace == pytest.approx(monte_carlo, abs=0.15)


def _hframe_data(factors: dict, seed: int) -> fp.ModalData:
    truth = _through_file(HFRAME.with_element_moduli({e: f * HFRAME.element_modulus_pa(e) for e, f in factors.items()}))
    return fp.synthetic_measurement(truth, 8, dofs=HFRAME.measured_dofs, freq_noise=FREQ_NOISE,
                                    shape_noise=SHAPE_NOISE, seed=seed, model_name="hframe")


@pytest.mark.parametrize("seed", [1, 2])
def test_two_adjacent_members_are_both_named(seed):
    """Column elements 2 and 3 of the H-frame (they meet at the beam's joint) at 0.75 and 0.85: a
    later round may add the member next to the one found; both named with their sizes, nothing
    else (main named element 2 with added masses at nodes 5 and 7, and in seed 2 called it adequate)."""
    diag = fp.diagnose(HFRAME, _hframe_data({2: 0.75, 3: 0.85}, seed))
    named = sorted((c.kind, (c.location or {}).get("element"), c.identifiable) for c in diag.causes)
    assert named == [("stiffness_loss", 2, True), ("stiffness_loss", 3, True)]
    ratio = {c.location["element"]: c.estimate["modulus_ratio"] for c in diag.causes}
    assert ratio[2] == pytest.approx(0.75, abs=0.03) and ratio[3] == pytest.approx(0.85, abs=0.03)
    assert diag.verdict.adequate


def test_a_gradient_over_three_members_is_never_one_member_alone():
    """Column elements 1, 2, 3 at 0.8, 0.85, 0.9: named as those members, or as a distributed or
    sparse class over them first by evidence, or flagged not adequate; never one member, adequate."""
    members = {1, 2, 3}
    diag = fp.diagnose(HFRAME, _hframe_data({1: 0.8, 2: 0.85, 3: 0.9}, 1))
    named = {(c.location or {}).get("element") for c in diag.causes if c.identifiable}
    assert not (diag.verdict.adequate and len(diag.causes) == 1), "one member alone, declared adequate"
    best = diag.evidence.classes[0]
    spread = best.family in ("distributed", "sparse") and members <= set(best.estimate.get("members", ()))
    assert (len(named & members) >= 2 and named <= members) or spread or not diag.verdict.adequate
    assert spread  # what the evidence says today: every_member_sparse@members=1+2+3



#: The two-springs cases of seed 19 (of `cases(19, {"two_springs": 7})`) the test runs: the
#: two that ran for hours (index 1: springs at 9 y and 5 x; index 4: 1 x and 8 x, answered 1 x +
#: 4 x decisively after the hang was mended) and the one answered as one spring, adequate and
#: decisive (index 6: 13 y and 7 y). Each is 'honest' on fcf98d6, in 17.4, 31.5 and 14.9 s of CPU
#: (`fp.diagnose`, time.process_time, OPENBLAS_NUM_THREADS=1, FEMU_SOLVER_WORKERS=1; 63.8 s in all).
TWO_SPRINGS = (1, 4, 6)


def test_two_springs_to_ground_are_both_named_or_flagged():
    """Two translational springs to ground at two nodes of the free H-frame (model-file springs to
    grounded nodes, `diagnosis_cases.springs_truth`, each sized to shift a mode by 1.5-6 %): both
    named ('right') or flagged ('honest': not adequate, or not identifiable with both among the
    causes, ties and alternatives); never one spring declared adequate, and never the answer one
    spring, decisive and adequate. Springs along an axially rigid member (the crossbar's x, a
    column's y) act as one: naming the truth's among tied candidates is what the data allow."""
    from diagnosis_cases import cases, classify

    all_cases = cases(19, {"two_springs": 7})
    outcomes = []
    for case in (all_cases[i] for i in TWO_SPRINGS):
        diag = fp.diagnose(HFRAME, case.data())
        record = diag.to_dict()
        springs = [c for c in diag.causes if c.kind == "boundary_stiffness" and c.identifiable]
        assert not (diag.verdict.adequate and len(diag.causes) == 1 and len(springs) == 1), case.truths
        one = record["answer"]["family"] == "local" and record["answer"]["kind"] == "boundary_stiffness"
        assert not (one and record["answer"]["decisive"] and diag.verdict.adequate), (case.truths, record["answer"])
        outcomes.append(classify(case, record))
    assert all(o in ("right", "honest") for o in outcomes), outcomes


def test_a_noise_mode_is_brought_by_no_candidate_and_a_suspension_mode_by_a_spring():
    """`fit.brings`, which chooses the candidates a round fits besides the screened ones when a
    measured mode pairs with nothing (rounds._next_cause). The H-frame crack data of
    tests/test_diagnose_cli.py with mode 3's shape replaced by noise: no candidate pairs that mode
    at any size of its grid (before, every candidate was fitted for it in every such round: the
    diagnosis took 9.8 s of CPU, now 6.2 s, the same record). Two springs to ground (seed 19, case
    2 of 7): the spring at node 5 x pairs a suspension mode the free frame has no partner for, and
    not every candidate does."""
    import dataclasses

    from diagnosis_cases import cases
    from fe_problem.diagnosis.candidates import all_candidates
    from fe_problem.diagnosis.fit import brings, profiled

    crack = fp.synthetic_measurement(fp.crack_element(HFRAME, 7, 0.3, 3e4), 8, freq_noise=0.002, shape_noise=0.02,
                                     model_name="hframe", seed=3)
    shapes = crack.shapes.copy()
    shapes[:, 2] = np.random.default_rng(5).standard_normal(shapes.shape[0])
    springs = cases(19, {"two_springs": 2})[1].data()
    for data, spring in ((dataclasses.replace(crack, shapes=shapes), None),
                         (springs, "boundary_stiffness@node=5,direction=x")):
        cal = calibrate(HFRAME, data, 0.002, 0.02)
        obs = cal.obs_all
        unpaired = np.flatnonzero(profiled(obs, cal.hz0, cal.sh0).pairing < 0)
        assert len(unpaired), data.meta
        cands = all_candidates(cal.setting)
        bringing = {c.label for c in cands if brings(obs, c, unpaired)}
        if spring is None:
            assert list(unpaired) == [2] and not bringing, bringing
        else:
            assert spring in bringing and len(bringing) < len(cands), (len(bringing), len(cands))


def test_a_revisit_keeps_a_spring_that_brings_a_mode_only_it_pairs():
    """The hang's cause (two springs to ground, `diagnosis_cases` seed 19, case 2 of 7: springs at
    node 9 y and node 5 x of the free H-frame, each bringing a suspension mode). With both springs
    in the model, choosing the first again without it leaves a measured mode unpaired; a
    first-order screen cannot see that mode come to pair, missed the spring and dropped it (the
    joint chi^2 without it is ~270x higher), the next round added it again, and so on for hours.
    The revisit must keep both springs, and the model it keeps must fit no worse."""
    from diagnosis_cases import cases
    from fe_problem.diagnosis.core import ALPHA, N_FIT
    from fe_problem.diagnosis.kinds import CandidateKey
    from fe_problem.diagnosis.rounds import _final_obs, _joint_refit, _revisit

    case = cases(19, {"two_springs": 2})[1]
    assert {t[1]["node"] for t in case.truths} == {9, 5}  # the case the hang was found on
    cal = calibrate(HFRAME, case.data(), 0.002, 0.02)
    assert len(cal.unpaired)  # the nominal free frame has no partner for the suspension modes
    st = cal.setting
    picks = [CandidateKey.of("boundary_stiffness", {"node": 10, "direction": "y"}),
             CandidateKey.of("boundary_stiffness", {"node": 5, "direction": "x"})]
    sizes = [0.47, 0.026]  # where the rounds had them (stiffness ratios to the frame's)
    obs = _final_obs(cal, st, picks, sizes)
    _, _, chi2_both = _joint_refit(cal, st, picks, sizes, obs)
    kept, kept_sizes, _, _ = _revisit(cal, st, (picks, sizes, [0.0, 0.0], [(), ()]), 1, None, N_FIT, ALPHA)
    places = {key.label().split("@")[1] for key in kept}
    assert len(kept) == 2 and "node=5,direction=x" in places, kept
    assert any(p.endswith("direction=y") for p in places), kept  # the y spring (10 y or a tie of it)
    _, _, chi2_kept = _joint_refit(cal, st, kept, kept_sizes, obs)
    assert chi2_kept <= chi2_both * 1.01, (chi2_kept, chi2_both)


#: Two consecutive column elements lowered by different amounts (element moduli in the model file)
#: and the seeds: on the code before the two-adjacent-members class, (9, 10) was named as element
#: 10 alone (uniform or a weak zone), adequate and decisive, in 5 of these 6 cases; (1, 2) at
#: 0.85/0.75 as element 2 with a mass, decisive, in seeds 2 and 3. (9, 10) at 0.8/0.9 in seed 3
#: was a weak zone in element 10 decisive by 2.40 over the pair until each row was charged for
#: the labels its class picks (the zone's centre, log 7; a side, a direction: docs/diagnosis.md,
#: "How the rows are charged"); now 1.84, not decisive.
GRADIENTS = [((9, 10), (0.85, 0.75), 1), ((9, 10), (0.85, 0.75), 2), ((9, 10), (0.85, 0.75), 3),
             ((9, 10), (0.8, 0.9), 1), ((9, 10), (0.8, 0.9), 2), ((9, 10), (0.8, 0.9), 3),
             ((1, 2), (0.85, 0.75), 2), ((1, 2), (0.85, 0.75), 3), ((2, 3), (0.8, 0.9), 3)]


def _evidence_page_row(members, factors, seed) -> tuple[str, str]:
    """docs/diagnosis-evidence.md's row of this case in its before/after table: (before, after) cells."""
    page = (Path(__file__).resolve().parents[1] / "docs" / "diagnosis-evidence.md").read_text()
    case = f"({members[0]}, {members[1]}) {factors[0]:g}/{factors[1]:g}, seed {seed}"
    rows = [ln for ln in page.splitlines() if ln.startswith(f"| {case} |")]
    assert len(rows) == 1, f"docs/diagnosis-evidence.md: {len(rows)} rows for {case!r}"
    return tuple(c.strip() for c in rows[0].strip("|").split("|")[1:])


def _said(label: str, members) -> str:
    """An evidence row's label as the page's table writes it."""
    if label.startswith("adjacent_members_free@members="):
        return "pair"
    m = re.fullmatch(r"stiffness_loss@element=(\d+)(\(zone [\d.]+\))?", label)
    if m:
        return f"{'zone' if m[2] else 'loss'} in element {m[1]}"
    m = re.fullmatch(r"node_position@node=(\d+)\(([-+][xyz])\)", label)
    assert m, label
    return f"node {m[1]} {m[2]}"


@pytest.mark.parametrize("members, factors, seed", GRADIENTS)
def test_a_two_member_gradient_is_named_or_not_decisive(members, factors, seed):
    """Two consecutive elements of one H-frame column at different moduli: the answer names both
    members softer (the local search's two causes, two adjacent members free, the sparse class),
    or it is not decisive and the evidence table holds such a class (in seed 2 of 0.8/0.9 the
    answer is a moved node 6, not decisive against a weak zone in element 10, the pair third);
    never one member (a weak zone or a uniform loss) or other physics, decisive."""
    from fe_problem.diagnosis.answer import members_changed

    diag = fp.diagnose(HFRAME, _hframe_data(dict(zip(members, factors)), seed))
    both = frozenset((e, -1) for e in members)
    rows = {c.label: c for c in diag.evidence.classes}
    a = diag.answer
    answer_row = rows.get(a.label)
    named = answer_row is not None and members_changed(answer_row) == both
    flagged = not a.decisive and any(members_changed(c) == both for c in diag.evidence.classes)
    assert named or flagged, (a.label, a.decisive, a.runner_up and a.runner_up["label"])
    # docs/diagnosis-evidence.md's "after" column: the answer, decisive or not, the margin to the next
    # row (and, when the pair is not second, how far below it is); "the same": the "before" answer
    order = sorted(diag.evidence.classes, key=lambda c: -c.log_evidence)
    before, after = _evidence_page_row(members, factors, seed)
    m = re.fullmatch(r"(.+), (no|yes), ([\d.]+)(?: \(the pair ([\d.]+) below\))?", after)
    assert m, f"docs/diagnosis-evidence.md: after cell {after!r}"
    said = before.split(",")[0] if m[1] == "the same" else m[1]
    assert (said, m[2] == "yes", m[3]) == (_said(order[0].label, members), a.decisive,
                                           f"{order[0].log_evidence - order[1].log_evidence:.2f}")
    pair = next(c for c in order if c.label.startswith("adjacent_members_free@"))
    assert (m[4] is None) == (pair in order[:2]), after
    if m[4] is not None:
        assert m[4] == f"{order[0].log_evidence - pair.log_evidence:.2f}"
    if named and a.family != "several":  # a class of moduli as the answer: its ratios near the truth
        est = answer_row.estimate
        ratios = dict(zip(est["members"], est["modulus_ratio"]))  # against the rest of the frame
        for e, f in zip(members, factors):
            assert ratios[e] == pytest.approx(f, abs=0.05), ratios


def test_two_separated_members_are_the_sparse_answer():
    """The `separated_members` case of `diagnosis_cases.cases(6)` (REAL, one per class): members 2 and
    9 of the H-frame with their section inertia times 0.814 and 0.775 in the model file (bending
    alone), 2.75 % largest shift. Before, the search named element 2 only, adequate, and the sparse
    class holding both, with the full range 0.1-4 for each ratio, was 1.6 below it in log
    evidence: a confident, incomplete answer. With each member's change on the local family's range
    for its side (a loss on the loss candidate's) the sparse class is the answer with both members'
    ratios near the truth; not decisive (member 9 alone gives a chi^2 drop of 15), the runner-up
    element 2 alone, and the text says it cannot tell them apart."""
    from diagnosis_cases import REAL, cases, classify_real
    from fe_problem.diagnosis.sparse_class import KIND as SPARSE

    case = cases(6, {k: 1 for k in REAL})[-1]
    assert case.cls == "separated_members" and sorted(loc["element"] for _, loc in case.truths) == [2, 9]
    diag = fp.diagnose(HFRAME, case.data())
    a = diag.answer
    assert (a.kind, a.location) == (SPARSE, {"members": [2, 9]}), (a.label, a.decisive)
    assert not a.decisive and a.runner_up["label"] == "stiffness_loss@element=2"
    # docs/diagnosis-forms.md: "now the class is the answer, X above member 2 alone"
    order = sorted(diag.evidence.classes, key=lambda c: -c.log_evidence)
    assert order[1].label == "stiffness_loss@element=2"
    page = " ".join((Path(__file__).resolve().parents[1] / "docs" / "diagnosis-forms.md").read_text().split())
    said = re.search(r"now the class is the answer, ([\d.]+) above member 2 alone", page)
    assert said and said[1] == f"{order[0].log_evidence - order[1].log_evidence:.1f}", said
    assert any(w.startswith("answer not decisive: cannot tell apart " + a.label) for w in diag.warnings)
    ratios = dict(zip(a.estimate["members"], a.estimate["modulus_ratio"]))
    assert ratios[2] == pytest.approx(0.814, abs=0.04) and ratios[9] == pytest.approx(0.775, abs=0.06)
    assert diag.adequate and classify_real(case, diag.to_dict()) == "right"


def _line_frame() -> fp.FrameModel:
    """A two-bay three-storey steel frame (`regular_frame`: 6 m bays, 3 m storeys, 2 t at each
    node above the base), x and y measured at those nodes."""
    return fp.regular_frame(2, 3, 6.0, 3.0, floor_mass_kg=2000.0, name="frame2x3")


def _members_at(model: fp.FrameModel, axis: str, places) -> dict[int, float]:
    """The members whose two ends share their `axis` coordinate ("x": columns, "y": beams) at one
    of `places` (m): element id -> that coordinate."""
    out = {}
    for e in model.elements:
        a, b = getattr(model.node(e.node_i), axis), getattr(model.node(e.node_j), axis)
        if a == b and a in places:
            out[e.id] = a
    return out


def _scaled_at(model: fp.FrameModel, axis: str, ratios: dict) -> fp.FrameModel:
    """The members `_members_at(model, axis, ratios)` with their moduli times ratios[coordinate],
    in the model file."""
    return _through_file(model.with_element_moduli(
        {e: model.element_modulus_pa(e) * ratios[c] for e, c in _members_at(model, axis, ratios).items()}))


@pytest.mark.parametrize("seed", [0, 1])
def test_a_column_line_pattern_is_every_column_line_free(seed):
    """One column line 15 % softer (x = 0), another 15 % stiffer (x = 6 m), the third as modelled
    (6 modes, default noise): the local search names a gain and a loss of two columns; the class
    "every column line free" is the answer, decisive and adequate, each line's ratio within 2 % of
    the truth, and its extended model carries them. (Its fit moves two close modes past each other:
    fitted with the nominal pairing only, it stopped at chi^2 662 instead of 89.)"""
    from fe_problem.diagnosis.group_free import FAMILY

    model = _line_frame()
    data = fp.synthetic_measurement(_scaled_at(model, "x", {0.0: 0.85, 6.0: 1.15}), 6, dofs=model.measured_dofs,
                                    freq_noise=FREQ_NOISE, shape_noise=SHAPE_NOISE, seed=seed, model_name="frame2x3")
    diag = fp.diagnose(model, data)
    a = diag.answer
    assert a.family == FAMILY and a.kind == "every_column_line_free" and a.decisive, (a.label, a.decisive)
    assert a.location == {"groups": ["column_line_x0", "column_line_x6", "column_line_x12"]}
    assert np.allclose(a.estimate["column_line_ratio"], [0.85, 1.15, 1.0], atol=0.02), a.estimate
    assert diag.adequate and diag.evidence.classes[0].label == a.label
    ext = diag.extended_model
    ratio = {x: ext.element_modulus_pa(e) / model.element_modulus_pa(e) for x, e in ((0.0, 1), (6.0, 2), (12.0, 3))}
    assert [ratio[x] for x in (0.0, 6.0, 12.0)] == pytest.approx(a.estimate["column_line_ratio"], rel=1e-9)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_a_floor_pattern_is_every_floor_free(seed):
    """The first floor's beams 20 % softer, the second's 20 % stiffer, the roof's as modelled (the
    frame of the column-line test, 6 modes, default noise): "every floor free" is the answer and
    first by evidence, adequate, each floor's ratio within 0.05 of the truth (measured: 0.815 /
    1.163 / 1.001, 0.795 / 1.226 / 1.000, 0.807 / 1.187 / 1.000 for seeds 0-2, each with a standard
    deviation near 0.02). Where it is not decisive (seed 0: 27.87 against 26.55), its runner-up
    holds only beams of the two changed floors."""
    from fe_problem.diagnosis.group_free import FAMILY

    model = _line_frame()
    data = fp.synthetic_measurement(_scaled_at(model, "y", {3.0: 0.8, 6.0: 1.2}), 6, dofs=model.measured_dofs,
                                    freq_noise=FREQ_NOISE, shape_noise=SHAPE_NOISE, seed=seed, model_name="frame2x3")
    diag = fp.diagnose(model, data)
    a = diag.answer
    assert a.family == FAMILY and a.kind == "every_floor_free", (a.label, a.decisive)
    assert a.location == {"groups": ["floor_y3", "floor_y6", "floor_y9"]}
    assert np.allclose(a.estimate["floor_ratio"], [0.8, 1.2, 1.0], atol=0.05), a.estimate
    assert diag.adequate and diag.evidence.classes[0].label == a.label
    changed = set(_members_at(model, "y", (3.0, 6.0)))
    if not a.decisive:
        from fe_problem.diagnosis.answer import members_changed

        runner = next(c for c in diag.evidence.classes if c.label == a.runner_up["label"])
        held = members_changed(runner)
        assert held is not None and {e for e, _ in held} <= changed, runner.label


def test_a_re_paired_refit_keeps_its_best_pass_never_a_pairing_that_drops_a_mode(monkeypatch):
    """The column-line case of seed 0: the sparse class's 14 members refitted on the modes but the
    held-out one (`sparse_class.held_out`). Re-pairing, its passes went chi^2 72.29 -> 72.21 ->
    27,024 (fitted with a pairing that left a measured mode unpaired) -> 467.08, and the last was
    returned. The refit with its re-pairings is never worse than its first pass alone (REPAIRS
    0), and the held-out refit pairs every mode it was fitted to."""
    from fe_problem.diagnosis import sparse_class
    from fe_problem.diagnosis.residuals import Observations

    model = _line_frame()
    data = fp.synthetic_measurement(_scaled_at(model, "x", {0.0: 0.85, 6.0: 1.15}), 6, dofs=model.measured_dofs,
                                    freq_noise=FREQ_NOISE, shape_noise=SHAPE_NOISE, seed=0, model_name="frame2x3")
    cal = calibrate(model, data, FREQ_NOISE, SHAPE_NOISE)
    sf = sparse_class.fit_sparse(cal.setting, cal.obs, cal.base.pairing)
    assert sf is not None and len(sf.members) == 14, sf
    n_hold = max(1, int(round(len(cal.used) / 4)))
    obs = Observations.of(data, modes=cal.used[:-n_hold], freq_noise=FREQ_NOISE, shape_noise=SHAPE_NOISE)
    am = sparse_class._AllMembers(cal.setting)
    support = np.array([am.names.index(e) for e in sf.members])
    pairing = am.residuals(obs, np.zeros((1, len(am.names))))[0].pairing
    got = sparse_class.refit(am, obs, support, sf.theta, pairing)
    theta = np.zeros(len(am.names))
    theta[support] = got.theta
    assert np.all(am.residuals(obs, theta[None])[0].pairing >= 0)
    monkeypatch.setattr(sparse_class, "REPAIRS", 0)
    first = sparse_class.refit(am, obs, support, sf.theta, pairing)
    assert got.chi2 <= first.chi2 + 1e-9, (got.chi2, first.chi2)
    assert got.chi2 < 100.0, got.chi2


def _setback_frame() -> fp.FrameModel:
    """A two-bay four-storey steel frame (6 m bays, 3 m storeys) whose top storey is set back to
    one bay (x 0..6 m): the roof has one beam (element 18). 1 t at each node above the base, x
    measured there; written as a model file's dict."""
    nodes, at = [], {}
    for y in (0.0, 3.0, 6.0, 9.0, 12.0):
        for x in (0.0, 6.0, 12.0):
            if not (y == 12.0 and x == 12.0):
                at[x, y] = len(nodes) + 1
                nodes.append({"id": at[x, y], "x": x, "y": y})
    elements = []
    for (x, y), n in at.items():
        for other in ((x, y + 3.0), (x + 6.0, y) if y > 0 else None):
            if other in at:
                elements.append({"id": len(elements) + 1, "nodes": [n, at[other]], "section": "c", "material": "steel"})
    return model_from_dict({
        "format": "femu.model/1", "name": "setback",
        "materials": {"steel": {"youngs_modulus_pa": 2.1e11, "density_kg_m3": 7850.0, "poisson_ratio": 0.3}},
        "sections": {"c": {"area_m2": 0.01, "inertia_m4": 1e-4}},
        "nodes": nodes, "elements": elements,
        "masses": [{"node": n["id"], "mass_kg": 1000.0} for n in nodes if n["y"] > 0],
        "supports": [{"node": n["id"], "directions": ["x", "y", "rz"]} for n in nodes if n["y"] == 0],
        "measured_dofs": [[n["id"], "x"] for n in nodes if n["y"] > 0]})


def test_a_set_back_roof_beam_is_the_top_floor_group_and_held_members_are_named():
    """On the set-back frame the roof's one beam is a floor group of its own, the top floor, the
    reference of "every floor free" (it was in no group, silently held at the global scale, with
    the floor at 9 m the reference); every beam is in a floor group, every column in a storey and
    a column line; the fitted floor class names the members it holds at the scale (the columns)."""
    from fe_problem.diagnosis.group_free import partition

    model = _setback_frame()
    cal = calibrate(model, fp.synthetic_measurement(model, 6, dofs=model.measured_dofs, freq_noise=FREQ_NOISE,
                                                    shape_noise=SHAPE_NOISE, seed=0, model_name="setback"),
                    FREQ_NOISE, SHAPE_NOISE)
    floors = partition(cal.setting, "every_floor_free")
    assert floors == {"floor_y3": (5, 7), "floor_y6": (10, 12), "floor_y9": (15, 17), "floor_y12": (18,)}
    columns = [e.id for e in model.elements if model.node(e.node_i).x == model.node(e.node_j).x]
    beams = sorted(set(model.element_ids) - set(columns))
    assert sorted(e for g in floors.values() for e in g) == beams
    for kind in ("every_storey_free", "every_column_line_free"):
        assert sorted(e for g in partition(cal.setting, kind).values() for e in g) == sorted(columns), kind
    assert list(partition(cal.setting, "every_storey_free"))[-1] == "storey4"
    fit = fit_storeys(cal.setting, cal.obs, cal.base.pairing, "every_floor_free")
    est = fit.estimate()
    assert est["groups"][-1] == "floor_y12" and est["members"] == beams
    assert est["held_members"] == sorted(columns) and len(est["floor_ratio"]) == 4


def test_a_member_below_the_detection_limit_is_not_required_of_a_separated_members_answer():
    """`diagnosis_cases.classify_real` for separated members requires only the truth's members whose
    own effect on the data reaches Currie's detection limit (noncentrality 13.0, `DETECTABLE`),
    measured with the truth model alone (`own_effect`). The case of seed 5 with members 2, 4 and 9
    (inertia 0.76, 0.78, 0.83): member 9, the right column's free lower end, gives 6.15 (a 5 %
    test would find it in 70 % of noise draws, the diagnosis's 1 % test in 46 %), 2 and 4 give
    1,196 and 334. The noncentrality is checked against the chi^2 drop over 40 noise draws of the
    truth against the truth without member 9's change: its mean (the expectation for a linear
    model; sd 2 sqrt(lambda / n)) and its variance (4 lambda, which holds only at the right noise
    level; bounds the sample variance's chi^2 quantiles at 3 sd). The limit itself is checked
    against the closed form (z_0.975 + z_0.95)^2 of normal quantiles. Naming 2 and 4 is right, so
    is naming all three; naming 2 alone, or 2, 4 and another member, confidently, is wrong."""
    from scipy.stats import chi2, norm

    from diagnosis_cases import (DETECTABLE, REAL, cases, classify_real, detection_limit, own_effect, required_members,
                                 without_change)

    currie = (norm.ppf(0.975) + norm.ppf(0.95)) ** 2
    assert detection_limit(1) == pytest.approx(currie, rel=1e-6) and DETECTABLE == pytest.approx(currie, abs=0.01)

    case = next(c for c in cases(5, REAL) if c.cls == "separated_members")
    assert sorted(loc["element"] for _, loc in case.truths) == [2, 4, 9]
    effect = {e: own_effect(case, e) for e in (2, 4, 9)}
    assert effect[9] < DETECTABLE < min(effect[2], effect[4]), effect
    assert required_members(case) == [2, 4]
    without = without_change(case, 9)
    drops = []
    for seed in range(40):
        data = dataclasses.replace(case, seed=1000 + seed).data()
        drops.append(calibrate(without, data, FREQ_NOISE, SHAPE_NOISE).base.chi2
                     - calibrate(case.truth, data, FREQ_NOISE, SHAPE_NOISE).base.chi2)
    assert np.mean(drops) == pytest.approx(effect[9], abs=3 * 2 * np.sqrt(effect[9] / len(drops)))
    n = len(drops)
    ratio = np.var(drops, ddof=1) / (4 * effect[9])
    assert chi2.ppf(0.00135, n - 1) / (n - 1) < ratio < chi2.ppf(0.99865, n - 1) / (n - 1), ratio

    def record(elements):
        causes = [{"kind": "stiffness_loss", "location": {"element": e}, "identifiable": True} for e in elements]
        return {"adequate": True, "cause": causes[0], "causes": causes,
                "evidence": {"classes": [{"family": "local", "estimate": {}}]}}

    assert classify_real(case, record([2, 4])) == "right"
    assert classify_real(case, record([2, 4, 9])) == "right"
    assert classify_real(case, record([2])) == "wrong"
    assert classify_real(case, record([2, 4, 7])) == "wrong"
    assert classify_real(case, record([2, 4, 4])) == "wrong"


def test_members_below_the_limit_are_excused_only_if_undetectable_together(monkeypatch):
    """`required_members` excuses members below the one-parameter limit only when their joint
    effect (all undone at once) stays below the limit for as many parameters: two members at 10
    each, 20 together (above the two-parameter limit, 15.4), are both required; at 12 together
    both are excused. The two-parameter limit is checked against scipy's noncentral chi^2 power."""
    import diagnosis_cases
    from scipy.stats import chi2, ncx2

    assert ncx2.sf(chi2.ppf(0.95, 2), 2, diagnosis_cases.detection_limit(2)) == pytest.approx(0.95, abs=1e-9)
    assert 15.3 < diagnosis_cases.detection_limit(2) < 15.5
    case = next(c for c in diagnosis_cases.cases(5, diagnosis_cases.REAL) if c.cls == "separated_members")
    for together, required in ((20.0, [2, 4, 9]), (12.0, [2])):
        effects = {(2,): 500.0, (4,): 10.0, (9,): 10.0, (4, 9): together}
        monkeypatch.setattr(diagnosis_cases, "own_effect", lambda c, *e, fx=effects: fx[tuple(sorted(e))])
        assert diagnosis_cases.required_members(case) == required
