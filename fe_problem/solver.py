"""The one modal solver: batched dense eigen-solves of K(theta) phi = omega^2 M(theta) phi
for a whole population theta at once, over the affine matrices of assembly.py.

With a constant mass matrix (no mass or density parameter) the problem is put once in
mass-normalised coordinates, A(theta) = L^-1 K(theta) L^-T with M = L L^T, and the motions
no parameter can strain (rigid-body modes of a free structure) are projected out once; each
evaluation is then one contraction and one `numpy.linalg.eigvalsh`/`eigh` on the stack.

DOFs without mass (`massless`: the rotations of lumped-mass beams, a pinned end's released
rotation) carry no inertia force, so they are condensed out exactly for each theta:
K_c = K_aa - K_ab K_bb^-1 K_ba on the massed DOFs a, solved with M_aa, and the massless
components recovered as phi_b = -K_bb^-1 K_ba phi_a (batched solves, `_condensed`).
"""

from __future__ import annotations

import numpy as np


def cholesky(m: np.ndarray, name: str) -> np.ndarray:
    """Lower Cholesky factor of mass matrices (..., n, n); ValueError naming model `name`
    if one is not positive definite."""
    try:
        return np.linalg.cholesky(m)
    except np.linalg.LinAlgError:
        raise ValueError(f"model {name!r}: the mass matrix is not positive definite "
                         "(a DOF with no mass: a released end of a massless element, or a zero density)") from None


#: Entries within this fraction of a shape's largest |entry| count as tied for the sign rule.
SIGN_TIE = 1e-8


def signed(phi: np.ndarray) -> np.ndarray:
    """Shapes (..., n, m) signed so that the entry that decides is positive: the first (lowest
    row) whose magnitude is within `SIGN_TIE` of the largest. A symmetric structure has
    modes whose two largest entries are equal and opposite; a plain argmax would let
    rounding (a different factorisation, BLAS) choose between them and flip the shape."""
    a = np.abs(phi)
    first = np.argmax(a >= (1.0 - SIGN_TIE) * _column_max(a), axis=-2)
    big = np.take_along_axis(phi, first[..., None, :], axis=-2)
    return phi * np.where(big < 0, -1.0, 1.0)


def _column_max(a: np.ndarray) -> np.ndarray:
    """a.max(axis=-2, keepdims=True), exactly. When the rows are not adjacent in memory (a
    C-ordered tall (n, m) array with few columns), by halving the rows with np.maximum: numpy's
    reduction walks such an array a row at a time; along adjacent rows (ARPACK's column-major
    shapes) its own reduction is faster. Per call on a 3,024 x 14 array, one run at load 2.5:
    111 us by numpy against 31 us halved (C order), 6 us by numpy (Fortran order), from
    `python -m timeit -s "import numpy as np; from fe_problem.solver import _column_max;
    a = np.random.default_rng(0).random((3024, 14))" "_column_max(a)"` (and "a.max(axis=-2,
    keepdims=True)"; np.asfortranarray(...) for the last)."""
    if a.ndim < 2 or a.strides[-2] == a.itemsize:
        return a.max(axis=-2, keepdims=True)
    while a.shape[-2] > 1:
        h = a.shape[-2] // 2
        top = np.maximum(a[..., :h, :], a[..., h:2 * h, :])
        if a.shape[-2] % 2:
            np.maximum(top[..., :1, :], a[..., 2 * h:, :], out=top[..., :1, :])
        a = top
    return a


def _rayleigh(phi: np.ndarray, k: np.ndarray, m: np.ndarray, vectors: bool, rows):
    """Eigenvalues as the Rayleigh quotients phi^T K phi / phi^T M phi of approximate shapes phi
    (b, n, m) on the full K and M (b, n, n), and with `vectors` the shapes mass-normalised against
    that M and signed (at `rows` if given): the refinement `_eigen_condensed` and
    `_eigen_varying_mass` share (the latter's docstring says why it is needed)."""
    mass = np.einsum("bim,bim->bm", phi, m @ phi)
    lam = np.einsum("bim,bim->bm", phi, k @ phi) / mass
    if not vectors:
        return lam, None
    phi = signed(phi / np.sqrt(mass)[:, None, :])
    return lam, (phi if rows is None else take_rows(phi, rows))


