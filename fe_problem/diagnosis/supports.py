"""Support conditions as model-form classes: the structure is not held where and as its model says.

A column base modelled fixed that is really pinned, or a support that gives a little, moves the
modes as a crack near the base or a spring would; fitted by those candidates it becomes
confident local physics. These classes are the support alternatives at every support of the
model, in every direction of its layout (x, y, rz on a planar frame; x, y, z, rx, ry, rz on a
space frame), each with one parameter a, scored beside the other model-form classes
(modelform.py).

- ``released`` (a direction the support holds): the DOF held by a spring to ground instead,
  k = k_members (1 - a) / a. a = 0: the support as modelled; a = 1: free in that direction (a
  fixed base that is really pinned about that axis). A translation is released up to
  `MAX_TRANSLATION_RELEASE` (k >= k_members / 999: a support released in every translation would
  leave the structure a rigid body).
- ``held`` (a rotation the support leaves free): a rotational spring to ground,
  k = k_members a / (1 - a); a = 1: the support fixed in it (a pinned base that is really fixed).
- On a space frame also the support's rotations together, one a for all (each with its own
  k_members): a fixed column base that is really pinned turns about both bending axes and twists.

k_members is the members' own stiffness at that DOF: the sum of the diagonal entries of their
element stiffness matrices there (4 E I / L for a beam's end rotation, E A / L along its axis,
12 E I / L^3 across it). The estimate's ``fixity`` is k / (k + k_members), 1 fixed and 0 free
(Monforton and Wu's fixity factor, with k_members for their 3 E I / L), and ``condition`` names
it: ``pinned`` (a rotation) or ``free`` (a translation) when the spring is below
1 / `plausibility.MAX_SPRING_PER_MEMBER` of k_members, ``fixed`` above that many times it (the
rule by which a spring to ground that stiff is called a support), else ``spring``.

Every size is a solve of the support's own system with the springs as parameters (affine, so a
batch of sizes is one batched solve). Each candidate also has a first-order term (local.Term) for
the sparse path's screen from one set of modes: a held rotation's is a spring to ground, a
released direction's the support's dynamic reaction (`reaction_term`). They are ranked for
fitting with a look along their grid as well (modelform.screen_forms).
"""

from __future__ import annotations

import dataclasses
from typing import Iterator

import numpy as np

from ..assembly import AffineModel
from ..model import FrameModel, Spring, Support
from ..parameters import Parameter
from .setting import Candidate, Setting, lazy_system, solve
from .local import Term
from .bounds import MAX_SPRING_PER_MEMBER

#: A support's translation is released down to this a (k >= k_members (1 - a) / a = k_members / 999).
MAX_TRANSLATION_RELEASE = 0.999
#: The sizes tried: k / k_members from 1000 to 1/1000 (the fixity from 0.999 to 0.001), and both ends.
RATIOS = np.geomspace(1e3, 1e-3, 13)


def member_stiffness(model: FrameModel, local, node: int, direction: str) -> float:
    """The members' own stiffness at `node`'s DOF `direction` (N/m or N m/rad): the sum of the
    diagonal entries of their element stiffness matrices there (an end released in that
    rotation adds nothing: its own end rotation is another DOF)."""
    dof = local.dofmap.dof(node, direction, model)
    hit = local.dofmap.element_dofs == dof                      # (n_el, k)
    diag = np.einsum("ekk->ek", local.k_el)                     # per unit modulus
    return float(np.sum(local.modulus[:, None] * diag * hit))


def _member_mass(model: FrameModel, local, node: int, direction: str) -> float:
    """The mass (or rotary inertia) the members and lumped masses give the DOF: a released
    support must not leave a DOF without mass (assembly refuses such a model)."""
    dof = local.dofmap.dof(node, direction, model)
    hit = local.dofmap.element_dofs == dof
    diag = np.einsum("ekk->ek", local.m_el)
    lumped = sum(m.mass_kg if direction in model.layout.translations else m.inertia_kg_m2
                 for m in model.masses if m.node == node)
    return float(np.sum(local.density[:, None] * diag * hit)) + lumped


