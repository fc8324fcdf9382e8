"""``every_storey_free``, ``every_column_line_free``, ``every_floor_free`` (each group of members of a
partition its own modulus change) and ``adjacent_members_free``
(two adjacent members each free): the free group classes of group_free.py (distributed), charged for
their sides there (`evidence.sides_log_prior`)."""

from __future__ import annotations

from .spec import KindSpec

STOREYS = KindSpec("every_storey_free", "distributed", ("groups",), doc="every storey's moduli free")
COLUMN_LINES = KindSpec("every_column_line_free", "distributed", ("groups",), doc="every column line's moduli free")
FLOORS = KindSpec("every_floor_free", "distributed", ("groups",), doc="every floor's moduli free")
PAIR = KindSpec("adjacent_members_free", "distributed", ("members",), doc="two adjacent members' moduli free")