def take_rows(phi: np.ndarray, rows) -> np.ndarray:
    """Shapes (b, n_free, k) at free-DOF `rows`: (b, len(rows), k), zero where a row is -1."""
    rows = np.asarray(rows)
    out = phi[:, np.maximum(rows, 0), :]
    out[:, rows < 0, :] = 0.0
    return out


class ModalSolver:
    """Eigen-solves of K0 + sum theta_k dK_k, M0 + sum theta_k dM_k (free DOFs only).

    Zero-energy modes are dropped: the `n_body` rigid-body motions the supports allow at the
    initial parameters `x0` (known from the geometry; `n_null` of them, default all, strained by
    no term at any theta) and any other motion nothing strains at `x0` (a mechanism); `n_rigid`
    counts them and `n_elastic` the modes left. `name` names the model in errors.
    """

    #: An eigenvalue below this fraction of the 12th lowest is a zero-energy mode (the sparse
    #: path's rule; relative to the largest eigenvalue, a fine mesh's axial stiffness would make
    #: its first real mode look like zero)
    ZERO_TOL = 1e-8

    def __init__(self, k0: np.ndarray, m0: np.ndarray, dk: np.ndarray, dm: np.ndarray, x0: np.ndarray,
                 name: str, n_body: int = 0, n_null: int | None = None, massless=()):
        self.k0, self.m0, self.dk, self.dm, self.name = k0, m0, dk, dm, name
        self.n_free = k0.shape[0]
        self.mass_constant = not np.any(dm)
        #: free DOFs without mass, condensed out (`_condensed`); empty: the plain solve
        self.massless = np.asarray(massless, dtype=int)
        self.condensed = self.massless.size > 0
        if self.condensed:
            self._split()
            n_fixed_null = 0
        else:
            n_fixed_null = self._project(n_body if n_null is None else n_null) if self.mass_constant else 0
        lam = np.linalg.eigvalsh(self.operator(x0[None, :]))[0]
        # zero modes left in the solve: the rigid-body motions not projected out, and any other
        # motion no element strains at x0 (a mechanism)
        left = n_body - n_fixed_null
        ref = lam[min(len(lam) - 1, left + 11)]
        zero = int(np.sum(lam < self.ZERO_TOL * ref)) if ref > 0 else len(lam)
        self._skip = max(zero, left)
        self.n_rigid = self._skip + n_fixed_null                      # rigid-body modes dropped
        self.n_elastic = self.n_free - self.massless.size - self.n_rigid

    def _project(self, n_null: int) -> int:
        """Set up the mass-normalised operator without the rigid-body motions; returns the
        directions dropped."""
        # Work in mass-normalised coordinates once: A = L^-1 K L^-T with M0 = L L^T.
        self._linv = np.linalg.inv(cholesky(self.m0, self.name))
        a0 = self._linv @ self.k0 @ self._linv.T
        da = self._linv @ self.dk @ self._linv.T        # (p, n, n); matmul, not a 3-operand einsum (O(p n^4))
        # The rigid-body motions that no term strains (`n_null` of them, known from the geometry)
        # are zero modes for any theta: project them out once, so each solve is smaller (39 -> 36
        # DOFs for the free-free H-frame). They are the `n_null` directions on which every term,
        # each normalised by its own size (dA_k is per unit of theta_k, whose range can be
        # anything), is smallest: the terms' own numerical null space. Their number comes from
        # the geometry, not from a tolerance: on a fine mesh a real bending mode is 1e-12 of the
        # axial stiffness, and a tolerance took it for a rigid-body mode.
        terms = [t / np.linalg.norm(t) for t in (a0, *da) if np.linalg.norm(t) > 0]
        _, _, vt = np.linalg.svd(np.vstack(terms), full_matrices=False)  # not the (p n)^2 U
        self._q = vt[: self.n_free - n_null].T      # (n_free, n_kept) orthonormal
        self._a0 = self._q.T @ a0 @ self._q
        k = self._q.shape[1]
        self._da_flat = (self._q.T @ da @ self._q).reshape(len(self.dk), k * k)
        return self.n_free - k

    def _split(self) -> None:
        """Partition K and M into the massed DOFs a and the massless ones b (`massless`; K_bb
        positive definite at x0 is AffineModel's check)."""
        n = self.n_free
        b = self.massless
        a = np.setdiff1d(np.arange(n), b)
        self._a, self._b = a, b
        ia, ib = np.ix_(a, a), np.ix_(a, b)
        self._k_aa, self._k_ab = self.k0[ia], self.k0[ib]
        self._k_bb = self.k0[np.ix_(b, b)]
        self._dk_aa = self.dk[:, a[:, None], a[None, :]]
        self._dk_ab = self.dk[:, a[:, None], b[None, :]]
        self._dk_bb = self.dk[:, b[:, None], b[None, :]]
        self._m_aa, self._dm_aa = self.m0[ia], self.dm[:, a[:, None], a[None, :]]
        if self.mass_constant:
            self._linv = np.linalg.inv(cholesky(self._m_aa, self.name))

    def _condensed(self, theta: np.ndarray):
        """For theta (b, p): the symmetric operators L^-1 K_c L^-T (b, n_a, n_a) of the condensed
        problem (M_aa = L L^T), the factors L^-1 (b, n_a, n_a) and X = K_bb^-1 K_ba (b, n_b, n_a),
        with which phi_b = -X phi_a."""
        k_aa = self._k_aa + np.einsum("bp,pij->bij", theta, self._dk_aa)
        k_ab = self._k_ab + np.einsum("bp,pij->bij", theta, self._dk_ab)
        k_bb = self._k_bb + np.einsum("bp,pij->bij", theta, self._dk_bb)
        try:
            x = np.linalg.solve(k_bb, np.swapaxes(k_ab, 1, 2))
        except np.linalg.LinAlgError:
            raise ValueError(f"model {self.name!r}: the stiffness of the DOFs without mass is singular at "
                             "this point (a massless DOF that nothing holds)") from None
        kc = k_aa - k_ab @ x
        if self.mass_constant:
            linv = np.broadcast_to(self._linv, kc.shape)
        else:
            linv = np.linalg.inv(cholesky(self._m_aa + np.einsum("bp,pij->bij", theta, self._dm_aa), self.name))
        a = linv @ kc @ np.swapaxes(linv, 1, 2)
        return 0.5 * (a + np.swapaxes(a, 1, 2)), linv, x

    def _eigen_condensed(self, theta: np.ndarray, sl: slice, vectors: bool, rows):
        """`eigen` with DOFs without mass: the condensed problem's eigenvectors, their massless
        components recovered, and the eigenvalues refined as the Rayleigh quotients
        phi^T K phi / phi^T M phi on the full K and M (as `_eigen_varying_mass`)."""
        a, linv, x = self._condensed(theta)
        _, y = np.linalg.eigh(a)
        phi_a = np.swapaxes(linv, 1, 2) @ y[:, :, sl]
        phi = np.empty((theta.shape[0], self.n_free, phi_a.shape[2]))
        phi[:, self._a, :] = phi_a
        phi[:, self._b, :] = -(x @ phi_a)
        return _rayleigh(phi, self.stiffness(theta), self.mass(theta), vectors, rows)

    def zero_modes(self, x0: np.ndarray) -> np.ndarray:
        """The zero-energy modes at x0 (n_free, n_rigid), M-normalised (the condensed solve's)."""
        return self._eigen_condensed(x0[None, :], slice(0, self.n_rigid), True, None)[1][0]

    def stiffness(self, theta: np.ndarray) -> np.ndarray:
        """K(theta) on the free DOFs, (b, n, n) for theta (b, p)."""
        return self.k0 + np.einsum("bp,pij->bij", theta, self.dk)

    def mass(self, theta: np.ndarray) -> np.ndarray:
        """M(theta) on the free DOFs, (b, n, n) for theta (b, p)."""
        return self.m0 + np.einsum("bp,pij->bij", theta, self.dm)

    def operator(self, theta: np.ndarray) -> np.ndarray:
        """The symmetric operators (b, n, n) whose eigenvalues are omega^2, for theta (b, p)
        (n: the massed DOFs, where some are condensed out)."""
        if self.condensed:
            return self._condensed(theta)[0]
        if self.mass_constant:
            n = self._a0.shape[0]
            # A stacked (b, 1, p) @ (p, n*n) product computes every row by the same routine, so
            # f(x) does not depend on the batch x comes in (a plain (b, p) @ (p, n*n) does, in
            # the last bits: gemv for one row, gemm tiles for many).
            rows = np.matmul(theta[:, None, :], self._da_flat)[:, 0, :]
            return self._a0 + rows.reshape(theta.shape[0], n, n)
        linv = np.linalg.inv(cholesky(self.mass(theta), self.name))
        return linv @ self.stiffness(theta) @ np.swapaxes(linv, 1, 2)

    def _linv_batch(self, theta: np.ndarray) -> np.ndarray:
        if self.mass_constant:
            return np.broadcast_to(self._linv, (theta.shape[0],) + self._linv.shape)
        return np.linalg.inv(cholesky(self.mass(theta), self.name))

    def eigen(self, theta: np.ndarray, n_modes: int, vectors: bool = False, rows=None):
        """Lowest `n_modes` elastic eigenpairs for a population theta (b, p).

        Returns eigenvalues omega^2 (b, n_modes) in (rad/s)^2 and, with `vectors`, mass-
        normalised shapes on the free DOFs (b, n_free, n_modes), each signed so that its
        largest-magnitude entry is positive (else None); with `rows` (free-DOF rows, -1 for a
        supported DOF: zero) only those rows, (b, len(rows), n_modes).
        ValueError if `n_modes` > `n_elastic`.
        """
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        if n_modes > self.n_elastic:
            raise ValueError(f"model {self.name!r} has only {self.n_elastic} elastic modes, "
                             f"asked for {n_modes}")
        sl = slice(self._skip, self._skip + n_modes)
        if self.condensed:
            return self._eigen_condensed(theta, sl, vectors, rows)
        if not self.mass_constant:
            return self._eigen_varying_mass(theta, sl, vectors, rows)
        a = self.operator(theta)
        if not vectors:
            return np.linalg.eigvalsh(a)[:, sl], None
        lam, y = np.linalg.eigh(a)
        y = y[:, :, sl]
        if self.mass_constant:
            y = self._q @ y
        phi = np.swapaxes(self._linv_batch(theta), 1, 2) @ y
        phi = signed(phi)
        return lam[:, sl], (phi if rows is None else take_rows(phi, rows))

    def _eigen_varying_mass(self, theta: np.ndarray, sl: slice, vectors: bool, rows):
        """`eigen` where M varies with theta: the eigenvalues are refined by Rayleigh quotients.

        A(theta) = L^-1 K L^-T, formed with an explicit inverse of M(theta)'s Cholesky factor,
        carries a rounding error of about eps ||A||; a stiff joint spring beside small rotary
        masses makes ||A|| 1e12 while the modes of interest are 1e5, so its eigenvalues are only
        good to eps ||A|| / lambda (3e-9 measured). Its eigenvectors are good to that error over
        the gap to the next mode, and the Rayleigh quotient phi^T K phi / phi^T M phi on the
        original K and M is correct to the square of that (3e-11 of scipy's generalized eigh
        measured): one more matrix product per point, not another factorisation. So the values
        need `eigh`, not `eigvalsh`, here too.
        """
        k, m = self.stiffness(theta), self.mass(theta)
        linv = np.linalg.inv(cholesky(m, self.name))
        _, y = np.linalg.eigh(linv @ k @ np.swapaxes(linv, 1, 2))
        return _rayleigh(np.swapaxes(linv, 1, 2) @ y[:, :, sl], k, m, vectors, rows)

    def eigen_sensitivities(self, theta: np.ndarray, n_modes: int, rows=None):
        """Eigenvalues, shapes (all free DOFs, or at `rows`) and d(omega^2)/d(theta)
        (b, n_modes, p) for theta (b, p).

        For mass-normalised phi: d lambda / d theta_k = phi^T (dK_k - lambda dM_k) phi.
        """
        lam, phi = self.eigen(theta, n_modes, vectors=True)
        dk = np.einsum("bim,pij,bjm->bmp", phi, self.dk, phi)
        dm = np.einsum("bim,pij,bjm->bmp", phi, self.dm, phi)
        return lam, (phi if rows is None else take_rows(phi, rows)), dk - lam[:, :, None] * dm