def reaction_term(model: FrameModel, local, node: int, directions, k_ref: np.ndarray) -> Term:
    """The first-order term of a support released onto springs k = k_ref (1 - a) / a at a = 0.

    A stiff spring of compliance c = 1 / k in place of a support moves each mode by the support's
    dynamic reaction R_i = g^T phi_i, g = (K - lambda_i M)[dof, :] (the node's row of the
    members' matrices): d lambda_i = -c R_i^2 to first order in c (the penalty method's
    asymptotics), and dc / da = 1 / k_ref at a = 0. So D_i = -(1 / k_ref) g g^T, written as
    dk - lambda dm + lambda^2 dm2 (as a joint's, local.py), summed over the directions; the
    constrained DOFs' own entries fall away (screening maps them to a zero row)."""
    dofmap = local.dofmap
    rows = np.unique(np.concatenate([np.flatnonzero((dofmap.element_dofs == dofmap.dof(node, d, model)).any(axis=1))
                                     for d in directions]))
    dofs = np.unique(dofmap.element_dofs[rows])
    where = np.searchsorted(dofs, dofmap.element_dofs[rows])     # (r, k) into `dofs`
    n = len(dofs)
    dk, dm, dm2 = np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, n))
    for d, kr in zip(directions, k_ref):
        g_k, g_m = np.zeros(n), np.zeros(n)
        for j, e in enumerate(rows):  # the support DOF's row of each member's K and M
            r = np.flatnonzero(dofmap.element_dofs[e] == dofmap.dof(node, d, model))
            if len(r):
                np.add.at(g_k, where[j], local.modulus[e] * local.k_el[e][r[0]])
                np.add.at(g_m, where[j], local.density[e] * local.m_el[e][r[0]])
        dk -= np.outer(g_k, g_k) / kr
        dm -= (np.outer(g_m, g_k) + np.outer(g_k, g_m)) / kr
        dm2 -= np.outer(g_m, g_m) / kr
    return Term(dofs, dk, dm, dm2)


def _with_support(model: FrameModel, node: int, directions: tuple[str, ...]) -> FrameModel:
    """`model` with the support at `node` holding `directions` (no support there if none)."""
    others = tuple(s for s in model.supports if s.node != node)
    order = [d for d in model.layout.names if d in directions]
    return model.replace(supports=others + ((Support(node, tuple(order)),) if order else ()))


def _condition(ratio: float, rotation: bool) -> str:
    """pinned / free, spring or fixed, by k / k_members (see the module docstring)."""
    if ratio < 1.0 / MAX_SPRING_PER_MEMBER:
        return "pinned" if rotation else "free"
    return "fixed" if ratio > MAX_SPRING_PER_MEMBER else "spring"


def support_candidates(st: Setting, nodes=None) -> list[Candidate]:
    """The support-condition candidates of every support of `st.model` (only those at `nodes`
    when given)."""
    model, lay = st.model, st.model.layout
    out: list[Candidate] = []
    baseline = lazy_system(lambda: _own(model))  # a = 0 of every support: the model as it is
    for sup in model.supports:
        if nodes is not None and sup.node not in nodes:
            continue
        held = set(sup.directions)

        def usable(d):  # a DOF the members hold and give mass to: freeing it is a valid model
            return (member_stiffness(model, st.local, sup.node, d) > 0.0
                    and _member_mass(model, st.local, sup.node, d) > 0.0)

        fixed = [d for d in lay.names if d in held and usable(d)]
        free = [d for d in lay.rotations if d not in held and usable(d)]
        groups = [((d,), "released") for d in fixed] + [((d,), "held") for d in free]
        # a layout's several rotations together (a space frame's; a planar one has one)
        for dirs, mode in (([d for d in fixed if d in lay.rotations], "released"), (free, "held")):
            if len(dirs) > 1:
                groups.append((tuple(dirs), mode))
        out += [_candidate(st, sup.node, dirs, mode, baseline) for dirs, mode in groups]
    return out


def _own(model: FrameModel, parameters=()) -> AffineModel:
    """A support's own system, solved in this process: it serves a few batches of a few sizes,
    and shipping it to the sparse path's worker pool cost more than it saved (5 sizes of a
    1,092-DOF frame's support: 8.5 s through the pool, 0.6 s here)."""
    system = AffineModel(model, tuple(parameters))
    system.workers = 1
    return system


