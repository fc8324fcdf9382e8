"""``distributed_mass`` along an element: the element's density times (1 + a) (mass spread over it;
the estimate gives the added mass in kg)."""

from __future__ import annotations

import dataclasses
from typing import Iterator

import numpy as np

from ...assembly import AffineModel
from ...parameters import Parameter
from ..bounds import MASS_OF_TOTAL, MASS_PER_TRIBUTARY, element_mass_kg
from ..setting import Candidate, Setting, lazy_system, reduced_linear, solve
from .spec import CandidateKey, KindSpec

_DISTRIBUTED_STEPS = np.geomspace(1e-3, 1.0, 14)   # distributed mass / the element's upper


def distributed_mass(st: Setting) -> Iterator[Candidate]:
    """Mass spread evenly along an element: its density times (1 + a)."""
    total = st.model.total_mass_kg()
    for e in st.model.elements:
        rho0 = st.model.materials[e.material].density_kg_m3
        m_e = rho0 * st.model.sections[e.section].area_m2 * st.model.element_length_m(e.id)
        upper = max(0.5 * total / m_e, 0.1)
        system = lazy_system(lambda e=e, rho0=rho0, upper=upper: AffineModel(
            st.model, (Parameter("density", (e.id,), 0.0, rho0 * (1 + upper), rho0),), like=st.system))

        def forward(a, system=system, rho0=rho0):
            return solve(system(), (rho0 * (1.0 + np.asarray(a)))[:, None], st.coords, st.n_modes)

        def estimate(a, s, m_e=m_e, e=e):
            return {"mass_kg": a * m_e, "mass_per_length_kg_m": a * m_e / st.model.element_length_m(e.id),
                    "mass_ratio": a}

        def extend(a, e=e, rho0=rho0):
            name = f"{e.material}+mass@{e.id}"
            material = dataclasses.replace(st.model.materials[e.material], density_kg_m3=rho0 * (1.0 + a))
            return st.model.replace(materials={**st.model.materials, name: material},
                                    elements=tuple(dataclasses.replace(x, material=name) if x.id == e.id else x
                                                   for x in st.model.elements))

        key = CandidateKey.of("distributed_mass", {"element": e.id})
        yield Candidate("distributed_mass", {"element": e.id}, upper,
                        np.concatenate([[0.0], upper * _DISTRIBUTED_STEPS]), forward, estimate, extend,
                        step=0.01 * upper, term=lambda key=key: term(st, key),
                        reduced=reduced_linear(st, lambda key=key: term(st, key)))


def term(st: Setting, key: CandidateKey):
    """dM/da of the key's element: its mass at its nominal density (`LocalMatrices.density_change`)."""
    e = st.model.element(key.get("element"))
    return st.local.density_change(e.id, st.model.materials[e.material].density_kg_m3)


def check(model, loc: dict, estimate: dict) -> str | None:
    """More than `MASS_PER_TRIBUTARY` times the member's own mass, or `MASS_OF_TOTAL` of the whole."""
    if "mass_kg" not in estimate or loc.get("element") not in model.element_ids:
        return None
    total = model.total_mass_kg()
    m, own = estimate["mass_kg"], element_mass_kg(model, loc["element"])
    if m > MASS_PER_TRIBUTARY * own:
        return (f"{m:.4g} kg spread along element {loc['element']} is {m / own:.3g} times the member's own "
                f"{own:.4g} kg (more than {MASS_PER_TRIBUTARY:g}x)")
    if m > MASS_OF_TOTAL * total:
        return f"{m:.4g} kg spread along a member is {100 * m / total:.3g} % of the structure's {total:.4g} kg"
    return None


SPEC = KindSpec("distributed_mass", "local", ("element",), distributed_mass, default=True, check=check,
                term=term, doc="mass spread along a member")
