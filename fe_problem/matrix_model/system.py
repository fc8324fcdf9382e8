"""`MatrixSystem`: the solver interface of a matrix model, the same methods as
`assembly.AffineModel` (`eigen`, `eigen_sensitivities`, `nodal_rows`, `at_rows`, `expand`, `x0`,
`lower`, `upper`, `n_params`, `path`), so that `UpdatingProblem` and `femu model` take either.

K(x) = sum_i theta_i K_i and M(x) = sum_j mu_j M_j are handed to the project's one sparse
solver (sparse.py: one CSR pattern, values c0 + G x, CHOLMOD or SuperLU, ARPACK shift-invert
from a fixed start vector, Rayleigh-quotient eigenvalues, signed shapes) as triplets: a
parameter term's entries carry its parameter's index, a fixed term's entries are scaled by its
`initial` and go to the constant part. dK/dx_i is K_i itself, so the analytic sensitivities
phi^T (K_i - lambda M_i) phi come out of the solver's triplet map as for a frame.

DOFs without mass are handled exactly: M stays singular (no small fake mass), and the
shift-invert operator (K - sigma M)^-1 M, with sigma < 0 and K - sigma M positive definite,
maps their infinite eigenvalues to 0, never among the largest ARPACK looks for; ARPACK's start
vector is taken in the operator's range, so the Lanczos vectors have no massless component to
purify. Only as many modes as there are DOFs with mass are ever asked for (`n_finite`).
"""

from __future__ import annotations

import numpy as np

from ..sparse import SparseModalSolver
from ..solver import take_rows
from .._threads import blas_pinned, one_blas_thread
from ..parameters import ParameterVectors
from .types import MatrixModel, MatrixModelError, MatrixParameter

#: The solver paths a matrix model takes: sparse only (its matrices are sparse as read).
MATRIX_SOLVERS = ("auto", "sparse")


class MatrixSystem(ParameterVectors):
    """K(x), M(x) of a matrix model over its parameters (default: every term with bounds;
    `parameters`: a subset, the other terms fixed at their `initial`), and their modes.

    Every DOF of a matrix model is free (an export has its supported DOFs removed); zero-energy
    modes (a free structure's rigid-body motions), counted at x0 by the eigenvalues as on the
    sparse path of a frame, are dropped."""

    @blas_pinned
    def __init__(self, model: MatrixModel, parameters=None, solver: str = "auto", workers: int | None = None):
        if solver not in MATRIX_SOLVERS:
            raise ValueError(f"a matrix model is solved on the sparse path: solver must be one of {MATRIX_SOLVERS}, "
                             f"got {solver!r}")
        self.model = model
        self.parameters = self._select(model, parameters)
        index = {p.name: i for i, p in enumerate(self.parameters)}
        n = model.n_dof
        parts = {"stiffness": [], "mass": []}
        for t in model.terms:
            coo = t.matrix.tocoo()
            i = index.get(t.name, -1)
            values = coo.data if i >= 0 else coo.data * t.initial
            parts[t.family].append((coo.row.astype(np.int64), coo.col.astype(np.int64), values,
                                    np.full(coo.nnz, i, dtype=np.int64)))
        k_trip, m_trip = (tuple(np.concatenate(a) for a in zip(*parts[f])) for f in ("stiffness", "mass"))
        self.path = "sparse"
        self.n_massless = int(np.sum(model.total("mass").diagonal() <= 0.0))
        self._solver = SparseModalSolver(k_trip, m_trip, n, self.x0, model.name, workers,
                                         n_finite=n - self.n_massless)
        #: a matrix model names no element or node to blame for a mechanism: None
        self.mechanism = None

    @staticmethod
    def _select(model: MatrixModel, parameters) -> tuple[MatrixParameter, ...]:
        """The model's parameters, or the ones named (names or MatrixParameter), in that order."""
        own = {p.name: p for p in model.parameters}
        if parameters is None:
            return tuple(own.values())
        out = []
        for p in parameters:
            if isinstance(p, MatrixParameter):
                if p.name not in {t.name for t in model.terms}:
                    raise MatrixModelError(f"{model.source or model.name}: no term {p.name!r} to update")
                if p.family != model.term(p.name).family:
                    raise MatrixModelError(f"{model.source or model.name}: term {p.name!r} is a {model.term(p.name).family} "
                                           f"term, not {p.family}")
                out.append(p)
            elif isinstance(p, str) and p in own:
                out.append(own[p])
            else:
                raise MatrixModelError(f"{model.source or model.name}: {p!r} is not a parameter of the model "
                                       f"(parameters: {', '.join(own) or 'none'})")
        if len({p.name for p in out}) != len(out):
            raise MatrixModelError(f"{model.source or model.name}: a parameter is named twice")
        return tuple(out)

    # -- the solver's interface (AffineModel's) ----------------------------------------------
    @property
    def n_free(self) -> int:
        """Number of DOFs (all free)."""
        return self._solver.n_free

    @property
    def n_rigid(self) -> int:
        """Zero-energy modes dropped."""
        return self._solver.n_rigid

    @property
    def n_elastic(self) -> int:
        """Elastic modes the model has (DOFs with mass less the zero-energy modes)."""
        return self._solver.n_elastic

    @property
    def workers(self) -> int:
        """Processes a batch is split over."""
        return self._solver.workers

    @workers.setter
    def workers(self, n: int) -> None:
        self._solver.set_workers(n)

    @property
    def k0(self):
        """The constant part of K (CSR)."""
        return self._solver.k0

    @property
    def m0(self):
        """The constant part of M (CSR)."""
        return self._solver.m0

    def stiffness(self, x: np.ndarray):
        """K(x), one CSR matrix per row of x (b, p)."""
        return self._solver.stiffness(x)

    def mass(self, x: np.ndarray):
        """M(x), one CSR matrix per row of x (b, p)."""
        return self._solver.mass(x)

    def eigen(self, x: np.ndarray, n_modes: int, vectors: bool = False, rows=None):
        """Lowest `n_modes` elastic eigenpairs for a population x (b, p), as `AffineModel.eigen`:
        omega^2 (b, n_modes) in (rad/s)^2 and, with `vectors`, mass-normalised shapes (b, n, n_modes)
        or at `rows` only, each signed so that its largest entry is positive."""
        with one_blas_thread():
            return self._solver.eigen(x, n_modes, vectors, rows)

    def eigen_sensitivities(self, x: np.ndarray, n_modes: int, rows=None):
        """Eigenvalues, shapes and d(omega^2)/dx (b, m, p) = phi^T (K_i - lambda M_i) phi."""
        with one_blas_thread():
            return self._solver.eigen_sensitivities(x, n_modes, rows)

    # -- DOFs -------------------------------------------------------------------------------
    def expand(self, phi: np.ndarray) -> np.ndarray:
        """Shapes on every DOF: the solver's own (every DOF of a matrix model is free)."""
        return np.asarray(phi)

    def nodal_rows(self, dofs) -> np.ndarray:
        """Row indices of DOF labels (integers 1..n, or (node, direction) pairs); ValueError
        naming a label the model does not have."""
        rows = []
        for d in dofs:
            label = tuple(d) if isinstance(d, list) else d
            r = self.model.row_of(label)
            if r is None:
                raise ValueError(f"model {self.model.name!r} has no DOF {label!r}")
            rows.append(r)
        return np.array(rows, dtype=int)

    @staticmethod
    def at_rows(phi: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """Shapes (b, n, k) at the rows `nodal_rows` gave: (b, len(rows), k)."""
        return take_rows(phi, rows)


__all__ = ["MATRIX_SOLVERS", "MatrixSystem"]
