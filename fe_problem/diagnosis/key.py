"""A candidate's identity (`CandidateKey`): its kind, its place and its profile, typed and hashable.

Its `label()` is the label string the records and tables carry; `CandidateKey.parse` reads one
back, at the JSON boundary only. Declared with the kinds (kinds/spec.py names it); kept in a
module of its own so that `setting.Candidate` has its key without importing the kinds' registry.
"""

from __future__ import annotations

from dataclasses import dataclass


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
