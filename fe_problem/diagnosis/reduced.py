"""A reduced basis shared by the candidate searches of one diagnosis on a large model.

Every candidate of one diagnosis changes the same calibrated model: K(a) = K0 + dK(a),
M(a) = M0 + dM(a). Each point of a candidate's fit was one sparse eigen-solve of its own
system (a factorisation and ARPACK's 30-odd triangular solves). Here a batch of sizes is solved
by Rayleigh-Ritz on a small basis in one batched dense eigen-solve (Kirsch's combined
approximations):

    V = [Phi, A0^-1 R, (A0^-1 M0) A0^-1 R, ...]   (`POWERS` blocks after Phi)

Phi: the calibrated model's lowest `n_modes + EXTRA_MODES` modes; A0 = K0 - sigma M0, the
model's one factorisation (the sparse solver's shift: positive definite), reused by every
candidate; R the candidate's change pattern: the unit vectors of the DOFs a local change
touches (an element's ends, a node: any change on them, linear in a or not, e.g. a weak zone;
`local`). The first block is the static correction of the modes to the change, the next ones
its corrections in frequency. The Ritz values are the Rayleigh quotients of their vectors:
above the true eigenvalues by a term second order in the basis' error (the shapes: first order).

Measured against full sparse solves (tests/test_reduced_basis.py): frequencies within 1e-8
for a local change of stiffness up to half its largest size, within 1e-6 over every grid
(a mass of half the model's at one node: 3e-7). A change spread over many members is not held:
with R = dK Phi (a group's or a trend's moduli, the basis of a first version) the frequencies
were off by up to 4.5e-2 relative for a column line losing 0.9 of its modulus, 9.6e-2 for a
trend, and chi^2 by up to 3.6e4 away from the grid's best point, so those candidates have no
reduced forward on this basis (groups.py). A basis of the change's own series
(`SharedBasis.spread`: powers of A0^-1 dK applied to the modes) holds them far better where they
are ranked and worse as a grows (a trend's frequencies off by 0.1 at its largest size): they are
ranked on it (the best ranked solved in full, `fit.class_promises`) and their fits search on it
(`fit._search_forward`), confirmed like a local change's below, at the points solved only. Even
for a local change the basis serves the
search only: `fit._reduced_fit` solves the search's answer, the grid's best point, the answer
-+ twice the search's tolerance and the best points outside the grid's bracket in full and
falls back to the full grid unless they confirm it (`fit._confirmed_grid`, for
`fit.look_along`: the grid's best point and its neighbours too; a rule of thumb checked at
those points, not a bound), so a fit's answer is always solved in full. A joint's flexibility
adds a DOF, the released end's rotation relative to its node: its basis is the element's local
one and that DOF (`SharedBasis.joint`, solved in flexibility form; frequencies within 1.1e-7 of
full solves over the whole grid of every joint of the planar test frame, 7.3e-8 on a gable's
skew axes down to a = 1e-8, tests/test_reduced_joint.py). Only a model on the sparse path with
no zero-energy mode has a basis; a candidate that is not a local change (shear deformation, a
model-form change, a support, a group), or a joint at an end already released in another
rotation or with a skew release's relative-rotation DOF, has no reduced form.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from ..assembly import AffineModel
from ..modal import frequencies_hz
from ..solver import signed, take_rows

#: Modes of the calibrated model in the basis beyond the candidate's own (`n_modes`).
EXTRA_MODES = 40
#: Blocks of static correction: A0^-1 R, (A0^-1 M0) A0^-1 R, ... (this many).
POWERS = 3
#: Powers of A0^-1 dk in the basis of a spread change (`SharedBasis.spread`).
SPREAD_POWERS = 3
#: Modes of the calibrated model in the basis of a spread change beyond the candidate's own.
SPREAD_EXTRA_MODES = 10
#: Basis vectors whose M0-norm falls below this fraction after orthogonalisation are dropped.
DEPENDENT = 1e-10


class SharedBasis:
    """The calibrated model's factor and modes, and the reduced forward of a candidate's change.

    system: the model's `AffineModel` (no parameters, sparse path, no zero-energy mode);
    coords: the measured (node, direction) pairs; n_modes: modes a forward returns."""

    def __init__(self, system: AffineModel, coords, n_modes: int):
        s = system._solver
        theta = np.zeros(0)
        kd, md = s.k_data(theta), s.m_data(theta)
        self.k0, self.m0 = s.matrix(kd), s.matrix(md)
        self.a0_solve = s._factor(kd - s.sigma * md)
        self.n_modes = min(n_modes, system.n_elastic)
        n_b = min(self.n_modes + EXTRA_MODES, system.n_elastic)
        lam, phi = system.eigen(theta[None, :], n_b, vectors=True)
        self.lam, self.phi = lam[0], phi[0]
        self.n_free = system.n_free
        self.rows = system.nodal_rows(coords)
        pos = np.full(system.dofmap.n_total, -1)
        pos[system.dofmap.free] = np.arange(system.n_free)
        self._pos = pos

    # -- bases ------------------------------------------------------------------------------
    def _basis(self, r: np.ndarray) -> np.ndarray:
        """[Phi, A0^-1 R, (A0^-1 M0) A0^-1 R, ...] (`POWERS` blocks after Phi), M0-orthonormal
        (n_free, n_v)."""
        blocks = [self.a0_solve(r)]
        for _ in range(POWERS - 1):
            blocks.append(self.a0_solve(self.m0 @ blocks[-1]))
        return _m_orthonormal(self.phi, blocks, self.m0)

    def local(self, dofs: np.ndarray, change):
        """The reduced forward of a change on the model DOFs `dofs` (DofMap numbering):
        change(a) -> (dK, dM), each (b, k, k) on those DOFs (dM may be None). Returns
        forward(a) -> (frequencies (b, n_modes) Hz, shapes at the coordinates (b, n_coord, n_modes))."""
        free = self._pos[np.asarray(dofs)]
        keep = free >= 0
        rows = free[keep]
        e = np.zeros((self.n_free, len(rows)))
        e[rows, np.arange(len(rows))] = 1.0
        v = self._basis(e)
        kr0 = v.T @ (self.k0 @ v)
        vs = v[rows]

        def forward(a):
            a = np.atleast_1d(np.asarray(a, dtype=float))
            dk, dm = change(a)
            kr = kr0 + vs.T @ dk[:, keep][:, :, keep] @ vs
            mr = None if dm is None else np.eye(v.shape[1]) + vs.T @ dm[:, keep][:, :, keep] @ vs
            return self._solve(v, kr, mr)
        return forward

    def joint(self, dofs: np.ndarray, kr: np.ndarray, mr: np.ndarray, turn: np.ndarray, ref: float):
        """The reduced forward of an element end released at its node and tied back by a rotational
        spring of stiffness ref / a (N m/rad; a joint's flexibility), on the element's DOFs `dofs`
        (DofMap numbering; an element with no relative-rotation DOF of a skew release): kr, mr the
        element's stiffness and mass columns for a unit rotation `turn` of that end
        (`LocalMatrices.joint_columns`). The released model has one DOF more, the end's rotation
        relative to the node, delta: with (u, delta) its matrices are [[K0, kr], [kr^T, krr +
        ref / a]] and [[M0, mr], [mr^T, mrr]] (krr = turn . kr, mrr = turn . mr; u the model's
        DOFs), exactly. Basis: the element's `local` basis for u and the unit delta (its static
        correction A0^-1 kr is in the local basis' first block already). a = 0 is the rigid joint:
        the local basis alone. Returns forward(a) -> (frequencies (b, n_modes) Hz, shapes at the
        coordinates (b, n_coord, n_modes)), or None where the end's rotation carries no mass
        (mrr <= 0: no Ritz solve)."""
        free = self._pos[np.asarray(dofs)]
        keep = free >= 0
        rows = free[keep]
        krr, mrr = float(turn @ kr), float(turn @ mr)
        if mrr <= 0.0:
            return None
        e = np.zeros((self.n_free, len(rows)))
        e[rows, np.arange(len(rows))] = 1.0
        v = self._basis(e)
        n = v.shape[1]
        kr0 = v.T @ (self.k0 @ v)
        c = 1.0 / np.sqrt(mrr)  # delta scaled to unit mass
        b, bm = c * (v[rows].T @ kr[keep]), c * (v[rows].T @ mr[keep])

        def forward(a):
            a = np.atleast_1d(np.asarray(a, dtype=float))
            hz = np.empty((len(a), self.n_modes))
            shapes = np.empty((len(a), len(self.rows), self.n_modes))
            rigid = a <= 0.0
            if rigid.any():
                r = int(rigid.sum())
                hz[rigid], shapes[rigid] = self._solve_flexibility(v, np.broadcast_to(kr0, (r, n, n)),
                                                                   np.broadcast_to(np.eye(n), (r, n, n)))
            if (~rigid).any():
                m = int((~rigid).sum())
                kk = np.zeros((m, n + 1, n + 1))
                kk[:, :n, :n], kk[:, :n, n], kk[:, n, :n] = kr0, b, b
                kk[:, n, n] = c * c * (krr + ref / a[~rigid])
                mm = np.broadcast_to(np.eye(n + 1), (m, n + 1, n + 1)).copy()
                mm[:, :n, n], mm[:, n, :n] = bm, bm
                hz[~rigid], shapes[~rigid] = self._solve_flexibility(v, kk, mm)
            return hz, shapes
        return forward

    def spread(self, dk: sp.spmatrix):
        """The reduced forward of a change spread over many members, K0 + a dk with M unchanged
        (dk: n_free x n_free on the model's free DOFs; a group's or a trend's moduli), for the
        ranking of those classes (`fit.class_promises`: the classes kept are solved in full)
        and the search of their fits (`fit._search_forward`: its answer confirmed by full solves
        at the points `fit._reduced_fit` checks, else the grid solved in full). Basis: [Phi, (A0^-1 dk) Phi_k, (A0^-1 dk)^2 Phi_k, ..., (A0^-1 M0) A0^-1 dk Phi_k]
        (`SPREAD_POWERS` powers of A0^-1 dk; Phi_k the `n_modes` lowest modes, Phi those and
        `SPREAD_EXTRA_MODES` more), the Krylov space of the change's own series rather than of
        the frequency alone (R = dk Phi with powers of A0^-1 M0 alone, the first version, was
        off by up to 9.6e-2). On the 3,024-DOF benchmark frame, every one of its 244 classes at
        the sizes ranked (the step and the look along's, to 0.42 of the largest): the paired
        modes' frequencies within 2.1e-5 relative, chi^2 within 1.7e-4 relative (7.6 of 1.5e5,
        a quadratic trend); the unpaired higher modes and the largest sizes are held worse (a
        trend's frequencies off by 0.1 at its largest size). Returns
        forward(a) -> (frequencies (b, n_modes) Hz, shapes at the coordinates)."""
        phi = self.phi[:, :self.n_modes + SPREAD_EXTRA_MODES]
        blocks = [self.a0_solve(np.asarray(dk @ phi[:, :self.n_modes]))]
        for _ in range(SPREAD_POWERS - 1):
            blocks.append(self.a0_solve(np.asarray(dk @ blocks[-1])))
        blocks.append(self.a0_solve(self.m0 @ blocks[0]))
        v = _m_orthonormal(phi, [np.hstack(blocks)], self.m0)
        kr0, dkr = v.T @ (self.k0 @ v), v.T @ (dk @ v)

        def forward(a):
            a = np.atleast_1d(np.asarray(a, dtype=float))
            return self._solve(v, kr0[None] + a[:, None, None] * dkr[None], None)
        return forward

    # -- the batched Rayleigh-Ritz solve ----------------------------------------------------
    def _solve(self, v: np.ndarray, kr: np.ndarray, mr: np.ndarray | None):
        """Lowest `n_modes` Ritz pairs of (kr, mr) (b, n_v, n_v; mr None: identity): frequencies
        (b, n_modes) Hz, shapes at the coordinates signed by the solvers' rule."""
        kr = 0.5 * (kr + np.swapaxes(kr, -1, -2))
        if mr is None:
            lam, y = np.linalg.eigh(kr)
        else:
            mr = 0.5 * (mr + np.swapaxes(mr, -1, -2))
            l = np.linalg.cholesky(mr)
            li = np.linalg.inv(l)
            lam, w = np.linalg.eigh(li @ kr @ np.swapaxes(li, -1, -2))
            y = np.swapaxes(li, -1, -2) @ w
        k = self.n_modes
        return self._pairs(v, lam[:, :k], y[:, :, :k])

    def _solve_flexibility(self, v: np.ndarray, kr: np.ndarray, mr: np.ndarray):
        """As `_solve`, in flexibility form: with kr = L L^T (Cholesky), the largest eigenvalues
        mu of L^-1 mr L^-T, lambda = 1 / mu, y = L^-T w / sqrt(mu) (mr-orthonormal). eigh's
        absolute error is about eps times the largest eigenvalue of the matrix it is given: in
        stiffness form that is the joint's stiff spring (`joint`: its entry grows as 1 / a), so
        the low eigenvalues lost precision as a joint stiffened (on the 2 x 8 test frame, a beam's
        end, relative to full solves: 4.3e-6 at a = 1e-6, 7.7e-4 at 1e-8); in flexibility form it
        is the lowest mode's 1 / lambda, so the modes kept are held to relative precision."""
        kr = 0.5 * (kr + np.swapaxes(kr, -1, -2))
        mr = 0.5 * (mr + np.swapaxes(mr, -1, -2))
        li = np.linalg.inv(np.linalg.cholesky(kr))
        mu, w = np.linalg.eigh(li @ mr @ np.swapaxes(li, -1, -2))
        k = self.n_modes
        mu, w = mu[:, ::-1][:, :k], w[:, :, ::-1][:, :, :k]  # the largest mu: the lowest modes
        y = (np.swapaxes(li, -1, -2) @ w) / np.sqrt(mu)[:, None, :]
        return self._pairs(v, 1.0 / mu, y)

    def _pairs(self, v: np.ndarray, lam: np.ndarray, y: np.ndarray):
        """Frequencies (b, n_modes) Hz and shapes at the coordinates, signed by the solvers' rule,
        of the Ritz pairs (lam (b, n_modes) rad^2/s^2, y (b, >= n_v, n_modes) mr-orthonormal)."""
        y = y[:, :v.shape[1], :]  # a joint's released rotation (`joint`) is no model DOF
        # the shapes (b, n_free, n_modes) laid out mode by mode, (v y)^T = y^T v^T: the sign
        # rule's reductions over the DOFs then run along contiguous memory (3,024 DOFs, 66 basis
        # vectors: 0.9 against 1.1 ms a batch of one size, 13 against 15.5 ms of 19; the same
        # products to rounding, bit for bit with this venv's OpenBLAS: tests/test_reduced_basis.py)
        phi = signed(np.swapaxes(np.swapaxes(y, -1, -2) @ v.T, -1, -2))
        return frequencies_hz(lam), take_rows(phi, self.rows)


def reduced_joint(st, element_id: int, node: int, ref: float, rotation):
    """The reduced-forward factory (`Candidate.reduced`) of a joint's flexibility at the end of
    `element_id` at `node` (`SharedBasis.joint`; `rotation` as `LocalMatrices.joint`): None
    (no reduced form) for an element with a skew release's relative-rotation DOF, or where the
    diagnosis has no shared basis. Built afresh at each call, as `candidates.reduced_linear`."""
    def make():
        local = st.local
        row = local.row[element_id]
        if st.basis is None or row in local.dofmap.extended:
            return None
        kr, mr, turn = local.joint_columns(element_id, node, rotation)
        return st.basis.joint(local.dofmap.element_dofs[row], kr, mr, turn, ref)
    return make


def _m_orthonormal(phi: np.ndarray, blocks: list[np.ndarray], m: sp.spmatrix) -> np.ndarray:
    """[phi, each block made M-orthogonal to phi and the blocks before it, M-orthonormal]: phi
    (M-orthonormal modes) is kept as it is, so the basis holds the model's modes exactly. Each
    block is projected out of the basis so far twice (classical Gram-Schmidt, reorthogonalised),
    its columns scaled to unit M-norm, and made M-orthonormal by the eigen-decomposition of its
    Gram matrix; a direction below `DEPENDENT` of its block's largest, or a column that
    the projection left below `DEPENDENT` of its norm, is dropped (already in the basis)."""
    q = phi
    for block in blocks:
        v = block
        for _ in range(2):
            mv = m @ v  # one product for the norm before and the projection
            before = np.sqrt(np.einsum("ij,ij->j", v, mv))
            v = v - q @ (q.T @ mv)
            norm = np.sqrt(np.einsum("ij,ij->j", v, m @ v))
            ok = norm > DEPENDENT * np.maximum(before, 1e-300)
            v = v[:, ok] / norm[ok]
            if not v.shape[1]:
                break
            g = v.T @ (m @ v)
            w, u = np.linalg.eigh(0.5 * (g + g.T))
            keep = w > DEPENDENT * w.max()
            v = v @ (u[:, keep] / np.sqrt(w[keep]))
        if v.shape[1]:
            q = np.hstack([q, v])
    return q


__all__ = ["EXTRA_MODES", "POWERS", "SharedBasis", "reduced_joint"]
