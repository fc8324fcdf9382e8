"""The interface every element formulation implements, and the registry of formulations.

A formulation computes, for a group of elements of one model (vectorised over the group),
the global-axis stiffness per unit modulus (E = 1), the mass per unit density (rho = 1), and
the displaced shape between the ends for drawing. Its matrices act on the element's end DOFs:
the model layout's DOFs of node_i, then of node_j (`layout.names` order, see dofs.py).
A new element type is a subclass registered with `register`; nothing else changes. The
registry is keyed by (name, layout): "euler-bernoulli" of the planar frame and of the space
frame are two formulations, and a model's elements are looked up in its own layout.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import TYPE_CHECKING, Sequence

import numpy as np

from ..dofs import PLANAR_FRAME, DofLayout

if TYPE_CHECKING:
    from ..model import Element, FrameModel


#: The last model's (nodes, layout, coordinates): the copies a diagnosis builds keep the nodes
#: tuple (`FrameModel.coordinates` is per model object; the same tuple in the same layout gives
#: the same array). One tuple, read once and replaced whole: a thread never pairs one model's
#: nodes with another's array. The layout is part of the key: a planar model and its space copy
#: (`replace(layout=...)`) share one nodes tuple but not their coordinates' columns.
_KEPT_COORDINATES: tuple | None = None


def coordinates(model: FrameModel) -> np.ndarray:
    """`model.coordinates` (read-only), taken from the last model asked with the same nodes
    tuple and layout when this one has not computed its own."""
    global _KEPT_COORDINATES
    own = model.__dict__.get("coordinates")
    if own is None:
        kept = _KEPT_COORDINATES
        if kept is not None and kept[0] is model.nodes and (kept[1] is model.layout or kept[1] == model.layout):
            return kept[2]
        own = model.coordinates
    _KEPT_COORDINATES = (model.nodes, model.layout, own)
    return own


class ElementFormulation(ABC):
    """One element formulation. Subclasses set `name` and `layout` and implement the methods."""

    #: the name model files use (``"formulation"`` of an element)
    name: str = ""
    #: the nodal DOFs the element's ends connect to
    layout: DofLayout
    #: whether an element of this formulation may hold a crack (``crack_position``)
    supports_crack: bool = False
    #: whether a modulus profile along the element (`PROFILES`) can be assembled
    supports_profile: bool = False
    #: whether an element of this formulation may hold a weak zone (``weak_zone``)
    supports_weak_zone: bool = False
    #: whether its weak zone bends about a named local rotation (``weak_zone_about``: one zone per
    #: bending plane) with the stiffness its own `zone_stiffness` gives (a space beam's); False: the
    #: one bending plane of a planar beam, whose zone diagnosis/zones.py assembles
    zone_planes: bool = False

    @abstractmethod
    def stiffness(self, model: FrameModel, elements: Sequence[Element]) -> np.ndarray:
        """Global-axis stiffness per unit modulus, (n, k, k), k = 2 * layout.per_node."""

    @abstractmethod
    def mass(self, model: FrameModel, elements: Sequence[Element]) -> np.ndarray:
        """Global-axis consistent mass per unit density, (n, k, k)."""

    @abstractmethod
    def displaced(self, model: FrameModel, elements: Sequence[Element], ends: np.ndarray,
                  xi: np.ndarray) -> np.ndarray:
        """Displacement (n, n_points, layout.dimension) in metres along each element at length
        fractions `xi` (n_points,), from its end DOF values `ends` (n, k) (for drawing)."""

    def zone_stiffness(self, model: FrameModel, elements: Sequence[Element], start: np.ndarray, end: np.ndarray,
                       ratio: np.ndarray, about: Sequence[tuple[str, ...]]) -> np.ndarray:
        """Global-axis stiffness (b, k, k) per unit modulus of `elements` (b, repeats allowed),
        each with a weak zone from start to end (fractions of its length from node_i) whose
        bending stiffness about the local rotations `about` (per element, e.g. ("ry",)) is
        ratio times E I (a space frame's formulation; the planar one: diagnosis/zones.py)."""
        raise ValueError(f"formulation {self.name!r} has no weak zones")

    def profile_stiffness(self, model: FrameModel, element: Element, weights: tuple) -> np.ndarray:
        """Global-axis stiffness (1, k, k) per unit modulus of one element whose modulus varies
        as E w(xi), w piecewise linear through `weights` at xi = 0, 1/2, 1."""
        raise ValueError(f"formulation {self.name!r} has no modulus profiles")


_REGISTRY: dict[tuple[str, DofLayout], ElementFormulation] = {}


def register(formulation: ElementFormulation) -> ElementFormulation:
    """Add a formulation to the registry under its `name` and its own `layout`; returns it."""
    _REGISTRY[(formulation.name, formulation.layout)] = formulation
    return formulation


def formulation(name: str, layout: DofLayout = PLANAR_FRAME) -> ElementFormulation:
    """The registered formulation called `name` for models of `layout` (KeyError naming the
    known ones of that layout)."""
    if (name, layout) not in _REGISTRY:
        raise KeyError(f"unknown element formulation {name!r} for a {layout.dimension}-D model; "
                       f"known: {sorted(formulations(layout))}")
    return _REGISTRY[(name, layout)]


def formulations(layout: DofLayout = PLANAR_FRAME) -> tuple[str, ...]:
    """Names of the formulations registered for models of `layout`, in registration order."""
    return tuple(n for n, lay in _REGISTRY if lay == layout)
