"""The sparse modal solver: the lowest modes of K(theta) phi = omega^2 M(theta) phi by
shift-invert Lanczos, for models too large for the dense batched path (solver.py).

K and M share one CSR pattern on the free DOFs, fixed at construction: each matrix's values
are `c0 + G @ theta` with G a sparse (nnz, p) map, so a point costs O(nnz) to build and no
per-parameter matrix is ever dense. Each point factorises A = K - sigma M once (CHOLMOD's
simplicial LDL^T on an analysis kept per model, `CHOLMOD_MODE`; SuperLU, `scipy.sparse.linalg.splu`,
where scikit-sparse is absent) and runs ARPACK (`scipy.sparse.linalg.eigsh`, shift-invert mode)
from a fixed start vector, so a point's modes do not depend on the points solved before it or
beside it. The eigenvalues returned are the Rayleigh quotients phi^T K phi / phi^T M phi of
ARPACK's vectors, free of the factorisation's rounding that its Ritz values carry (`_modes`).
The shift sigma is negative (a fraction of the first elastic eigenvalue at the initial
parameters), so A is positive definite even for a free-free structure; its zero-energy modes
(rigid-body motions, mechanisms), counted at the initial parameters, are computed and dropped
as the dense path drops them.

A batch of points on a model of `PARALLEL_MIN_DOFS` free DOFs or more is split over `workers`
processes: this one and a pool of worker processes shared by all models (_pool.py: started
without importing the user's main module; SuperLU and the ARPACK driver hold the GIL, so threads
gave no speed-up), each with one BLAS thread. The points are
independent and each is solved by the same code from the same start vector, so the result is
the same for any worker count and any batch.
"""

from __future__ import annotations

import multiprocessing
import os
import pickle
import threading
import uuid

import numpy as np
import scipy.linalg
import scipy.sparse as sp
from scipy.sparse.linalg import ArpackNoConvergence, LinearOperator, eigsh, splu

from . import _pool
from .solver import signed

try:  # the Cholesky path: an optional extra (`pip install femu-bench[cholmod]`, needs libsuitesparse-dev)
    from sksparse import cholmod as _cholmod
except ImportError:  # SuperLU then: the same frequencies to 1e-10, slower per point (docs/scale.md)
    _cholmod = None

#: Factorisations of K - sigma M: "cholmod" (sparse Cholesky, scikit-sparse) and "superlu" (scipy).
FACTORIZATIONS = ("cholmod", "superlu")


def default_factorization() -> str:
    """"cholmod" when scikit-sparse is installed, else "superlu"."""
    return "superlu" if _cholmod is None else "cholmod"


#: CHOLMOD's factorisation: simplicial LDL^T. On the scale frames (benchmarks/scale_frames.py) it
#: factors and solves about twice as fast as the supernodal LL^T that mode "auto" chooses (3,000
#: and 9,000 DOFs: 39 + 56 ms against 27 + 29 ms for a factor and ARPACK's 41 solves at 9,000,
#: with 25 % less fill): a frame's factor has small supernodes, so dense blocks gain nothing and
#: cost their padding. LDL^T does not stop on an indefinite matrix as LL^T does: `_factor` checks D.
CHOLMOD_MODE = "simplicial"


#: ARPACK's relative tolerance on the Ritz values of the shift-invert operator. The requirement:
#: no frequency moves by more than 1e-10 relative against tol=0 (machine precision). Measured on
#: the scale frames (300-9,000 DOFs, 10 modes; benchmarks/arpack_tolerance.py): at most 3e-12,
#: for fewer solves per point; tests/test_sparse_cholesky.py holds it to 1e-10.
ARPACK_TOL = 1e-10


#: Free DOFs from which a batch of points is split over worker processes (below: one process).
#: Measured at 300 DOFs (8 points, 10 modes): the parent's CPU time per point went from 4.40 ms
#: with one process to 2.34 ms with two, so splitting costs about 0.1 ms a point.
PARALLEL_MIN_DOFS = 200


#: Environment variable that fixes the processes of a batch (`default_workers`); the study
#: executors set it to 1 in the processes that run a study's runs, whose own parallelism is the
#: study's (its --workers): a run's batches must not start processes of their own there.
WORKERS_ENV = "FEMU_SOLVER_WORKERS"


