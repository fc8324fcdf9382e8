"""The consistent unit systems a Nastran deck or an OpenSees script may be written in
(`femu import --units`), in a module of their own so that the command line lists them
without loading the physics. A model itself is always SI."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Units:
    """A consistent unit system: the SI value of its unit of length (m), mass (kg) and force (N)."""

    length: float
    mass: float
    force: float

    def scale(self, kind: str) -> float:
        """The factor from this system to SI of a quantity `kind` (length, mass, pressure,
        density, area, inertia, spring, rotational_spring, rotary_inertia)."""
        L, M, F = self.length, self.mass, self.force
        return {"length": L, "mass": M, "pressure": F / L**2, "density": M / L**3, "area": L**2,
                "inertia": L**4, "spring": F / L, "rotational_spring": F * L, "rotary_inertia": M * L**2}[kind]


#: SI (m, kg, N, s); mm-N-t (mm, tonne, N, s: MPa, t/mm^3); in-lbf-s (inch, lbf s^2/in, lbf, s: psi).
UNITS = {"SI": Units(1.0, 1.0, 1.0), "mm-N-t": Units(1e-3, 1e3, 1.0),
         "in-lbf-s": Units(0.0254, 4.4482216152605 / 0.0254, 4.4482216152605)}
