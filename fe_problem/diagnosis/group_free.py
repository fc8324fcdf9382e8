"""Free group classes: one stiffness per member group, for members that deviate together and unevenly.

Real members deviate together and unevenly (a laboratory four-storey shear frame: storeys about
0.71, 0.81, 0.91 and 1.47 of nominal from the base up; one column line softer, another stiffer;
a column's two lower elements lowered by different amounts). No one-parameter class of groups.py
expresses that: a group class moves one group, a trend cannot make the top storey stiffer while
the lower ones stiffen with height. Each class here frees a set of groups, the members of group k
with the modulus E0 (1 + theta_k):

- ``every_storey_free``: every storey (the storey groups of `groups.classified`);
- ``every_column_line_free``: every column line (the vertical members at one x);
- ``every_floor_free``: every floor's beams (the horizontal members at one y);
- ``adjacent_members_free``: two adjacent members of one chain (collinear members sharing a
  node: a column's consecutive elements), each its own group.

For the first three the groups cover every member of that kind (`groups.classified`: a group of
one member kept, as a set-back top storey's one roof beam); a common change of all of them is
(up to the other members') the global stiffness-to-mass scale s, profiled out in every class, so
the last group (the top storey, the right-most column line, the top floor) is the reference with
no parameter of its own: n - 1 parameters, each a ratio to that group. The members in no group
(the other kind's: the beams of the storey and column-line classes, the columns of the floor
class; a member neither vertical nor horizontal) are held at s with the reference group, and the
estimate names them (``held_members``). They apply with at least
`MIN_GROUPS` groups: with two, the class is one group's change and the scale, which groups.py's
group classes already are. The pair's two members are both free (the rest of the structure is the
reference, at s). A partition's theta_k has the prior [LOW, HIGH] (sparse_class's range, a ratio
0.1 to 4); the pair's each the one-sided range of the local family for the side its fit lies on
(`sparse_class.sided`: a loss in [LOW, 0], a gain in [0, HIGH]), as the sparse class's members. The
estimate gives each group's stiffness relative to the nominal model, s (1 + theta_k) (a
reference group s), with the mass as modelled.

Fitted by bounded nonlinear least squares from the nominal model (`sparse_class.refit`); the
evidence is Laplace's with the Gauss-Newton Hessian and each parameter's Gaussian truncated to
its prior (`sparse_class.log_occam`, one support: no combinatorial charge, as every group class
and every local label), comparable with the other classes (evidence.py). The pair is fitted on
the chains through the elements the other classes point at (the best local stiffness classes,
the sparse class's members: `pair_seeds`), the best of those pairs by chi^2 entering the table.
Only for planar models on the dense solver path (as the sparse class). Under ``--evidence
nested`` a class here among the best `nested.N_NESTED` by Laplace is sampled as the local and
sparse rows are (`integrand`: its chi^2 paired afresh, its uniform prior's box, no support charge).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import sparse_class
from .setting import Setting
from .evidence import ScoredClass, sides_log_prior
from .groups import _direction, classified
from .residuals import Observations

#: The every-storey class's label's kind, and the family of every class here in the evidence table.
KIND, FAMILY = "every_storey_free", "distributed"
#: The classes of a partition of one kind of member: kind -> (group-name prefix, estimate's unit).
PARTITIONS = {KIND: ("storey", "storey"), "every_column_line_free": ("column_line_x", "column_line"),
              "every_floor_free": ("floor_y", "floor")}
#: The two-adjacent-members class's kind.
PAIR_KIND = "adjacent_members_free"
#: Groups a partition must have for its class to apply (see the module docstring).
MIN_GROUPS = MIN_STOREYS = 3
#: Two members are of one chain when their directions are within this of each other (cosine).
CHAIN_COS = 0.999


@dataclass(frozen=True, eq=False)
class GroupFit:
    """A free group class: its kind, its groups (names, the reference last), their members, the fit
    of its parameters (`sparse_class.SparseFit`: theta, std at D = 1, chi^2, s, Jacobian), the
    parameter set it was fitted on (to refit it: held-out error, the extended model) and whether
    the last group is the reference (no parameter of its own)."""

    kind: str
    groups: tuple[str, ...]
    members: tuple[int, ...]
    fit: sparse_class.SparseFit
    params: object
    reference: bool = True

    @property
    def storeys(self) -> tuple[str, ...]:
        """The groups (the name of the every-storey class's)."""
        return self.groups

    @property
    def label(self) -> str:
        if self.kind == PAIR_KIND:
            return f"{PAIR_KIND}@members={'+'.join(str(e) for e in self.members)}"
        return f"{self.kind}@groups={'+'.join(self.groups)}"

    @property
    def location(self) -> dict:
        return {"members": list(self.members)} if self.kind == PAIR_KIND else {"groups": list(self.groups)}

    def estimate(self, dispersion: float = 1.0) -> dict:
        """Each group's stiffness relative to nominal, s (1 + theta_k) (a reference group s), with
        its std at the dispersion D (theta's std times s; the scale's own spread is not included),
        the members, the global scale and the members held at it (in no group); for the pair, as
        the sparse class's, each member's modulus ratio 1 + theta_k to the rest of the structure (at
        the global scale) and its std."""
        s = self.fit.s
        if self.kind == PAIR_KIND:  # as the sparse class's: each member's modulus against the rest's
            return {"members": list(self.members), "modulus_ratio": [float(1.0 + t) for t in self.fit.theta],
                    "modulus_ratio_std": [float(x * np.sqrt(dispersion)) for x in self.fit.theta_std],
                    "global_scale": float(s)}
        ratios = [float(s * (1.0 + t)) for t in self.fit.theta] + ([float(s)] if self.reference else [])
        std = [float(s * x * np.sqrt(dispersion)) for x in self.fit.theta_std] + ([0.0] if self.reference else [])
        unit = PARTITIONS[self.kind][1]
        return {"groups": list(self.groups), "members": list(self.members), f"{unit}_ratio": ratios,
                f"{unit}_ratio_std": std, "global_scale": float(s), "held_members": list(self.held)}

    @property
    def held(self) -> tuple[int, ...]:
        """The members in no group, held at the global scale s (for the pair, every other member)."""
        return tuple(e for e in self.params.ids if e not in self.members)

    def sides(self) -> float:
        """log of the prior weight of the sides the pair's fit picks (`evidence.sides_log_prior`, one
        per member); 0 for the partitions, each group on the whole range [LOW, HIGH]."""
        return sides_log_prior(len(self.fit.theta)) if self.kind == PAIR_KIND else 0.0

    def prior(self) -> tuple:
        """The uniform prior's range of each parameter: [LOW, HIGH] (sparse_class's), or for the
        pair each member's as the local family's and the sparse class's, by the side its fit lies
        on (`sparse_class.sided`)."""
        if self.kind != PAIR_KIND:
            return sparse_class.LOW, sparse_class.HIGH
        return sparse_class.sided(self.fit.theta)

    def scored(self, chi2_base: float, dispersion: float, held_out_error_pct: float | None = None) -> ScoredClass:
        """The class's row of the evidence table (log evidence against the calibrated model)."""
        f = self.fit
        occam = sparse_class.log_occam(f.theta, f.jacobian, len(f.theta), dispersion, *self.prior()) + self.sides()
        return ScoredClass(self.label, FAMILY, len(f.theta), f.chi2, -(f.chi2 - chi2_base) / (2 * dispersion) + occam,
                           self.estimate(dispersion), held_out_error_pct)


#: The every-storey class's fit (the name it had when it was the only class here).
StoreyFit = GroupFit


def partition(st: Setting, kind: str = KIND) -> dict[str, tuple[int, ...]]:
    """The groups of a partition class (`PARTITIONS`) of the model, ordered by height or x (the
    reference last): name -> element ids. From the raw classification (`groups.classified`):
    every member of the kind is in one group, a group of one member (a set-back storey's one roof
    beam) and a group with the same members as a group of another kind included."""
    prefix = PARTITIONS[kind][0]
    found = {k: v for k, v in classified(st.model).items() if k.startswith(prefix)}
    return dict(sorted(found.items(), key=lambda kv: float(kv[0][len(prefix):])))


def storeys(st: Setting) -> dict[str, tuple[int, ...]]:
    """The storey groups of the model, base first: name -> element ids."""
    return partition(st, KIND)


def applicable(st: Setting, kind: str = KIND) -> bool:
    """Planar, the dense solver path (`sparse_class.applicable`) and at least `MIN_GROUPS` groups."""
    return sparse_class.applicable(st) and len(partition(st, kind)) >= MIN_GROUPS


def _fit(st: Setting, obs: Observations, base_pairing: np.ndarray, kind: str, groups: dict, reference: bool
         ) -> GroupFit:
    names = list(groups)
    free = names[:-1] if reference else names
    ids = list(st.model.element_ids)
    weights = np.zeros((len(ids), len(free)))
    for k, name in enumerate(free):
        weights[[ids.index(e) for e in groups[name]], k] = 1.0
    params = sparse_class._AllMembers(st, weights, free)
    f = sparse_class.refit(params, obs, np.arange(len(free)), np.zeros(len(free)), base_pairing)
    return GroupFit(kind, tuple(names), tuple(sorted(e for g in groups.values() for e in g)), f, params, reference)


def fit_storeys(st: Setting, obs: Observations, base_pairing: np.ndarray, kind: str = KIND) -> GroupFit | None:
    """The partition class `kind` (default every storey) fitted to `obs` (None where it does not apply)."""
    if not applicable(st, kind):
        return None
    return _fit(st, obs, base_pairing, kind, partition(st, kind), True)


def fit_partitions(st: Setting, obs: Observations, base_pairing: np.ndarray) -> list[GroupFit]:
    """Every partition class (storeys, column lines, floors) that applies, fitted to `obs`."""
    return [f for f in (fit_storeys(st, obs, base_pairing, kind) for kind in PARTITIONS) if f is not None]


def adjacent_pairs(st: Setting, elements) -> list[tuple[int, int]]:
    """The pairs of members of one chain (collinear, sharing a node) that hold one of `elements`."""
    model = st.model
    ends = {e.id: {e.node_i, e.node_j} for e in model.elements}
    direction = {e.id: _direction(model, e.id)[2] for e in model.elements}
    out = set()
    for a in elements:
        if a not in ends:
            continue
        for b in ends:
            if b != a and ends[a] & ends[b] and abs(float(direction[a] @ direction[b])) >= CHAIN_COS:
                out.add((min(a, b), max(a, b)))
    return sorted(out)


def fit_pair(st: Setting, obs: Observations, base_pairing: np.ndarray, elements) -> GroupFit | None:
    """The best (lowest chi^2) two-adjacent-members class over the chains through `elements`
    (None where the class does not apply or no such pair exists)."""
    if not sparse_class.applicable(st):
        return None
    fits = [_fit(st, obs, base_pairing, PAIR_KIND, {str(a): (a,), str(b): (b,)}, False)
            for a, b in adjacent_pairs(st, elements)]
    return min(fits, key=lambda g: g.fit.chi2) if fits else None


def integrand(st: Setting, obs: Observations, g: GroupFit) -> tuple:
    """The class's integrand for nested sampling (nested.rescored): chi^2 (paired afresh) of its
    parameters theta (k,), the rest as in its fit; its prior's box (`GroupFit.prior`, one range per
    parameter); the log offset of its Laplace value: no support charge, the pair's sides
    (`GroupFit.sides`)."""
    k = len(g.fit.theta)
    lower, upper = (np.broadcast_to(np.asarray(b, float), (k,)).copy() for b in g.prior())
    return sparse_class.chi2_function(st, obs, g.fit, g.params), lower, upper, g.sides()


def held_out_error(st: Setting, data, used: np.ndarray, sf: GroupFit, freq_noise: float,
                   shape_noise: float) -> float | None:
    """Mean |frequency error| (%) on the held-out modes of the class refitted on the others
    (`sparse_class.held_out_error`)."""
    return sparse_class.held_out_error(st, data, used, sf.fit, freq_noise, shape_noise, sf.params)
