"""Kernels of the 2-node space frame element, vectorised over elements: local axes from an
orientation vector, matrices, and the shape interpolation used for drawing.

Local DOFs per element (OpenSees' order): (u, v, w, theta_x, theta_y, theta_z) at node i,
then at node j; u along the member (local x), v along local y, w along local z. The element
is an axial bar, a torsion bar (G J / L) and two bending planes: Iz resists bending in the
local x-y plane (v, theta_z; theta_z = dv/dx), Iy in the local x-z plane (w, theta_y;
theta_y = -dw/dx, the right-hand rule). Each bending plane is the planar element of
beam2d.py (one way to write it): Euler-Bernoulli (phi = 0, no rotary inertia) or Timoshenko
(shear ratio phi, Przemieniecki's consistent mass with rotary inertia of the section, the
formulation of OpenSees' ElasticTimoshenkoBeam3d); the x-z plane is the x-y plane with the
sign of its rotations flipped.

Torsional inertia: a consistent mass rho Ip L / 6 [[2, 1], [1, 2]] with the polar moment of
the section Ip, which the caller passes (the model file form takes Ip = Iy + Iz). OpenSees'
elasticBeamColumn (-cMass) and ElasticTimoshenkoBeam3d both take rho J instead, J the
torsion constant (equal to Ip for a circular section only, orders of magnitude smaller for an
open steel section); tests/test_beam3d.py builds the OpenSees elements with J' = Iy + Iz and
G' = G J / J' (so G'J' = G J) to compare the same structure.

Every matrix function takes arrays of shape (n,) (or (n, 3) for vectors) and returns
(n, 12, 12); no loop over elements.
"""

from __future__ import annotations

import numpy as np

from . import beam2d

#: Local positions of the x-y bending plane (v_i, theta_z_i, v_j, theta_z_j), the x-z bending
#: plane (w_i, theta_y_i, w_j, theta_y_j), the axial (u_i, u_j) and torsion (theta_x_i, _j) DOFs.
PLANE_XY = np.array([1, 5, 7, 11])
PLANE_XZ = np.array([2, 4, 8, 10])
AXIAL = np.array([0, 6])
TORSION = np.array([3, 9])

#: The planar element's local DOFs (u, v, theta) that map to a bending plane's 4 DOFs.
_BEND_2D = np.array([1, 2, 4, 5])
#: theta_y = -dw/dx: the x-z plane is the planar element with its rotations negated.
_XZ_SIGN = np.array([1.0, -1.0, 1.0, -1.0])


def rotation(start: np.ndarray, end: np.ndarray, orientation: np.ndarray) -> np.ndarray:
    """Rotation matrices R (n, 3, 3) whose rows are the local x, y, z axes in global
    components (so that local = R @ global), for members from `start` to `end` (n, 3) (m)
    with orientation vectors `orientation` (n, 3) in their local x-z plane (OpenSees' vecxz):
    local x = (end - start) / L, local y = orientation x local x (normalised), local z =
    local x x local y (LinearCrdTransf3d::getLocalAxes).

    ValueError if a member has zero length or its orientation is parallel to it."""
    d = np.asarray(end, dtype=float) - np.asarray(start, dtype=float)
    length = np.linalg.norm(d, axis=1)
    if np.any(length == 0.0):
        raise ValueError(f"zero-length member at position(s) {np.flatnonzero(length == 0.0).tolist()}")
    x = d / length[:, None]
    y = np.cross(np.asarray(orientation, dtype=float), x)
    ny = np.linalg.norm(y, axis=1)
    # relative test: the sine of the angle between orientation and member
    sine = ny / np.maximum(np.linalg.norm(orientation, axis=1), np.finfo(float).tiny)
    bad = ~(sine > 1e-9)
    if np.any(bad):
        raise ValueError(f"orientation vector parallel to the member (or zero) at position(s) "
                         f"{np.flatnonzero(bad).tolist()}")
    y /= ny[:, None]
    z = np.cross(x, y)
    return np.stack([x, y, z], axis=1)


def lengths(start: np.ndarray, end: np.ndarray) -> np.ndarray:
    """Member lengths (n,) in metres."""
    return np.linalg.norm(np.asarray(end, dtype=float) - np.asarray(start, dtype=float), axis=1)


