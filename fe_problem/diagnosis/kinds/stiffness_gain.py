"""``stiffness_gain`` at an element: its modulus times (1 + a), a in [0, 3] (a member stiffer than
its model; the estimate gives the modulus ratio 1 + a). The other side of the stiffness class
(stiffness_loss.py)."""

from __future__ import annotations

from typing import Iterator

import numpy as np

from ...assembly import AffineModel
from ...parameters import Parameter
from ..bounds import MAX_GAIN_RATIO
from ..setting import Candidate, Setting, lazy_system, reduced_linear, shared_grid, solve
from .spec import CandidateKey, KindSpec

GAIN_GRID = shared_grid([0.0, 0.01, 0.02, 0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0])


def stiffness_gain(st: Setting) -> Iterator[Candidate]:
    """A member stiffer than its model: its modulus times (1 + a), uniform over the element."""
    for e in st.model.elements:
        e0 = st.model.element_modulus_pa(e.id)
        system = lazy_system(lambda e=e, e0=e0: AffineModel(
            st.model, (Parameter("modulus", (e.id,), 1e-3 * e0, 10 * e0, e0),), like=st.system))

        def forward(a, system=system, e0=e0):
            return solve(system(), (e0 * (1.0 + np.asarray(a)))[:, None], st.coords, st.n_modes)

        def estimate(a, s, e0=e0):
            return {"stiffness_gain_pct": 100.0 * a, "modulus_ratio": 1.0 + a, "modulus_pa": s * e0 * (1.0 + a)}

        key = CandidateKey.of("stiffness_gain", {"element": e.id})
        yield Candidate("stiffness_gain", {"element": e.id}, 3.0,
                        GAIN_GRID, forward, estimate,
                        lambda a, e=e, e0=e0: st.model.with_element_moduli({e.id: e0 * (1 + a)}),
                        step=0.01, term=lambda key=key: term(st, key),
                        reduced=reduced_linear(st, lambda key=key: term(st, key)))


def term(st: Setting, key: CandidateKey):
    """dK/da of the key's element: its stiffness at its nominal modulus (`LocalMatrices.stiffness`)."""
    e = key.get("element")
    return st.local.stiffness(e, st.model.element_modulus_pa(e))


def check(model, loc: dict, estimate: dict) -> str | None:
    """A member more than `MAX_GAIN_RATIO` times stiffer than its model."""
    if estimate.get("modulus_ratio", 0.0) > MAX_GAIN_RATIO:
        return f"a member {estimate['modulus_ratio']:.3g} times stiffer than its model (beyond {MAX_GAIN_RATIO:g}x)"
    return None


SPEC = KindSpec("stiffness_gain", "local", ("element",), stiffness_gain, default=True, sides="stiffness", side=1,
                check=check, term=term, doc="a member's modulus times (1 + a)")
