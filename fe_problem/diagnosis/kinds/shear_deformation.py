"""``shear_deformation`` (no place): every element Timoshenko, with shear parameter
phi = a * phi_nominal (a = 1: the section's own shear coefficient)."""

from __future__ import annotations

import dataclasses
import functools
from typing import Iterator

import numpy as np

from ...elements import formulations
from ...model import FrameModel, with_formulation
from ..bounds import MAX_SHEAR_FACTOR
from ..setting import Candidate, Setting, solve_model
from .spec import KindSpec


def shear_deformation(st: Setting) -> Iterator[Candidate]:
    if all(e.formulation == "timoshenko" for e in st.model.elements):
        return
    if "timoshenko" not in formulations(st.model.layout):  # no shear-deformable element of this layout
        return
    # the Timoshenko copy once (a copy of every element: 45 ms at 3,000 DOFs), each size's sections on it
    timoshenko = functools.lru_cache(maxsize=1)(lambda: with_formulation(st.model, "timoshenko"))

    def model_at(a: float) -> FrameModel:
        sections = {k: dataclasses.replace(v, shear_coefficient=v.shear_coefficient / a)
                    for k, v in st.model.sections.items()}
        return timoshenko().replace(sections=sections)

    def forward(a):
        a = np.atleast_1d(np.asarray(a, dtype=float))
        out = [solve_model(model_at(v), st) if v > 0 else st.modes0 for v in a]
        return np.concatenate([o[0] for o in out]), np.concatenate([o[1] for o in out])

    def estimate(a, s):
        kappa = {k: v.shear_coefficient / a if a > 0 else float("inf") for k, v in st.model.sections.items()}
        return {"shear_factor": a, "effective_shear_coefficient": kappa}

    yield Candidate("shear_deformation", None, 30.0, np.concatenate([[0.0], np.geomspace(0.02, 30.0, 14)]),
                    forward, estimate, lambda a: model_at(a) if a > 0 else st.model, step=0.05)


def check(model, loc: dict, estimate: dict) -> str | None:
    """Shear beyond `MAX_SHEAR_FACTOR` times the section's own."""
    if estimate.get("shear_factor", 0.0) > MAX_SHEAR_FACTOR:
        return (f"shear deformation {estimate['shear_factor']:.3g} times the section's own (beyond "
                f"{MAX_SHEAR_FACTOR:g}x)")
    return None


SPEC = KindSpec("shear_deformation", "local", (), shear_deformation, default=True, check=check,
                doc="every element Timoshenko, its shear parameter scaled (no place)")
