"""The candidate kinds of a model given as matrices, as the registry holds them (kinds/):
``term_loss`` and ``term_gain`` (kinds/matrix_terms.py), ``dof_mass`` (kinds/matrix_mass.py),
``dof_spring`` (kinds/matrix_spring.py) and the class ``every_term_sparse`` (matrix.py). None is a
default kind: a frame's search never builds them, and a matrix model's builds only them."""

from __future__ import annotations

from .kinds import KINDS, all_candidates
from .kinds.matrix_terms import varied_terms
from .matrix_setting import MatrixSetting

#: The kinds a matrix model's local search builds, in this order.
MATRIX_KINDS = ("term_loss", "term_gain", "dof_mass", "dof_spring")


def matrix_candidates(st: MatrixSetting, kinds=None) -> list:
    """Every candidate of the kinds asked (default `MATRIX_KINDS`); ValueError naming a kind that is
    not a matrix model's."""
    kinds = MATRIX_KINDS if kinds is None else tuple(kinds)
    unknown = [k for k in kinds if k not in MATRIX_KINDS or k not in KINDS]
    if unknown:
        raise ValueError(f"candidate kind(s) {', '.join(map(repr, unknown))} are not a model given as matrices' "
                         f"(its kinds: {', '.join(MATRIX_KINDS)})")
    return all_candidates(st, kinds)


__all__ = ["MATRIX_KINDS", "matrix_candidates", "varied_terms"]
