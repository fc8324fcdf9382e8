"""Kernels of the 2-node planar frame element, vectorised over elements: matrices and the
shape interpolation used for drawing.

Local DOFs per element: (u_i, v_i, theta_i, u_j, v_j, theta_j); axial bar plus bending.
Bending is either Euler-Bernoulli (Hermite cubics, consistent mass) or Timoshenko
(shear-deformable, Przemieniecki's consistent mass with rotary inertia: the formulation of
OpenSees' ElasticTimoshenkoBeam2d). With phi = 0 and no rotary inertia the Timoshenko
matrices reduce to the Euler-Bernoulli ones.

Every matrix function takes arrays of shape (n_el,) and returns (n_el, 6, 6).
"""

from __future__ import annotations

import numpy as np


def rotation(cos: np.ndarray, sin: np.ndarray) -> np.ndarray:
    """Global-to-local transformation T, so that k_global = T^T k_local T."""
    n = cos.shape[0]
    t = np.zeros((n, 6, 6))
    for o in (0, 3):
        t[:, o, o] = t[:, o + 1, o + 1] = cos
        t[:, o, o + 1] = sin
        t[:, o + 1, o] = -sin
        t[:, o + 2, o + 2] = 1.0
    return t


def local_stiffness(length: np.ndarray, ea: np.ndarray, ei: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Local stiffness; ``phi = 12 EI / (kappa G A L^2)`` (0 for Euler-Bernoulli)."""
    L = length
    k = np.zeros((L.shape[0], 6, 6))
    a = ea / L
    k[:, 0, 0] = k[:, 3, 3] = a
    k[:, 0, 3] = k[:, 3, 0] = -a
    b = ei / (L**3 * (1.0 + phi))
    k[:, 1, 1] = k[:, 4, 4] = 12.0 * b
    k[:, 1, 4] = k[:, 4, 1] = -12.0 * b
    k[:, 2, 2] = k[:, 5, 5] = b * L**2 * (4.0 + phi)
    k[:, 2, 5] = k[:, 5, 2] = b * L**2 * (2.0 - phi)
    k[:, 1, 2] = k[:, 2, 1] = k[:, 1, 5] = k[:, 5, 1] = 6.0 * b * L
    k[:, 2, 4] = k[:, 4, 2] = k[:, 4, 5] = k[:, 5, 4] = -6.0 * b * L
    return k


def local_mass(length: np.ndarray, rho_a: np.ndarray, rho_i: np.ndarray, phi: np.ndarray) -> np.ndarray:
    """Local consistent mass. ``rho_a`` mass per length (kg/m); ``rho_i`` rotary inertia per
    length (kg m); use rho_i = 0 and phi = 0 for Euler-Bernoulli."""
    L = length
    m = np.zeros((L.shape[0], 6, 6))
    c = rho_a * L / 210.0
    m[:, 0, 0] = m[:, 3, 3] = 70.0 * c
    m[:, 0, 3] = m[:, 3, 0] = 35.0 * c
    cz = c / (1.0 + phi) ** 2
    p2 = phi**2
    m[:, 1, 1] = m[:, 4, 4] = cz * (70.0 * p2 + 147.0 * phi + 78.0)
    m[:, 1, 4] = m[:, 4, 1] = cz * (35.0 * p2 + 63.0 * phi + 27.0)
    m[:, 2, 2] = m[:, 5, 5] = cz * L**2 / 4.0 * (7.0 * p2 + 14.0 * phi + 8.0)
    m[:, 2, 5] = m[:, 5, 2] = -cz * L**2 / 4.0 * (7.0 * p2 + 14.0 * phi + 6.0)
    m[:, 1, 2] = m[:, 2, 1] = cz * L / 4.0 * (35.0 * p2 + 77.0 * phi + 44.0)
    m[:, 4, 5] = m[:, 5, 4] = -m[:, 1, 2]
    m[:, 1, 5] = m[:, 5, 1] = -cz * L / 4.0 * (35.0 * p2 + 63.0 * phi + 26.0)
    m[:, 2, 4] = m[:, 4, 2] = -m[:, 1, 5]
    # rotary inertia of the cross-section (Timoshenko only)
    r = rho_i / (30.0 * L * (1.0 + phi) ** 2)
    m[:, 1, 1] += 36.0 * r
    m[:, 4, 4] += 36.0 * r
    m[:, 1, 4] -= 36.0 * r
    m[:, 4, 1] -= 36.0 * r
    m[:, 2, 2] += r * L**2 * (10.0 * p2 + 5.0 * phi + 4.0)
    m[:, 5, 5] += r * L**2 * (10.0 * p2 + 5.0 * phi + 4.0)
    m[:, 2, 5] += r * L**2 * (5.0 * p2 - 5.0 * phi - 1.0)
    m[:, 5, 2] += r * L**2 * (5.0 * p2 - 5.0 * phi - 1.0)
    s = -r * L * (15.0 * phi - 3.0)
    for i, j in ((1, 2), (2, 1), (1, 5), (5, 1)):
        m[:, i, j] += s
    for i, j in ((2, 4), (4, 2), (4, 5), (5, 4)):
        m[:, i, j] -= s
    return m


def cracked_bending_stiffness(length: np.ndarray, ei: np.ndarray, position: np.ndarray,
                              compliance: np.ndarray) -> np.ndarray:
    """Local 6x6 stiffness of the bending part of Euler-Bernoulli elements with a crack: a
    rotational compliance (rad / N m) at `position` (fraction of the length from node i).

    Flexibility formulation: in the simply supported basic system with end moments
    (M_i, M_j), the bending moment is m(xi) = -M_i (1 - xi) + M_j xi; the flexibility is the
    beam's L/(6 EI) [[2, -1], [-1, 2]] plus the crack's c b b^T with b = (-(1 - xi), xi).
    The stiffness is Gamma^T f^-1 Gamma, Gamma mapping (v_i, th_i, v_j, th_j) to the chord-
    relative end rotations. With c = 0 it is the Hermite-cubic stiffness.
    """
    b = np.stack([-(1.0 - position), position], axis=1)
    return flexibility_bending_stiffness(length, ei, compliance[:, None, None] * b[:, :, None] * b[:, None, :])


def zone_flexibility(length: np.ndarray, ei: np.ndarray, start: np.ndarray, end: np.ndarray,
                     ratio: np.ndarray) -> np.ndarray:
    """The end-moment flexibility (n, 2, 2) a zone [start, end] (fractions of the length) of
    bending stiffness ratio * EI adds to an element: (1/ratio - 1) / EI times the integral
    of b b^T over the zone, b = (-(1 - xi), xi) as in `cracked_bending_stiffness` (exact:
    the integrand is quadratic). The whole element (0, 1) gives the uniform beam's
    flexibility times (1/ratio - 1)."""
    s, e = start, end
    i11 = ((1.0 - s) ** 3 - (1.0 - e) ** 3) / 3.0
    i22 = (e**3 - s**3) / 3.0
    i12 = -((e**2 - s**2) / 2.0 - (e**3 - s**3) / 3.0)
    g = np.stack([np.stack([i11, i12], -1), np.stack([i12, i22], -1)], -2)
    return ((1.0 / ratio - 1.0) * length / ei)[:, None, None] * g


def flexibility_bending_stiffness(length: np.ndarray, ei: np.ndarray, extra: np.ndarray) -> np.ndarray:
    """Local 6x6 bending stiffness of Euler-Bernoulli elements whose end-moment flexibility is
    the uniform beam's L/(6 EI) [[2, -1], [-1, 2]] plus `extra` (n, 2, 2): a crack, a weak
    zone (see `cracked_bending_stiffness` for the basic system)."""
    L = length
    n = L.shape[0]
    f = np.empty((n, 2, 2))
    f[:] = np.array([[2.0, -1.0], [-1.0, 2.0]])
    f *= (L / (6.0 * ei))[:, None, None]
    f += extra
    kb = np.linalg.inv(f)
    gamma = np.zeros((n, 2, 4))
    gamma[:, :, 0] = (1.0 / L)[:, None]
    gamma[:, :, 2] = (-1.0 / L)[:, None]
    gamma[:, 0, 1] = 1.0
    gamma[:, 1, 3] = 1.0
    k4 = np.swapaxes(gamma, 1, 2) @ kb @ gamma
    k = np.zeros((n, 6, 6))
    idx = np.array([1, 2, 4, 5])
    k[:, idx[:, None], idx[None, :]] = k4
    return k


def weighted_stiffness(length: np.ndarray, area: np.ndarray, inertia: np.ndarray, w: tuple) -> np.ndarray:
    """Local Euler-Bernoulli stiffness of elements whose modulus varies as E w(xi), w piecewise
    linear through w = (w(0), w(1/2), w(1)) (per unit E).

    Axial: EA/L times the mean of w. Bending: the integral of EI w B^T B, B the curvatures of
    the Hermite cubics (linear in xi): on each half the integrand is cubic, so two Gauss
    points per half are exact. w = (1, 1, 1) gives `local_stiffness` with phi = 0.
    """
    L = length
    n = L.shape[0]
    w0, wm, w1 = w
    k = np.zeros((n, 6, 6))
    a = area / L * 0.25 * (w0 + 2.0 * wm + w1)
    k[:, 0, 0] = k[:, 3, 3] = a
    k[:, 0, 3] = k[:, 3, 0] = -a
    idx = np.array([1, 2, 4, 5])
    g = 0.5 / np.sqrt(3.0)
    for lo, wa, wb in ((0.0, w0, wm), (0.5, wm, w1)):
        for t in (0.5 - g, 0.5 + g):
            xi = lo + 0.5 * t
            b = np.stack([(-6.0 + 12.0 * xi) / L**2, (-4.0 + 6.0 * xi) / L,
                          (6.0 - 12.0 * xi) / L**2, (-2.0 + 6.0 * xi) / L], axis=1)
            wt = wa * (1.0 - t) + wb * t
            k[:, idx[:, None], idx[None, :]] += (0.25 * L * inertia * wt)[:, None, None] * b[:, :, None] * b[:, None, :]
    return k


#: From this many elements `to_global` transforms each distinct (a, T) once.
DISTINCT_MIN = 16


def to_global(local: np.ndarray, t: np.ndarray) -> np.ndarray:
    """T^T a T for a stack of element matrices a (n, 6, 6) and transformations T (n, 6, 6), any
    (`rotation`'s or another's).

    A frame's elements repeat (a regular grid: a few lengths, angles and sections): from
    `DISTINCT_MIN` elements each distinct pair (a, T), compared by their bytes, is transformed
    once and copied to the others. The same numbers bit for bit: an element's product does not
    depend on the others in its stack (tests/test_element_reuse.py)."""
    n = len(local)
    if n >= DISTINCT_MIN:
        # each pair's bits (all of a and all of T: any T, not only `rotation`'s) hashed to one
        # integer, the pairs grouped by hash, and a group taken as one pair only if its members'
        # bits are all the same
        bits = np.ascontiguousarray(np.concatenate([local.reshape(n, -1), t.reshape(n, -1)], axis=1),
                                    dtype=np.float64).view(np.uint64)
        _, first, back = np.unique((bits * _MIX[: bits.shape[1]]).sum(axis=1), return_index=True,
                                   return_inverse=True)
        back = back.ravel()
        if len(first) < n and np.array_equal(bits[first][back], bits):
            return np.einsum("eki,ekl,elj->eij", t[first], local[first], t[first])[back]
    return np.einsum("eki,ekl,elj->eij", t, local, t)


#: Odd 64-bit multipliers of `to_global`'s hash (fixed: the same grouping in every run).
_MIX = np.random.default_rng(20261127).integers(1, 2**63, 72, dtype=np.uint64) * np.uint64(2) + np.uint64(1)


def interpolate(length: np.ndarray, cos: np.ndarray, sin: np.ndarray, ends: np.ndarray, smooth: np.ndarray,
                xi: np.ndarray) -> np.ndarray:
    """Displacement (n_el, n_points, 2) in global x, y (m) along elements at fractions `xi`
    (n_points,) of their length, from the end values `ends` (n_el, 6) in global axes.

    Axial displacement is linear; transverse the Hermite cubic of the end displacements and
    rotations where `smooth` (n_el,) is True, as in the element itself, else linear (an
    element whose ends' own rotations are not the nodes' rotations)."""
    c, s = cos[:, None], sin[:, None]
    ui, uj = ends[:, 0:3], ends[:, 3:6]
    axial_i, axial_j = cos * ui[:, 0] + sin * ui[:, 1], cos * uj[:, 0] + sin * uj[:, 1]
    trans_i, trans_j = -sin * ui[:, 0] + cos * ui[:, 1], -sin * uj[:, 0] + cos * uj[:, 1]
    xi = xi[None, :]
    L = length[:, None]
    hermite = ((1 - 3 * xi**2 + 2 * xi**3) * trans_i[:, None] + L * (xi - 2 * xi**2 + xi**3) * ui[:, 2][:, None]
               + (3 * xi**2 - 2 * xi**3) * trans_j[:, None] + L * (xi**3 - xi**2) * uj[:, 2][:, None])
    linear = (1 - xi) * trans_i[:, None] + xi * trans_j[:, None]
    trans = np.where(smooth[:, None], hermite, linear)
    axial = (1 - xi) * axial_i[:, None] + xi * axial_j[:, None]
    return (axial[..., None] * np.stack([c, s], -1)
            + trans[..., None] * np.stack([-s, c], -1))