def default_workers() -> int:
    """Processes for a batch of points: `FEMU_SOLVER_WORKERS` when set, else the cores this
    process may use (at most 8); 1 inside a daemonic process (a worker of a pool, which may not
    start processes of its own)."""
    if multiprocessing.current_process().daemon:
        return 1
    env = os.environ.get(WORKERS_ENV, "").strip()
    if env:
        try:
            return max(1, int(env))
        except ValueError:
            raise ValueError(f"{WORKERS_ENV}={env!r}: not a whole number of processes") from None
    try:
        n = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        n = os.cpu_count() or 1
    return max(1, min(n, 8))


class _Direct(LinearOperator):
    """The square operator (n x n) whose `matvec` is the function `f` itself, for eigsh's use:
    eigsh calls `aslinearoperator(op).matvec` with (n,) float64 vectors two or three times per
    Lanczos step, and LinearOperator's own `matvec` checks and reshapes around its function each
    time. So `matvec` takes (n,) float64 only (what `f` accepts: `_csr_product` raises on
    anything else, including the (n, 1) that LinearOperator sends `op @ X` to `matvec` with);
    `op @ X` for X (n, k), k > 1, applies `f` column by column and returns (n, k)."""

    def __init__(self, f, n: int):
        super().__init__(np.dtype(float), (n, n))
        self.matvec = f

    def _matvec(self, x: np.ndarray) -> np.ndarray:
        return self.matvec(x)

    def _matmat(self, x: np.ndarray) -> np.ndarray:
        return np.column_stack([self.matvec(np.ascontiguousarray(x[:, j])) for j in range(x.shape[1])])


def _csr_product(a: sp.csr_matrix):
    """v -> a @ v for a CSR matrix of floats (m x n), v: (n,) float64, eigsh's use: the kernel
    `a @ v` runs (scipy's `csr_matvec` into zeros, the same sums in the same order) without the
    sparse dispatch layers around it, and a v of another shape or type raises ValueError (the
    kernel itself would read past a short buffer); `a @ v` itself if that kernel is not where
    it was (tests/test_sparse.py holds the two identical)."""
    matvec = getattr(getattr(sp, "_sparsetools", None), "csr_matvec", None)
    if matvec is None or a.format != "csr" or a.dtype != np.float64:
        return a.__matmul__
    m, n = a.shape
    indptr, indices, data = a.indptr, a.indices, a.data

    def product(v: np.ndarray) -> np.ndarray:
        if v.shape != (n,) or v.dtype != np.float64:
            raise ValueError(f"_csr_product: v must be ({n},) float64, got {v.shape} {v.dtype}")
        out = np.zeros(m)
        matvec(m, n, indptr, indices, data, v, out)
        return out
    return product


#: The sparsity patterns of the last few systems, most recent first: (n, lin, rows, cols,
#: indptr), lin the sorted entries row * n + col. A diagnosis builds hundreds of systems of one
#: model (a parameter on an element, a spring, a section changed) on the same pattern: a new
#: system's entries are looked up in a kept pattern instead of sorted anew (`_pattern`).
_PATTERNS: list[tuple] = []
#: CHOLMOD's analyses of the last few patterns (indptr, indices, analysis): a pattern met again
#: in this process is not analysed again (`SparseModalSolver._analysis`).
_ANALYSES: list[tuple] = []
_KEEP_PATTERNS = 3
#: Held while `_PATTERNS` or `_ANALYSES` is changed: systems may be built on several threads.
_KEPT_LOCK = threading.Lock()


def _to_front(kept: list, entry: tuple) -> None:
    """Put `entry` first in `kept` (a module list of `_KEEP_PATTERNS` at most), under the lock:
    the list is rebuilt from one read, so no thread pops or inserts by a stale index."""
    with _KEPT_LOCK:
        kept[:] = ([entry] + [e for e in kept if e is not entry])[:_KEEP_PATTERNS]


def _same_pattern(indptr: np.ndarray, cols: np.ndarray, other_indptr: np.ndarray, other_cols: np.ndarray) -> bool:
    """Whether two CSC patterns (indptr, row indices) are the same (the same arrays, or equal)."""
    return ((indptr is other_indptr or np.array_equal(indptr, other_indptr))
            and (cols is other_cols or np.array_equal(cols, other_cols)))


