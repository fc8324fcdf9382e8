"""Is an estimate physically plausible? Each cause's size against the structure it sits in.

A fit can always reach a small misfit with an effect of absurd size: a kilogram spread along a
column that weighs grams, a member losing its whole stiffness, a spring to ground stiffer than
any member (that is a support, not a spring). A statistical test does not see that; these
bounds do. The bounds (module constants) are generous on purpose: they flag what no real
structure of the model's kind carries, not what is merely unusual.

- added mass at a node: more than `MASS_PER_TRIBUTARY` times the mass the node already carries
  (half of every member meeting there, plus its lumped masses), or more than `MASS_OF_TOTAL` of
  the whole structure's mass;
- mass spread along a member: more than `MASS_PER_TRIBUTARY` times the member's own mass, or more
  than `MASS_OF_TOTAL` of the structure's;
- a loss of modulus over a whole member beyond `MAX_UNIFORM_LOSS` (80 %); a weak zone (a crack's
  model, a section depth wide) beyond `MAX_ZONE_LOSS` (a crack through nearly the whole section);
- a member stiffer than its model by more than `MAX_GAIN_RATIO` (3x);
- a spring to ground stiffer than `MAX_SPRING_PER_MEMBER` times the stiffest member meeting the
  node (axial E A / L): the node is held, a support condition, not a soft spring;
- Timoshenko shear beyond `MAX_SHEAR_FACTOR` times the section's own;
- a support released in a translation onto a spring below 1 / `MAX_SPRING_PER_MEMBER` of the
  members' own stiffness there (supports.py): the support would hardly hold at all, a support the
  model has and the structure lacks, not a soft support. (A rotation released that far is a
  pinned support, common physics; a spring stiffer than the members is a fixed support.)
"""

from __future__ import annotations

import dataclasses

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


def check(model: FrameModel, kind: str, location: dict | None, estimate: dict) -> str | None:
    """Why the estimate of a cause (`kind` at `location`, the candidate's own `estimate` keys)
    is implausible for `model` (the user's model), or None if it is within the bounds."""
    loc = location or {}
    total = model.total_mass_kg()
    if kind == "added_mass" and "mass_kg" in estimate and loc.get("node") in model.node_ids:
        m, carried = estimate["mass_kg"], tributary_mass_kg(model, loc["node"])
        if m > MASS_PER_TRIBUTARY * carried:
            return (f"an added mass of {m:.4g} kg is {m / carried:.3g} times the {carried:.4g} kg node {loc['node']} "
                    f"carries (more than {MASS_PER_TRIBUTARY:g}x)")
        if m > MASS_OF_TOTAL * total:
            return f"an added mass of {m:.4g} kg is {100 * m / total:.3g} % of the structure's {total:.4g} kg"
    if kind == "distributed_mass" and "mass_kg" in estimate and loc.get("element") in model.element_ids:
        m, own = estimate["mass_kg"], element_mass_kg(model, loc["element"])
        if m > MASS_PER_TRIBUTARY * own:
            return (f"{m:.4g} kg spread along element {loc['element']} is {m / own:.3g} times the member's own "
                    f"{own:.4g} kg (more than {MASS_PER_TRIBUTARY:g}x)")
        if m > MASS_OF_TOTAL * total:
            return f"{m:.4g} kg spread along a member is {100 * m / total:.3g} % of the structure's {total:.4g} kg"
    if kind == "stiffness_loss" and "modulus_ratio" in estimate:
        loss = 1.0 - estimate["modulus_ratio"]
        zone = estimate.get("profile") == "zone"
        bound = MAX_ZONE_LOSS if zone else MAX_UNIFORM_LOSS
        if loss > bound:
            what = "a weak zone" if zone else "a whole member"
            return f"{what} losing {100 * loss:.3g} % of its stiffness (beyond {100 * bound:.0f} %)"
    if kind == "stiffness_gain" and estimate.get("modulus_ratio", 0.0) > MAX_GAIN_RATIO:
        return f"a member {estimate['modulus_ratio']:.3g} times stiffer than its model (beyond {MAX_GAIN_RATIO:g}x)"
    if kind == "boundary_stiffness" and "stiffness_n_per_m" in estimate and loc.get("node") in model.node_ids:
        members = [axial_stiffness_n_per_m(model, e.id) for e in model.elements if loc["node"] in (e.node_i, e.node_j)]
        k, k_member = estimate["stiffness_n_per_m"], max(members, default=0.0)
        if k_member > 0 and k > MAX_SPRING_PER_MEMBER * k_member:
            return (f"a spring to ground of {k:.4g} N/m is {k / k_member:.3g} times the stiffest member at node "
                    f"{loc['node']} (E A / L {k_member:.4g} N/m): the node is held, a support, not a spring")
    if kind == "support_condition" and estimate.get("condition") == "free":
        return (f"the support at node {loc.get('node')} would hold in {loc.get('direction')} with "
                f"{100 * estimate['fixity']:.2g} % fixity (a spring {estimate['stiffness_ratio']:.3g} times the members' "
                f"stiffness there): a support that is hardly there, not a soft support; check the model's supports")
    if kind == "shear_deformation" and estimate.get("shear_factor", 0.0) > MAX_SHEAR_FACTOR:
        return (f"shear deformation {estimate['shear_factor']:.3g} times the section's own (beyond "
                f"{MAX_SHEAR_FACTOR:g}x)")
    return None


#: The residual degrees of freedom an answer needs to be decisive (answer.choose) and to pass
#: without the note below: with nu residual dof the reduced chi^2 of a right model scatters by
#: sqrt(2 / nu) (100 % at nu = 2), so on fewer than 3 almost any class with that many parameters
#: fits, and its evidence is mostly the charge for its parameters.
MIN_DOF = 3


def few_dof_note(dof: int, n_params: int) -> str | None:
    """A sentence when an answer rests on fewer than `MIN_DOF` degrees of freedom (the goodness of
    fit then says little: almost any model with that many parameters fits)."""
    if dof >= MIN_DOF:
        return None
    return (f"the answer rests on {dof} degree(s) of freedom ({n_params} fitted parameters): the data can hardly "
            "test it; more modes or measured shapes are needed before it can be trusted")


def judged(model: FrameModel, cause):
    """A cause (`record.Cause` or `record.Found`) with its estimate checked against physical
    bounds (`check`): `plausible` False and `implausible_because` set when beyond one."""
    if not cause.estimate:
        return cause
    why = check(model, cause.kind, cause.location, cause.estimate)
    return cause if why is None else dataclasses.replace(cause, plausible=False, implausible_because=why)
