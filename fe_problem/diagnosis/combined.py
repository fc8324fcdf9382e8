"""Several distributed classes at once: a pattern no one group or trend describes.

A storey-wise pattern (each storey's columns changed by their own ratio: 0.71, 0.81, 0.91 and
1.47 of nominal) is not one group nor one smooth trend; fitted by one class it is the nearest of
them, "the top storey only", not adequate. Here the distributed classes (groups.py, and the
regions a later round grows, rounds.grown_regions) are combined greedily, as the search combines
local causes: the best one first, then the class that lowers chi^2 most with the ones before it
held, all sizes refitted jointly, while the drop is significant (the search's test: likelihood
ratio, Bonferroni over the classes tried, quasi-likelihood dispersion, alpha). The moduli compose
multiplicatively, E_e = E0_e prod_j (1 + a_j w_j,e), so each class rebuilt on the model extended by
the others is exactly the combined model (its profile interval and held-out gain are those of
one-parameter classes, as for several local causes). Each combination of k classes enters the
evidence table as one class of k parameters (family ``distributed``), its evidence from each
size's curvature with the others held (evidence.py).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares
from scipy.stats import chi2 as chi2_dist

from ..assembly import AffineModel
from ..parameters import Parameter
from .candidates import Candidate, Setting, lazy_system, solve
from .fit import Fit, chi2_batch, profiled
from .residuals import Observations

#: Distributed classes combined at most (the search's MAX_CAUSES).
MAX_CLASSES = 4
#: The modulus of a member may not fall below this fraction of nominal in a combination.
MIN_RATIO = 0.1


@dataclass(frozen=True, eq=False)
class Combination:
    """k distributed classes at their joint sizes: `parts` are (candidate rebuilt on the model
    extended by the others, size), `fit` the joint fit (its `a` the last part's size)."""

    parts: tuple[tuple[Candidate, float], ...]
    fit: Fit

    @property
    def label(self) -> str:
        return " + ".join(c.label for c, _ in self.parts)


#: Each further class is tried with the earlier sizes held at these multiples of theirs (one
#: batched solve with its grid): an earlier class fitted alone took up part of the next one.
HELD = (0.6, 0.8, 1.0, 1.2)


def combinations(st: Setting, obs: Observations, fitted: list[tuple[Candidate, Fit]], alpha: float,
                 others: list[Candidate] = ()) -> list[Combination]:
    """The greedy combinations of distributed classes (candidates with ``meta["weights"]``), from
    the best of `fitted` (each with its own fit), each further class chosen among `fitted` and
    `others` (those never fitted alone: a storey whose change the global scale hides alone):
    every prefix of two or more classes whose last class was significant (see the module
    docstring); the Bonferroni correction counts every class tried."""
    fitted = [(c, f) for c, f in fitted if "weights" in c.meta]
    seen = {c.label for c, _ in fitted}
    pool = [(c, f) for c, f in fitted if f.a > 0] + [(c, None) for c in others
                                                     if "weights" in c.meta and c.label not in seen]
    n_tried = len(seen | {c.label for c, _ in pool})
    if len(pool) < 2 or all(f is None for _, f in pool):
        return []
    model = st.model
    ids = list(model.element_ids)
    e0 = np.array([model.element_modulus_pa(e) for e in ids])
    system = lazy_system(lambda: AffineModel(model, tuple(
        Parameter("modulus", (e,), 1e-3 * v, 1e3 * v, v, name=f"E{e}") for e, v in zip(ids, e0))))
    pool.sort(key=lambda x: (x[1] is None, np.inf if x[1] is None else x[1].chi2, x[0].label))
    weights = {c.label: np.asarray(c.meta["weights"], dtype=float) for c, _ in pool}
    upper = {c.label: c.upper for c, _ in pool}

    def fits_at(labels: list[str], sizes: np.ndarray) -> list[Fit]:
        """Profiled fits of the combination `labels` at sizes (b, k)."""
        factor = np.prod([1.0 + sizes[:, [j]] * weights[lab][None, :] for j, lab in enumerate(labels)], axis=0)
        hz, sh = solve(system(), e0[None, :] * np.maximum(factor, MIN_RATIO), st.coords, st.n_modes)
        return [profiled(obs, hz[i], sh[i]) for i in range(sizes.shape[0])]

    chosen, sizes = [pool[0][0].label], np.array([pool[0][1].a])
    chi2 = pool[0][1].chi2
    out = []
    while len(chosen) < MAX_CLASSES:
        trials = []
        for c, _ in pool:
            if c.label in chosen:
                continue
            grid = c.grid[1:]
            held = np.repeat(np.outer(HELD, sizes), len(grid), axis=0)
            batch = np.column_stack([np.minimum(held, [upper[lab] for lab in chosen]), np.tile(grid, len(HELD))])
            fs = fits_at(chosen + [c.label], batch)
            k = int(np.argmin([x.chi2 for x in fs]))
            trials.append((fs[k].chi2, c.label, batch[k]))
        if not trials:
            break
        _, label, start = min(trials, key=lambda t: (t[0], t[1]))
        labels = chosen + [label]
        hi = np.array([upper[lab] for lab in labels])
        x0 = np.minimum(start, hi)
        res = least_squares(lambda a: fits_at(labels, a[None, :])[0].residuals, x0, bounds=(0.0, hi),
                            diff_step=1e-4, max_nfev=40 * len(labels))
        joint = fits_at(labels, res.x[None, :])[0]
        dispersion = max(1.0, joint.chi2 / obs.dof(1 + len(labels)))
        if chi2 - joint.chi2 < dispersion * chi2_dist.isf(min(1.0, 2.0 * alpha / max(n_tried, 1)), 1):
            break
        chosen, sizes, chi2 = labels, res.x, joint.chi2
        out.append(_combination(st, pool, chosen, sizes, joint))
    return out


def _combination(st: Setting, pool, labels: list[str], sizes: np.ndarray, joint: Fit) -> Combination:
    """Each class of the combination rebuilt on the model extended by the others at their sizes."""
    from .groups import weighted_candidates

    by_label = {c.label: c for c, _ in pool}
    ids = list(st.model.element_ids)
    e0 = np.array([st.model.element_modulus_pa(e) for e in ids])
    parts = []
    for j, lab in enumerate(labels):
        factor = np.prod([1.0 + sizes[k] * np.asarray(by_label[other].meta["weights"], dtype=float)
                          for k, other in enumerate(labels) if k != j], axis=0)
        model = st.model.with_element_moduli(dict(zip(ids, (e0 * np.maximum(factor, MIN_RATIO)).tolist())))
        c = by_label[lab]
        rebuilt = weighted_candidates(Setting(model, st.coords, st.n_modes, st.nominal),
                                      [(c.kind, c.location, c.meta["weights"])])[0]
        parts.append((rebuilt, float(sizes[j])))
    last = parts[-1][1]
    return Combination(tuple(parts), Fit(last, joint.s, joint.chi2, joint.pairing, joint.residuals))
