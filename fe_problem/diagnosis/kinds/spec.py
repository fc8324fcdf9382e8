"""What a candidate kind declares (`KindSpec`), and a candidate's identity (`CandidateKey`).

A kind is one module of this package with one `KindSpec` and one line in the registry
(`kinds/__init__.py`). The spec holds everything the diagnosis asks of a kind: how its
candidates are made (`generate`), its place's keys and its family, how many labelled variants
its class is built with at a place (the charge a row pays, `evidence.label_variants`), the
physical bounds of its estimate (`plausibility.check`) and its sides (a loss and a gain of one
place are the two variants of one class). The first-order term of a candidate is made by its
generator (`Candidate.term`, from `local.LocalMatrices`); `term` names the matrices' method.

A candidate's identity is a `CandidateKey`: its kind, its place as ordered (name, value) pairs
and its profile (a weak zone's position). Its `label()` is the label string the records and
tables carry, exactly as before the registry; `CandidateKey.parse` reads one back, at the JSON
boundary only (a record's label, a label given by the user).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterator

#: The families a kind belongs to (the evidence table's `ScoredClass.family`).
FAMILIES = ("local", "model_form", "distributed", "sparse")


def _frozen(v):
    """A location's value made hashable: a list (a class's members) as a tuple."""
    return tuple(_frozen(x) for x in v) if isinstance(v, (list, tuple)) else v


def _shown(v) -> str:
    """A value as the label shows it: a tuple as the list it was given as."""
    return str(list(v)) if isinstance(v, tuple) else str(v)


@dataclass(frozen=True)
class CandidateKey:
    """A candidate's identity: `kind`, its place `where` ((name, value) pairs in the location's
    order; None for a kind with no place) and its `profile` ("uniform", or a weak zone's "zone 0.30",
    "zone 0.30 ry"). Hashable and ordered as built; `label()` is the record's label string."""

    kind: str
    where: tuple[tuple[str, object], ...] | None = None
    profile: str = "uniform"

    @classmethod
    def of(cls, kind: str, location: dict | None, profile: str | None = "uniform") -> "CandidateKey":
        """The key of `kind` at `location` (a dict, or None for no place) with `profile`."""
        where = None if location is None else tuple((k, _frozen(v)) for k, v in location.items())
        return cls(kind, where, profile or "uniform")

    def __post_init__(self) -> None:
        if self.where is not None and not isinstance(self.where, tuple):
            raise TypeError(f"CandidateKey.where must be a tuple of (name, value) pairs, got {self.where!r}")

    @property
    def location(self) -> dict | None:
        """The place as the candidate's `location` dict (None: a kind with no place)."""
        return None if self.where is None else {k: (list(v) if isinstance(v, tuple) else v) for k, v in self.where}

    def get(self, name: str, default=None):
        """The value of one of the place's keys (`default` when the place has no such key)."""
        return next((v for k, v in (self.where or ()) if k == name), default)

    @property
    def place(self) -> "CandidateKey":
        """The key with its profile dropped: the answer a class names (the profiles of one
        element's loss are one answer)."""
        return CandidateKey(self.kind, self.where)

    def label(self) -> str:
        """The label string: ``kind@name=value,...(profile)``; no ``@`` for no place, no
        parenthesis for the uniform profile."""
        where = "" if self.where is None else "@" + ",".join(f"{k}={_shown(v)}" for k, v in self.where)
        return self.kind + where + ("" if self.profile == "uniform" else f"({self.profile})")

    def __str__(self) -> str:
        return self.label()

    @classmethod
    def parse(cls, label: str) -> "CandidateKey":
        """The key of a label string (`label()`'s inverse for the places candidates have: integer
        and name values). For a label read from a record or given by the user, not for a
        candidate's own identity (use `Candidate.key`)."""
        head, _, profile = label.partition("(")
        kind, at, where = head.partition("@")
        pairs = None
        if at:
            pairs = []
            for part in _parts(where):
                name, eq, value = part.partition("=")
                if not eq or not name:
                    raise ValueError(f"label {label!r}: the place {where!r} is not name=value pairs")
                pairs.append((name, _value(value)))
            pairs = tuple(pairs)
        return cls(kind, pairs, profile[:-1] if profile.endswith(")") else (profile or "uniform"))


def _parts(where: str) -> list[str]:
    """A label's place split at its commas outside brackets (a list value's own commas kept)."""
    out, depth, start = [], 0, 0
    for i, ch in enumerate(where):
        depth += (ch == "[") - (ch == "]")
        if ch == "," and depth == 0:
            out.append(where[start:i])
            start = i + 1
    return out + [where[start:]]


def _value(text: str):
    """A place's value from its label text: an integer, a list of them (a tuple), or the name."""
    if text.startswith("[") and text.endswith("]"):
        return tuple(_value(t.strip()) for t in text[1:-1].split(",") if t.strip())
    return int(text) if text.lstrip("-").isdigit() else text


@dataclass(frozen=True)
class KindSpec:
    """A candidate kind's declaration.

    name: the kind (a candidate's `kind`, the label's head); family: its class family (`FAMILIES`);
    place: the keys of its location, in order (() for a kind with no place);
    generate: Setting -> its candidates (None: built by its family's module as a class over many
    members, e.g. groups.py, sparse_class.py, and named here for its labels, sides and bounds);
    default: whether `all_candidates` builds it when no kinds are named (the local search's set);
    sides: a name shared by the kinds whose candidates at one place are the two sides of one class
    (a loss and a gain); a kind with sides is charged for 2 variants;
    side: -1 for the side that softens (a loss), +1 for the one that stiffens (a gain), 0 none;
    variants: (Setting, Candidate) -> how many labelled variants its class is built with at the
    candidate's place (the charge of a row, `evidence.label_variants`); None: 2 with sides, else 1;
    check: (model, location dict, estimate dict) -> why the estimate is physically implausible, or
    None (`plausibility.check`); None: no bound;
    term: the `local.LocalMatrices` method giving its first-order term (None: a global effect or
    one solved per size);
    doc: one line for the docs' table of kinds.
    """

    name: str
    family: str
    place: tuple[str, ...]
    generate: Callable[..., Iterator] | None = None
    default: bool = False
    sides: str | None = None
    side: int = 0
    variants: Callable[..., int] | None = None
    check: Callable[..., str | None] | None = None
    term: str | None = None
    doc: str = ""

    def __post_init__(self) -> None:
        if self.family not in FAMILIES:
            raise ValueError(f"kind {self.name!r}: family {self.family!r} is not one of {FAMILIES}")

    def n_variants(self, st, cand) -> int:
        """The charge of one of its rows: `variants`, or 2 for a kind with sides, else 1."""
        if self.variants is not None:
            return self.variants(st, cand)
        return 2 if self.sides is not None else 1

    def key(self, location: dict | None, profile: str = "uniform") -> CandidateKey:
        """The key of this kind at `location`."""
        return CandidateKey.of(self.name, location, profile)
