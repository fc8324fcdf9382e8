"""Fitting candidates to observations: the global scale profiled out, screening by first-order
sensitivities, then a proper one-parameter nonlinear fit.

chi^2 of a model = ||r||^2 of `Observations.residuals` with the global stiffness-to-mass
scale s at its best value: s multiplies every eigenvalue, so for the frequency residuals
the best sqrt(s) = sum(q) / sum(q^2) with q_i = f_model_i / f_meas_i, in closed form.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from . import dropped
from .setting import Candidate
from .residuals import Observations


@dataclass(frozen=True)
class Fit:
    """The best effect size `a`, the global scale `s`, chi^2 and the pairing at that point."""

    a: float
    s: float
    chi2: float
    pairing: np.ndarray
    residuals: np.ndarray


def profiled(obs: Observations, hz: np.ndarray, shapes: np.ndarray, pairing: np.ndarray | None = None) -> Fit:
    """chi^2 of one model (frequencies (k,), shapes (n_coord, k)) with s at its best value.

    Pairs afresh (unless `pairing` is given), finds s, and pairs once more with the scaled
    frequencies so that frequency-only modes pair with the calibrated model."""
    return profiled_batch(obs, hz[None], shapes[None], pairing)[0]


def _scale(obs: Observations, hz: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """The best global scale s of each model (frequencies (b, k), pairing (b, m)): (b,). A row
    whose paired modes are all finite takes its sums in one reduction over the batch, the same
    bits as the row alone; a row with a failed solve's mode (no scale from it) or an unpaired
    mode sums its own paired modes."""
    b = hz.shape[0]
    f_pair = hz[np.arange(b)[:, None], np.maximum(idx, 0)]
    ok = (idx >= 0) & np.isfinite(f_pair)
    if ok.all():  # the usual case: every row at once
        q = f_pair / obs.frequencies_hz
        return np.array([float((n / d) ** 2) for n, d in zip(q.sum(axis=1), (q * q).sum(axis=1))])
    s = np.ones(b)
    full = ok.all(axis=1)
    if full.any():
        q = f_pair[full] / obs.frequencies_hz
        num, den = q.sum(axis=1), (q * q).sum(axis=1)
        s[full] = [float((n / d) ** 2) for n, d in zip(num, den)]
    for i in np.flatnonzero(~full & ok.any(axis=1)):
        q = hz[i, idx[i, ok[i]]] / obs.frequencies_hz[ok[i]]
        s[i] = float((q.sum() / (q * q).sum()) ** 2)
    return s


def profiled_batch(obs: Observations, hz: np.ndarray, shapes: np.ndarray,
                   pairing: np.ndarray | None = None) -> list[Fit]:
    """`profiled` of each model of a batch (frequencies (b, k), shapes (b, n_coord, k)), the same
    bits as one at a time: the MACs computed once per model (they do not change with the scale)
    and the pairings of the whole batch at once; the residuals in one batch per distinct pairing."""
    b = hz.shape[0]
    if b == 0:  # an empty batch (no sizes asked): no fits, as one at a time gives
        return []
    if pairing is None:
        mm = obs.mac_batch(shapes)
        idx = obs.pair_batch(hz, mm)
        s = _scale(obs, hz, idx)
        new = obs.pair_batch(hz * np.sqrt(s)[:, None], mm)
        again = np.flatnonzero((new != idx).any(axis=1))
        if again.size:
            idx[again] = new[again]
            s[again] = _scale(obs, hz[again], idx[again])
            new = obs.pair_batch(hz[again] * np.sqrt(s[again])[:, None], mm[again] if mm is not None else None)
            idx[again] = new
    else:
        idx = np.broadcast_to(np.asarray(pairing), (b, len(pairing)))
        s = _scale(obs, hz, idx)
    scaled = hz * np.sqrt(s)[:, None]
    out: list[Fit | None] = [None] * b
    groups = [np.arange(b)] if pairing is not None or (idx == idx[0]).all() else _same_rows(idx)
    for rows in groups:
        sub = slice(None) if len(groups) == 1 else rows  # the whole batch: no copy
        r = obs.residuals_paired(scaled[sub], shapes[sub], idx[rows[0]])
        for i, ri in zip(rows, r):
            out[i] = Fit(0.0, float(s[i]), float(ri @ ri), idx[i] if pairing is None else pairing, ri)
    return out


def _same_rows(idx: np.ndarray) -> list[np.ndarray]:
    """Row indices of `idx` grouped by equal rows (in order of first appearance)."""
    _, first, inverse = np.unique(idx, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.reshape(-1)
    return [np.flatnonzero(inverse == g) for g in np.argsort(first, kind="stable")]


def profiled_paired(obs: Observations, hz: np.ndarray, shapes: np.ndarray, pairing: np.ndarray) -> np.ndarray:
    """`profiled` with the pairing held, for a batch of models at once (frequencies (b, k), shapes
    (b, n_coord, k)): the residuals (b, n_residuals) at each model's best scale."""
    ok = pairing >= 0
    if ok.any():
        q = hz[:, pairing[ok]] / obs.frequencies_hz[ok]
        s = (q.sum(axis=1) / (q * q).sum(axis=1)) ** 2
    else:
        s = np.ones(len(hz))
    return obs.residuals_paired(hz * np.sqrt(s)[:, None], shapes, pairing)


