"""A further cause chosen by its joint fit with the causes already found (rounds.py).

A round screens and fits its candidates against the model extended by the causes found so
far, each at its size. When two effects interact, the first cause fitted alone has taken part
of the second's effect (a roof mass of a symmetric space frame, fitted while a column's loss
was unexplained, is off in size), and held there it leaves a misfit that another candidate of
its own kind mends better than the second effect's candidate does: the second effect ranks far
down, often not fitted at all. So the round's candidates are screened once more with the
earlier causes' sizes free:

- the Jacobian J of the residuals with respect to each earlier cause's size, by a central
  difference at its size (pairing held), and Q an orthonormal basis of its columns;
- for the `N_SCREEN` candidates the round screened best, each one's residual change j per unit
  size, from one exact step as the screen takes it (`fit.screen`), the pairing held;
- the linearised joint fit of the candidate with the earlier sizes free: the residuals and j
  projected off J (r' = r - Q Q^T r, j' likewise), a = -r'.j' / j'.j' in [0, upper], the
  promised drop |r'|^2 - |r' + a j'|^2.

The `N_JOINT` candidates of best promise and the best of every kind (one per answer), and the
round's own choice, are then
refitted exactly with every earlier cause (`rounds._joint_refit`, `SWEEPS` sweeps), and the round's
choice is replaced by the lowest joint chi^2 only when that is lower than the round's own choice
refitted jointly by more than the ambiguity margin (chi^2 6 at the dispersion): where the round's
choice is the answer, it stays exactly as it was.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import chi2 as chi2_dist

from .fit import chi2_batch
from .picks import Step, _ambiguity, _answer, _candidate_on, _joint_refit, _with

#: Candidates of best joint promise refitted exactly with the earlier causes (one per answer),
#: besides the best of every kind.
N_JOINT = 4
#: Candidates judged by their linearised joint fit: the round's best screened (with the earlier
#: causes held), three times the candidates a round fits.
N_SCREEN = 36
#: Sweeps of each joint refit (two correlated sizes, a mass and a loss that each took part of
#: the other's effect, move toward their joint optimum a part of the way each sweep).
SWEEPS = 3
#: Further sweeps at most of the trials near the best (within twice the ambiguity margin), until
#: none drops by more than `SETTLED` (chi^2 at the dispersion) in a sweep.
MORE_SWEEPS, SETTLED = 8, 0.5
#: The size step of the earlier causes' Jacobian, relative to the size (the candidate's own
#: screening step where that is larger).
REL_STEP = 0.02


def choose(cal, st, picks, sizes, skip: int, cal_k, found_k, step, obs=None):
    """The round's `step` (rounds.Step), or the candidate of `found_k` whose joint refit with the
    earlier causes (`picks` at `sizes`, all but number `skip`) fits `obs` (default the round's
    modes) better than `step`'s by more than the ambiguity margin (see the module docstring)."""
    others = [(p, a) for j, (p, a) in enumerate(zip(picks, sizes)) if j != skip]
    if not others:
        return step
    obs = cal_k.obs if obs is None else obs
    base = cal_k.base
    jac = []
    for j, (key, a) in enumerate(zip(picks, sizes)):
        if j == skip:
            continue
        cand = _candidate_on(_with(st.model, st, picks, sizes, skip=j), st, key)
        h = REL_STEP * max(a, cand.step)
        at = np.array([a + h, max(a - h, 0.0)])
        f = chi2_batch(obs, cand, at, pairing=base.pairing)
        jac.append((f[0].residuals - f[1].residuals) / (at[0] - at[1]))
    promise = _joint_screen(cal_k, found_k, np.linalg.qr(np.column_stack(jac))[0])
    chosen, seen, kinds = [], {_answer(step.pick)}, set()
    for i in np.argsort(-promise[:, 0], kind="stable"):
        if promise[i, 0] <= 0.0:
            break
        c = found_k.candidates[i]
        # the best promises, and the best of every kind: candidates of one kind at many places
        # (a joint's flexibility at every column end) can fill the best few on their own
        if _answer(c.key) not in seen and (len(chosen) < N_JOINT or c.kind not in kinds):
            seen.add(_answer(c.key))
            kinds.add(c.kind)
            chosen.append(int(i))
    if not chosen:
        return step
    starts = [(step.pick, step.a)] + [(found_k.candidates[i].key,
                                       found_k.fitted[i].a if i in found_k.fitted else float(promise[i, 1]))
                                      for i in chosen]
    return _refit_starts(cal, st, picks, skip, others, starts, step, obs)


