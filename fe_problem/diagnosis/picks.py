"""The causes a search holds (its picks: `CandidateKey`s, kinds/spec.py) and what both the rounds
(rounds.py) and the joint choice (joint.py) do with them: a pick's candidate rebuilt on a model
extended by the others (`_candidate_on`), the model extended by every pick (`_with`), the joint
refit of their sizes (`_joint_refit`, a crack's position refined too: `_refine_zone`) and a round's
answer (`Step`). Below both, so that neither imports the other inside a function."""

from __future__ import annotations

import contextlib
import contextvars
import dataclasses
from dataclasses import dataclass

from scipy.optimize import minimize_scalar

from ..assembly import AffineModel
from ..model import FrameModel
from . import zones
from .fit import Fit, fit
from .kinds import CandidateKey, iter_candidates
from .kinds.stiffness_loss import zone_candidate, zone_profile
from .setting import Candidate, Setting
from .steps import AMBIGUITY_CHI2, calibrate


@dataclass
class Step:
    """A round's answer: the best candidate's key, its size and adjusted p-value, and the keys it
    ties with (empty when it is the one answer)."""

    pick: CandidateKey
    a: float
    p: float
    ties: tuple[CandidateKey, ...] = ()


#: The first round's candidates of the diagnosis under way in this context (thread or task): the
#: setting they were built in, and key -> candidate for the uniform (not weak zone) ones, filled
#: on the first look-up (15,566 at 3,024 DOFs); None outside `rounds.further_causes` (`_listed`).
_LISTED: contextvars.ContextVar[tuple[Setting, list[Candidate], dict[CandidateKey, Candidate]] | None] = (
    contextvars.ContextVar("femu_diagnosis_listed", default=None))


@contextlib.contextmanager
def _listed(setting: Setting, candidates: list[Candidate]):
    """While the rounds run, `_candidate_on` of a uniform (not a weak zone) key in `setting`
    itself (its model, coordinates, mode count and nominal model: one cause, its size refitted:
    `_joint_refit`, `rounds._finish`) gives the first round's own candidate: the same setting and
    key build the same candidate, and that one keeps its solved sizes and its setting's shared
    basis (built once more per refit before). The listing belongs to this context only (a
    ContextVar), so diagnoses run at once in other threads never see it."""
    token = _LISTED.set((setting, candidates, {}))
    try:
        yield
    finally:
        _LISTED.reset(token)


def _listed_candidate(model: FrameModel, st: Setting, key: CandidateKey) -> Candidate | None:
    """The first round's candidate `key` where the listing's setting is the one `_candidate_on`
    would build (`model`, `st`'s coordinates, mode count and nominal model), else None."""
    listed = _LISTED.get()
    if listed is None or _zone_centre(key) is not None:
        return None
    setting, candidates, by_key = listed
    if not (setting.model is model and setting.coords == st.coords and setting.n_modes == st.n_modes
            and setting.nominal is st.nominal):
        return None
    if not by_key:
        by_key.update((k, c) for k, c in ((c.key, c) for c in candidates) if _zone_centre(k) is None)
    return by_key.get(key)


def _candidate_on(model: FrameModel, st: Setting, key: CandidateKey) -> Candidate:
    """The candidate `key`, rebuilt on `model` (the others' effects included), or the first
    round's where it was built in the same setting (`_listed`); a weak zone at any position (a
    refined one too) from the centre its key's profile gives."""
    listed = _listed_candidate(model, st, key)
    if listed is not None:
        return listed
    setting = Setting(model, st.coords, st.n_modes, st.nominal)
    centre = _zone_centre(key)
    if centre is not None:
        return zone_candidate(setting, key.get("element"), centre, about=_zone_about(key) or "rz")
    return next(c for c in iter_candidates(setting, [key.kind]) if c.key == key)


def _zone_centre(key: CandidateKey) -> float | None:
    """The centre of a weak zone's key (profile 'zone 0.353'), else None."""
    words = key.profile.split()
    return float(words[1]) if len(words) > 1 and words[0] == "zone" else None


