"""``added_mass`` at a node: a lumped mass of a kg (x and y), a up to half the model's mass."""

from __future__ import annotations

from typing import Iterator

import numpy as np

from ...assembly import AffineModel
from ...model import add_mass
from ...parameters import Parameter
from ..bounds import MASS_OF_TOTAL, MASS_PER_TRIBUTARY, tributary_mass_kg
from ..setting import Candidate, Setting, lazy_system, reduced_linear, shared_grid, solve
from .spec import CandidateKey, KindSpec

_MASS_STEPS = np.geomspace(1e-3, 0.5, 15)          # added mass / the model's mass


def added_mass(st: Setting) -> Iterator[Candidate]:
    """A lumped mass of a kg added at a node, to what the node already carries (a floor's mass,
    a mass found before): a `mass` parameter is the node's whole lumped mass, so it is set to
    m0 + a."""
    total = st.model.total_mass_kg()
    grid = shared_grid(np.concatenate([[0.0], total * _MASS_STEPS]))
    for node in st.model.node_ids:
        m0 = sum(lm.mass_kg for lm in st.model.masses if lm.node == node)
        system = lazy_system(lambda node=node, m0=m0: AffineModel(
            st.model, (Parameter("mass", (node,), 0.0, m0 + total, m0),), like=st.system))

        def forward(a, system=system, m0=m0):
            return solve(system(), m0 + np.asarray(a, dtype=float)[:, None], st.coords, st.n_modes)

        def estimate(a, s, node=node):
            return {"mass_kg": a, "mass_ratio": a / total}

        def extend(a, node=node):
            return add_mass(st.model, node, a)

        key = CandidateKey.of("added_mass", {"node": node})
        yield Candidate("added_mass", {"node": node}, 0.5 * total,
                        grid, forward, estimate, extend, step=0.005 * total,
                        term=lambda key=key: term(st, key),
                        reduced=reduced_linear(st, lambda key=key: term(st, key)))


def term(st: Setting, key: CandidateKey):
    """dM/da of a kg at the key's node (`LocalMatrices.node_mass`)."""
    return st.local.node_mass(key.get("node"))


def check(model, loc: dict, estimate: dict) -> str | None:
    """More than `MASS_PER_TRIBUTARY` times what the node carries, or `MASS_OF_TOTAL` of the whole."""
    if "mass_kg" not in estimate or loc.get("node") not in model.node_ids:
        return None
    total = model.total_mass_kg()
    m, carried = estimate["mass_kg"], tributary_mass_kg(model, loc["node"])
    if m > MASS_PER_TRIBUTARY * carried:
        return (f"an added mass of {m:.4g} kg is {m / carried:.3g} times the {carried:.4g} kg node {loc['node']} "
                f"carries (more than {MASS_PER_TRIBUTARY:g}x)")
    if m > MASS_OF_TOTAL * total:
        return f"an added mass of {m:.4g} kg is {100 * m / total:.3g} % of the structure's {total:.4g} kg"
    return None


SPEC = KindSpec("added_mass", "local", ("node",), added_mass, default=True, check=check, term=term,
                doc="a lumped mass at a node")
