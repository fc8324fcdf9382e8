"""``term_loss`` / ``term_gain`` of a model given as matrices, at a term (``{"term": name}``): one
stiffness or mass term's multiplier times (1 - a), a in [0, 0.9], or times (1 + a), a in [0, 3] (a
substructure, a material group, a floor softer or stiffer, lighter or heavier than its model);
the two sides of one class. A family's only term is left out (its change is the global
stiffness-to-mass scale every model is allowed already), and so is a term at 0. Each is linear in
one column of the diagnosis's system (matrix_setting.py): its first-order term is +-K_i (or M_i)
times the multiplier (`term_of`), which the first-order screen takes (screening.py)."""

from __future__ import annotations

from typing import Iterator

import numpy as np

from ...matrix_model import MatrixModel, MatrixTerm
from ..bounds import MAX_GAIN_RATIO, MAX_UNIFORM_LOSS
from ..local import Term
from ..matrix_setting import MatrixSetting
from ..setting import Candidate
from .spec import KindSpec
from .stiffness_gain import GAIN_GRID
from .stiffness_loss import LOSS_GRID

LOSS_UPPER, GAIN_UPPER = 0.9, 3.0
#: A term touching more DOFs than this has no first-order term (its dense block would take
#: 8 x n^2 bytes: 18 MB at this size): it is screened by exact steps (matrix.py).
MAX_TERM_DOFS = 1500


def varied_terms(model: MatrixModel) -> list[MatrixTerm]:
    """The terms whose change is a candidate: every term, less a family's only term (its change is
    the global scale's) and a term whose multiplier is 0 (it is not in the model)."""
    out = []
    for family in (model.stiffness, model.mass):
        live = [t for t in family if t.initial != 0.0]
        out += live if len(live) > 1 else []
    return out


def term_change(st: MatrixSetting, side: str) -> Iterator[Candidate]:
    """``term_loss`` (side "loss") or ``term_gain`` (side "gain") of every varied term."""
    sign, upper, grid = (-1.0, LOSS_UPPER, LOSS_GRID) if side == "loss" else (1.0, GAIN_UPPER, GAIN_GRID)
    for t in varied_terms(st.model):
        col = st.columns[t.name]

        def forward(a, col=col, m0=t.initial):
            return st.forward(col, m0 * (1.0 + sign * np.asarray(a, dtype=float)))

        def estimate(a, s, t=t):
            ratio = 1.0 + sign * a
            scale = s if t.family == "stiffness" else 1.0
            return {"term": t.name, "family": t.family, "change_pct": 100.0 * sign * a, "ratio": ratio,
                    "multiplier": scale * t.initial * ratio}

        def extend(a, t=t):
            return st.model.with_initials({t.name: t.initial * (1.0 + sign * a)})

        touched = np.unique(t.matrix.tocoo().row).size
        yield Candidate(f"term_{side}", {"term": t.name}, upper, grid, forward, estimate, extend, step=0.01,
                        meta={"family": t.family},
                        term=(lambda t=t: term_of(t, sign * t.initial)) if touched <= MAX_TERM_DOFS else None)


def term_of(t: MatrixTerm, per_a: float) -> Term:
    """The first-order term of a term's multiplier changed by `per_a` per unit a: d(K or M)/da =
    per_a x its matrix, on the DOFs its matrix touches (a dense block: a substructure's)."""
    coo = t.matrix.tocoo()
    dofs = np.unique(np.concatenate([coo.row, coo.col]))
    block = per_a * t.matrix[dofs][:, dofs].toarray()
    zero = np.zeros_like(block)
    return Term(dofs, block, zero) if t.family == "stiffness" else Term(dofs, zero, block)


def term_loss(st: MatrixSetting) -> Iterator[Candidate]:
    """A term's multiplier times (1 - a)."""
    return term_change(st, "loss")


def term_gain(st: MatrixSetting) -> Iterator[Candidate]:
    """A term's multiplier times (1 + a)."""
    return term_change(st, "gain")


def check(model, loc: dict, estimate: dict) -> str | None:
    """A term at less than 1 - `MAX_UNIFORM_LOSS` of its model, or more than `MAX_GAIN_RATIO` times it
    (each ratio of the sparse class's terms too)."""
    ratios = estimate.get("ratio")
    for r in ratios if isinstance(ratios, list) else [] if ratios is None else [ratios]:
        if r < 1.0 - MAX_UNIFORM_LOSS:
            return f"a term at {r:.3g} of its model (a loss beyond {MAX_UNIFORM_LOSS:.0%})"
        if r > MAX_GAIN_RATIO:
            return f"a term at {r:.3g} times its model (more than {MAX_GAIN_RATIO:g}x)"
    return None


LOSS = KindSpec("term_loss", "local", ("term",), term_loss, sides="term", side=-1, check=check,
                doc="a matrix model's term softer or lighter (its multiplier times 1 - a)")
GAIN = KindSpec("term_gain", "local", ("term",), term_gain, sides="term", side=1, check=check,
                doc="a matrix model's term stiffer or heavier (its multiplier times 1 + a)")
#: "every term", sparse (matrix.py, the localisation of sparse_class.py over the terms).
SPARSE = KindSpec("every_term_sparse", "sparse", ("terms",), check=check,
                  doc="a matrix model's every term free, sparse")
