"""Several causes: after the first significant cause, the next one is sought against the model
extended by the causes found so far, with the same test (likelihood ratio, Bonferroni over the
candidates of that round, quasi-likelihood dispersion, alpha); the causes are then refitted
jointly (each cause's size refitted with the others at theirs, on the measured modes that pair
with the extended model) and every earlier cause is chosen again with the others in the model
(`_revisit`: replaced when another candidate improves the joint fit, dropped when nothing is
significant in its place, its tie judged again; when a measured mode pairs with no mode of the
model without the cause sought, every candidate that pairs it at some size of its grid is fitted
besides the screened ones, as a first-order screen cannot see a mode come to pair, and a mode
that no candidate pairs, a noise shape, costs no fits). The
search stops when a round finds nothing significant, when its candidates tie (that cause enters
the model with its best candidate and is reported as not identifiable), when the revisit returns
the causes to a set the search already held (a further round would repeat itself), or after
`max_causes` causes. A later round tries no
candidate at a place where a cause was already found, only places of the user's model, and no
stiffness change in an element next to one where a stiffness change was found (that is the
first one's form: a crack is neither uniform nor linear along its element), except a uniform
change of the same kind next to a uniform change found: real members deviate together (a
storey's columns, a gradient along a column), and a change spread over adjacent members is
found member by member; like every further cause it stays only if the joint fit without it,
the others refitted, is significantly worse (`_prune`). A measured mode that pairs with no
mode of the user's model makes every cause be chosen again on every measured mode, so that a
cause that brings its partner (a spring to ground: the suspension mode) is preferred; a mode
that no cause found brings is sought by a search judged on every measured mode, and a cause that
brings a mode is chosen by its joint refit with the others (`joint.choose_bringing`)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2 as chi2_dist

from ..model import FrameModel
from . import joint
from .fit import Fit, fit, profiled
from .kinds import KINDS as _KINDS
from .picks import (_LISTED, ZONE_RANGE, ZONE_REACH, ZONE_XTOL, Step, _ambiguity, _answer,  # noqa: F401 (named here)
                    _candidate_on, _final_obs, _joint_refit, _listed, _listed_candidate, _refine_zone, _with,
                    _zone_about, _zone_centre)
from .record import Cause, Found, Gain
from .setting import Candidate, Setting, scale_stiffness
from .steps import calibrate, gain, screen_and_fit, select
from .verdict import interval_of, profile_interval


@dataclass(frozen=True, eq=False)
class Rounds:
    """The causes found (in order of evidence), the final model's fit to the measured modes that
    pair with it (`obs`), the final model (calibrated, every cause) and the held-out gain."""

    causes: tuple[Found, ...]
    final: Fit
    model: FrameModel
    gain: Gain
    obs: object = None
    #: each cause's candidate built on the model with the others at their sizes, and its size
    #: (the evidence's curvature of each size, evidence.py)
    sized: tuple = ()


def further_causes(cal, found, sel, cause: Cause, kinds, n_fit, alpha: float, max_causes: int) -> Rounds:
    """Add causes one by one after the first (see the module docstring)."""
    with _listed(cal.setting, found.candidates):
        return _further_causes(cal, found, sel, cause, kinds, n_fit, alpha, max_causes)


def _further_causes(cal, found, sel, cause: Cause, kinds, n_fit, alpha: float, max_causes: int) -> Rounds:
    """`further_causes` with the first round's candidates listed (`_listed`)."""
    st = cal.setting
    states = []
    for i in joint.starts(found, sel, st):  # the best first cause and the runner-up of another place
        c0, f0 = found.candidates[i], found.fitted[i]
        # a first round whose candidates tie goes on with its best: a second effect's misfit can be
        # what blurs the first choice; the revisit below chooses it again once the second is in
        picks, sizes, ps = [c0.key], [f0.a], [cause.p_adjusted]
        ties: list[tuple] = [() if cause.identifiable or i != sel.best else _keys(found, cause.indistinguishable)]
        # its size refitted on the modes that pair with the model it extends (a spring to ground
        # brings a suspension mode the first round could not fit)
        picks, sizes, _ = _joint_refit(cal, st, picks, sizes)
        states.append(_search(cal, st, (picks, sizes, ps, ties), kinds, n_fit, alpha, max_causes))
    state = joint.better(cal, st, states, alpha, len(found.candidates))
    if len(cal.unpaired):
        # a measured mode the model has no partner for (a suspension mode; a mode a deep crack
        # moved past pairing): every cause chosen again on every measured mode, so that a cause
        # that brings its partner is preferred. Each round fits, besides the screened, every
        # candidate that pairs a mode the model without the cause sought leaves unpaired (a
        # first-order screen cannot see a mode come to pair: `_next_cause`)
        again = _revisit(cal, st, state, len(state[0]), kinds, n_fit, alpha, cal.obs_all)
        changed = again[0] != state[0]
        state = _search(cal, st, again, kinds, n_fit, alpha, max_causes) if changed else again
        if _final_obs(cal, st, state[0], state[1]).n_modes < cal.obs_all.n_modes:
            # a measured mode that no cause found brings (a second spring's suspension mode): the
            # rounds judged on the modes that pair saw nothing of it; sought on every measured mode
            state = _search(cal, st, state, kinds, n_fit, alpha, max_causes, cal.obs_all)
    state = _prune(cal, st, state, alpha, len(found.candidates))
    return _finish(cal, st, *state, gain)


