"""``joint_flexibility`` at a node where members meet: one element end released and tied to the
node by a rotational spring k = (E I / L)_element / a (a: the joint's compliance relative to the
element's own bending compliance); on a space frame about each bending axis and in torsion
(k = (G J / L)_element / a), the member's local axes, skew or not (a skew axis' release is a
relative rotation, terms.py).

Joints are found from the model's topology (`joint_nodes`): every node where three or more
element ends meet, or two that are not in line (a corner), so any frame has its joints.
"""

from __future__ import annotations

import collections
from typing import Iterator

import numpy as np
from scipy.linalg import orth

from ...assembly import AffineModel
from ...model import FrameModel, release_element_end
from ...model.edits import bending_hinges
from ...parameters import Parameter
from ..reduced import reduced_joint
from ..setting import Candidate, Setting, lazy_system, shared_grid, solve, solve_model
from .spec import KindSpec

JOINT_GRID = shared_grid(np.concatenate([[0.0], np.geomspace(1e-3, 50.0, 18)]))


def _bending_compliance_ref(model: FrameModel, element_id: int, rotation: str = "rz") -> float:
    """The element's own end stiffness about its local axis `rotation`, N m/rad: E I / L for
    bending (ry, rz), G J / L for torsion (rx; G scales with the element's modulus, the
    material's G / E fixed as the space element takes it): the scale of a joint spring at its end."""
    e = model.element(element_id)
    modulus = model.element_modulus_pa(element_id)
    if rotation == "rx":
        mat = model.materials[e.material]
        modulus *= mat.shear_modulus / mat.youngs_modulus_pa
    return modulus * model.sections[e.section].inertia_about(rotation) / model.element_length_m(element_id)


def joint_nodes(model: FrameModel) -> tuple[int, ...]:
    """Nodes where members join: three or more element ends, or two ends not in line (cosine
    of the angle between the members, seen from the node, above -0.999: a corner)."""
    ends: dict[int, list[np.ndarray]] = {}
    at, pos = model.coordinates, model._node_pos
    for e in model.elements:
        for a, b in ((e.node_i, e.node_j), (e.node_j, e.node_i)):
            d = at[pos[b]] - at[pos[a]]
            ends.setdefault(a, []).append(d / np.linalg.norm(d))
    return tuple(n for n, ds in ends.items()
                 if len(ds) > 2 or (len(ds) == 2 and float(ds[0] @ ds[1]) > -0.999))


def _rotation_axis(model: FrameModel, e, local: str):
    """The rotation an end of element `e` turns in when released in its rotation `local`: the
    planar frame's rotation name; on a space frame the local axis as a global unit vector (3,)
    (along a global axis or skew: a brace's, an inclined rafter's)."""
    if model.layout.planar:
        return local
    return np.asarray(model.local_axes(e.id)[("rx", "ry", "rz").index(local)], dtype=float)


def _frees(axes: list, axis) -> bool:
    """Whether rotations about `axes` (names, or global unit vectors) let a rotation about `axis`
    (the same form) happen: the name among them; the vector in their span."""
    if isinstance(axis, str):
        return axis in axes
    if not axes:
        return False
    a = np.array(axes, dtype=float)
    coef = np.linalg.lstsq(a.T, axis, rcond=None)[0]
    return float(np.linalg.norm(a.T @ coef - axis)) <= 1e-9


def _released(model: FrameModel, e, node: int, axis) -> bool:
    """Whether the end of element `e` at `node` is released about `axis` (`_rotation_axis`'s
    form): its released rotations free that rotation."""
    releases = model.end_releases(e)[0 if node == e.node_i else 1]
    return _frees([_rotation_axis(model, e, r) for r in releases], axis)


def _last_rigid_end(model: FrameModel, node: int, axis, element=None) -> bool:
    """Whether releasing the end of `element` at `node` about `axis` (`_rotation_axis`'s form)
    would leave a rotation of the node that no element end, support or rotary inertia holds
    (the others released by joints already found): a rotation with no mass, an invalid model;
    at a corner, releasing either end is one and the same joint. Planar: one element end at most
    is still rigidly tied to the node's rotation. Space: the rotations every end leaves free
    (each the span of its released axes, `element`'s with `axis`) meet in more than zero."""
    if any(m.node == node and m.inertia_kg_m2 > 0 for m in model.masses):
        return False
    ends = model.elements_at(node)
    if isinstance(axis, str):
        rigid = sum(1 for e in ends if not _released(model, e, node, axis))
        return rigid <= 1 and not any(s.node == node and axis in s.directions for s in model.supports)
    held = np.zeros((3, 3))
    for e in ends:
        free = [_rotation_axis(model, e, r) for r in model.end_releases(e)[0 if node == e.node_i else 1]]
        free += [axis] if e is element else []
        q = orth(np.array(free).T) if free else np.zeros((3, 0))
        held += np.eye(3) - q @ q.T  # the rotations this end ties to the node
    for s in model.supports:
        if s.node == node:
            held += sum((np.outer(u, u) for d, u in zip(("rx", "ry", "rz"), np.eye(3)) if d in s.directions),
                        np.zeros((3, 3)))
    return float(np.linalg.eigvalsh(held).min()) <= 1e-9


