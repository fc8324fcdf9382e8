"""Every storey free: one stiffness per storey, the distributed class of a gradient over height.

Real storeys deviate together and unevenly (a laboratory four-storey shear frame: about 0.71,
0.81, 0.91 and 1.47 of nominal from the base up). No one-parameter class of groups.py expresses
that: a storey group moves one storey, a linear or quadratic trend cannot make the top storey
stiffer while the lower ones stiffen with height. This class frees every storey (the storey
groups of `groups.member_groups`): the columns of storey k have the modulus E0 (1 + theta_k).
The global stiffness-to-mass scale s, profiled out as in every class, is the top storey's own:
a common change of every storey is that scale (up to the beams'), so the top storey has no
parameter of its own and n - 1 parameters remain, theta_k in [LOW, HIGH] (sparse_class's range,
a ratio 0.1 to 4 to the top storey). The estimate gives each storey's stiffness relative to the
nominal model, s (1 + theta_k) (the top storey s), with the mass as modelled.

Fitted by bounded nonlinear least squares from the nominal model (`sparse_class.refit`); its
evidence is Laplace's with the Gauss-Newton Hessian and each parameter's Gaussian truncated to
its prior (`sparse_class.log_occam`, one support: no combinatorial charge), comparable with the
other classes (evidence.py). Only for planar models on the dense solver path (as the sparse
class) with at least three storeys: with two, the class is one storey's change and the global
scale, which groups.py's storey classes already are. Under ``--evidence nested`` the class keeps
its Laplace value (its row says so): a diagnosis of the shear frame with it sampled did not end
within 15 minutes on the loaded shared machine.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import sparse_class
from .candidates import Setting
from .evidence import ScoredClass
from .groups import member_groups
from .residuals import Observations

#: The class's label's kind, and its family in the evidence table.
KIND, FAMILY = "every_storey_free", "distributed"
#: Storeys the model must have for the class to apply (see the module docstring).
MIN_STOREYS = 3


@dataclass(frozen=True, eq=False)
class StoreyFit:
    """The storeys (group names, base first), their columns, the fit of the n - 1 lower storeys'
    parameters (`sparse_class.SparseFit`: theta, std at D = 1, chi^2, s, Jacobian) and the
    parameter set it was fitted on (to refit it: held-out error, nested sampling)."""

    storeys: tuple[str, ...]
    members: tuple[int, ...]
    fit: sparse_class.SparseFit
    params: object

    @property
    def label(self) -> str:
        return f"{KIND}@groups={'+'.join(self.storeys)}"

    def estimate(self, dispersion: float = 1.0) -> dict:
        """Each storey's stiffness relative to nominal, s (1 + theta_k), base first (the top one
        s), with its std at the dispersion D (theta's std times s; the scale's own spread is not
        included), the columns and the global scale."""
        s = self.fit.s
        ratios = [float(s * (1.0 + t)) for t in self.fit.theta] + [float(s)]
        std = [float(s * x * np.sqrt(dispersion)) for x in self.fit.theta_std] + [0.0]
        return {"groups": list(self.storeys), "members": list(self.members), "storey_ratio": ratios,
                "storey_ratio_std": std, "global_scale": float(s)}

    def scored(self, chi2_base: float, dispersion: float, held_out_error_pct: float | None = None) -> ScoredClass:
        """The class's row of the evidence table (log evidence against the calibrated model)."""
        f = self.fit
        occam = sparse_class.log_occam(f.theta, f.jacobian, len(f.theta), dispersion)
        return ScoredClass(self.label, FAMILY, len(f.theta), f.chi2, -(f.chi2 - chi2_base) / (2 * dispersion) + occam,
                           self.estimate(dispersion), held_out_error_pct)


def storeys(st: Setting) -> dict[str, tuple[int, ...]]:
    """The storey groups of the model, base first: name -> element ids."""
    found = {k: v for k, v in member_groups(st.model).items() if k.startswith("storey")}
    return dict(sorted(found.items(), key=lambda kv: int(kv[0][len("storey"):])))


def applicable(st: Setting) -> bool:
    """Planar, the dense solver path (`sparse_class.applicable`) and at least `MIN_STOREYS` storeys."""
    return sparse_class.applicable(st) and len(storeys(st)) >= MIN_STOREYS


def fit_storeys(st: Setting, obs: Observations, base_pairing: np.ndarray) -> StoreyFit | None:
    """The class fitted to `obs` (None where it does not apply)."""
    if not applicable(st):
        return None
    groups = storeys(st)
    names = list(groups)
    ids = list(st.model.element_ids)
    weights = np.zeros((len(ids), len(names) - 1))
    for k, name in enumerate(names[:-1]):
        weights[[ids.index(e) for e in groups[name]], k] = 1.0
    params = sparse_class._AllMembers(st, weights, names[:-1])
    f = sparse_class.refit(params, obs, np.arange(len(names) - 1), np.zeros(len(names) - 1), base_pairing)
    return StoreyFit(tuple(names), tuple(sorted(e for g in groups.values() for e in g)), f, params)


def held_out_error(st: Setting, data, used: np.ndarray, sf: StoreyFit, freq_noise: float,
                   shape_noise: float) -> float | None:
    """Mean |frequency error| (%) on the held-out modes of the class refitted on the others
    (`sparse_class.held_out_error`)."""
    return sparse_class.held_out_error(st, data, used, sf.fit, freq_noise, shape_noise, sf.params)