def _pattern(keys: np.ndarray, n: int):
    """((lin, rows, cols, indptr), slot) of the entries keys = row * n + col (n x n): lin the
    sorted distinct keys, their rows and columns, the CSR row pointer, and each key's position
    in lin; `np.unique(keys, return_inverse=True)`'s, from a kept pattern (`_PATTERNS`) when
    the keys fill exactly its entries (checked: every key found, every entry hit)."""
    for entry in list(_PATTERNS):  # a copy: read once
        m, lin, *arrays = entry
        if m != n or len(keys) < len(lin):
            continue
        slot = np.minimum(np.searchsorted(lin, keys), len(lin) - 1)
        if np.array_equal(lin[slot], keys) and np.bincount(slot, minlength=len(lin)).all():
            _to_front(_PATTERNS, entry)
            return (lin, *arrays), slot
    lin, slot = np.unique(keys, return_inverse=True)
    rows = lin // n
    made = (lin, rows, lin % n, np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=n))]))
    _to_front(_PATTERNS, (n,) + made)
    return made, slot.ravel()


def _dense_lowest(k: np.ndarray, m: np.ndarray, count: int, sigma: float):
    """The `count` lowest eigenpairs of K phi = lambda M phi (dense), M-normalised. Where M is
    singular (DOFs without mass) the pencil (M, K - sigma M) is solved instead, K - sigma M
    positive definite: its eigenvalues mu = 1 / (lambda - sigma) are 0 for the infinite
    eigenvalues of the massless directions, and only the pairs with mu > 0 are returned."""
    try:
        return scipy.linalg.eigh(k, m, subset_by_index=(0, count - 1))
    except np.linalg.LinAlgError:
        n = len(k)
        mu, phi = scipy.linalg.eigh(m, k - sigma * m, subset_by_index=(n - count, n - 1))
        keep = mu > 1e-12 * mu[-1]
        mu, phi = mu[keep][::-1], phi[:, keep][:, ::-1]
        phi = phi / np.sqrt(np.einsum("im,im->m", phi, m @ phi))
        return sigma + 1.0 / mu, phi


