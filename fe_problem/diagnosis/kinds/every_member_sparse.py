"""``every_member_sparse``: every member's modulus free, with a sparsity penalty (sparse_class.py):
the few members that changed, each a loss or a gain (charged there, `evidence.sides_log_prior`).
Fitted as a whole (`KindSpec.fit`), reached through the registry (`kinds.class_fits`)."""

from __future__ import annotations

from .. import sparse_class
from .spec import KindSpec


def fit(st, obs, base_pairing, seeds=None):
    """The sparse class fitted (sparse_class.fit_sparse), None where it does not apply."""
    return sparse_class.fit_sparse(st, obs, base_pairing)


SPEC = KindSpec(sparse_class.KIND, sparse_class.FAMILY, ("members",), doc="every member free, sparse", fit=fit)
