"""``every_storey_free``, ``every_column_line_free``, ``every_floor_free`` (each group of members of a
partition its own modulus change) and ``adjacent_members_free`` (two adjacent members each free): the
free group classes of group_free.py (distributed), charged for their sides there
(`evidence.sides_log_prior`). Each is fitted as a whole (`KindSpec.fit`), reached through the
registry (`kinds.class_fits`); the pair on the seed elements the other classes point at
(`KindSpec.seeded`, core.pair_seeds)."""

from __future__ import annotations

from .. import group_free
from .spec import KindSpec


def _partition(kind: str):
    def fit(st, obs, base_pairing, seeds=None):
        """The partition class `kind` fitted (group_free.fit_storeys), None where it does not apply."""
        return group_free.fit_storeys(st, obs, base_pairing, kind)
    return fit


def _pair(st, obs, base_pairing, seeds):
    """The best two adjacent members free on the chains through `seeds` (group_free.fit_pair)."""
    return group_free.fit_pair(st, obs, base_pairing, seeds)


STOREYS = KindSpec(group_free.KIND, group_free.FAMILY, ("groups",), doc="every storey's moduli free",
                   fit=_partition(group_free.KIND))
COLUMN_LINES = KindSpec("every_column_line_free", group_free.FAMILY, ("groups",),
                        doc="every column line's moduli free", fit=_partition("every_column_line_free"))
FLOORS = KindSpec("every_floor_free", group_free.FAMILY, ("groups",), doc="every floor's moduli free",
                  fit=_partition("every_floor_free"))
PAIR = KindSpec(group_free.PAIR_KIND, group_free.FAMILY, ("members",), doc="two adjacent members' moduli free",
                fit=_pair, seeded=True)