def _candidate(st: Setting, node: int, directions: tuple[str, ...], mode: str, baseline) -> Candidate:
    """One support candidate: `directions` of the support at `node` released (held by springs
    k = k_members (1 - a) / a) or held (k = k_members a / (1 - a))."""
    model, lay = st.model, st.model.layout
    k_ref = np.array([member_stiffness(model, st.local, node, d) for d in directions])
    rotation = all(d in lay.rotations for d in directions)
    upper = 1.0 if mode == "held" or rotation else MAX_TRANSLATION_RELEASE
    sid = max((sp.id for sp in model.springs), default=0) + 1
    held = next((s.directions for s in model.supports if s.node == node), ())

    def sprung(k: np.ndarray) -> FrameModel:  # the directions free, each on its spring to ground
        base = _with_support(model, node, tuple(d for d in held if d not in directions))
        return base.replace(springs=model.springs + tuple(Spring(sid + j, (node, d), None, float(k[j]))
                                                          for j, d in enumerate(directions)))

    system = lazy_system(lambda: _own(sprung(k_ref), (
        Parameter("spring", (sid + j,), 0.0, 1e6 * k_ref[j], k_ref[j]) for j in range(len(directions)))))
    held_model = _with_support(model, node, tuple(held) + directions)
    end = lazy_system(lambda: _own(held_model))  # a = 1 of a held rotation: fixed in it

    def ratio(a):
        """k / k_members at sizes a (inf where the DOF stays held, 0 where it is free)."""
        a = np.asarray(a, dtype=float)
        with np.errstate(divide="ignore"):
            return (1.0 - a) / a if mode == "released" else a / (1.0 - a)

    def forward(a):
        a = np.clip(np.atleast_1d(np.asarray(a, dtype=float)), 0.0, upper)
        # a held rotation's end (fixed) has one DOF less: every size gives as many modes
        n = min(st.n_modes, baseline().n_elastic - (len(directions) if mode == "held" else 0))
        hz, shapes = np.zeros((len(a), n)), np.zeros((len(a), len(st.coords), n))
        as_modelled = a <= 0.0
        fixed_end = (a >= 1.0) if mode == "held" else np.zeros(len(a), dtype=bool)
        sprung_ = ~(as_modelled | fixed_end)
        if sprung_.any():
            hz[sprung_], shapes[sprung_] = solve(system(), k_ref[None, :] * ratio(a[sprung_])[:, None], st.coords, n)
        for mask, sys in ((as_modelled, baseline), (fixed_end, end)):
            if mask.any():
                h, sh = solve(sys(), np.zeros((1, 0)), st.coords, n)
                hz[mask], shapes[mask] = h[0], sh[0]
        return hz, shapes

    def estimate(a, s):
        r = float(ratio(a))
        unit = "rotational_stiffness_nm_per_rad" if rotation else "stiffness_n_per_m"
        k = {d: float(s * kr * r) for d, kr in zip(directions, k_ref)}
        members = {d: float(s * kr) for d, kr in zip(directions, k_ref)}
        one = len(directions) == 1
        return {"condition": _condition(r, rotation), "fixity": float(r / (1.0 + r)) if np.isfinite(r) else 1.0,
                "stiffness_ratio": r, unit: k[directions[0]] if one else k,
                "member_" + unit: members[directions[0]] if one else members}

    def extend(a):
        a = float(np.clip(a, 0.0, upper))
        if a <= 0.0:
            return model
        if mode == "held" and a >= 1.0:
            return held_model
        if mode == "released" and a >= 1.0:
            return _with_support(model, node, tuple(d for d in held if d not in directions))
        return sprung(k_ref * float(ratio(a)))

    if mode == "held":  # dk/da at a = 0: k_members on each DOF (a spring to ground)
        def term():
            dofs = np.array([st.local.dofmap.dof(node, d, model) for d in directions])
            return Term(dofs, np.diag(k_ref), np.zeros((len(dofs), len(dofs))))
    else:
        def term():
            return reaction_term(model, st.local, node, directions, k_ref)

    grid = 1.0 / (1.0 + RATIOS) if mode == "released" else RATIOS / (1.0 + RATIOS)
    grid = np.unique(np.concatenate([[0.0, upper], grid[grid < upper]]))
    where = "+".join(directions)
    return Candidate("support_condition", {"node": node, "direction": where}, upper, grid, forward, estimate, extend,
                     step=1e-3, meta={"profile": mode}, term=term)
