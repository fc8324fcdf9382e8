"""The registry of candidate kinds: one module per kind, each with its `KindSpec`, one line each.

A new kind: a module of this package (or anywhere) defining ``SPEC = KindSpec(...)`` with its
generator, place, family, sides, variants and bounds (spec.py), and one ``register(module.SPEC)``
line below (or a call of `register` from the code that brings it). `all_candidates` builds the
candidates of the registered kinds whose spec says `default`, in registration order;
`class_candidates` those of a class family (model-form, distributed) scored beside them;
`class_fits` the classes fitted as a whole (the free group classes, the sparse class);
`label_variants` / `label_log_prior` a row's charge, as its spec says;
`spec_of` answers for a key, a candidate or a kind's name.
"""

from __future__ import annotations

import contextlib
import gc

import numpy as np
from typing import Iterator

from .spec import FAMILIES, CandidateKey, KindSpec

#: kind name -> its spec, in registration order (the order candidates are built in).
KINDS: dict[str, KindSpec] = {}


def register(spec: KindSpec, replace: bool = False) -> KindSpec:
    """Add a kind to the registry (`replace`: over one of the same name); the spec back."""
    if not isinstance(spec, KindSpec):
        raise TypeError(f"register takes a KindSpec, not {type(spec).__name__}")
    if spec.name in KINDS and not replace:
        raise ValueError(f"candidate kind {spec.name!r} is registered already")
    KINDS[spec.name] = spec
    return spec


def unregister(name: str) -> None:
    """Remove a kind (a test's toy kind)."""
    KINDS.pop(name, None)


def spec_of(what) -> KindSpec | None:
    """The spec of a `CandidateKey`, a candidate (its `kind`), or a kind's name; None if unknown."""
    name = what if isinstance(what, str) else getattr(what, "kind", None)
    return KINDS.get(name)


def default_kinds() -> tuple[str, ...]:
    """The kinds `all_candidates` builds when none are named (the local search's set)."""
    return tuple(k for k, s in KINDS.items() if s.default and s.generate is not None)


def iter_candidates(st, kinds=None) -> Iterator:
    """The candidates of `kinds` (default: `default_kinds()`) for the Setting `st`, one at a time,
    each built when it is reached: a search for one label stops there (a 3,024-DOF frame has
    15,566 candidates, 9,408 of them weak zones)."""
    for kind in (kinds or default_kinds()):
        spec = KINDS.get(kind)
        if spec is None or spec.generate is None:
            known = ", ".join(default_kinds())
            raise ValueError(f"unknown candidate kind {kind!r}; known: {known}")
        yield from spec.generate(st)


def all_candidates(st, kinds=None) -> list:
    """Every candidate of the given kinds (default: `default_kinds()`) for this setting. Built with
    the cyclic garbage collector paused (`_collector_paused`): the candidates are a few closures
    each, all kept, and at 3,024 DOFs the collections their 15,566 sets of objects set off, each
    a pass over the whole heap, were two thirds of building them."""
    with _collector_paused():
        return list(iter_candidates(st, kinds))


def class_candidates(st, family: str, elements=None, nodes=None) -> list:
    """The candidates of every registered kind of `family` that is not a default one and has a
    generator, in registration order: the classes scored beside the local search (the model-form
    kinds, the distributed one-parameter classes). With `elements` or `nodes` (ids), each kind's
    candidates at those places only (its spec's `at`; a kind without one has none there)."""
    out: list = []
    for spec in list(KINDS.values()):
        if spec.family != family or spec.default or spec.generate is None:
            continue
        if elements is None and nodes is None:
            out += list(spec.generate(st))
        elif spec.at is not None:
            out += list(spec.at(st, list(elements or ()), list(nodes or ())))
    return out


def class_fits(st, obs, base_pairing, family: str, seeds=None) -> list:
    """The fits of the registered kinds of `family` fitted as a whole (`KindSpec.fit`), in
    registration order, those that do not apply (None) left out: without `seeds` the kinds fitted
    on their own, with `seeds` (elements) those fitted on them (`KindSpec.seeded`)."""
    out = []
    for spec in list(KINDS.values()):
        if spec.family == family and spec.fit is not None and spec.seeded == (seeds is not None):
            got = spec.fit(st, obs, base_pairing, seeds)
            if got is not None:
                out.append(got)
    return out


def label_variants(st, cand) -> int:
    """How many labelled variants the class of `cand` is built with at its place: the class is its
    kind (a loss and a gain of the same place one class: the kinds that share `KindSpec.sides`) at
    its place (the element, node, joint end, group or trend shape that names it); every other label
    it fits is a variant, counted by its kind's spec (`KindSpec.n_variants`, kinds/): a weak zone's
    centre (the centres `zones.zone_places` builds, in every bending plane), a uniform stiffness
    change's side (2), a member depth's (thinner or deeper: 2), a trend's or a group change's sign
    (2), a node move's direction and sign (4: +x, -x, +y, -y), a spring to ground's direction (the
    node's translations not held), a support condition's (the candidates
    `supports.support_candidates` builds at its node), a space frame joint's rotation (the
    rotations its candidates are built about at that end: up to 3). A kind not registered: 1.
    st: the `Setting` the candidates were made for."""
    spec = spec_of(cand.kind)
    return 1 if spec is None else spec.n_variants(st, cand)


def label_log_prior(st, cand) -> float:
    """log of the prior weight of one labelled row of its class: -log `label_variants`, the class's
    prior (the weight of no effect) spread evenly over the variants it is built with. A row's
    evidence is its own term times that weight, a lower bound of its class's (the sum over its
    variants)."""
    return -float(np.log(label_variants(st, cand)))


@contextlib.contextmanager
def _collector_paused():
    """The cyclic garbage collector off inside, as it was after (nothing is freed any later than
    the next collection: reference counting frees what is not in a cycle as before)."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


# == the registry: one line per kind =========================================================
from . import (added_mass, boundary_stiffness, distributed_mass, every_member_sparse,  # noqa: E402
               group_stiffness, joint_flexibility, member_depth, node_position, shear_deformation,
               stiffness_gain, stiffness_loss, stiffness_trend, storeys_free, support_condition)

register(stiffness_loss.SPEC)
register(added_mass.SPEC)
register(joint_flexibility.SPEC)
register(shear_deformation.SPEC)
register(stiffness_gain.SPEC)
register(boundary_stiffness.SPEC)
register(distributed_mass.SPEC)
register(member_depth.SPEC)
register(node_position.SPEC)
register(support_condition.SPEC)
register(group_stiffness.LOSS)
register(group_stiffness.GAIN)
register(stiffness_trend.SPEC)
register(storeys_free.STOREYS)
register(storeys_free.COLUMN_LINES)
register(storeys_free.FLOORS)
register(storeys_free.PAIR)
register(every_member_sparse.SPEC)
# a model given as matrices (matrix.py; not default: a frame's search never builds them)
from . import matrix_mass, matrix_spring, matrix_terms  # noqa: E402

register(matrix_terms.LOSS)
register(matrix_terms.GAIN)
register(matrix_mass.SPEC)
register(matrix_spring.SPEC)
register(matrix_terms.SPARSE)

__all__ = ["FAMILIES", "KINDS", "CandidateKey", "KindSpec", "all_candidates", "class_candidates", "class_fits",
           "default_kinds", "iter_candidates", "label_log_prior", "label_variants", "register", "spec_of",
           "unregister"]
