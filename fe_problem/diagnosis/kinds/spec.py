"""What a candidate kind declares (`KindSpec`), and a candidate's identity (`CandidateKey`).

A kind is one module of this package with one `KindSpec` and one line in the registry
(`kinds/__init__.py`). The spec holds everything the diagnosis asks of a kind: how its
candidates are made (`generate`), its place's keys and its family, how many labelled variants
its class is built with at a place (the charge a row pays, `kinds.label_variants`), the
physical bounds of its estimate (`plausibility.check`) and its sides (a loss and a gain of one
place are the two variants of one class). The first-order term of a candidate is made by its
generator; `term` is the spec's (Setting, key) -> term where the key gives it back bit for bit
(the local kinds' uniform changes, masses and springs), else the name of the matrices' method.

A candidate's identity is a `CandidateKey`: its kind, its place as ordered (name, value) pairs
and its profile (a weak zone's position). Its `label()` is the label string the records and
tables carry, exactly as before the registry; `CandidateKey.parse` reads one back, at the JSON
boundary only (a record's label, a label given by the user). It is defined in ../key.py (below
the registry: `setting.Candidate` has a key without importing the kinds) and named here.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable, Iterator

from ..key import CandidateKey  # noqa: F401 (named here: kinds.spec.CandidateKey)

#: The families a kind belongs to (the evidence table's `ScoredClass.family`).
FAMILIES = ("local", "model_form", "distributed", "sparse")


@dataclass(frozen=True)
class KindSpec:
    """A candidate kind's declaration.

    name: the kind (a candidate's `kind`, the label's head); family: its class family (`FAMILIES`);
    place: the keys of its location, in order (() for a kind with no place);
    generate: Setting -> its candidates, the one entry the diagnosis builds them by (a default kind's
    through `kinds.all_candidates`, a model-form or distributed class's through
    `kinds.class_candidates`); None: a class fitted as a whole over many members (its `fit`);
    default: whether `all_candidates` builds it when no kinds are named (the local search's set);
    sides: a name shared by the kinds whose candidates at one place are the two sides of one class
    (a loss and a gain); a kind with sides is charged for 2 variants;
    side: -1 for the side that softens (a loss), +1 for the one that stiffens (a gain), 0 none;
    variants: (Setting, Candidate) -> how many labelled variants its class is built with at the
    candidate's place (the charge of a row, `kinds.label_variants`); None: 2 with sides, else 1;
    check: (model, location dict, estimate dict) -> why the estimate is physically implausible, or
    None (`plausibility.check`); None: no bound;
    term: (Setting, CandidateKey) -> its first-order term (`local.Term`: dK/da, dM/da on the DOFs it
    touches), the one its generator's candidates carry (`Candidate.term`, `Candidate.reduced`);
    a str where the key does not give the term back to the last bit (a weak zone's ends, a
    joint's axis, a model-form or support term: docs/diagnosis-kinds.md), naming the
    `local.LocalMatrices` method its generator builds it with; None: a global effect or one
    solved per size;
    doc: one line for the docs' table of kinds;
    at: (Setting, elements, nodes) -> its candidates at those places only (ids; a model-form kind's
    look at the causes' places, `kinds.class_candidates`); None: it has none there;
    fit: (Setting, Observations, base pairing, seeds) -> the class fitted as a whole over many
    members (group_free.GroupFit, sparse_class.SparseFit) or None where it does not apply: a
    class with no generator, reached through `kinds.class_fits`;
    seeded: its fit takes the seed elements the other classes point at (fitted after them).
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
    term: Callable[..., object] | str | None = None
    doc: str = ""
    at: Callable[..., list] | None = None
    fit: Callable[..., object] | None = None
    seeded: bool = False

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
