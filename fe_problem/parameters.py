"""What can be updated: the updating parameters of a model.

Every parameter enters the stiffness or the mass matrix linearly (assembly.py builds
K(theta), M(theta) as affine sums), with theta in physical units: an element modulus in Pa,
a density in kg/m^3, a lumped mass in kg, a spring stiffness in N/m or N m/rad.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .elements import PROFILES
from .model import FrameModel

PARAMETER_KINDS = ("modulus", "density", "mass", "spring", "release")


@dataclass(frozen=True)
class Parameter:
    """One updating parameter.

    kind: ``modulus`` (Pa, shared by the elements in `targets`), ``density`` (kg/m^3, elements),
    ``mass`` (kg, a lumped mass in every translation of the node in `targets`), ``spring`` (the
    stiffness of the model's spring with id in `targets`), ``release`` (N m/rad, the rotational
    spring at element end ``targets = (element id, node id)``, which must be released in the
    model).

    ``profile`` (modulus of one Euler-Bernoulli element only): how a change of the modulus is
    spread along the element. With value E' the element's modulus becomes
    E(xi) = E - (E - E') w(xi), w from `elements.PROFILES`: ``uniform`` (w = 1, the whole
    element), ``toward_i`` / ``toward_j`` (w linear, 1 at that end, 0 at the other),
    ``middle`` (w a hat: 1 at mid-length, 0 at both ends).
    """

    kind: str
    targets: tuple[int, ...]
    lower: float
    upper: float
    initial: float
    name: str = ""
    profile: str = "uniform"

    def __post_init__(self) -> None:
        if self.kind not in PARAMETER_KINDS:
            raise ValueError(f"parameter kind must be one of {PARAMETER_KINDS}, got {self.kind!r}")
        if not (np.isfinite(self.lower) and np.isfinite(self.upper) and self.lower < self.upper):
            raise ValueError(f"parameter {self.label}: need finite lower < upper, got [{self.lower}, {self.upper}]")
        if not self.lower <= self.initial <= self.upper:
            raise ValueError(f"parameter {self.label}: initial {self.initial} outside [{self.lower}, {self.upper}]")
        if self.profile not in PROFILES:
            raise ValueError(f"parameter {self.label}: profile must be one of {list(PROFILES)}, got {self.profile!r}")
        if self.profile != "uniform" and (self.kind != "modulus" or len(self.targets) != 1):
            raise ValueError(f"parameter {self.label}: a profile applies to the modulus of one element")

    @property
    def label(self) -> str:
        """The parameter's name, or kind and targets if it has none."""
        return self.name or f"{self.kind}{list(self.targets)}"


def element_moduli(model: FrameModel, element_ids=None, lower: float = 6.0e10, upper: float = 8.0e10,
                   initial: float | None = None) -> tuple[Parameter, ...]:
    """One modulus parameter per element (default: every element, the paper's 12 moduli)."""
    ids = model.element_ids if element_ids is None else tuple(element_ids)
    return tuple(Parameter("modulus", (e,), lower, upper,
                           model.element_modulus_pa(e) if initial is None else initial, name=f"E{e}")
                 for e in ids)


__all__ = ["PARAMETER_KINDS", "Parameter", "element_moduli"]
