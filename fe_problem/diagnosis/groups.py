"""Distributed model classes: a change spread over many members at once.

Real members deviate together: a storey's columns, a column line, a floor's beams, every member
of one section, a stiffness that varies smoothly with height. Each class here is one parameter
``a >= 0`` acting on many element moduli at once, E_e = E0_e (1 + a w_e), with weights w over the
elements:

- a member group losing or gaining stiffness together (w = -1 or +1 on its members, 0 elsewhere):
  ``storey`` (the vertical members between two consecutive levels where horizontal members
  are), ``column_line`` (the vertical members at one x), ``floor`` (the horizontal members at
  one y), ``section`` (every member of one section); groups of one element (the local candidates
  are those) and of every element (the global scale is that) are left out;
- a trend along the height (y) or the span (x): w = +-t (linear) or +-(t^2 - mean) (quadratic) of
  the element midpoint's position t scaled to [-1, 1], centred so that the trend is not a change
  of the global scale.

The candidates are built on one affine system with every element's modulus a parameter, so a
class's sizes are solved in full in one batched eigen-solve (`Candidate.forward`). On the shared
reduced basis (reduced.py) a group's or a trend's frequencies were off by up to 9.6e-2 relative
and its chi^2 by up to 3.6e4 (tests/test_reduced_basis.py's frame), so none has a reduced
forward (`Candidate.reduced`). Each has a basis of its own change instead (`Candidate.reduced_screen`,
`SharedBasis.spread`), whose error is small where the classes are ranked and grows with a (a
trend's frequencies off by 0.1 at its largest size). Their ranking (which `core.N_DISTRIBUTED_FIT`
classes are fitted) runs on it, the best solved in full to confirm it (`fit.class_promises`);
the fit of each class kept searches on it too (`fit._search_forward`: grid and scalar search),
and `fit._reduced_fit`'s batch of at most six full solves confirms the search or the grid is
solved in full. That confirmation measures the basis's error at the points it solves only, not
over the grid: the answer (a, s, chi^2) is the full model's at its a, and tests compare it with
the fit solved in full (tests/test_reduced_basis.py, a storey at 0.2 of its modulus among them).
They are scored beside
the local classes by their evidence (evidence.py); they do not enter the likelihood-ratio search
for local causes.
"""

from __future__ import annotations

from collections import defaultdict

import numpy as np

from ..assembly import AffineModel
from ..model import FrameModel
from ..parameters import Parameter
from .setting import Candidate, Setting, lazy_system, solve

#: A member counts as vertical / horizontal when its direction is within this of the axis (cosine).
AXIS_COS = 0.999
#: The largest modulus change of any member a class may reach (the weights are scaled to it).
MAX_CHANGE = 0.9