def choose_bringing(cal, st, picks, sizes, skip: int, found_k, step, obs):
    """`choose` for a round in which a measured mode of `obs` pairs only once a cause brings it (a
    spring to ground's suspension mode; every candidate that pairs it fitted, `found_k`): the linearised screen
    of `choose` holds the pairing and cannot see a mode come to pair, so the `N_JOINT` best fitted
    effects by their fit with the earlier causes held are the ones refitted jointly. A spring held
    beside another at the size it took alone takes part of the other's effect: held, a spring at
    the wrong column fitted best. Candidates whose held fits are equal (`EQUAL`: springs along
    an axially rigid member act as one) are one effect: one of them is refitted, and all are
    named when it ties."""
    others = [(p, a) for j, (p, a) in enumerate(zip(picks, sizes)) if j != skip]
    if not others:
        return step
    groups: list[list[int]] = []
    for i in sorted(found_k.fitted, key=lambda i: found_k.fitted[i].chi2):
        chi2 = found_k.fitted[i].chi2
        same = next((g for g in groups if abs(found_k.fitted[g[0]].chi2 - chi2) <= EQUAL * max(1.0, chi2)), None)
        if same is not None:
            same.append(i)
        elif len(groups) < N_JOINT + 1:
            groups.append([i])
    key_of = {i: found_k.candidates[i].key for g in groups for i in g}
    own = next((g for g in groups if any(key_of[i] == step.pick for i in g)), [])
    starts = [(step.pick, step.a)] + [(key_of[g[0]], found_k.fitted[g[0]].a)
                                      for g in groups if g is not own][:N_JOINT]
    chosen = _refit_starts(cal, st, picks, skip, others, starts, step, obs)
    if chosen is step:
        return step
    # every member of a tied effect's group is named with it
    names = chosen.ties or (chosen.pick,)
    tied = tuple(dict.fromkeys(key_of[i] for key in names for g in groups if any(key_of[k] == key for k in g)
                               for i in g)) or names
    return Step(chosen.pick, chosen.a, chosen.p, () if len({_answer(k) for k in tied}) == 1 else tied)


#: Held fits that differ by less than this fraction of chi^2 are one effect (`choose_bringing`).
EQUAL = 1e-4


def _refit_starts(cal, st, picks, skip: int, others, starts, step, obs):
    """The round's `step` or the start (key, size) of `starts` (the step's first) whose
    joint refit with `others` fits `obs` better by more than the ambiguity margin (see the module
    docstring)."""
    trials = []
    for pick, a in starts:
        t_picks, t_sizes = [p for p, _ in others] + [pick], [x for _, x in others] + [a]
        for _ in range(SWEEPS):  # the candidate's size moves the others', and back
            t_picks, t_sizes, chi2 = _joint_refit(cal, st, t_picks, t_sizes, obs)
        trials.append([chi2, t_picks, t_sizes])
    # the trials near the best swept on until each settles: which of them ties with the best is
    # judged at their joint optima, not part of the way there
    dof = obs.dof(1 + len(picks) + (skip < 0))
    for _ in range(MORE_SWEEPS):
        best = min(t[0] for t in trials)
        near = [t for t in trials if (t[0] - best) / max(1.0, best / dof) < 2.0 * _ambiguity()]
        moved = False
        for t in near:
            t_picks, t_sizes, chi2 = _joint_refit(cal, st, t[1], t[2], obs)
            moved |= t[0] - chi2 > SETTLED * max(1.0, best / dof)
            t[:] = [min(chi2, t[0]), t_picks, t_sizes] if chi2 < t[0] else t
        if not moved:
            break
    trials = [(chi2, t_picks[-1], t_sizes[-1]) for chi2, t_picks, t_sizes in trials]
    held = trials[0][0]
    best = min(trials, key=lambda t: t[0])
    dispersion = max(1.0, best[0] / obs.dof(1 + len(picks) + (skip < 0)))
    if (held - best[0]) / dispersion < _ambiguity():
        return step
    tied = tuple(key for chi2, key, _ in trials if (chi2 - best[0]) / dispersion < _ambiguity())
    return Step(best[1], best[2], step.p, () if len({_answer(k) for k in tied}) == 1 else tied)