def chi2_batch(obs: Observations, cand: Candidate, a: np.ndarray, pairing=None, forward=None) -> list[Fit]:
    """Profiled fits for a batch of effect sizes, one batched eigen-solve (of the candidate's
    own system, or `forward`: its reduced form, `reduced_forward`)."""
    a = np.asarray(a, dtype=float)
    try:
        hz, shapes = (cand.forward if forward is None else forward)(a)
    except Exception as exc:  # noqa: BLE001 - a reduced form's numerical failure: the full solve instead
        if forward is None or not dropped.is_numerical(exc):
            raise
        hz, shapes = cand.forward(a)
    return [Fit(float(ai), f.s, f.chi2, f.pairing, f.residuals)
            for ai, f in zip(a, profiled_batch(obs, hz, shapes, pairing))]


def screen(obs: Observations, cand: Candidate, base: Fit) -> tuple[float, float]:
    """First-order screening: the chi^2 drop a linearised model promises, and its a.

    The sensitivity of the (profiled) residuals to a is taken from one small step, with the
    baseline pairing held fixed; the effect is one-sided (a >= 0)."""
    return _linear_drop(cand, base, chi2_batch(obs, cand, np.array([cand.step]), pairing=base.pairing)[0])


def _linear_drop(cand: Candidate, base: Fit, step: Fit) -> tuple[float, float]:
    """`screen`'s drop and a from the fit at the candidate's step."""
    j = (step.residuals - base.residuals) / cand.step
    jj = float(j @ j)
    if jj <= 0.0:
        return 0.0, 0.0
    a = min(max(-float(base.residuals @ j) / jj, 0.0), cand.upper)
    drop = base.chi2 - float(np.sum((base.residuals + a * j) ** 2))
    return max(drop, 0.0), a


def look_along(obs: Observations, cand: Candidate, base: Fit) -> tuple[float, float]:
    """The best chi^2 drop, and its a, at every third size of the candidate's own grid (one
    batched solve, the baseline pairing held as in `screen`: pairing afresh at every size
    doubled a diagnosis's time). A first-order screen misjudges an effect far from linear in
    its size: a crack through 3/4 of a building column (a zone losing 95 % of its bending
    stiffness, chi^2 88 where the best candidate fitted reached 923) was not fitted. With a
    reduced forward the sizes are searched on the shared basis under the confirmation of
    `_confirmed_grid`, else solved in full; the promise is always a full solve's."""
    sizes = cand.grid[1::3]
    confirmed = _confirmed_grid(obs, cand, sizes, pairing=base.pairing)
    if confirmed is None:
        best = min(chi2_batch(obs, cand, sizes, pairing=base.pairing), key=lambda f: f.chi2)
    else:
        k, full, _ = confirmed
        best = full[k]
    return max(base.chi2 - best.chi2, 0.0), best.a


