"""K(theta), M(theta) of a model as affine sums, built once, and the solver path that uses them.

    K(theta) = K0 + sum_k theta_k dK_k,      M(theta) = M0 + sum_k theta_k dM_k

with theta in physical units (parameters.py). terms.py assembles every term as sparse
triplets once; `AffineModel` hands them to one of two solvers behind one interface:

- "dense" (solver.py): n x n matrices per term, the whole population in one tensor
  contraction and one batched LAPACK eigen-solve. Fastest for small models.
- "sparse" (sparse.py): one CSR pattern, values affine in theta, the lowest modes per point
  by shift-invert Lanczos; memory O(nnz), cost about linear in the DOFs.

`solver="auto"` takes the dense path up to `SPARSE_MIN_DOFS` free DOFs and the sparse path
above (the crossover measured on this project's frames, see `SPARSE_MIN_DOFS`).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
import scipy.sparse as sp
from scipy.sparse.linalg import splu

from .limits import MAX_SPARSE_DOFS  # noqa: F401  (fe_problem.assembly.MAX_SPARSE_DOFS, as before)
from .elements import element_blocks
from .elements.base import coordinates
from .model import FrameModel, ModelFileError
from .parameters import Parameter, ParameterVectors
from .paths import SOLVERS
from .solver import ModalSolver, take_rows
from .sparse import SparseModalSolver
from .terms import DofMap, Terms, dense_terms
from ._threads import blas_pinned, one_blas_thread

#: Free DOFs above which `solver="auto"` takes the sparse path. Measured (benchmarks/
#: crossover.py): per point, the dense batched eigvalsh and the sparse shift-invert solve
#: cost the same at about this size on frames of beam elements (10 modes).
SPARSE_MIN_DOFS = 200


#: `solver="auto"` also takes the sparse path when the dense one would hold more than this
#: (bytes, `dense_bytes`): a small model with very many parameters.
AUTO_DENSE_BYTES = 512 * 2**20


def solver_path(n_free: int, solver: str = "auto", n_params: int = 0) -> str:
    """The path ("dense" or "sparse") `AffineModel` takes for `n_free` free DOFs and `n_params`
    parameters: `solver` if forced, else sparse above `SPARSE_MIN_DOFS` DOFs or above
    `AUTO_DENSE_BYTES` of dense matrices."""
    if solver not in SOLVERS:
        raise ValueError(f"solver must be one of {SOLVERS}, got {solver!r}")
    if solver != "auto":
        return solver
    big = n_free > SPARSE_MIN_DOFS or dense_bytes(n_free, n_params) > AUTO_DENSE_BYTES
    return "sparse" if big else "dense"


#: The most memory the dense path may take for one model's matrices (bytes): K0, M0 and one
#: dK (and dM) per parameter, each n_dof x n_dof float64, and the work arrays of the solve.
MAX_DENSE_BYTES = 4 * 2**30


def dense_bytes(n_dof: int, n_params: int) -> int:
    """Memory (bytes) the dense path needs for a model of `n_dof` DOFs and `n_params` parameters:
    the constant and per-parameter matrices and their mass-normalised copies, n_dof^2 float64 each."""
    return 8 * n_dof * n_dof * (2 * max(n_params, 1) + 6)


def check_dense_size(model: FrameModel, n_params: int) -> None:
    """ModelFileError naming the model, its size and the limit if the dense path would need more
    than `MAX_DENSE_BYTES`: refused up front, never a machine run out of memory."""
    n = DofMap.of(model).n_total
    need = dense_bytes(n, n_params)
    if need > MAX_DENSE_BYTES:
        raise ModelFileError(f"{model.source or model.name}: {len(model.nodes)} nodes, {n} DOFs and {n_params} "
                         f"parameters need about {need / 2**30:.1f} GiB as dense matrices, more than the "
                         f"{MAX_DENSE_BYTES / 2**30:.0f} GiB limit (fe_problem.assembly.MAX_DENSE_BYTES); "
                         "use a coarser model or fewer parameters")




def check_sparse_size(model: FrameModel, n_free: int) -> None:
    """ModelFileError naming the model, its size and the limit above `MAX_SPARSE_DOFS`."""
    if n_free > MAX_SPARSE_DOFS:
        raise ModelFileError(f"{model.source or model.name}: {len(model.nodes)} nodes, {n_free} free DOFs: more than "
                             f"the {MAX_SPARSE_DOFS} the sparse path takes (fe_problem.assembly.MAX_SPARSE_DOFS); "
                             "use a coarser model")


class AffineModel(ParameterVectors):
    """K(theta), M(theta) of a model over a parameter set, reduced to the free DOFs, and the
    solver of its modes.

    Built once; `eigen(theta, n_modes, vectors, rows)` solves a whole population, on the path
    `path` ("dense" or "sparse": `solver="auto"` chooses by size, see `solver_path`; "dense" or
    "sparse" forces one). Zero-energy modes (rigid-body motions of an unsupported structure,
    mechanisms; counted at the initial parameters) are dropped, and the `n_modes` lowest
    elastic modes are returned. `workers`: threads for a batch on the sparse path (default:
    the cores this process may use); the result does not depend on it. `x0_modes`: on the
    sparse path, for a model with no parameter (solved at its own properties only), the elastic
    modes the caller will ask for: the solve that counts the zero-energy modes returns them too,
    so the model costs one eigen-solve, not two (their shift is the count's, not the one set
    from the first elastic mode: the same modes to ARPACK's tolerance; tests/test_sparse.py).
    `like`: on the sparse path, the system of `model` itself with no parameter (a candidate's
    Setting system): where this system's K and M at x0 are that one's to rounding (a parameter
    at its initial value), its zero-energy count and shift are taken, and the count's
    eigen-solve is not made (`SparseModalSolver._same_at_x0`; the same modes to ARPACK's
    tolerance, tests/test_element_reuse.py).
    """

    @blas_pinned  # K and M are built with BLAS products: the same matrices on any thread count
    def __init__(self, model: FrameModel, parameters: tuple[Parameter, ...] = (), solver: str = "auto",
                 workers: int | None = None, x0_modes: int = 0, like: "AffineModel | None" = None):
        self.model = model
        self.parameters = tuple(parameters)
        terms = Terms(model, self.parameters)
        self.dofmap = terms.dofmap
        n, p = len(self.dofmap.free), len(self.parameters)
        if n == 0:
            raise ModelFileError(f"{model.source or model.name}: every DOF is supported, so the model has no mode: "
                                 "remove a support")
        self.path = solver_path(n, solver, p)
        if self.path == "dense":
            check_dense_size(model, p)
        else:
            check_sparse_size(model, n)
        k_trip, m_trip = terms.free_arrays()
        self.massless = self._check_mass(m_trip)
        self._check_massless_held(k_trip)
        # the rigid-body motions the supports allow are zero modes however ill-conditioned the
        # model (an eigenvalue test alone can miss them, or take a real mode for one, on a fine mesh)
        n_body = self._n_rigid_motions(k_trip, self.x0)
        self._n_body = n_body  # the rigid-body motions the supports allow (`edited` reuses it)
        if self.path == "dense":
            k0, dk = dense_terms(k_trip, n, p)
            m0, dm = dense_terms(m_trip, n, p)
            # the ones no term strains at any theta (a spring to ground that is a parameter, 0
            # at x0, strains one at other theta): these are projected out for good
            n_null = self._n_rigid_motions(k_trip, np.where(self.x0 != 0.0, self.x0, self.upper))
            self._solver = ModalSolver(k0, m0, dk, dm, self.x0, model.name, n_body=n_body, n_null=n_null,
                                       massless=self.massless)
        else:
            same = like is not None and like.path == "sparse" and like.model is model and not like.parameters
            self._solver = SparseModalSolver(k_trip, m_trip, n, self.x0, model.name, workers, min_zero=n_body,
                                             x0_modes=x0_modes, count_from=like._solver if same else None,
                                             n_finite=n - self.massless.size)
        #: None, or what moves in the zero-energy motions that are not rigid-body motions
        self.mechanism: str | None = self._find_mechanism() if self.n_rigid > n_body else None

    @blas_pinned
    def edited(self, model: FrameModel, element_ids, x0_modes: int = 0) -> "AffineModel":
        """`AffineModel(model, x0_modes=x0_modes)` of a `model` that differs from this one only in
        the matrices of the elements `element_ids` (a member's section, the elements at a moved
        node), built from this system: on the sparse path, for a system with no parameter, K and M
        are this system's values with those elements' blocks replaced (new minus old, on the same
        pattern; an entry the new blocks fill that was zero joins it), and the rigid-body count
        is this one's when no supported or sprung node moved. The eigen-solve is `AffineModel`'s
        own (the zero-energy count and the modes from one solve), so the modes are a full
        rebuild's to rounding (tests/test_edited_system.py: K, M to 1e-13 of their largest entry,
        the frequencies to 1e-12). Anything else (the dense path, parameters, another topology, a
        support, spring or mass changed, a section or material changed under its name for an
        element not in `element_ids`, a skew release at a changed element): a full build."""
        rows = self._edit_rows(model, element_ids)
        if rows is None:
            return AffineModel(model, x0_modes=x0_modes)
        dofmap, n = self.dofmap, self.n_free
        pos = np.full(dofmap.n_total, -1)
        pos[dofmap.free] = np.arange(n)
        solver = self._solver
        parts_r, parts_c, parts_k, parts_m = [solver.rows], [solver.cols], [solver.k_data0], [solver.m_data0]
        for sign, mod in ((-1.0, self.model), (1.0, model)):
            k_el, m_el = element_blocks(mod, rows)
            k_el *= sign * np.array([mod.element_modulus_pa(mod.elements[r].id) for r in rows])[:, None, None]
            rho = [mod.materials[mod.elements[r].material].density_kg_m3 for r in rows]
            m_el *= sign * np.array(rho)[:, None, None]
            d = pos[dofmap.element_dofs[rows]]                             # (e, k) free positions, -1 held
            r, c = np.broadcast_arrays(d[:, :, None], d[:, None, :])
            keep = (r >= 0) & (c >= 0)
            parts_r.append(r[keep]), parts_c.append(c[keep]), parts_k.append(k_el[keep]), parts_m.append(m_el[keep])
        r, c = np.concatenate(parts_r), np.concatenate(parts_c)
        term = np.full(len(r), -1)
        k_trip = (r, c, np.concatenate(parts_k), term)
        m_trip = (r, c, np.concatenate(parts_m), term)
        new = object.__new__(AffineModel)
        new.model, new.parameters, new.dofmap, new.path = model, (), dofmap, "sparse"
        new.massless = new._check_mass(m_trip)
        new._check_massless_held(k_trip)
        new._n_body = self._n_body
        new._solver = SparseModalSolver(k_trip, m_trip, n, new.x0, model.name, min_zero=new._n_body, x0_modes=x0_modes,
                                        n_finite=n - new.massless.size)
        new.mechanism = new._find_mechanism() if new.n_rigid > new._n_body else None
        return new

    def _edit_rows(self, model: FrameModel, element_ids) -> list[int] | None:
        """The positions in model.elements of `element_ids`, when `edited` may build `model` from
        this system: the sparse path, no parameter, the same layout, nodes (ids, order), supports,
        springs and masses, the same element connectivity and releases (none at a changed space
        element), every element not in `element_ids` the same and with the same section and
        material (by name), and every node that moved one whose elements are all in
        `element_ids` and that no support or spring holds; else None."""
        base = self.model
        if (self.path != "sparse" or self.parameters or model.layout != base.layout
                or len(model.elements) != len(base.elements) or len(model.nodes) != len(base.nodes)
                or model.supports != base.supports or model.springs != base.springs or model.masses != base.masses):
            return None
        ids = set(element_ids)
        rows = [k for k, e in enumerate(base.elements) if e.id in ids]
        if len(rows) != len(ids) or any(k in self.dofmap.extended for k in rows):
            return None
        if base.layout.dimension == 3 and any(any(base.end_releases(base.elements[k])) for k in rows):
            return None  # a space release's node rotation follows the member's axes (terms.release_rotation)
        changed = set(rows)
        sections = {k for k, v in base.sections.items() if model.sections.get(k) != v}
        materials = {k for k, v in base.materials.items() if model.materials.get(k) != v}
        if (sections or materials) and any(e.section in sections or e.material in materials
                                           for k, e in enumerate(base.elements) if k not in changed):
            return None
        for k in [k for k, (a, b) in enumerate(zip(base.elements, model.elements)) if a is not b and a != b]:
            a, b = base.elements[k], model.elements[k]
            if k not in changed or (a.id, a.node_i, a.node_j) != (b.id, b.node_i, b.node_j) \
                    or base.end_releases(a) != model.end_releases(b):
                return None
        moved = [(a, b) for a, b in zip(base.nodes, model.nodes) if a is not b and a != b]
        if moved:
            held = {s.node for s in base.supports} | {sp.dof_a[0] for sp in base.springs} \
                | {sp.dof_b[0] for sp in base.springs if sp.dof_b}
            for a, b in moved:
                if a.id != b.id or a.id in held or any(
                        k not in changed for k, e in enumerate(base.elements) if a.id in (e.node_i, e.node_j)):
                    return None
        return rows

    # -- the solver's interface (either path) ---------------------------------------------
    @property
    def n_free(self) -> int:
        """Number of free (unsupported) DOFs."""
        return self._solver.n_free

    @property
    def n_rigid(self) -> int:
        """Zero-energy modes dropped (rigid-body motions and mechanisms)."""
        return self._solver.n_rigid

    @property
    def n_elastic(self) -> int:
        """Elastic modes the model has."""
        return self._solver.n_elastic

    @property
    def workers(self) -> int:
        """Processes a batch is split over on the sparse path (1 on the dense path)."""
        return getattr(self._solver, "workers", 1)

    @workers.setter
    def workers(self, n: int) -> None:
        if self.path == "sparse":
            self._solver.set_workers(n)

    @property
    def k0(self):
        """K0 on the free DOFs (dense array or CSR matrix, by path)."""
        return self._solver.k0

    @property
    def m0(self):
        """M0 on the free DOFs (dense array or CSR matrix, by path)."""
        return self._solver.m0

    def stiffness(self, theta: np.ndarray):
        """K(theta) on the free DOFs for theta (b, p): (b, n, n) dense, or b CSR matrices."""
        return self._solver.stiffness(theta)

    def mass(self, theta: np.ndarray):
        """M(theta) on the free DOFs for theta (b, p): (b, n, n) dense, or b CSR matrices."""
        return self._solver.mass(theta)

    def eigen(self, theta: np.ndarray, n_modes: int, vectors: bool = False, rows=None):
        """Lowest `n_modes` elastic eigenpairs for a population theta (b, p): omega^2 (b, n_modes)
        in (rad/s)^2 and, with `vectors`, mass-normalised shapes (b, n_free, n_modes), each
        signed so that its largest entry is positive (else None); with `rows` (`nodal_rows`)
        the shapes at those rows only, (b, len(rows), n_modes). ValueError if `n_modes` >
        `n_elastic`. Runs on one BLAS thread (`_threads.one_blas_thread`): the same numbers
        whatever thread count the process has."""
        with one_blas_thread():
            return self._solver.eigen(theta, n_modes, vectors, rows)

    def eigen_sensitivities(self, theta: np.ndarray, n_modes: int, rows=None):
        """Eigenvalues (b, m), shapes (as `eigen`, all free DOFs or at `rows`) and d(omega^2)/d(theta)
        (b, m, p), from phi^T (dK_k - lambda dM_k) phi for mass-normalised phi (one BLAS thread)."""
        with one_blas_thread():
            return self._solver.eigen_sensitivities(theta, n_modes, rows)

    def _check_mass(self, m_trip) -> np.ndarray:
        """The free DOFs without mass (no mass entry in their row for any parameter: the
        rotations of lumped-mass beams, a pinned end's rotation), which the solvers condense
        out exactly; ModelFileError naming the model and the DOFs if some other free DOF carries
        no mass at x0 (a mass parameter at zero)."""
        r, c, v, t = m_trip
        n = len(self.dofmap.free)
        d = r == c
        scale = np.append(self.x0, 1.0)[t[d]]  # term -1 (the constant part) takes the last entry: 1
        diag = np.bincount(r[d], weights=v[d] * scale, minlength=n)
        none = np.bincount(r, weights=np.abs(v), minlength=n) == 0.0
        massless = np.flatnonzero((diag <= 0.0) & ~none)
        if none.all():
            massless = np.arange(n)
        if massless.size:
            names = self._dof_names()
            shown = ", ".join(names[i] for i in massless[:4]) + (" ..." if massless.size > 4 else "")
            raise ModelFileError(f"{self.model.source or self.model.name}: {massless.size} DOF(s) carry no mass "
                             f"({shown}): connect the node to an element with density, give it a lumped mass "
                             "with rotary inertia, or support that DOF")
        return np.flatnonzero(none)

    #: Massless DOFs up to which a singular K_bb is explained by name (a dense eigen-solve).
    NAME_MASSLESS_MAX = 3000

    def _check_massless_held(self, k_trip) -> None:
        """ModelFileError naming the model and the DOFs if the DOFs without mass can move, at x0,
        without straining anything (K_bb singular: a rotation that only pinned ends meet): such a
        motion has no inertia and no stiffness, so no mode. The solvers condense the massless DOFs
        (dense) or factor K - sigma M (sparse), which both need K_bb positive definite."""
        b = self.massless
        if not b.size:
            return
        r, c, v, t = k_trip
        n = len(self.dofmap.free)
        k = sp.csc_matrix((v * np.append(self.x0, 1.0)[t], (r, c)), shape=(n, n))[b][:, b]
        scale = max(abs(k).max(), 1e-300)
        try:
            lu = splu(k.tocsc() / scale)
            ok = np.all(np.abs(lu.U.diagonal()) > 1e-12)
        except RuntimeError:
            ok = False
        if ok:
            return
        names = self._dof_names()
        shown = f"{b.size} DOFs without mass"
        if b.size <= self.NAME_MASSLESS_MAX:
            w, u = np.linalg.eigh(k.toarray() / scale)
            null = u[:, w <= 1e-10]
            if null.size:
                moving = np.flatnonzero(np.abs(null).max(axis=1) > 0.2 * np.abs(null).max())
                shown = ", ".join(names[b[i]] for i in moving[:4]) + (" ..." if moving.size > 4 else "")
        raise ModelFileError(f"{self.model.source or self.model.name}: {shown} can move without mass and without "
                             "straining anything (no mode): hold that rotation (a support, an end not released) "
                             "or give it mass")

    def _find_mechanism(self) -> str:
        """What moves, when the structure has more zero-energy motions than the rigid-body
        motions its supports allow (a mechanism: a pin joint, a chain of hinges): their number
        and the DOFs that move most. Such modes are dropped with the rigid-body modes; `femu
        model` shows this line."""
        k = self.stiffness(self.x0[None, :])[0]
        if self.path == "dense" and self._solver.condensed:
            null = self._solver.zero_modes(self.x0)
        elif self.path == "dense":
            # the modes the solver counted as zero-energy (the same rule, not a second one)
            _, null = scipy.linalg.eigh(k, self.mass(self.x0[None, :])[0], subset_by_index=[0, self.n_rigid - 1])
        else:
            null = self._solver.zero_modes(self.x0)
        allowed = self._rigid_allowed(k)
        q, _ = np.linalg.qr(allowed) if allowed.size else (np.zeros((len(allowed), 0)), None)
        extra = null - q @ (q.T @ null)
        u = extra[:, np.argmax(np.linalg.norm(extra, axis=0))]
        names = self._dof_names()
        moving = [names[i] for i in np.argsort(-np.abs(u))[:4] if abs(u[i]) > 0.2 * np.abs(u).max()]
        return (f"{null.shape[1] - q.shape[1]} mechanism motion(s) strain no element and no spring "
                f"(moving most: {', '.join(moving)})")

    def _n_rigid_motions(self, k_trip, theta: np.ndarray) -> int:
        """How many rigid-body motions the supports and springs allow at `theta` (p,)."""
        r, c, v, t = k_trip
        n = len(self.dofmap.free)
        k = sp.csr_matrix((v * np.append(theta, 1.0)[t], (r, c)), shape=(n, n))
        allowed = self._rigid_allowed(k)
        return int(np.linalg.matrix_rank(allowed, tol=1e-9)) if allowed.size else 0

    def _rigid_allowed(self, k) -> np.ndarray:
        """The rigid-body motions the supports allow (n_free, r): combinations c of the free
        structure's rigid motions with K r c = 0 (K dense or sparse)."""
        m = self.model
        rigid = np.zeros((self.dofmap.n_total, m.layout.n_rigid_motions))
        rigid[: self.dofmap.n_nodal] = m.layout.rigid_motions(coordinates(m))
        for (_, node), dofs in self.dofmap.hinges.items():  # a released end turns with the body
            for rot, dof in dofs.items():
                rigid[dof] = rigid[self.dofmap.dof(node, rot, m)]
        r = rigid[self.dofmap.free]
        _, sv, vt = np.linalg.svd(k @ r / max(abs(k).max(), 1e-300), full_matrices=False)  # not an n x n U
        return r @ vt[np.sum(sv > 1e-9):].T if sv.size else r

    def _dof_names(self) -> list[str]:
        """A name for every free DOF: 'node N dir' or 'the released end of element E at node N'."""
        m = self.model
        names = [f"node {node} {d}" for node, d in m.dofs]
        names += [""] * (self.dofmap.n_total - self.dofmap.n_nodal)
        for (eid, node), dofs in self.dofmap.hinges.items():
            for rot, dof in dofs.items():
                names[dof] = f"the released end of element {eid} at node {node}" + (
                    f" ({rot})" if len(m.layout.hinges) > 1 else "")
        for (eid, node), rel in self.dofmap.relative.items():
            for local, (dof, _) in rel.items():
                names[dof] = f"the released end of element {eid} at node {node} (local {local})"
        return [names[i] for i in self.dofmap.free]

    # -- nodal DOFs -------------------------------------------------------------------
    def expand(self, phi_free: np.ndarray) -> np.ndarray:
        """Free-DOF shapes (..., n_free, m) to nodal-DOF shapes (..., n_nodal, m), zeros at supports."""
        shape = phi_free.shape[:-2] + (self.dofmap.n_total, phi_free.shape[-1])
        full = np.zeros(shape)
        full[..., self.dofmap.free, :] = phi_free
        return full[..., : self.dofmap.n_nodal, :]

    def nodal_rows(self, dofs) -> np.ndarray:
        """Row indices into the free-DOF vector for nodal DOFs [(node, dir), ...].

        A supported DOF has no row: -1 (its shape entry is zero). Kept with the DOF map (shared
        by the systems of one model's copies, `DofMap.of`) for the last few DOF lists asked."""
        dofs = tuple(dofs)  # read once: `dofs` may be a generator
        try:
            key = dofs
            kept = self.dofmap.rows_kept.get(key)
        except TypeError:  # a list of lists: no key
            key, kept = None, None
        if kept is None:
            pos = np.full(self.dofmap.n_total, -1)
            pos[self.dofmap.free] = np.arange(len(self.dofmap.free))
            kept = np.array([pos[self.dofmap.dof(n, d, self.model)] for n, d in dofs], dtype=int)
            if key is not None:
                if len(self.dofmap.rows_kept) >= 8:
                    self.dofmap.rows_kept.clear()
                self.dofmap.rows_kept[key] = kept
        return kept.copy()

    @staticmethod
    def at_rows(phi_free: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """Shapes (b, n_free, k) at the rows `nodal_rows` gave: (b, len(rows), k), zero where
        a DOF is supported (row -1)."""
        return take_rows(phi_free, rows)


__all__ = ["AUTO_DENSE_BYTES", "AffineModel", "DofMap", "SPARSE_MIN_DOFS", "SOLVERS", "check_dense_size",
           "solver_path"]
