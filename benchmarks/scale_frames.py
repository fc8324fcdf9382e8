"""Regular planar frames for the scale benchmarks (`fe_problem.regular_frame`), and the same
frame in OpenSeesPy.

`regular_frame(bays, storeys)`: bays of 6 m, storeys of 3.5 m, fixed at every base node;
steel columns (A 1.2e-2 m^2, I 2.5e-4 m^4) and beams (A 8e-3 m^2, I 3e-4 m^4), E 210 GPa,
density 7850 kg/m^3, one Euler-Bernoulli element per member with its consistent mass.
Free DOFs: 3 * (bays + 1) * storeys. `SIZES` are the frames of the four benchmark sizes.
"""

from __future__ import annotations

import numpy as np
import openseespy.opensees as ops

import fe_problem as fp
from fe_problem.model import FrameModel, Material, Section

#: DOF target -> (bays, storeys): 300, 3,000, 9,000 and 30,000 free DOFs (3 per free node).
SIZES = {300: (9, 10), 3000: (24, 40), 9000: (49, 60), 30000: (99, 100)}
BAY_M, STOREY_M = 6.0, 3.5
STEEL = Material(2.1e11, 7850.0, 0.3)
COLUMN, BEAM = Section(1.2e-2, 2.5e-4), Section(8.0e-3, 3.0e-4)


def regular_frame(bays: int, storeys: int) -> FrameModel:
    """The `bays` x `storeys` benchmark frame: `fe_problem.regular_frame` with these sections."""
    return fp.regular_frame(bays, storeys, BAY_M, STOREY_M, column=COLUMN, beam=BEAM, material=STEEL,
                            name=f"frame-{bays}x{storeys}",
                            description=f"regular {bays}-bay {storeys}-storey steel frame (scale benchmark)")


def opensees_frequencies(model: FrameModel, n_modes: int, solver: str | None = None) -> np.ndarray:
    """Build `model` in OpenSees (elasticBeamColumn, consistent mass, Linear transformation)
    and return its lowest `n_modes` frequencies (Hz) from `ops.eigen` (default solver: ARPACK
    on the banded system)."""
    ops.wipe()
    ops.model("basic", "-ndm", 2, "-ndf", 3)
    for n in model.nodes:
        ops.node(n.id, n.x, n.y)
    for s in model.supports:
        ops.fix(s.node, 1, 1, 1)
    ops.geomTransf("Linear", 1)
    for e in model.elements:
        sec, mat = model.sections[e.section], model.materials[e.material]
        ops.element("elasticBeamColumn", e.id, e.node_i, e.node_j, sec.area_m2, mat.youngs_modulus_pa,
                    sec.inertia_m4, 1, "-mass", mat.density_kg_m3 * sec.area_m2, "-cMass")
    lam = np.array(ops.eigen(n_modes) if solver is None else ops.eigen(solver, n_modes))
    ops.wipe()
    return np.sqrt(lam) / (2.0 * np.pi)