def brings(obs: Observations, cand: Candidate, modes: np.ndarray) -> bool:
    """Whether the candidate, at some size of its grid (one batched solve, pairing afresh at
    every size), pairs one of the measured `modes` (indices into `obs`) that the model it
    extends leaves unpaired: a mode only such a candidate can bring (a spring to ground's
    suspension mode) is invisible to a screen that holds the pairing, and a mode no candidate
    can bring (a noise shape) is no reason to fit them all (rounds._next_cause).

    Solved on the candidate's reduced forward where it has one (the sparse path's shared basis:
    frequencies within 1e-6 of full solves over every grid, reduced.py); a full solve of the grid
    costs there more than the candidate's fit, whose search runs on that basis too."""
    fits = chi2_batch(obs, cand, cand.grid, forward=reduced_forward(cand))
    return any(bool((f.pairing[modes] >= 0).any()) for f in fits)


def promise(obs: Observations, cand: Candidate, base: Fit) -> tuple[float, float]:
    """The larger of `screen` and `look_along` (chi^2 drop, a): how much a class promises."""
    return max(screen(obs, cand, base), look_along(obs, cand, base), key=lambda x: x[0])


#: The distributed classes solved in full to confirm their ranking (`class_promises`): this many
#: times the classes kept.
CHECK_FACTOR = 2


def class_promises(obs: Observations, cands: list[Candidate], base: Fit, n_keep: int) -> list[tuple[float, float]]:
    """Each candidate's `promise`, for choosing the `n_keep` most promising: where every candidate
    has a reduced screen (`Candidate.reduced_screen`, the diagnosis's shared basis), all are
    ranked on it (the step and the look along's sizes in one batched Rayleigh-Ritz solve each)
    and the `CHECK_FACTOR * n_keep` best are solved in full. The ranking is confirmed when the
    `n_keep`-th best full promise exceeds every unchecked reduced one by `GRID_MARGIN` times the
    largest difference between reduced and full seen plus `GRID_SLACK` (as `_confirmed_grid`);
    then the checked entries are the full promises and the others the reduced ones (below the
    kept ones: they only rank). Else, and without a reduced screen, every promise is solved in
    full. The `n_keep` best are so the same classes, in the same order and with the same values,
    as from full solves of all (unless the rule's margin misjudges; a rule checked at the
    points solved, not a bound). A reduced promise that is not finite also sends every class to
    full solves."""
    if len(cands) <= CHECK_FACTOR * n_keep or any(c.reduced_screen is None for c in cands):
        return [promise(obs, c, base) for c in cands]
    approx = []
    for c in cands:
        forward = c.reduced_screen()  # one at a time: each holds its basis (n_free x 70-odd)
        if forward is None:
            return [promise(obs, c, base) for c in cands]
        sizes = np.concatenate([[c.step], c.grid[1::3]])
        fits = chi2_batch(obs, c, sizes, pairing=base.pairing, forward=forward)
        best = min(fits[1:], key=lambda f: f.chi2)
        approx.append(max(_linear_drop(c, base, fits[0]), (max(base.chi2 - best.chi2, 0.0), best.a),
                          key=lambda x: x[0]))
    if not np.all(np.isfinite(approx)):
        return [promise(obs, c, base) for c in cands]
    order = sorted(range(len(cands)), key=lambda i: -approx[i][0])
    checked, rest = order[:CHECK_FACTOR * n_keep], order[CHECK_FACTOR * n_keep:]
    full = {i: promise(obs, cands[i], base) for i in checked}
    error = max(abs(full[i][0] - approx[i][0]) for i in checked)
    kept = sorted((p[0] for p in full.values()), reverse=True)[n_keep - 1]
    if max(approx[i][0] for i in rest) + GRID_MARGIN * error + GRID_SLACK >= kept:
        return [full[i] if i in full else promise(obs, c, base) for i, c in enumerate(cands)]
    return [full.get(i, approx[i]) for i in range(len(cands))]


def reduced_forward(cand: Candidate):
    """The candidate's reduced forward on the diagnosis's shared basis (reduced.py), or None
    where it has none."""
    return None if cand.reduced is None else cand.reduced()


#: A reduced grid is trusted only where its best point beats every point outside its bracket
#: by this many times the largest difference from the full solves seen at the points checked
#: (plus `GRID_SLACK` in chi^2). A rule of thumb, not a bound: the difference is measured at
#: those points only (`_confirmed_grid`).
GRID_MARGIN, GRID_SLACK = 10.0, 1e-6


