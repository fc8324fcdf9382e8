"""``stiffness_loss`` at an element: its modulus times (1 - a), a in [0, 0.9]; or a weak zone about a
section depth wide at one of seven positions along it, its bending stiffness times (1 - a), a in
[0, 0.99] (a crack; zones.py); on a space frame in each bending plane (local ry, rz), each its own
candidate. One side of the stiffness class (the other: stiffness_gain.py)."""

from __future__ import annotations

from typing import Iterator

import numpy as np

from ...assembly import AffineModel
from ...elements import formulation
from ...parameters import Parameter
from .. import zones
from ..bounds import MAX_UNIFORM_LOSS, MAX_ZONE_LOSS
from ..setting import Candidate, Setting, _Once, lazy_system, reduced_linear, shared_grid, solve
from .spec import CandidateKey, KindSpec

LOSS_GRID = shared_grid([0.0, 0.005, 0.01, 0.02, 0.04, 0.07, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9])


def stiffness_loss(st: Setting) -> Iterator[Candidate]:
    """A loss of modulus in one element, spread uniformly over it, or concentrated in a weak
    zone about a section depth wide at one of seven positions along it (a crack; zones.py);
    the place is the element either way."""
    shared: dict = {}
    abouts = zones.bending_rotations(st.model)
    for e in st.model.elements:
        e0 = st.model.element_modulus_pa(e.id)
        system = lazy_system(lambda e=e, e0=e0: AffineModel(
            st.model, (Parameter("modulus", (e.id,), 1e-3 * e0, e0, e0),), like=st.system))

        def forward(a, system=system, e0=e0):
            return solve(system(), (e0 * (1.0 - np.asarray(a)))[:, None], st.coords, st.n_modes)

        def estimate(a, s, e0=e0):
            return {"stiffness_loss_pct": 100.0 * a, "modulus_ratio": 1.0 - a, "profile": "uniform",
                    "modulus_pa": s * e0 * (1.0 - a)}

        key = CandidateKey.of("stiffness_loss", {"element": e.id})
        yield Candidate("stiffness_loss", {"element": e.id}, 0.9, LOSS_GRID, forward, estimate,
                        lambda a, e=e, e0=e0: st.model.with_element_moduli({e.id: e0 * (1.0 - a)}),
                        step=0.01, meta={"profile": "uniform"},
                        term=lambda key=key: term(st, key),
                        reduced=reduced_linear(st, lambda key=key: term(st, key)))
        # a weak zone is built by the beam's flexibility formulation (zones.py), in each bending plane
        if (not formulation(e.formulation, st.model.layout).supports_weak_zone
                or e.crack_position is not None or e.weak_zone is not None):
            continue
        for about in abouts:
            yield from _zone_candidates(st, e, e0, shared, about=about)


def zone_candidate(st: Setting, element_id: int, centre: float, shared: dict | None = None,
                   about: str = "rz") -> Candidate:
    """The weak-zone loss of one element centred at `centre` (a fraction of its length),
    bending about `about`, at any position, not only the grid's: the crack's position is
    refined once the element is chosen. `shared`: the solver cache of zones.zone_forwards, to
    share among positions."""
    e = st.model.element(element_id)
    place = zones.zone_place(st.model, element_id, centre, about)
    return next(_zone_candidates(st, e, st.model.element_modulus_pa(element_id), {} if shared is None else shared,
                                 [place], about))


def zone_profile(centre: float, about: str | None = None) -> str:
    """The profile of a zone candidate's label: 'zone 0.30' on the grid, 'zone 0.353' refined;
    a space frame's names its bending rotation too: 'zone 0.30 ry'."""
    at = f"zone {centre:.2f}" if abs(centre - round(centre, 2)) < 1e-9 else f"zone {centre:.3f}"
    return at if about is None else f"{at} {about}"