class SparseModalSolver:
    """Eigen-solves of K0 + sum theta_k dK_k, M0 + sum theta_k dM_k (free DOFs) from triplets.

    k_trip, m_trip: (rows, cols, vals, term) on the free DOFs, term -1 for the constant part
    and k for parameter k (terms.py). `n_rigid` counts the zero-energy modes at `x0` (dropped):
    the eigenvalues below `ZERO_TOL` of the 12th, and at least `min_zero` (the rigid-body
    motions the supports allow, known from the geometry). `n_elastic`: the modes left. `name`
    names the model in errors. `x0_modes`: for a system with no parameter (solved at x0 only),
    the elastic modes the caller will ask for: the count's solve then finds those too, with
    their vectors (at the provisional shift), and `eigen` returns them without a second solve.
    `n_finite`: how many eigenvalues are finite (default n; fewer where M is singular, the DOFs
    without mass of a matrix model): no more modes than these are asked of ARPACK, whose
    shift-invert mode takes M positive semi-definite (the massless directions are the
    eigenvalue 0 of the inverted operator, never among the largest).
    """

    #: An eigenvalue below this fraction of the first clearly elastic one is a zero-energy mode.
    ZERO_TOL = 1e-8
    #: The shift is -SHIFT times the first elastic eigenvalue at the initial parameters.
    SHIFT = 0.5

    def __init__(self, k_trip, m_trip, n: int, x0: np.ndarray, name: str, workers: int | None = None,
                 min_zero: int = 0, factorization: str | None = None, arpack_tol: float = ARPACK_TOL,
                 x0_modes: int = 0, count_from: "SparseModalSolver | None" = None, n_finite: int | None = None):
        self.n_free, self.name, self.n_params = n, name, len(x0)
        # the eigenvalues that are finite: n, or fewer where M is singular (DOFs without mass, a
        # matrix model's: their eigenvalues are infinite, 1/(lambda - sigma) = 0 in shift-invert)
        self.n_finite = n if n_finite is None else int(n_finite)
        self.workers = default_workers() if workers is None else int(workers)
        self.factorization = default_factorization() if factorization is None else factorization
        if self.factorization not in FACTORIZATIONS or (self.factorization == "cholmod" and _cholmod is None):
            raise ValueError(f"factorization must be one of {FACTORIZATIONS} (cholmod needs scikit-sparse), "
                             f"got {self.factorization!r}")
        self.arpack_tol = float(arpack_tol)
        self._symbolic = None  # CHOLMOD's analysis of the pattern: made on first use in each process
        rows = np.concatenate([k_trip[0], m_trip[0]])
        cols = np.concatenate([k_trip[1], m_trip[1]])
        (lin, self.rows, self.cols, self.indptr), slot = _pattern(rows * n + cols, n)
        nk = len(k_trip[0])
        self.k_data0, self.gk = self._affine(slot[:nk], k_trip, len(lin))
        self.m_data0, self.gm = self._affine(slot[nk:], m_trip, len(lin))
        self.mass_constant = self.gm.nnz == 0
        self._v0 = np.random.default_rng(0).uniform(0.5, 1.5, n)  # fixed: reproducible
        self._token, self._blob = uuid.uuid4().hex, None  # how worker processes know this solver
        self.sigma = -1.0  # provisional; set from the first elastic mode below
        self._order(x0)
        self._x0_pairs = None  # the modes at x0 the count's solve found (`x0_modes`), or None
        if self._same_at_x0(count_from, x0):  # the same matrices at x0: its count and shift
            self.n_rigid, self.sigma = count_from.n_rigid, count_from.sigma
            self.n_elastic = self.n_finite - self.n_rigid
            return
        if x0_modes > 0 and self.n_params == 0:
            k = min(self.n_finite, max(12, min_zero + x0_modes))
            pairs = self._point(x0, k, vectors=True)
            lam = pairs[0][:min(self.n_finite, 12)]
        else:
            lam = self._lowest(x0[None, :])
        nonzero = lam > self.ZERO_TOL * lam[-1] if lam[-1] > 0 else np.zeros(len(lam), bool)
        self.n_rigid = max(int(len(lam) - nonzero.sum()), min(min_zero, len(lam)))
        if self.n_rigid < len(lam):
            self.sigma = -self.SHIFT * float(lam[self.n_rigid])
        self.n_elastic = self.n_finite - self.n_rigid
        if x0_modes > 0 and self.n_params == 0 and self.n_rigid + min(x0_modes, self.n_elastic) <= len(pairs[0]):
            self._x0_pairs = pairs

    #: `count_from`'s matrices and these at x0 agree to this fraction of their largest entry: the
    #: same sums in another order (a parameter's element taken out of K0 and put back at x0).
    SAME_AT_X0 = 1e-13

    def _same_at_x0(self, other: "SparseModalSolver | None", x0: np.ndarray) -> bool:
        """Whether `other` (a system with no parameter, on the same pattern, with the same
        zero-energy floor) has K and M equal to these at x0 to `SAME_AT_X0`: then its zero-energy
        count and shift are this system's (a candidate's parameter at its initial value is the
        model itself: its count's eigen-solve would find the same eigenvalues to rounding)."""
        if other is None or other.n_params or other.n_free != self.n_free or other.n_rigid >= self.n_free:
            return False
        if not _same_pattern(other.indptr, other.cols, self.indptr, self.cols):
            return False
        for mine, theirs in ((self.k_data(x0), other.k_data0), (self.m_data(x0), other.m_data0)):
            if np.abs(mine - theirs).max() > self.SAME_AT_X0 * np.abs(theirs).max():
                return False
        return True

    def _affine(self, slot, trip, nnz: int):
        """Constant values (nnz,) and the sparse (nnz, p) map G of one family."""
        _, _, v, t = trip
        const = t < 0
        c0 = np.bincount(slot[const], weights=v[const], minlength=nnz)
        g = sp.csr_matrix((v[~const], (slot[~const], t[~const])), shape=(nnz, self.n_params))
        g.sum_duplicates()
        return c0, g

    def _order(self, x0: np.ndarray) -> None:
        """Fix a fill-reducing ordering of the pattern once (SuperLU's minimum degree on A + A^T
        at x0): each point then factorises the permuted matrix as it is, without ordering anew.
        `_perm` (new -> old DOF), and the permuted pattern with `_pdata`, the value index map.
        (The Cholesky path orders in CHOLMOD's analysis instead, `_analysis`.)"""
        if self.factorization == "cholmod":
            return
        a = sp.csc_matrix((self.k_data(x0) - self.sigma * self.m_data(x0), self.cols, self.indptr),
                          shape=(self.n_free, self.n_free))
        if self.n_free < 3:
            self._perm = np.arange(self.n_free)
        else:
            self._perm = np.argsort(splu(a, permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                                         options={"SymmetricMode": True}).perm_c)
        tag = sp.csc_matrix((np.arange(1.0, len(self.rows) + 1), self.cols, self.indptr), shape=a.shape)
        tag = tag[self._perm][:, self._perm].tocsc()
        tag.sort_indices()
        self._pdata = tag.data.astype(np.int64) - 1
        self._pindices, self._pindptr = tag.indices, tag.indptr

    def _analysis(self):
        """CHOLMOD's symbolic analysis of the pattern (its fill-reducing order and the structure of
        the factor), once per model and process: it is not pickled, a worker makes its own."""
        if self._symbolic is None:
            for entry in list(_ANALYSES):  # the same pattern analysed before in this process: the same analysis
                if _same_pattern(entry[0], entry[1], self.indptr, self.cols):
                    self._symbolic = entry[2]
                    break
            else:
                self._symbolic = _cholmod.analyze(self._csc(np.ones(len(self.rows))), mode=CHOLMOD_MODE)
                _to_front(_ANALYSES, (self.indptr, self.cols, self._symbolic))
        return self._symbolic

    def _csc(self, data: np.ndarray) -> sp.csc_matrix:
        """The symmetric matrix with values `data` on the pattern, as CSC: the CSR arrays of a
        symmetric pattern read as CSC are its transpose, the same matrix."""
        return sp.csc_matrix((data, self.cols, self.indptr), shape=(self.n_free, self.n_free))

    def _factor(self, a_data: np.ndarray):
        """The factors of the matrix with values `a_data` on the pattern: a function b -> A^-1 b.
        Cholesky (numeric step only, on the kept analysis), or LU in the fixed order."""
        if self.factorization == "cholmod":
            try:
                chol = self._analysis().cholesky(self._csc(a_data))
                definite = bool(np.all(chol.D() > 0.0))  # LDL^T: positive definite iff every D_ii > 0
            except _cholmod.CholmodNotPositiveDefiniteError:
                definite = False
            if not definite:
                raise ValueError(f"model {self.name!r}: K - sigma M is not positive definite at this point (a "
                                 "DOF with no stiffness and no mass, or a negative modulus?)")
            return chol.solve_A
        ap = sp.csc_matrix((a_data[self._pdata], self._pindices, self._pindptr), shape=(self.n_free, self.n_free))
        try:
            lu = splu(ap, permc_spec="NATURAL", diag_pivot_thresh=0.0, options={"SymmetricMode": True})
        except RuntimeError:
            raise ValueError(f"model {self.name!r}: K - sigma M is singular at this point (a DOF with no "
                             "stiffness and no mass?)") from None
        perm = self._perm

        def solve(b: np.ndarray) -> np.ndarray:
            x = np.empty_like(b)
            x[perm] = lu.solve(b[perm])
            return x
        return solve

    def _lowest(self, x0: np.ndarray) -> np.ndarray:
        """Eigenvalues at x0, enough to see every zero-energy mode and a few elastic ones."""
        k = min(self.n_finite, 12)
        return self._point(x0[0], k, vectors=False)[0]

    def zero_modes(self, x0: np.ndarray) -> np.ndarray:
        """The zero-energy modes at x0 (n_free, n_rigid), M-orthonormal."""
        return self._point(x0, self.n_rigid, vectors=True)[1] if self.n_rigid else np.zeros((self.n_free, 0))

    # -- matrices ---------------------------------------------------------------------
    def matrix(self, data: np.ndarray) -> sp.csr_matrix:
        """A CSR matrix on the fixed pattern with values `data` (nnz,)."""
        return sp.csr_matrix((data, self.cols, self.indptr), shape=(self.n_free, self.n_free))

    def k_data(self, theta: np.ndarray) -> np.ndarray:
        """Values of K(theta) on the pattern, for one point theta (p,)."""
        return self.k_data0 + self.gk @ theta

    def m_data(self, theta: np.ndarray) -> np.ndarray:
        """Values of M(theta) on the pattern, for one point theta (p,)."""
        return self.m_data0 + self.gm @ theta if not self.mass_constant else self.m_data0

    def stiffness(self, theta: np.ndarray) -> list[sp.csr_matrix]:
        """K(theta) on the free DOFs, one CSR matrix per row of theta (b, p)."""
        return [self.matrix(self.k_data(t)) for t in np.atleast_2d(theta)]

    def mass(self, theta: np.ndarray) -> list[sp.csr_matrix]:
        """M(theta) on the free DOFs, one CSR matrix per row of theta (b, p)."""
        return [self.matrix(self.m_data(t)) for t in np.atleast_2d(theta)]

    @property
    def k0(self) -> sp.csr_matrix:
        """The constant part K0 (CSR)."""
        return self.matrix(self.k_data0)

    @property
    def m0(self) -> sp.csr_matrix:
        """The constant part M0 (CSR)."""
        return self.matrix(self.m_data0)

    # -- one point ----------------------------------------------------------------------
    def _point(self, theta: np.ndarray, k: int, vectors: bool, matrices=None):
        """The k lowest eigenpairs (zero-energy ones included) at one point theta (p,):
        eigenvalues (k,) ascending and, with `vectors`, M-normalised vectors (n_free, k).
        `matrices`: K and M at theta as (k_data, m_data, K, M), when the caller has them."""
        kd, md, kmat, mmat = self._matrices(theta) if matrices is None else matrices
        if k >= self.n_finite - 1:  # ARPACK needs k < n - 1 (n: the operator's rank): a tiny model, solved densely
            return _dense_lowest(kmat.toarray(), mmat.toarray(), k, self.sigma)
        # eigsh calls both operators through `aslinearoperator(op).matvec` two or three times per
        # Lanczos step: `_Direct` hands it the function itself, without LinearOperator's checks
        # and scipy's sparse dispatch around the same CSR product and the same solve
        op = _Direct(self._factor(kd - self.sigma * md), self.n_free)
        m_op = _Direct(_csr_product(mmat), self.n_free)
        ncv = max(2 * k + 1, 20)
        while True:  # a wider Krylov space if the first does not converge (never seen on frames)
            try:
                out = eigsh(kmat, k=k, M=m_op, sigma=self.sigma, which="LM", OPinv=op, v0=self._v0,
                            ncv=min(self.n_finite, ncv), tol=self.arpack_tol, return_eigenvectors=vectors)
                break
            except ArpackNoConvergence:
                if ncv >= min(self.n_finite, 8 * k + 40):
                    raise ValueError(f"model {self.name!r}: the Lanczos iteration for the lowest {k} modes did "
                                     "not converge at this point") from None
                ncv *= 2
        if not vectors:
            return np.sort(out), None
        lam, phi = out
        order = np.argsort(lam)
        return lam[order], phi[:, order]

    def _matrices(self, theta: np.ndarray):
        """(k_data, m_data, K, M) at one point theta (p,)."""
        kd, md = self.k_data(theta), self.m_data(theta)
        return kd, md, self.matrix(kd), self.matrix(md)

    def _modes(self, theta: np.ndarray, n_modes: int, shapes: bool, rows, sens: bool):
        """One point: elastic eigenvalues, with `shapes` the shapes (all rows, or `rows`), with
        `sens` d lambda / d theta."""
        # The eigenvalues are the Rayleigh quotients phi^T K phi / phi^T M phi of the Lanczos
        # vectors, not ARPACK's Ritz values: those carry the factorisation's backward error,
        # about eps ||K|| ||phi||^2, which on a fine mesh (a 1,500-node thin beam, K's condition
        # 1e13) is 3e-5 of the first elastic eigenvalue, whatever ARPACK's tol. The vectors are
        # good to that error over the spectral gap and the quotient to its square, so it is left
        # with the assembled K's own rounding (3e-6 there; 1e-12 on ordinary frames, where it
        # changes nothing that matters). Hence vectors even when only values are asked for.
        matrices = self._matrices(theta)  # built once: the solve's and the quotients'
        k = self.n_rigid + n_modes
        if self._x0_pairs is not None and k <= len(self._x0_pairs[0]):  # no parameters: theta is x0
            lam, phi = self._x0_pairs[0][:k], self._x0_pairs[1][:, :k]
        else:
            lam, phi = self._point(theta, k, True, matrices)
        phi = phi[:, self.n_rigid:]
        mass = np.einsum("im,im->m", phi, matrices[3] @ phi)
        lam = np.einsum("im,im->m", phi, matrices[2] @ phi) / mass
        need_vec = shapes or sens
        if not need_vec:
            return lam, None, None
        phi = signed(phi / np.sqrt(mass))
        dlam = None
        if sens:  # phi^T (dK_k - lambda dM_k) phi through the triplet map: no matrix per parameter
            q = phi[self.rows] * phi[self.cols]                  # (nnz, m)
            dlam = (self.gk.T @ q).T - lam[:, None] * (self.gm.T @ q).T
        if rows is not None:
            phi = phi[np.clip(rows, 0, None)] * (np.asarray(rows) >= 0)[:, None]
        return lam, (phi if shapes else None), dlam

    # -- batches --------------------------------------------------------------------------
    def _batch(self, theta: np.ndarray, n_modes: int, shapes: bool, rows, sens: bool):
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        if n_modes > self.n_elastic:
            raise ValueError(f"model {self.name!r} has only {self.n_elastic} elastic modes, asked for {n_modes}")
        w = min(self.workers, len(theta)) if self.n_free >= PARALLEL_MIN_DOFS else 1
        if w > 1:  # this process and w - 1 workers of the shared pool (_pool.py)
            res = _pool.map_split(self._modes, self._token, self._pickled, "_modes",
                                  np.array_split(theta, w), (n_modes, shapes, rows, sens))
        else:
            res = [self._modes(t, n_modes, shapes, rows, sens) for t in theta]
        lam = np.stack([r[0] for r in res])
        phi = np.stack([r[1] for r in res]) if res[0][1] is not None else None
        dlam = np.stack([r[2] for r in res]) if sens else None
        return lam, phi, dlam

    def set_workers(self, n: int) -> None:
        """Split later batches over `n` processes (this one and n - 1 workers)."""
        self.workers = max(1, int(n))

    def _pickled(self) -> bytes:
        """This solver pickled, once (it does not change after construction)."""
        if self._blob is None:
            self._blob = pickle.dumps(self, protocol=pickle.HIGHEST_PROTOCOL)
        return self._blob

    def __getstate__(self):
        state = self.__dict__.copy()
        state["_blob"] = None
        state["_symbolic"] = None  # CHOLMOD's analysis does not pickle: each process makes its own
        return state

    def eigen(self, theta: np.ndarray, n_modes: int, vectors: bool = False, rows=None):
        """Lowest `n_modes` elastic eigenpairs for a population theta (b, p), as the dense
        `ModalSolver.eigen`: omega^2 (b, n_modes) and, with `vectors`, mass-normalised shapes
        (b, n_free, n_modes), or (b, len(rows), n_modes) at `rows` only (row -1: zero)."""
        lam, phi, _ = self._batch(theta, n_modes, vectors, rows, False)
        return lam, phi

    def eigen_sensitivities(self, theta: np.ndarray, n_modes: int, rows=None):
        """Eigenvalues, shapes (all free DOFs, or at `rows`) and d(omega^2)/d(theta)
        (b, n_modes, p): phi^T (dK_k - lambda dM_k) phi summed over the pattern's triplets."""
        return self._batch(theta, n_modes, True, rows, True)


__all__ = ["ARPACK_TOL", "CHOLMOD_MODE", "FACTORIZATIONS", "PARALLEL_MIN_DOFS", "WORKERS_ENV", "SparseModalSolver",
           "default_factorization", "default_workers"]
