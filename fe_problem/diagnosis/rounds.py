"""Several causes: after the first significant cause, the next one is sought against the model
extended by the causes found so far, with the same test (likelihood ratio, Bonferroni over the
candidates of that round, quasi-likelihood dispersion, alpha); the causes are then refitted
jointly (one sweep: each cause's size refitted with the others at theirs), and the search
stops when a round finds nothing significant, cannot tell its candidates apart, or after
`max_causes` causes. A later round tries no candidate at a place and kind already found, and
only places of the user's model (a profiled loss splits an element; its parts are no new
places), and no candidate at a place where a cause was already found."""

from __future__ import annotations

from dataclasses import dataclass

from ..model import FrameModel
from .candidates import Candidate, Setting, all_candidates, scale_stiffness
from .fit import Fit, fit
from .record import Cause, Found, Gain
from .verdict import interval_of, profile_interval


@dataclass(frozen=True, eq=False)
class Rounds:
    """The causes found (in order of evidence), the final model's fit to the paired modes of the
    first calibration, the final model (calibrated, every cause) and the held-out gain."""

    causes: tuple[Found, ...]
    final: Fit
    model: FrameModel
    gain: Gain


def _candidate_on(model: FrameModel, st: Setting, kind: str, label: str) -> Candidate:
    """The candidate `label` of `kind`, rebuilt on `model` (the others' effects included)."""
    return next(c for c in all_candidates(Setting(model, st.coords, st.n_modes), [kind]) if c.label == label)


def _with(base: FrameModel, st: Setting, picks: list[tuple[str, str]], sizes: list[float], skip: int = -1):
    """`base` extended by every picked (kind, label) at its size, except number `skip`."""
    m = base
    for j, ((kind, label), a) in enumerate(zip(picks, sizes)):
        if j != skip:
            m = _candidate_on(m, st, kind, label).extend(a)
    return m


def further_causes(cal, found, sel, cause: Cause, kinds, n_fit, alpha: float, max_causes: int) -> Rounds:
    """Add causes one by one after the first (see the module docstring)."""
    from .core import calibrate, gain, screen_and_fit, select

    st, obs = cal.setting, cal.obs
    c0, f0 = found.candidates[sel.best], found.fitted[sel.best]
    picks, sizes, ps = [(c0.kind, c0.label)], [f0.a], [cause.p_adjusted]
    places = {(c0.kind, str(c0.location))}
    extra: list[Found] = []
    noise = (obs.freq_noise, obs.shape_noise)
    while cause.identifiable and len(picks) < max_causes:
        cal_k = calibrate(_with(st.model, st, picks, sizes), cal.data, *noise)
        found_k = screen_and_fit(cal_k, kinds, n_fit, keep=lambda c: _new_place(c, st.model, places))
        if not found_k.candidates:
            break
        sel_k = select(cal_k, found_k, alpha)
        if sel_k.selection.p_adjusted >= alpha:
            break
        ck = found_k.candidates[sel_k.best]
        tied = [i for i in found_k.fitted
                if (found_k.fitted[i].chi2 - found_k.fitted[sel_k.best].chi2) / sel_k.dispersion < _ambiguity()]
        if len({(found_k.candidates[i].kind, str(found_k.candidates[i].location)) for i in tied}) > 1:
            extra.append(Found("undetermined", None, {}, {}, None, sel_k.selection.p_adjusted, False,
                               tuple(found_k.candidates[i].label for i in tied)))
            break
        picks.append((ck.kind, ck.label))
        sizes.append(found_k.fitted[sel_k.best].a)
        ps.append(sel_k.selection.p_adjusted)
        places.add((ck.kind, str(ck.location)))
        sizes = _joint_refit(obs, st, picks, sizes)
    return _finish(cal, st, obs, picks, sizes, ps, cause, extra, gain)


def _ambiguity() -> float:
    from .core import AMBIGUITY_CHI2
    return AMBIGUITY_CHI2


def _new_place(c: Candidate, model: FrameModel, places: set) -> bool:
    loc = c.location or {}
    if "element" in loc and loc["element"] not in model.element_ids:
        return False
    if "node" in loc and loc["node"] not in model.node_ids:
        return False
    # a further effect at a place already explained (a gain where a loss was found, a second
    # spread of the same loss) only corrects the first effect's form: not a new cause
    return str(c.location) not in {where for _, where in places}


def _joint_refit(obs, st: Setting, picks, sizes) -> list[float]:
    """One sweep: each cause's size refitted with the others at their current sizes."""
    sizes = list(sizes)
    for j, (kind, label) in enumerate(picks):
        cand = _candidate_on(_with(st.model, st, picks, sizes, skip=j), st, kind, label)
        sizes[j] = fit(obs, cand, sizes[j]).a
    return sizes


def _finish(cal, st, obs, picks, sizes, ps, cause: Cause, extra, gain) -> Rounds:
    """Each cause's estimate and profile interval (the others at their sizes), the final fit,
    the final model and the held-out gain of the last cause (the others at their sizes)."""
    out, final, cand = [], None, None
    for j, (kind, label) in enumerate(picks):
        cand = _candidate_on(_with(st.model, st, picks, sizes, skip=j), st, kind, label)
        f = fit(obs, cand, sizes[j])
        final = f if final is None or f.chi2 < final.chi2 else final
        dispersion = max(1.0, f.chi2 / obs.dof(1 + len(picks)))
        low, high = profile_interval(obs, cand, f, dispersion)
        out.append(Found(kind, cand.location, cand.estimate(f.a, f.s), interval_of(cand, low, high, f.s), label,
                         ps[j]))
    final_model = scale_stiffness(cand.extend(f.a), f.s)
    if not cause.identifiable:  # the first round's candidates tie: no single cause to report
        out = [Found(cause.kind, cause.location, {}, {}, None, cause.p_adjusted, False, cause.indistinguishable)]
    return Rounds(tuple(out) + tuple(extra), final, final_model, gain(cal, cand))