def _prune(cal, st: Setting, state, alpha: float, n_candidates: int):
    """The last word on every cause, the latest first: the model without it, each other cause
    refitted (sizes and a crack's position, two sweeps), judged on the same modes, must fit
    significantly worse (the selection's test: likelihood ratio, Bonferroni over the first
    round's candidates, quasi-likelihood dispersion). The revisit judges a cause with the
    others at their joint sizes, where a further cause can look significant only because it
    mends an earlier one's size or place (a spring beside a crack in a building column, with
    the crack alone fitting better); such a cause goes."""
    picks, sizes, ps, ties = (list(x) for x in state)
    if len(picks) < 2:
        return picks, sizes, ps, ties
    obs = _final_obs(cal, st, picks, sizes)
    picks, sizes, chi2 = _joint_refit(cal, st, picks, sizes, obs)
    for j in reversed(range(len(picks))):
        if len(picks) < 2:
            break
        rest = [k for k in range(len(picks)) if k != j]
        r_picks, r_sizes = [picks[k] for k in rest], [sizes[k] for k in rest]
        for _ in range(2):
            r_picks, r_sizes, r_chi2 = _joint_refit(cal, st, r_picks, r_sizes, obs)
        dispersion = max(1.0, chi2 / obs.dof(1 + len(picks)))
        if r_chi2 - chi2 < dispersion * chi2_dist.isf(min(1.0, 2.0 * alpha / n_candidates), 1):
            picks, sizes, chi2 = r_picks, r_sizes, min(chi2, r_chi2)
            ps, ties = [ps[k] for k in rest], [ties[k] for k in rest]
    return picks, sizes, ps, ties


def _search(cal, st: Setting, state, kinds, n_fit, alpha: float, max_causes: int, obs=None):
    """Further causes one by one, each followed by a revisit of the earlier ones; returns the
    state (picks, sizes, p-values, ties). obs: the modes each round judges on (default: those
    that pair with the model extended by the causes so far)."""
    picks, sizes, ps, ties = (list(x) for x in state)
    held = {_held(picks)}
    while len(picks) < max_causes:
        step = _next_cause(cal, st, picks, sizes, kinds, n_fit, alpha, obs=obs)
        if step is None:
            break
        # a significant cause whose candidates tie enters the model with its best (the verdict
        # judges the model with it) and ends the search; it is reported as not identifiable
        picks, sizes, ps, ties = picks + [step.pick], sizes + [step.a], ps + [step.p], ties + [step.ties]
        picks, sizes, _ = _joint_refit(cal, st, picks, sizes)
        picks, sizes, ps, ties = _revisit(cal, st, (picks, sizes, ps, ties), len(picks) - 1, kinds, n_fit, alpha, obs)
        if step.ties or _held(picks) in held:  # the revisit undid the round: a further one would repeat it
            break
        held.add(_held(picks))
    return picks, sizes, ps, ties


def _held(picks) -> frozenset:
    """The causes of a state as a set of answers (kind, place): what the search has held."""
    return frozenset(_answer(key) for key in picks)


