"""``boundary_stiffness`` at a node and direction (each translation of the layout): a spring to
ground of stiffness a * k_ref, k_ref = total mass * (2 pi f_1)^2 of the nominal model (a soft
support, a suspension, a base that is not rigid)."""

from __future__ import annotations

from typing import Iterator

import numpy as np

from ...assembly import AffineModel
from ...model import Spring
from ...parameters import Parameter
from ..bounds import MAX_SPRING_PER_MEMBER, axial_stiffness_n_per_m
from ..setting import Candidate, Setting, lazy_system, reduced_linear, shared_grid, solve
from .spec import CandidateKey, KindSpec

BOUNDARY_GRID = shared_grid(np.concatenate([[0.0], np.geomspace(1e-4, 100.0, 16)]))


def _reference_stiffness(st: Setting) -> float:
    """total mass * (2 pi f_1)^2 (N/m) of the user's model: a spring this stiff moves the first mode
    by about its size. Solved once per setting (`Setting.memo`)."""
    if _K_REF not in st.memo:
        f1 = float(solve(st.system if st.reference is None else AffineModel(st.nominal), np.zeros((1, 0)),
                         st.coords, 1)[0][0, 0])
        st.memo[_K_REF] = st.nominal.total_mass_kg() * (2.0 * np.pi * f1) ** 2
    return st.memo[_K_REF]


#: `Setting.memo`'s entry of the reference stiffness.
_K_REF = "boundary_stiffness.k_ref"


def term(st: Setting, key: CandidateKey):
    """dK/da of the key's spring to ground: k_ref in its node's direction (`LocalMatrices.ground_spring`)."""
    return st.local.ground_spring(key.get("node"), key.get("direction"), _reference_stiffness(st))


def boundary_stiffness(st: Setting) -> Iterator[Candidate]:
    """A spring to ground at a node, in each translation (the planar frame's x and y; a space
    frame's x, y and z): soft supports, suspensions, bases."""
    k_ref = _reference_stiffness(st)
    baseline = lazy_system(lambda: st.system)
    sid = max((sp.id for sp in st.model.springs), default=0) + 1
    fixed = {(sup.node, d) for sup in st.model.supports for d in sup.directions}
    for node in st.model.node_ids:
        for direction in st.model.layout.translations:
            if (node, direction) in fixed:
                continue
            # the zero-frequency modes are counted with the spring in place (initial k_ref): a
            # suspension mode is a mode of the extended model, not a rigid-body one to drop
            system = lazy_system(lambda node=node, direction=direction: AffineModel(
                st.model.replace(springs=st.model.springs + (Spring(sid, (node, direction), None, 0.0),)),
                (Parameter("spring", (sid,), 0.0, 1e3 * k_ref, k_ref),)))

            def forward(a, system=system):
                system = system()
                a = np.asarray(a, dtype=float)
                hz, shapes = solve(system, (k_ref * np.maximum(a, 1e-12))[:, None], st.coords, st.n_modes)
                # the modes the spring adds (the lowest while it is soft) come last, so that every
                # mode of the model keeps its index as the spring grows from zero (the first-order
                # screen holds the pairing by index)
                new = system.n_elastic - baseline().n_elastic
                hz, shapes = np.roll(hz, -new, axis=1), np.roll(shapes, -new, axis=2)
                if (a <= 0.0).any():  # no spring: the unextended model itself
                    hz0, sh0 = st.modes0
                    hz[a <= 0.0], shapes[a <= 0.0] = hz0[0], sh0[0]
                return hz, shapes

            def estimate(a, s):
                return {"stiffness_n_per_m": s * k_ref * a, "stiffness_ratio": a}

            def extend(a, node=node, direction=direction):
                return st.model.replace(springs=st.model.springs + (Spring(sid, (node, direction), None, k_ref * a),))

            key = CandidateKey.of("boundary_stiffness", {"node": node, "direction": direction})
            yield Candidate("boundary_stiffness", {"node": node, "direction": direction}, 100.0,
                            BOUNDARY_GRID, forward, estimate, extend,
                            step=1e-3, term=lambda key=key: term(st, key),
                            reduced=reduced_linear(st, lambda key=key: term(st, key)))


def variants(st: Setting, cand: Candidate) -> int:
    """Its row's directions: the node's translations no support holds."""
    model, node = st.model, cand.location["node"]
    held = {d for s in model.supports if s.node == node for d in s.directions}
    return max(1, sum(d not in held for d in model.layout.translations))


def check(model, loc: dict, estimate: dict) -> str | None:
    """A spring stiffer than `MAX_SPRING_PER_MEMBER` times the stiffest member at the node (E A / L)."""
    if "stiffness_n_per_m" not in estimate or loc.get("node") not in model.node_ids:
        return None
    members = [axial_stiffness_n_per_m(model, e.id) for e in model.elements if loc["node"] in (e.node_i, e.node_j)]
    k, k_member = estimate["stiffness_n_per_m"], max(members, default=0.0)
    if k_member > 0 and k > MAX_SPRING_PER_MEMBER * k_member:
        return (f"a spring to ground of {k:.4g} N/m is {k / k_member:.3g} times the stiffest member at node "
                f"{loc['node']} (E A / L {k_member:.4g} N/m): the node is held, a support, not a spring")
    return None


SPEC = KindSpec("boundary_stiffness", "local", ("node", "direction"), boundary_stiffness, default=True,
                variants=variants, check=check, term=term, doc="a spring to ground at a node")