def _zone_about(key: CandidateKey) -> str | None:
    """The bending rotation of a space frame's weak zone's key (profile 'zone 0.30 ry'), else None."""
    words = key.profile.split()
    return words[2] if len(words) > 2 and words[0] == "zone" else None


def _answer(key: CandidateKey) -> CandidateKey:
    """The answer a key names (its kind and place): profiles of one element's loss are one answer."""
    return key.place


def _with(base: FrameModel, st: Setting, picks: list[CandidateKey], sizes: list[float], skip: int = -1):
    """`base` extended by every pick at its size, except number `skip`."""
    m = base
    for j, (key, a) in enumerate(zip(picks, sizes)):
        if j != skip:
            m = _candidate_on(m, st, key).extend(a)
    return m


def _final_obs(cal, st: Setting, picks, sizes):
    """The measured modes that pair with the model extended by every cause (a spring to ground
    can bring a measured suspension mode that the nominal model has no partner for)."""
    return calibrate(_with(st.model, st, picks, sizes), cal.data, cal.obs.freq_noise, cal.obs.shape_noise,
                     st.model).obs


def _ambiguity() -> float:
    return AMBIGUITY_CHI2


def _joint_refit(cal, st: Setting, picks, sizes, obs=None) -> tuple[list, list[float], float]:
    """One sweep: each cause's size refitted with the others at their current sizes, on `obs`
    (default: the modes that pair with the extended model), a crack's position along its
    element too (`_refine_zone`); returns the picks (a refined crack's key at its new centre),
    the sizes and the joint chi^2."""
    picks, sizes = list(picks), list(sizes)
    obs = _final_obs(cal, st, picks, sizes) if obs is None else obs
    chi2 = float("inf")
    for j, key in enumerate(picks):
        base = _with(st.model, st, picks, sizes, skip=j)
        if _zone_centre(key) is not None:
            picks[j], f = _refine_zone(obs, st, base, key, sizes[j])
        else:
            f = fit(obs, _candidate_on(base, st, key), sizes[j])
        sizes[j], chi2 = f.a, f.chi2
    return picks, sizes, chi2


#: How far (a fraction of the element) a crack's position is refined from its grid position,
#: the range it may reach (nearer an end a crack acts as the joint there, and the joint
#: candidate is the one that says so; zones.py), and the tolerance of the search.
ZONE_REACH, ZONE_RANGE, ZONE_XTOL = 0.1, (0.15, 0.85), 0.002


def _refine_zone(obs, st: Setting, base: FrameModel, pick: CandidateKey, a: float):
    """A weak zone's centre refined along its element (a bounded scalar search, each trial the
    zone's size fitted at that centre): the grid's seven positions are where a crack is looked
    for; where it is, between them, decides how much misfit a crack leaves for a further
    cause to take. Returns the pick's key at the refined centre, and its fit. On the sparse path
    (a large model: every trial a model assembled afresh) the position stays."""
    element, centre, about = pick.get("element"), _zone_centre(pick), _zone_about(pick)
    setting = Setting(base, st.coords, st.n_modes, st.nominal)
    shared = {"system": AffineModel(base)}  # one solver for every trial position
    fits: dict[float, Fit] = {}

    def chi2_at(c: float) -> float:
        c = round(float(c), 3)
        if c not in fits:
            fits[c] = fit(obs, zone_candidate(setting, element, c, shared, about or "rz"), a)
        return fits[c].chi2

    chi2_at(centre)
    if zones.batched(shared["system"]):
        lo, hi = max(ZONE_RANGE[0], centre - ZONE_REACH), min(ZONE_RANGE[1], centre + ZONE_REACH)
        minimize_scalar(chi2_at, bounds=(lo, hi), method="bounded", options={"xatol": ZONE_XTOL})
    best = min(fits, key=lambda c: fits[c].chi2)
    return dataclasses.replace(pick, profile=zone_profile(best, about)), fits[best]