def _zone_candidates(st: Setting, e, e0: float, shared: dict, places=None, about: str = "rz") -> Iterator[Candidate]:
    """The weak-zone losses of element e (see zones.py) bending about `about`, at the grid's
    places or at `places`; a: the zone's loss of bending stiffness. Each forward is
    `zones.zone_forwards`' for its place, made when it is first called (most zones are only
    screened: making every zone's forward, each with the element's nominal stiffness, was a
    sixth of building the candidates)."""
    space = formulation(e.formulation, st.model.layout).zone_planes  # a zone per bending plane, named
    for start, end in zones.zone_places(st.model, e.id, about) if places is None else places:
        centre = round(0.5 * (start + end), 6)

        made = _Once(lambda start=start, end=end: next(zones.zone_forwards(
            st.model, e.id, st.coords, st.n_modes, shared, [(start, end)], about))[2])

        def forward(a, made=made):
            return made()(a)

        def estimate(a, s, start=start, end=end, centre=centre):
            ei = s * e0 * st.model.sections[e.section].inertia_about(about)
            width = (end - start) * st.model.element_length_m(e.id)
            out = {"stiffness_loss_pct": 100.0 * a, "modulus_ratio": 1.0 - a, "profile": "zone",
                   "zone_position": centre, "zone_start": start, "zone_end": end,
                   "modulus_pa": s * e0 * (1.0 - a),
                   "equivalent_crack_stiffness_nm_per_rad": ei * (1.0 - a) / (a * width) if a > 0 else float("inf")}
            return {**out, "zone_about": about} if space else out

        def extend(a, start=start, end=end):
            return zones.with_zone(st.model, e.id, start, end, 1.0 - a, about)

        def reduced(start=start, end=end):
            if st.basis is None:
                return None
            row, dofmap = st.local.row[e.id], st.local.dofmap
            nominal = zones.zone_stiffness(st.model, e.id, 0.0, 1.0, np.ones(1), about)[0]

            def change(a):
                dk = zones.zone_stiffness(st.model, e.id, start, end, 1.0 - np.clip(a, 0.0, zones.UPPER), about)
                return dofmap.element_block(row, dk - nominal)[1], None
            return st.basis.local(dofmap.block_dofs(row), change)

        yield Candidate("stiffness_loss", {"element": e.id}, zones.UPPER, zones.GRID, forward, estimate, extend,
                        step=0.01, meta={"profile": zone_profile(centre, about if space else None)},
                        term=lambda start=start, end=end: st.local.zone(e.id, start, end, about),
                        reduced=reduced)


def term(st: Setting, key: CandidateKey):
    """dK/da of the key's uniform loss: minus its element's stiffness at its nominal modulus
    (`LocalMatrices.stiffness`). A weak zone's key gives no term here: its ends along the element
    are the generator's (zones.zone_places), which the key's centre, rounded in its profile, does
    not give back to the last bit; its candidates carry `LocalMatrices.zone` of their own ends."""
    if key.profile != "uniform":
        return None
    e = key.get("element")
    return st.local.stiffness(e, -st.model.element_modulus_pa(e), "uniform")


def variants(st: Setting, cand: Candidate) -> int:
    """A weak zone's row: the centres `zones.zone_places` builds, in every bending plane; a uniform
    loss's: its two sides (a loss or a gain)."""
    if (cand.meta or {}).get("profile", "").startswith("zone"):
        model, element = st.model, cand.location["element"]
        return sum(len(zones.zone_places(model, element, about)) for about in zones.bending_rotations(model))
    return 2


def check(model, loc: dict, estimate: dict) -> str | None:
    """A whole member losing more than `MAX_UNIFORM_LOSS`, a weak zone more than `MAX_ZONE_LOSS`."""
    if "modulus_ratio" not in estimate:
        return None
    loss = 1.0 - estimate["modulus_ratio"]
    zone = estimate.get("profile") == "zone"
    bound = MAX_ZONE_LOSS if zone else MAX_UNIFORM_LOSS
    if loss > bound:
        what = "a weak zone" if zone else "a whole member"
        return f"{what} losing {100 * loss:.3g} % of its stiffness (beyond {100 * bound:.0f} %)"
    return None


SPEC = KindSpec("stiffness_loss", "local", ("element",), stiffness_loss, default=True, sides="stiffness", side=-1,
                variants=variants, check=check, term=term,
                doc="a member's modulus times (1 - a), uniform or in a weak zone (a crack)")
