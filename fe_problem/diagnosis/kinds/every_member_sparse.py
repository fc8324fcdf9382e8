"""``every_member_sparse``: every member's modulus free, with a sparsity penalty (sparse_class.py):
the few members that changed, each a loss or a gain (charged there, `evidence.sides_log_prior`)."""

from __future__ import annotations

from .spec import KindSpec

SPEC = KindSpec("every_member_sparse", "sparse", ("members",), doc="every member free, sparse")
