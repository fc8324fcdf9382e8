"""The physical bounds of an estimate (plausibility.py's rules, each kind's `KindSpec.check` in
kinds/): module constants and the structure's own sizes they are measured against. Generous on
purpose: they flag what no real structure of the model's kind carries, not what is merely unusual.
"""

from __future__ import annotations

from ..model import FrameModel

MASS_PER_TRIBUTARY = 10.0
MASS_OF_TOTAL = 0.5
MAX_UNIFORM_LOSS = 0.8
MAX_ZONE_LOSS = 0.98
MAX_GAIN_RATIO = 3.0
MAX_SPRING_PER_MEMBER = 100.0
MAX_SHEAR_FACTOR = 10.0


def element_mass_kg(model: FrameModel, element_id: int) -> float:
    """A member's own mass (kg): density x area x length."""
    e = model.element(element_id)
    return (model.materials[e.material].density_kg_m3 * model.sections[e.section].area_m2
            * model.element_length_m(element_id))


def tributary_mass_kg(model: FrameModel, node: int) -> float:
    """The mass a node carries: half of every member meeting there plus its lumped masses (kg)."""
    members = sum(0.5 * element_mass_kg(model, e.id) for e in model.elements if node in (e.node_i, e.node_j))
    return members + sum(m.mass_kg for m in model.masses if m.node == node)


def axial_stiffness_n_per_m(model: FrameModel, element_id: int) -> float:
    """A member's axial stiffness E A / L (N/m)."""
    e = model.element(element_id)
    return model.element_modulus_pa(element_id) * model.sections[e.section].area_m2 / model.element_length_m(element_id)