def _joint_screen(cal_k, found_k, q: np.ndarray) -> np.ndarray:
    """(promised drop, a) rows (c, 2) of the `N_SCREEN` candidates the round screened best, each
    by its linearised fit with the earlier causes' sizes free (residuals and its change projected
    off the orthonormal columns `q` of the earlier causes' Jacobian); 0 for the others. A
    candidate's change is one exact step of its own size (`fit.screen`'s): a first-order change
    of modes is no guide where modes are close (a symmetric frame's sway pairs), which any small
    step turns into each other."""
    obs, base = cal_k.obs, cal_k.base
    out = np.zeros((len(found_k.candidates), 2))
    r0 = base.residuals
    rp = r0 - q @ (q.T @ r0)
    rr = float(rp @ rp)
    for i in [i for i in found_k.order if found_k.candidates[i].location is not None][:N_SCREEN]:
        c = found_k.candidates[i]
        j = (chi2_batch(obs, c, np.array([c.step]), pairing=base.pairing)[0].residuals - r0) / c.step
        jp = j - q @ (q.T @ j)
        jj = float(jp @ jp)
        if jj <= 0.0:
            continue
        a = min(max(-float(jp @ rp) / jj, 0.0), c.upper)
        out[i] = max(rr - float(np.sum((rp + a * jp) ** 2)), 0.0), a
    return out


#: First-round answers the search of further causes starts from: the best, and the best of
#: another place (`starts`).
N_STARTS = 2
#: The joint choice and the second start are used on models whose layout is not planar
#: (`DofLayout.planar`). Space frames only for now: there the close sway and torsion modes of a symmetric frame make two effects interact
#: (a roof mass and a column loss), and the greedy rounds missed the second. On planar models
#: the rounds stay greedy, as they were when the planar confusion tables were measured: the
#: joint choice made an H-frame two-effect diagnosis 2.8x slower (23.6 -> 66.7 CPU-s) and the
#: planar tables have not been re-run with it.


def applies(st) -> bool:
    """Whether the joint choice and the second start are used on `st`'s model (not planar)."""
    return not st.model.layout.planar


def starts(found, sel, st) -> list[int]:
    """The first-round candidates (indices into `found`) a search of further causes starts from:
    the best, then the best fitted ones of other places (one per answer), `N_STARTS` in all. Two
    effects that interact (a roof mass and a column's loss of a symmetric space frame) can make
    the best single candidate one that mimics both (the mass spread over a roof beam), from
    which no later round reaches the pair; the runner-up (the mass at the beam's end) does."""
    out, seen = [sel.best], {_answer(found.candidates[sel.best].key)}
    for i in sorted(found.fitted, key=lambda i: found.fitted[i].chi2):
        if len(out) >= (N_STARTS if applies(st) else 1):
            break
        if _answer(found.candidates[i].key) not in seen:
            seen.add(_answer(found.candidates[i].key))
            out.append(i)
    return out


def better(cal, st, states, alpha: float, n_candidates: int):
    """The best of the searches' final states (picks, sizes, p-values, ties): the lowest joint
    chi^2 on the measured modes that pair with the nominal model, each cause charged the chi^2
    drop the selection demands of one (the test's threshold at the dispersion of the best fit),
    so that a cause more buys no preference; the first state on a tie."""
    if len(states) == 1:
        return states[0]
    scored = []
    for state in states:
        chi2 = _joint_refit(cal, st, state[0], state[1], cal.obs)[2]
        scored.append((chi2, len(state[0])))
    dispersion = max(1.0, min(c / cal.obs.dof(1 + n) for c, n in scored))
    cost = dispersion * chi2_dist.isf(min(1.0, 2.0 * alpha / n_candidates), 1)
    penalised = [c + cost * n for c, n in scored]
    return states[int(np.argmin(penalised))]