def _direction(model: FrameModel, element_id: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    e = model.element(element_id)
    a, b = model.node(e.node_i), model.node(e.node_j)
    pa, pb = np.array([a.x, a.y], float), np.array([b.x, b.y], float)
    d = pb - pa
    return pa, pb, d / np.linalg.norm(d)


def classified(model: FrameModel) -> dict[str, tuple[int, ...]]:
    """Every member by the raw classification of the topology: name -> element ids, for
    ``storey<k>`` and ``column_line_x<x>`` (the vertical members), ``floor_y<y>`` (the horizontal
    members) and ``section_<name>`` (every member), each group kept however small and whatever
    other group has its members (`member_groups` leaves those out; group_free.partition does not:
    a set-back top storey's one roof beam is that floor's group). A member neither vertical nor
    horizontal is in a section's group only."""
    vertical, horizontal = [], []
    info = {}
    for e in model.elements:
        pa, pb, d = _direction(model, e.id)
        info[e.id] = (pa, pb)
        if abs(d[1]) >= AXIS_COS:
            vertical.append(e.id)
        elif abs(d[0]) >= AXIS_COS:
            horizontal.append(e.id)
    groups: dict[str, list[int]] = defaultdict(list)
    # the levels: the lowest node and every height where horizontal members are; storey k lies
    # between the (k-1)th and the kth level
    levels = sorted({round(float(info[e][0][1]), 6) for e in horizontal} | {min(n.y for n in model.nodes)})
    for e in vertical:
        mid = 0.5 * (info[e][0][1] + info[e][1][1])
        groups[f"storey{sum(lv < mid for lv in levels)}"].append(e)
        groups[f"column_line_x{round(float(info[e][0][0]), 4):g}"].append(e)
    for e in horizontal:
        groups[f"floor_y{round(float(info[e][0][1]), 4):g}"].append(e)
    for e in model.elements:
        groups[f"section_{e.section}"].append(e.id)
    return {name: tuple(sorted(ids)) for name, ids in groups.items()}


def member_groups(model: FrameModel) -> dict[str, tuple[int, ...]]:
    """The member groups the topology offers as one-parameter classes: `classified`'s groups less
    those of one element (a local candidate) or of every element (the global scale) and less a
    group whose members an earlier group has (see the module docstring)."""
    n = len(model.elements)
    out, seen = {}, set()
    for name, key in classified(model).items():
        if 2 <= len(key) < n and key not in seen:  # one element: a local candidate; all: the global scale
            seen.add(key)
            out[name] = key
    return out


def trends(model: FrameModel) -> dict[str, np.ndarray]:
    """Smooth weights over the elements: name -> w (n_elements,), max |w| = 1, zero mean."""
    mids = np.array([0.5 * (a + b) for a, b, _ in (_direction(model, e.id) for e in model.elements)])
    out = {}
    for axis, name in ((1, "height"), (0, "span")):
        t = mids[:, axis]
        if np.ptp(t) <= 1e-9 * max(1.0, np.abs(t).max()):
            continue
        t = 2.0 * (t - t.min()) / np.ptp(t) - 1.0
        for shape, w in (("linear", t), ("quadratic", t * t)):
            w = w - w.mean()
            if np.abs(w).max() <= 1e-12:
                continue
            w = w / np.abs(w).max()
            out[f"{shape}_{name}+"] = w
            out[f"{shape}_{name}-"] = -w
    return out


def distributed_candidates(st: Setting, kinds=None) -> list[Candidate]:
    """Every group (loss and gain) and trend class as a one-parameter candidate (planar models:
    the groups are read from x and y); `kinds`: those of these kinds only (each kind's generator,
    kinds/group_stiffness.py, kinds/stiffness_trend.py: the diagnosis builds them through the
    registry, `kinds.class_candidates`). Every class of one setting shares one system with every
    element's modulus a parameter (`Setting.memo`)."""
    model = st.model
    if not model.layout.planar:
        return []
    ids = list(model.element_ids)
    e0 = np.array([model.element_modulus_pa(e) for e in ids])
    system = st.memo.get(_SYSTEM)
    if system is None:
        system = st.memo[_SYSTEM] = lazy_system(lambda: AffineModel(model, tuple(
            Parameter("modulus", (e,), 1e-3 * v, 1e3 * v, v, name=f"E{e}") for e, v in zip(ids, e0))))
    weights: list[tuple[str, dict, np.ndarray]] = []
    for name, members in member_groups(model).items():
        mask = np.isin(ids, members).astype(float)
        weights.append(("group_stiffness_loss", {"group": name}, -mask))
        weights.append(("group_stiffness_gain", {"group": name}, mask))
    for name, w in trends(model).items():
        weights.append(("stiffness_trend", {"trend": name}, w))
    return [_candidate(st, system, ids, e0, kind, where, w) for kind, where, w in weights
            if kinds is None or kind in kinds]


#: `Setting.memo`'s entry of the distributed classes' shared system (every element's modulus).
_SYSTEM = "groups.moduli_system"


def _candidate(st, system, ids, e0, kind, where, w) -> Candidate:
    upper = MAX_CHANGE / float(np.abs(w[w < 0]).max()) if (w < 0).any() else 3.0

    def forward(a):
        a = np.asarray(a, dtype=float)
        return solve(system(), e0[None, :] * (1.0 + a[:, None] * w[None, :]), st.coords, st.n_modes)

    def moduli(a):
        return {e: float(v) for e, v in zip(ids, e0 * (1.0 + a * w)) if w[ids.index(e)] != 0}

    def estimate(a, s):
        ratios = 1.0 + a * w
        out = {"size": a, "members": [e for e, x in zip(ids, w) if x != 0],
               "modulus_ratio_min": float(ratios.min()), "modulus_ratio_max": float(ratios.max())}
        if kind != "stiffness_trend":
            out["modulus_ratio"] = float(1.0 + a * (1.0 if kind.endswith("gain") else -1.0))
        return out

    def reduced_screen():
        basis = st.basis
        if basis is None:
            return None
        s = system()._solver
        return basis.spread(s.matrix(s.gk @ (e0 * w)))

    grid = upper * np.concatenate([[0.0], np.geomspace(2e-3, 1.0, 15)])
    return Candidate(kind, where, upper, grid, forward, estimate, lambda a: st.model.with_element_moduli(moduli(a)),
                     step=0.01 * upper, reduced_screen=reduced_screen)