def _confirmed_grid(obs: Observations, cand: Candidate, grid: np.ndarray, pairing=None):
    """The reduced grid's best index, the full fits of the points checked (index -> Fit) and
    the reduced forward, if the full solves confirm the reduced grid's choice; None if the
    candidate has no reduced forward or they do not (then the caller solves the grid in full).

    Checked in full, in one batch: the best point and its two neighbours (the bracket), the
    best point outside the bracket and the best local minimum outside it (the reduced grid's
    runner-up, where a minimum it misjudged would show). Confirmed when the best point is the
    lowest of them in full and every point outside the bracket lies above it by `GRID_MARGIN`
    times the largest difference seen plus `GRID_SLACK`. Used for local changes (`look_along`),
    whose reduced forward holds frequencies within 1e-6 of full solves over every grid
    (reduced.py). `_reduced_fit` applies the same rule to a distributed class's spread basis,
    whose error is known and grows with a (a trend's frequencies off by 0.1 at its largest
    size): there the rule rests on the error measured at the points it solves, not on a bound
    over the grid."""
    reduced = reduced_forward(cand)
    if reduced is None:
        return None
    approx = np.array([f.chi2 for f in chi2_batch(obs, cand, grid, pairing=pairing, forward=reduced)])
    k = int(np.argmin(approx))
    near = list(range(max(k - 1, 0), min(k + 2, len(grid))))
    outside = np.setdiff1d(np.arange(len(grid)), near)
    check = list(near)
    if outside.size:
        padded = np.concatenate([[np.inf], approx, [np.inf]])
        minima = outside[(approx[outside] <= padded[outside]) & (approx[outside] <= padded[outside + 2])]
        for group in (outside, minima):
            if group.size:
                check.append(int(group[np.argmin(approx[group])]))
    check = sorted(set(check))
    full = dict(zip(check, chi2_batch(obs, cand, grid[check], pairing=pairing)))
    error = max(abs(full[i].chi2 - approx[i]) for i in check)
    if full[k].chi2 <= min(f.chi2 for f in full.values()) and \
            (outside.size == 0 or approx[outside].min() > full[k].chi2 + GRID_MARGIN * error + GRID_SLACK):
        return k, full, reduced
    return None


def _bracket(grid: np.ndarray, k: int) -> tuple[float, float, float]:
    """The bracket around grid point `k` (its neighbours, lo and hi) and the scalar search's
    xatol in it (1e-4 of hi, in the units of a)."""
    lo, hi = grid[max(k - 1, 0)], grid[min(k + 1, len(grid) - 1)]
    return float(lo), float(hi), 1e-4 * max(float(hi), 1e-9)


def _refined(obs: Observations, cand: Candidate, grid: np.ndarray, k: int, forward=None) -> tuple[float, Fit | None]:
    """The bounded scalar search in the bracket around grid point `k` (`forward`: the reduced
    forward, or None: the candidate's own system) and its fit (None where the bracket is one
    point): its answer is one of the search's fits, not solved again."""
    lo, hi, xatol = _bracket(grid, k)
    if hi <= lo:
        return float(grid[k]), None
    tried: dict[float, Fit] = {}

    def chi2_at(v: float) -> float:
        v = float(v)
        if v not in tried:
            tried[v] = chi2_batch(obs, cand, np.array([v]), forward=forward)[0]
        return tried[v].chi2

    res = minimize_scalar(chi2_at, bounds=(lo, hi), method="bounded", options={"xatol": xatol})
    chi2_at(res.x)
    return float(res.x), tried[float(res.x)]


