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


def model_value(model: FrameModel, kind: str, targets) -> float:
    """The model's own value of a parameter of `kind` on `targets` (the value that makes K, M
    the model's): a modulus or density its elements', a mass the lumped mass at its nodes, a
    spring's stiffness, a released end's stiffness. ValueError when the targets disagree."""
    targets = tuple(targets)
    if kind == "modulus":
        values = {model.element_modulus_pa(e) for e in targets}
    elif kind == "density":
        values = {model.materials[model.element(e).material].density_kg_m3 for e in targets}
    elif kind == "mass":
        values = {sum(lm.mass_kg for lm in model.masses if lm.node == n) for n in targets}
    elif kind == "spring":
        values = {s.stiffness for s in model.springs if s.id in targets}
    elif kind == "release":
        e = model.element(targets[0])
        i, j = model.end_releases(e)
        values = set((i if targets[1] == e.node_i else j).values())
    else:
        raise ValueError(f"unknown parameter kind {kind!r}")
    if len(values) != 1:
        raise ValueError(f"the model's {kind} values of targets {list(targets)} differ ({sorted(values)})")
    return float(values.pop())


def model_with(model: FrameModel, parameters, x) -> FrameModel:
    """A copy of `model` whose parameters take the values x (n_var,): the updated model, whose K
    and M are the affine model's at x. A modulus becomes its elements' own modulus; a density a
    material of its own (named ``material@parameter``); a mass the lumped mass at its nodes (their
    rotary inertia kept); a spring's and a released end's stiffness their new values. A
    non-uniform modulus profile has no model field and is refused."""
    import dataclasses

    from .model.edits import release_element_end
    from .model.types import LumpedMass

    x = np.asarray(x, dtype=float).reshape(-1)
    moduli, densities, masses, springs = {}, {}, {}, {}
    releases = []
    for p, v in zip(parameters, x):
        if p.kind == "modulus":
            if p.profile != "uniform":
                raise ValueError(f"parameter {p.label}: a {p.profile} modulus profile cannot be written to a model")
            moduli.update({e: float(v) for e in p.targets})
        elif p.kind == "density":
            densities.update({e: (p.label, float(v)) for e in p.targets})
        elif p.kind == "mass":
            masses.update({n: float(v) for n in p.targets})
        elif p.kind == "spring":
            springs.update({s: float(v) for s in p.targets})
        else:
            releases.append((p.targets, float(v)))
    out = model.with_element_moduli(moduli) if moduli else model
    if densities:
        materials = dict(out.materials)
        for label, rho in set(densities.values()):
            for e in densities:
                if densities[e] == (label, rho):
                    base = out.element(e).material
                    materials[f"{base}@{label}"] = dataclasses.replace(out.materials[base], density_kg_m3=rho)
        elements = tuple(dataclasses.replace(e, material=f"{e.material}@{densities[e.id][0]}")
                         if e.id in densities else e for e in out.elements)
        out = out.replace(materials=materials, elements=elements)
    if masses:  # one lumped mass per node: the parameter's mass, the node's rotary inertia kept
        inertia = {n: sum(lm.inertia_kg_m2 for lm in out.masses if lm.node == n) for n in masses}
        out = out.replace(masses=tuple(lm for lm in out.masses if lm.node not in masses)
                          + tuple(LumpedMass(n, m, inertia[n]) for n, m in masses.items()))
    if springs:
        out = out.replace(springs=tuple(dataclasses.replace(s, stiffness=springs[s.id]) if s.id in springs else s
                                        for s in out.springs))
    for (e, node), k in releases:
        i, j = out.end_releases(out.element(e))
        rotations = tuple(i if node == out.element(e).node_i else j)
        out = release_element_end(out, e, node, k, rotations if len(out.layout.hinges) > 1 else None)
    return out


def frame_default_parameters(model: FrameModel, spread: float = 0.3) -> tuple[Parameter, ...]:
    """The parameters `femu update` takes without a parameter file: each element's modulus
    within +-`spread` (30 %) of the model's own, named E<element id>."""
    return tuple(Parameter("modulus", (e,), (1 - spread) * model.element_modulus_pa(e),
                           (1 + spread) * model.element_modulus_pa(e), model.element_modulus_pa(e), name=f"E{e}")
                 for e in model.element_ids)


__all__ = ["PARAMETER_KINDS", "Parameter", "element_moduli", "frame_default_parameters", "model_value",
           "model_with"]


class ParameterVectors:
    """The vectors of a system's `parameters` (anything with `initial`, `lower`, `upper`): the
    one place AffineModel (frames) and MatrixSystem (matrix models) take them from."""

    parameters: tuple

    @property
    def n_params(self) -> int:
        """Number of parameters."""
        return len(self.parameters)

    @property
    def x0(self) -> np.ndarray:
        """Initial parameter values (p,), in the parameters' own units (multipliers for a matrix
        model's terms)."""
        return np.array([p.initial for p in self.parameters], dtype=float)

    @property
    def lower(self) -> np.ndarray:
        """Lower bounds (p,)."""
        return np.array([p.lower for p in self.parameters], dtype=float)

    @property
    def upper(self) -> np.ndarray:
        """Upper bounds (p,)."""
        return np.array([p.upper for p in self.parameters], dtype=float)