def _next_cause(cal, st: Setting, picks, sizes, kinds, n_fit, alpha: float, skip: int = -1,
                obs=None) -> Step | None:
    """The best further candidate against the model extended by `picks` (all but number `skip`),
    tested as the first was, on the modes that pair with that model or on `obs`; None if
    nothing is significant."""
    places = [(k.kind, k.location, _zone_centre(k) is None) for j, k in enumerate(picks) if j != skip]
    cal_k = calibrate(_with(st.model, st, picks, sizes, skip), cal.data, cal.obs.freq_noise, cal.obs.shape_noise,
                      st.model)
    unpaired = np.zeros(0, dtype=int)
    if obs is not None:
        cal_k = dataclasses.replace(cal_k, obs=obs, base=profiled(obs, cal_k.hz0, cal_k.sh0))
        unpaired = np.flatnonzero(cal_k.base.pairing < 0)
    bringing = bool(len(unpaired))
    # a mode of `obs` that only the cause sought brings (a spring to ground's suspension mode): a
    # first-order screen cannot see a mode come to pair (screened, the cause itself was missed and
    # dropped, then found again, forever), so every candidate that pairs it at some size is fitted
    # (`fit.brings`); a mode that none brings (a noise shape) asks for no more fits than a round's
    ids = (frozenset(st.model.element_ids), frozenset(st.model.node_ids))  # once, not per candidate
    found_k = screen_and_fit(cal_k, kinds, n_fit, keep=lambda c: _new_place(c, st.model, places, ids),
                             bring=unpaired)
    cal_k.setting.baselines.clear()  # a round screens its model once: its adjoint blocks go
    if not found_k.candidates:
        return None
    sel_k = select(cal_k, found_k, alpha)
    if sel_k.selection.p_adjusted >= alpha:
        return None
    ck = found_k.candidates[sel_k.best]
    tied = _tied(found_k, sel_k)
    keys = tuple(found_k.candidates[i].key for i in tied)
    one = len({_answer(k) for k in keys}) == 1
    step = Step(ck.key, found_k.fitted[sel_k.best].a, sel_k.selection.p_adjusted, () if one else keys)
    # a new cause: chosen again by its joint fit with the causes found (their sizes free); so is
    # any cause that brings a mode, beside the others (`joint.choose_bringing`)
    if bringing:
        return joint.choose_bringing(cal, st, picks, sizes, skip, found_k, step, obs)
    return joint.choose(cal, st, picks, sizes, skip, cal_k, found_k, step) if skip < 0 and joint.applies(st) else step


def _tied(found, sel) -> list[int]:
    """The fitted candidates within the ambiguity margin of the best, best first."""
    best = found.fitted[sel.best].chi2
    return sorted((i for i in found.fitted if (found.fitted[i].chi2 - best) / sel.dispersion < _ambiguity()),
                  key=lambda i: found.fitted[i].chi2)


def _undetermined(step: Step, location=None) -> Found:
    """The entry for tied candidates: their kind and place where all agree, else undetermined/None."""
    kinds = {t.kind for t in step.ties}
    places = {_answer(t) for t in step.ties}
    return Found(step.pick.kind if len(kinds) == 1 else "undetermined",
                 (location or step.pick.location) if len(places) == 1 else None,
                 {}, {}, None, step.p, False, tuple(t.label() for t in step.ties))


#: Sweeps of `_revisit` at most, and the least drop of the joint chi^2 that counts as a change
#: (a crack's refined position moves a little each time it is refitted).
MAX_SWEEPS, CHI2_TOL = 4, 1e-3


def _revisit(cal, st: Setting, state, n: int, kinds, n_fit, alpha: float, obs=None):
    """Choose the first `n` causes again with the others in the model, on the modes that pair
    with the model extended by all of them: a first choice made while a second effect was
    unexplained may be its neighbour or tie with it. A cause is replaced only when the joint
    fit improves, and dropped when nothing is significant in its place given the others; its
    tie is what is left of it given the others. Once one changes, every cause (the newest too)
    is chosen again in the next sweep: a later cause chosen beside a wrong first one may be
    there only to mend it. obs: the modes to judge on instead (every measured mode)."""
    picks, sizes, ps, ties = (list(x) for x in state)
    obs = _final_obs(cal, st, picks, sizes) if obs is None else obs
    picks, sizes, chi2 = _joint_refit(cal, st, picks, sizes, obs)
    for _ in range(MAX_SWEEPS):
        changed = dropped = False
        for j in range(min(n, len(picks))):
            step = _next_cause(cal, st, picks, sizes, kinds, n_fit, alpha, skip=j, obs=obs)
            if step is None and len(picks) > 1:  # the others explain what it did
                picks, sizes, ps, ties = ([x for k, x in enumerate(v) if k != j] for v in (picks, sizes, ps, ties))
                picks, sizes, chi2 = _joint_refit(cal, st, picks, sizes, obs)
                n, changed, dropped = n - 1, True, True
                break
            if step is None:
                continue
            if step.pick != picks[j]:
                trial = picks[:j] + [step.pick] + picks[j + 1:]
                trial, t_sizes, t_chi2 = _joint_refit(cal, st, trial, sizes[:j] + [step.a] + sizes[j + 1:], obs)
                if t_chi2 >= chi2 - CHI2_TOL:
                    if picks[j] in step.ties:  # it ties with the others chosen: it says so
                        ties[j] = step.ties
                    continue
                picks, sizes, chi2, changed = trial, t_sizes, t_chi2, True
            ties[j] = step.ties
        if not changed or (len(picks) == 1 and not dropped):  # a second sweep would repeat the first
            break
        n = len(picks)
    return picks, sizes, ps, ties


