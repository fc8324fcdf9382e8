"""Candidate extensions of a model: each a physical effect with a place and one magnitude.

Every candidate maps an effect size ``a >= 0`` (0: the unextended model) to the modes of the
extended model. The global stiffness-to-mass scale every model is allowed multiplies all
eigenvalues and leaves shapes alone, so it is profiled out in closed form by the fit and is
not part of a candidate.

Kinds (the set is open: a kind is one module of kinds/ with its `KindSpec` and one registry line,
kinds/__init__.py; this module names them for the code that imports them from here):

- ``stiffness_loss`` at an element: its modulus times (1 - a), a in [0, 0.9]; or a weak zone
  about a section depth wide at one of seven positions along it, its bending stiffness times
  (1 - a), a in [0, 0.99] (a crack; zones.py); on a space frame in each bending plane (local
  ry, rz), each its own candidate.
- ``added_mass`` at a node: a lumped mass of a kg (x and y), a up to half the model's mass.
- ``joint_flexibility`` at a node where members meet: one element end released and tied to
  the node by a rotational spring k = (E I / L)_element / a (a: the joint's compliance
  relative to the element's own bending compliance); on a space frame about each bending
  axis and in torsion (k = (G J / L)_element / a), the member's local axes, skew or not (a
  skew axis' release is a relative rotation, terms.py).
- ``shear_deformation`` (no place): every element Timoshenko, with shear parameter
  phi = a * phi_nominal (a = 1: the section's own shear coefficient).
- ``stiffness_gain`` at an element: its modulus times (1 + a), a in [0, 3] (a member stiffer
  than its model; the estimate gives the modulus ratio 1 + a).
- ``boundary_stiffness`` at a node and direction (x or y): a spring to ground of stiffness
  a * k_ref, k_ref = total mass * (2 pi f_1)^2 of the nominal model (a soft support, a
  suspension, a base that is not rigid).
- ``distributed_mass`` along an element: the element's density times (1 + a) (mass spread
  over it; the estimate gives the added mass in kg).

Joints are found from the model's topology (`joint_nodes`): every node where three or more
element ends meet, or two that are not in line (a corner), so any frame has its joints.
"""

from __future__ import annotations

from typing import Callable, Iterator

from .kinds import KINDS as _REGISTRY, all_candidates, default_kinds, iter_candidates  # noqa: F401
from .kinds.added_mass import added_mass  # noqa: F401
from .kinds.boundary_stiffness import BOUNDARY_GRID, _reference_stiffness, boundary_stiffness  # noqa: F401
from .kinds.distributed_mass import distributed_mass  # noqa: F401
from .kinds.joint_flexibility import (JOINT_GRID, _bending_compliance_ref, _frees, _last_rigid_end,  # noqa: F401
                                      _released, _rotation_axis, joint_flexibility, joint_nodes)
from .kinds.shear_deformation import shear_deformation  # noqa: F401
from .kinds.stiffness_gain import GAIN_GRID, stiffness_gain  # noqa: F401
from .kinds.stiffness_loss import LOSS_GRID, stiffness_loss, zone_candidate, zone_profile  # noqa: F401
from .setting import (Candidate, Setting, _Remembered, lazy_system, reduced_linear, scale_stiffness,  # noqa: F401
                      shared_grid, solve, solve_model)
from ..model import release_element_end  # noqa: F401 (named here for the code that took it from here)

#: The kinds `all_candidates` builds when none are named (the registry's `default` kinds, as
#: registered when this module was imported; `kinds.default_kinds()` answers for the registry now).
#: Not named KINDS: that is the registry itself (`kinds.KINDS`, kind -> KindSpec).
DEFAULT_KINDS = default_kinds()

#: kind -> function(Setting) yielding Candidates, of the kinds in `DEFAULT_KINDS` (a view of the
#: registry, kinds/__init__.py: a kind is added there).
CANDIDATE_KINDS: dict[str, Callable[[Setting], Iterator[Candidate]]] = {k: _REGISTRY[k].generate
                                                                         for k in DEFAULT_KINDS}