def joint_flexibility(st: Setting) -> Iterator[Candidate]:
    """A rotational spring between an element end and its joint node, at every element end of
    every joint, in each rotation the end may turn in apart from the node: the planar frame's
    rz; a space frame's two bending planes (local ry, rz) and its torsion (local rx, a member
    twisting in a connection that does not hold it: a spring of G J / L / a), each its own
    candidate, about the member's local axis whether it lies along a global axis or not (an
    inclined rafter's, a brace's: the release is the end's rotation relative to the node about
    that axis, terms.py). At a corner (two ends) one candidate per axis: releasing either end
    about the same axis is the same model (the first end's; the second's only about an axis
    along none of the first's, as at a gable's ridge)."""
    planar = st.model.layout.planar
    bending = bending_hinges(st.model)
    rotations = bending + tuple(r for r in st.model.layout.hinges if r not in bending)
    for node in joint_nodes(st.model):
        ends = st.model.elements_at(node)
        first = [_rotation_axis(st.model, ends[0], r) for r in rotations]
        for e, local in ((e, r) for e in ends for r in rotations):
            axis = _rotation_axis(st.model, e, local)  # a skew member's: a relative rotation (terms.py)
            if len(ends) == 2 and e is not ends[0] and any(_frees([a], axis) for a in first):
                continue  # at a corner, the first end's joint about the same axis
            if _released(st.model, e, node, axis) or _last_rigid_end(st.model, node, axis, e):
                continue
            ref = _bending_compliance_ref(st.model, e.id, local)
            system = lazy_system(lambda e=e, node=node, ref=ref, local=local: AffineModel(
                release_element_end(st.model, e.id, node, ref, None if planar else (local,)),
                (Parameter("release", (e.id, node), 0.0, 1e12 * ref, ref),)))

            def extend(a, e=e, node=node, ref=ref, local=local):
                return (release_element_end(st.model, e.id, node, ref / a, None if planar else (local,)) if a > 0
                        else st.model)

            # an end released in other rotations already (a joint found before): a `release`
            # parameter would vary those too (terms.py), so each size is its own model
            alone = not any(st.model.end_releases(e)[0 if node == e.node_i else 1])

            def forward(a, system=system, ref=ref, extend=extend, alone=alone):
                a = np.asarray(a, dtype=float)
                if not alone:
                    out = [solve_model(extend(v), st) for v in a]
                    return np.concatenate([o[0] for o in out]), np.concatenate([o[1] for o in out])
                hz, shapes = solve(system(), (ref / np.maximum(a, 1e-12))[:, None], st.coords, st.n_modes)
                rigid = a <= 0.0
                if rigid.any():  # a = 0 is the rigid joint: the unextended model itself
                    hz0, sh0 = st.modes0
                    hz[rigid], shapes[rigid] = hz0[0], sh0[0]
                return hz, shapes

            def estimate(a, s, ref=ref):
                k = s * ref / a if a > 0 else float("inf")
                return {"rotational_stiffness_nm_per_rad": k, "compliance_ratio": a}

            place = {"node": node, "element": e.id} if planar else {"node": node, "element": e.id, "rotation": local}
            yield Candidate("joint_flexibility", place, 50.0,
                            JOINT_GRID, forward, estimate, extend, step=0.01,
                            term=lambda e=e, node=node, ref=ref, axis=axis: st.local.joint(e.id, node, ref, axis),
                            reduced=reduced_joint(st, e.id, node, ref, axis) if alone else None)


def joint_rotations(st: Setting) -> dict:
    """How many joint-flexibility candidates `joint_flexibility` builds at each (node, element) of
    `st`: on a space frame up to its 3 hinges, fewer at an end already released about one, at a
    corner's second end or at the last rigid end (the variants a joint row is charged for).
    Counted once per setting (`Setting.memo`)."""
    if "joint_rotations" not in st.memo:
        st.memo["joint_rotations"] = dict(collections.Counter(
            (c.location["node"], c.location["element"]) for c in joint_flexibility(st)))
    return st.memo["joint_rotations"]


def variants(st: Setting, cand: Candidate) -> int:
    """A space frame joint's row: the rotations its candidates are built about at that end (up to
    3); a planar joint's: 1."""
    loc = cand.location or {}
    if "rotation" not in loc:
        return 1
    return max(1, joint_rotations(st).get((loc["node"], loc["element"]), 0))


SPEC = KindSpec("joint_flexibility", "local", ("node", "element", "rotation"), joint_flexibility, default=True,
                variants=variants, term="joint",
                doc="an element end tied to its joint by a rotational spring (planar: no rotation key)")