#: Kinds that change an element's stiffness (the two sides of the stiffness class, kinds/): a further
#: one next to one already found is the first effect's form (a crack is neither uniform nor linear
#: along its element), not a new cause, unless both are uniform and of one kind
#: (`_touches_found_stiffness`).
STIFFNESS_KINDS = tuple(k for k, spec in _KINDS.items() if spec.sides == "stiffness")


def _keys(found, labels) -> tuple:
    """The keys of the first round's candidates named by `labels` (a cause's tie), in their order."""
    by_label = {c.label: c.key for c in found.candidates}
    return tuple(by_label[lab] for lab in labels)


def _new_place(c: Candidate, model: FrameModel, places: list, ids=None) -> bool:
    """Whether candidate `c` is at a place of `model` where no cause in `places` (kind, location,
    uniform: not a weak zone) was found; `ids`: the model's (element ids, node ids) as sets, made
    once for the thousands of candidates."""
    element_ids, node_ids = ids if ids is not None else (frozenset(model.element_ids), frozenset(model.node_ids))
    loc = c.location or {}
    if c.kind in STIFFNESS_KINDS and _touches_found_stiffness(model, loc.get("element"), places, element_ids,
                                                              (c.kind, _zone_centre(c.key) is None)):
        return False
    if "element" in loc and loc["element"] not in element_ids:
        return False
    if "node" in loc and loc["node"] not in node_ids:
        return False
    # a further effect at a place already explained (a gain where a loss was found, a second
    # spread of the same loss) only corrects the first effect's form: not a new cause
    return c.location not in [where for _, where, _ in places]


def _touches_found_stiffness(model: FrameModel, element: int | None, places: list, element_ids=None,
                             change: tuple[str, bool] | None = None) -> bool:
    """Whether `element` shares a node with an element where a stiffness change was found
    (`places`: kind, location, uniform), other than a uniform one of the kind of `change` when
    `change` (kind, uniform) is uniform too: that continues the change found (a gradient)."""
    if element is None or element not in (model.element_ids if element_ids is None else element_ids):
        return False
    def ends(eid: int) -> set:
        return {model.element(eid).node_i, model.element(eid).node_j}

    def continues(kind: str, uniform: bool) -> bool:
        return change is not None and change[1] and uniform and kind == change[0]

    return any(kind in STIFFNESS_KINDS and ends(element) & ends(where["element"]) and not continues(kind, uniform)
               for kind, where, uniform in places)


def _finish(cal, st, picks, sizes, ps, ties, gain) -> Rounds:
    """Each cause's estimate and profile interval (the others at their sizes), the final fit,
    the final model and the held-out gain of the last cause (the others at their sizes); a
    cause whose candidates tie (`ties`) is reported as not identifiable with them."""
    obs = _final_obs(cal, st, picks, sizes)
    out, final, best = [], None, None
    for j, key in enumerate(picks):
        cand = _candidate_on(_with(st.model, st, picks, sizes, skip=j), st, key)
        f = fit(obs, cand, sizes[j])
        if final is None or f.chi2 < final.chi2:  # the final model is the best of these joint fits
            final, best = f, cand
        if ties[j] and len({_answer(t) for t in ties[j]}) > 1:
            out.append(_undetermined(Step(key, f.a, ps[j], ties[j]), cand.location))
            continue
        dispersion = max(1.0, f.chi2 / obs.dof(1 + len(picks)))
        low, high = profile_interval(obs, cand, f, dispersion)
        out.append(Found(key.kind, cand.location, cand.estimate(f.a, f.s), interval_of(cand, low, high, f.s),
                         key.label(), ps[j]))
    final_model = scale_stiffness(best.extend(final.a), final.s)
    sized = tuple((_candidate_on(_with(st.model, st, picks, sizes, skip=j), st, key), sizes[j])
                  for j, key in enumerate(picks))
    return Rounds(tuple(out), final, final_model, gain(cal, cand), obs, sized)


