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

Each rule is its kind's (`KindSpec.check`, in the kind's module of kinds/); the constants and the
structure's sizes they are measured against are in bounds.py.
"""

from __future__ import annotations

import dataclasses

from ..model import FrameModel
from .bounds import (MASS_OF_TOTAL, MASS_PER_TRIBUTARY, MAX_GAIN_RATIO, MAX_SHEAR_FACTOR,  # noqa: F401 (named here)
                     MAX_SPRING_PER_MEMBER, MAX_UNIFORM_LOSS, MAX_ZONE_LOSS, axial_stiffness_n_per_m, element_mass_kg,
                     tributary_mass_kg)
from .kinds import spec_of

def check(model: FrameModel, kind: str, location: dict | None, estimate: dict) -> str | None:
    """Why the estimate of a cause (`kind` at `location`, the candidate's own `estimate` keys)
    is implausible for `model` (the user's model), or None if it is within the bounds: the kind's
    own rule (`KindSpec.check`, kinds/); a kind without one has no bound."""
    spec = spec_of(kind)
    if spec is None or spec.check is None:
        return None
    return spec.check(model, location or {}, estimate)


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