def _reduced_fit(obs: Observations, cand: Candidate, grid: np.ndarray, reduced) -> Fit | None:
    """`fit` on a reduced forward (`_search_forward`: the shared basis, or a distributed class's
    spread basis), confirmed by one batch of full solves (at most six), or None where they do
    not confirm it (then `fit` solves the grid in full). The grid and the scalar search run on
    the reduced forward; the answer x is the search's, or the grid's best point grid[k] where
    that is lower on the basis. None at once where x lies within xatol of a bracket end that is
    not the grid's end (the minimum may lie beyond it). Else solved in full, in one batch: x,
    grid[k], x -+ 2 xatol (inside the grid), the best grid point outside the bracket and the best
    local minimum outside it (where a minimum the reduced grid misjudged would show).
    Confirmed when, in full, x is at most grid[k] and x -+ 2 xatol (by `GRID_SLACK`: x is a
    local minimum of the full chi^2 at the search's resolution, which a reduced form biased in a
    would fail) and at most the points outside the bracket, and every grid point outside the
    bracket lies above it, on the basis, by `GRID_MARGIN` times the largest reduced-to-full
    difference seen at the points solved plus `GRID_SLACK` (the rule of `_confirmed_grid`).
    Returns the answer's fit, the full model's."""
    approx = np.array([f.chi2 for f in chi2_batch(obs, cand, grid, forward=reduced)])
    k = int(np.argmin(approx))
    x, at_x = _refined(obs, cand, grid, k, reduced)
    lo, hi, xatol = _bracket(grid, k)
    if at_x is None or at_x.chi2 > approx[k]:
        x, seen_x = float(grid[k]), approx[k]
    else:
        seen_x = at_x.chi2
        if (lo > grid[0] and x - lo <= xatol) or (hi < grid[-1] and hi - x <= xatol):
            return None
    near = list(range(max(k - 1, 0), min(k + 2, len(grid))))
    outside = np.setdiff1d(np.arange(len(grid)), near)
    local = [v for v in (grid[k], x - 2 * xatol, x + 2 * xatol) if v != x and grid[0] <= v <= grid[-1]]
    points = [x] + local
    if outside.size:
        padded = np.concatenate([[np.inf], approx, [np.inf]])
        minima = outside[(approx[outside] <= padded[outside]) & (approx[outside] <= padded[outside + 2])]
        far = sorted({int(g[np.argmin(approx[g])]) for g in (outside, minima) if g.size})
    else:
        far = []
    full = chi2_batch(obs, cand, np.array(points + [grid[i] for i in far], dtype=float))
    best, nearby, others = full[0], full[1:1 + len(local)], full[1 + len(local):]
    seen = [(best, seen_x)] + [(f, approx[i]) for f, i in zip(others, far)]
    if grid[k] != x:
        seen.append((nearby[0], approx[k]))
    error = max(abs(f.chi2 - v) for f, v in seen)
    if all(f.chi2 >= best.chi2 - GRID_SLACK for f in nearby) and all(f.chi2 >= best.chi2 for f in others) and \
            (outside.size == 0 or approx[outside].min() > best.chi2 + GRID_MARGIN * error + GRID_SLACK):
        return best
    return None


def _search_forward(cand: Candidate):
    """The reduced forward `fit` searches on: the candidate's own (`reduced_forward`: a local
    change on the shared basis), else its reduced screen (a group's or a trend's change on its
    spread basis, `SharedBasis.spread`), else None. The spread basis holds the paired modes'
    frequencies within 2.1e-5 relative where the classes are ranked and worse as a grows (a
    trend's off by 0.1 at its largest size); `_reduced_fit`'s full solves confirm the search,
    its margin measured at the points they solve only, or send it to full solves of the grid,
    so a class's fit is still the full model's at its a."""
    reduced = reduced_forward(cand)
    if reduced is None and cand.reduced_screen is not None:
        reduced = cand.reduced_screen()
    return reduced


def fit(obs: Observations, cand: Candidate, a_hint: float | None = None) -> Fit:
    """The best a in [0, upper]: a batched grid (plus the screening hint), then a bounded scalar
    refinement in the bracket around the best grid point. Where the candidate has a reduced
    forward (`_search_forward`: its own, or a distributed class's spread basis), grid and
    refinement run on it and one batch of full solves confirms them (`_reduced_fit`), else (or
    where they do not confirm it) both are solved with the candidate's own system: the Fit
    returned (a, s, chi^2, residuals) is always the full model's."""
    grid = np.unique(np.concatenate([cand.grid, [] if a_hint is None else [a_hint]]))
    reduced = _search_forward(cand)
    if reduced is not None:
        confirmed = _reduced_fit(obs, cand, grid, reduced)
        if confirmed is not None:
            return confirmed
    fits = chi2_batch(obs, cand, grid)
    k = int(np.argmin([f.chi2 for f in fits]))
    _, refined = _refined(obs, cand, grid, k)
    return refined if refined is not None and refined.chi2 < fits[k].chi2 else fits[k]