def transformation(r: np.ndarray) -> np.ndarray:
    """Global-to-local transformation T (n, 12, 12): R on each of the 4 blocks of 3 DOFs
    (translations and rotations of each end), so that k_global = T^T k_local T."""
    n = r.shape[0]
    t = np.zeros((n, 12, 12))
    for o in (0, 3, 6, 9):
        t[:, o:o + 3, o:o + 3] = r
    return t


def _bending(block6: np.ndarray, plane: np.ndarray, sign: np.ndarray, out: np.ndarray) -> None:
    """Put the bending part of planar 6x6 matrices into a bending plane of 12x12 ones."""
    s = sign[None, :, None] * sign[None, None, :]
    out[:, plane[:, None], plane[None, :]] += s * block6[:, _BEND_2D[:, None], _BEND_2D[None, :]]


def _bar(out: np.ndarray, dofs: np.ndarray, value: np.ndarray, off_diagonal: float) -> None:
    """A two-node bar value * [[1, off], [off, 1]] on `dofs`."""
    i, j = dofs
    out[:, i, i] += value
    out[:, j, j] += value
    out[:, i, j] += off_diagonal * value
    out[:, j, i] += off_diagonal * value


def shear_ratios(length: np.ndarray, iy: np.ndarray, iz: np.ndarray, shear_area: np.ndarray,
                 g_over_e: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Timoshenko's shear ratios (phi_y, phi_z) = 12 E I / (G A_s L^2) of the x-z (Iy) and
    x-y (Iz) bending planes, with shear area A_s = kappa A in both (m^2). They depend on E only
    through G / E, so the stiffness stays linear in E when G / E is fixed."""
    c = 12.0 / (g_over_e * shear_area * length**2)
    return c * iy, c * iz


def local_stiffness(length: np.ndarray, area: np.ndarray, iy: np.ndarray, iz: np.ndarray,
                    torsion: np.ndarray, phi_y: np.ndarray, phi_z: np.ndarray) -> np.ndarray:
    """Local stiffness per unit modulus (E = 1), (n, 12, 12). `torsion` is (G / E) J (m^4), the
    torsional stiffness per unit E; phi_y, phi_z the shear ratios (0 for Euler-Bernoulli)."""
    n = length.shape[0]
    k = np.zeros((n, 12, 12))
    _bar(k, AXIAL, area / length, -1.0)
    _bar(k, TORSION, torsion / length, -1.0)
    zero = np.zeros(n)
    _bending(beam2d.local_stiffness(length, zero, iz, phi_z), PLANE_XY, np.ones(4), k)
    _bending(beam2d.local_stiffness(length, zero, iy, phi_y), PLANE_XZ, _XZ_SIGN, k)
    return k


def local_mass(length: np.ndarray, area: np.ndarray, iy: np.ndarray, iz: np.ndarray, polar: np.ndarray,
               phi_y: np.ndarray, phi_z: np.ndarray, rotary: bool) -> np.ndarray:
    """Local consistent mass per unit density (rho = 1), (n, 12, 12).

    Axial: A L / 6 [[2, 1], [1, 2]]; torsion: `polar` L / 6 [[2, 1], [1, 2]] (polar: the
    polar moment of the section, m^4); each bending plane: the planar consistent mass of
    beam2d.local_mass with its shear ratio, plus the rotary inertia of the section (Iz in the
    x-y plane, Iy in the x-z plane) when `rotary` (Timoshenko; OpenSees' mlRot)."""
    n = length.shape[0]
    m = np.zeros((n, 12, 12))
    _bar(m, AXIAL, area * length / 3.0, 0.5)
    _bar(m, TORSION, polar * length / 3.0, 0.5)
    r = 1.0 if rotary else 0.0
    _bending(beam2d.local_mass(length, area, r * iz, phi_z), PLANE_XY, np.ones(4), m)
    _bending(beam2d.local_mass(length, area, r * iy, phi_y), PLANE_XZ, _XZ_SIGN, m)
    return m


def zone_stiffness(length: np.ndarray, area: np.ndarray, iy: np.ndarray, iz: np.ndarray, torsion: np.ndarray,
                   start: np.ndarray, end: np.ndarray, ratio_y: np.ndarray, ratio_z: np.ndarray) -> np.ndarray:
    """Local Euler-Bernoulli stiffness per unit E (n, 12, 12) of elements with a weak zone from
    `start` to `end` (fractions of the length from node i): the bending stiffness about local y
    is ratio_y * E Iy there, about local z ratio_z * E Iz (1: that plane unchanged), E I
    elsewhere; axial and torsion bars as `local_stiffness`. Each bending plane is the planar
    flexibility formulation (beam2d.zone_flexibility, flexibility_bending_stiffness: exact for
    the piecewise constant E I), placed as `local_stiffness` places the planar element."""
    n = length.shape[0]
    k = np.zeros((n, 12, 12))
    _bar(k, AXIAL, area / length, -1.0)
    _bar(k, TORSION, torsion / length, -1.0)
    for inertia, ratio, plane, sign in ((iz, ratio_z, PLANE_XY, np.ones(4)), (iy, ratio_y, PLANE_XZ, _XZ_SIGN)):
        extra = beam2d.zone_flexibility(length, inertia, start, end, ratio)
        _bending(beam2d.flexibility_bending_stiffness(length, inertia, extra), plane, sign, k)
    return k


def weighted_stiffness(length: np.ndarray, area: np.ndarray, iy: np.ndarray, iz: np.ndarray,
                       torsion: np.ndarray, w: tuple) -> np.ndarray:
    """Local Euler-Bernoulli stiffness per unit E (n, 12, 12) of elements whose modulus varies as
    E w(xi), w piecewise linear through w = (w(0), w(1/2), w(1)): each bending plane and the
    axial bar as beam2d.weighted_stiffness (exact integrals of the Hermite curvatures), the
    torsion bar (G / E) J / L times the mean of w, as the axial bar (G scales with E).
    w = (1, 1, 1) gives `local_stiffness` with phi = 0."""
    n = length.shape[0]
    k = np.zeros((n, 12, 12))
    zero = np.zeros(n)
    xy = beam2d.weighted_stiffness(length, area, iz, w)
    _bending(xy, PLANE_XY, np.ones(4), k)
    _bending(beam2d.weighted_stiffness(length, zero, iy, w), PLANE_XZ, _XZ_SIGN, k)
    k[:, AXIAL[:, None], AXIAL[None, :]] = xy[:, [[0], [3]], [[0, 3]]]
    mean_w = 0.25 * (w[0] + 2.0 * w[1] + w[2])
    _bar(k, TORSION, mean_w * torsion / length, -1.0)
    return k


def to_global(local: np.ndarray, t: np.ndarray) -> np.ndarray:
    """T^T a T for a stack of element matrices."""
    return np.einsum("eki,ekl,elj->eij", t, local, t, optimize=True)


def interpolate(length: np.ndarray, r: np.ndarray, ends: np.ndarray, smooth: np.ndarray,
                xi: np.ndarray) -> np.ndarray:
    """Displacement (n, n_points, 3) in global x, y, z (m) along elements at fractions `xi`
    (n_points,) of their length, from the end values `ends` (n, 12) in global axes (the
    element's DOF order: x, y, z, rx, ry, rz at node i, then at node j).

    In local axes: the axial displacement is linear; v the Hermite cubic of (v, theta_z) at
    the ends, w that of (w, -theta_y), where `smooth` (n,) is True, as in the element itself,
    else both linear (an element whose ends' own rotations are not its nodes' rotations)."""
    loc = np.einsum("eab,ekb->eka", r, np.asarray(ends, dtype=float).reshape(-1, 4, 3))
    (ui, ri, uj, rj) = (loc[:, 0], loc[:, 1], loc[:, 2], loc[:, 3])
    x = np.asarray(xi, dtype=float)[None, :]
    L = length[:, None]
    h1, h2 = 1 - 3 * x**2 + 2 * x**3, L * (x - 2 * x**2 + x**3)
    h3, h4 = 3 * x**2 - 2 * x**3, L * (x**3 - x**2)
    lin_i, lin_j = 1 - x, x

    def hermite(a_i, slope_i, a_j, slope_j):
        cubic = h1 * a_i[:, None] + h2 * slope_i[:, None] + h3 * a_j[:, None] + h4 * slope_j[:, None]
        return np.where(smooth[:, None], cubic, lin_i * a_i[:, None] + lin_j * a_j[:, None])

    u = lin_i * ui[:, 0:1] + lin_j * uj[:, 0:1]
    v = hermite(ui[:, 1], ri[:, 2], uj[:, 1], rj[:, 2])
    w = hermite(ui[:, 2], -ri[:, 1], uj[:, 2], -rj[:, 1])
    local = np.stack([u, v, w], axis=-1)  # (n, p, 3)
    return np.einsum("eab,epa->epb", r, local)
