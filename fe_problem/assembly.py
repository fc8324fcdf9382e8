"""K(theta), M(theta) of a model as affine sums, assembled once.

    K(theta) = K0 + sum_k theta_k dK_k,      M(theta) = M0 + sum_k theta_k dM_k

with theta in physical units (parameters.py). `AffineModel` assembles K0, M0, dK_k, dM_k on
the free DOFs once; the batched eigen-solver (solver.py) then evaluates a whole population
with one tensor contraction and one eigen-solve, no Python loop per sample or per element.

DOFs: the model's nodal DOFs (its `layout`, node-major), then one extra rotation per released
element end (the element's own end rotation, tied to the node's hinge rotation by a
rotational spring). Supported DOFs are removed before solving.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .elements import element_matrices, profile_stiffness
from .model import FrameModel, ModelFileError
from .parameters import Parameter
from .solver import ModalSolver


@dataclass(frozen=True)
class DofMap:
    """Where every element end, spring and mass sits in the global DOF vector."""

    n_nodal: int
    n_total: int
    element_dofs: np.ndarray          # (n_el, k) global DOF of each local DOF
    hinges: dict[tuple[int, int], int]  # (element id, node id) -> hinge DOF
    free: np.ndarray                   # indices of unsupported DOFs

    @classmethod
    def of(cls, model: FrameModel) -> "DofMap":
        """The DOF map of `model`: nodal DOFs first, then one hinge DOF per released end."""
        per, rot = model.layout.per_node, model.layout.rotation_position
        n_nodal = model.n_dof
        nxt = n_nodal
        hinges: dict[tuple[int, int], int] = {}
        edofs = np.zeros((len(model.elements), 2 * per), dtype=int)
        for k, e in enumerate(model.elements):
            for o, node, rel in ((0, e.node_i, e.release_i), (per, e.node_j, e.release_j)):
                edofs[k, o:o + per] = model.node_dof_indices(node)
                if rel is not None:
                    hinges[(e.id, node)] = edofs[k, o + rot] = nxt
                    nxt += 1
        fixed = {model.dof_index(s.node, d) for s in model.supports for d in s.directions}
        free = np.array([i for i in range(nxt) if i not in fixed], dtype=int)
        return cls(n_nodal, nxt, edofs, hinges, free)


def _scatter(n: int, dofs: np.ndarray, mats: np.ndarray) -> np.ndarray:
    """Assemble element matrices (e, k, k) on DOFs (e, k) into one (n, n) matrix."""
    out = np.zeros((n, n))
    rows = np.broadcast_to(dofs[:, :, None], mats.shape)
    cols = np.broadcast_to(dofs[:, None, :], mats.shape)
    np.add.at(out, (rows.ravel(), cols.ravel()), mats.ravel())
    return out


def _two_dof(n: int, a: int, b: int | None, value: float) -> np.ndarray:
    """A spring of unit `value` between DOFs a and b (b None: to ground)."""
    out = np.zeros((n, n))
    out[a, a] += value
    if b is not None:
        out[b, b] += value
        out[a, b] -= value
        out[b, a] -= value
    return out


def _unknown(model: FrameModel, what: str, ident, par: Parameter):
    raise ValueError(f"parameter {par.label}: model {model.name!r} has no {what} {ident}")


class _Assembly:
    """The full-size (all DOFs) affine terms of one model and parameter set."""

    def __init__(self, model: FrameModel, parameters: tuple[Parameter, ...]):
        self.model, self.dofmap = model, DofMap.of(model)
        n, p = self.dofmap.n_total, len(parameters)
        self.k_el, self.m_el = element_matrices(model)
        self.modulus = np.array([model.element_modulus_pa(e.id) for e in model.elements])
        self.k_weight = self.modulus.copy()
        self.m_weight = np.array([model.materials[e.material].density_kg_m3 for e in model.elements])
        self.index = {e.id: i for i, e in enumerate(model.elements)}
        self.dk, self.dm = np.zeros((p, n, n)), np.zeros((p, n, n))
        self.k_extra = np.zeros((n, n))
        self.taken: dict[str, set] = {"spring": set(), "release": set(), "mass": set()}
        for i, par in enumerate(parameters):
            self._term(i, par)

    def _spring(self, s, value: float) -> np.ndarray:
        m = self.model
        return _two_dof(self.dofmap.n_total, m.dof_index(*s.dof_a), m.dof_index(*s.dof_b) if s.dof_b else None,
                        value)

    def _hinge(self, element_id: int, node: int, value: float) -> np.ndarray:
        m = self.model
        return _two_dof(self.dofmap.n_total, m.dof_index(node, m.layout.rotation),
                        self.dofmap.hinges[(element_id, node)], value)

    def _term(self, p: int, par: Parameter) -> None:
        """Fill dK_p / dM_p of parameter `par` and take its share out of K0 / M0."""
        model, dm, n = self.model, self.dofmap, self.dofmap.n_total
        if par.kind in ("modulus", "density"):
            rows = [self.index[t] if t in self.index else _unknown(model, "element", t, par) for t in par.targets]
            w = np.zeros(len(model.elements))
            w[rows] = 1.0
            if par.kind == "modulus" and par.profile != "uniform":
                try:
                    k_w = profile_stiffness(model, model.element(par.targets[0]), par.profile)
                except ValueError as exc:
                    raise ValueError(f"parameter {par.label}: {exc}") from None
                self.dk[p] = _scatter(n, dm.element_dofs[rows], k_w)
                self.k_extra -= self.modulus[rows[0]] * self.dk[p]
            elif par.kind == "modulus":
                self.k_weight[rows] = 0.0
                self.dk[p] = _scatter(n, dm.element_dofs, self.k_el * w[:, None, None])
            else:
                self.m_weight[rows] = 0.0
                self.dm[p] = _scatter(n, dm.element_dofs, self.m_el * w[:, None, None])
        elif par.kind == "mass":
            for node in par.targets:
                if node not in model.node_ids:
                    _unknown(model, "node", node, par)
                for d in model.node_dof_indices(node, model.layout.translations):
                    self.dm[p, d, d] += 1.0
                self.taken["mass"].add(node)
        elif par.kind == "spring":
            springs = {s.id: s for s in model.springs}
            for sid in par.targets:
                s = springs[sid] if sid in springs else _unknown(model, "spring", sid, par)
                self.dk[p] += self._spring(s, 1.0)
                self.taken["spring"].add(sid)
        elif par.kind == "release":
            key = tuple(par.targets)
            if key not in dm.hinges:
                raise ValueError(f"parameter {par.label}: element end {key} is not released in the model")
            self.dk[p] = self._hinge(key[0], key[1], 1.0)
            self.taken["release"].add(key)

    def constant(self) -> tuple[np.ndarray, np.ndarray]:
        """K0, M0: everything no parameter holds."""
        model, dm, n = self.model, self.dofmap, self.dofmap.n_total
        k0 = _scatter(n, dm.element_dofs, self.k_el * self.k_weight[:, None, None]) + self.k_extra
        m0 = _scatter(n, dm.element_dofs, self.m_el * self.m_weight[:, None, None])
        for lm in model.masses:
            if lm.node not in self.taken["mass"]:
                for d in model.node_dof_indices(lm.node, model.layout.translations):
                    m0[d, d] += lm.mass_kg
            r = model.dof_index(lm.node, model.layout.rotation)
            m0[r, r] += lm.inertia_kg_m2
        for s in model.springs:
            if s.id not in self.taken["spring"]:
                k0 += self._spring(s, s.stiffness)
        for e in model.elements:
            for node, rel in ((e.node_i, e.release_i), (e.node_j, e.release_j)):
                if rel is not None and (e.id, node) not in self.taken["release"]:
                    k0 += self._hinge(e.id, node, rel)
        return k0, m0


#: The most memory the dense path may take for one model's matrices (bytes): K0, M0 and one
#: dK (and dM) per parameter, each n_dof x n_dof float64, and the work arrays of the solve.
MAX_DENSE_BYTES = 4 * 2**30


def dense_bytes(n_dof: int, n_params: int) -> int:
    """Memory (bytes) the dense path needs for a model of `n_dof` DOFs and `n_params` parameters:
    the constant and per-parameter matrices and their mass-normalised copies, n_dof^2 float64 each."""
    return 8 * n_dof * n_dof * (2 * max(n_params, 1) + 6)


def check_dense_size(model: FrameModel, n_params: int) -> None:
    """ValueError naming the model, its size and the limit if the dense path would need more
    than `MAX_DENSE_BYTES`: refused up front, never a machine run out of memory."""
    n = model.n_dof + sum((e.release_i is not None) + (e.release_j is not None) for e in model.elements)  # as DofMap
    need = dense_bytes(n, n_params)
    if need > MAX_DENSE_BYTES:
        raise ModelFileError(f"{model.source or model.name}: {len(model.nodes)} nodes, {n} DOFs and {n_params} "
                         f"parameters need about {need / 2**30:.1f} GiB as dense matrices, more than the "
                         f"{MAX_DENSE_BYTES / 2**30:.0f} GiB limit (fe_problem.assembly.MAX_DENSE_BYTES); "
                         "use a coarser model or fewer parameters")


class AffineModel(ModalSolver):
    """K(theta), M(theta) of a model over a parameter set, reduced to the free DOFs.

    Built once; `eigen(theta)` (solver.py) solves a whole population. Rigid-body modes (zero
    eigenvalues of the unconstrained structure, counted at the initial parameters) are
    dropped, and the `n_modes` lowest elastic modes are returned.
    """

    def __init__(self, model: FrameModel, parameters: tuple[Parameter, ...] = ()):
        self.model = model
        self.parameters = tuple(parameters)
        check_dense_size(model, len(self.parameters))
        asm = _Assembly(model, self.parameters)
        self.dofmap = asm.dofmap
        k0, m0 = asm.constant()
        f = self.dofmap.free
        if f.size == 0:
            raise ModelFileError(f"{model.source or model.name}: every DOF is supported, so the model has no mode: "
                             "remove a support")
        self._check_mass(m0[np.ix_(f, f)] + np.einsum("p,pij->ij", self.x0, asm.dm[:, f][:, :, f]))
        super().__init__(k0[np.ix_(f, f)], m0[np.ix_(f, f)], asm.dk[:, f][:, :, f], asm.dm[:, f][:, :, f],
                         self.x0, model.name)
        #: None, or what moves in the zero-energy motions that are not rigid-body motions
        self.mechanism: str | None = self._find_mechanism() if self.n_rigid else None

    def _check_mass(self, m: np.ndarray) -> None:
        """ModelFileError naming the model and the DOFs, if some free DOF carries no mass."""
        massless = np.flatnonzero(np.diag(m) <= 0.0)
        if massless.size:
            names = self._dof_names()
            shown = ", ".join(names[i] for i in massless[:4]) + (" ..." if massless.size > 4 else "")
            raise ModelFileError(f"{self.model.source or self.model.name}: {massless.size} DOF(s) carry no mass "
                             f"({shown}): connect the node to an element with density, give it a lumped mass "
                             "with rotary inertia, or support that DOF")

    def _find_mechanism(self) -> str | None:
        """What moves, if the structure has zero-energy motions that are not rigid-body motions
        (a mechanism: a pin joint, a chain of hinges): their number and the DOFs that move most.
        Such modes are dropped with the rigid-body modes; `femu model` shows this line."""
        k = self.stiffness(self.x0[None, :])[0]
        lam, vec = np.linalg.eigh(k)
        null = vec[:, lam < self.RIGID_TOL * max(lam.max(), 1e-300)]
        m = self.model
        rigid = np.zeros((self.dofmap.n_total, 3))
        rigid[: self.dofmap.n_nodal] = m.layout.rigid_motions(np.array([(n.x, n.y) for n in m.nodes]))
        for (_, node), dof in self.dofmap.hinges.items():  # a released end turns with the body
            rigid[dof, 2] = 1.0
        r = rigid[self.dofmap.free]
        # the rigid motions the supports allow: combinations c with K r c = 0
        _, sv, vt = np.linalg.svd(k @ r / max(np.abs(k).max(), 1e-300))
        allowed = r @ vt[np.sum(sv > 1e-9):].T if sv.size else r
        if null.shape[1] <= (np.linalg.matrix_rank(allowed, tol=1e-9) if allowed.size else 0):
            return None
        q, _ = np.linalg.qr(allowed) if allowed.size else (np.zeros((len(r), 0)), None)
        extra = null - q @ (q.T @ null)
        u = extra[:, np.argmax(np.linalg.norm(extra, axis=0))]
        names = self._dof_names()
        moving = [names[i] for i in np.argsort(-np.abs(u))[:4] if abs(u[i]) > 0.2 * np.abs(u).max()]
        return (f"{null.shape[1] - q.shape[1]} mechanism motion(s) strain no element and no spring "
                f"(moving most: {', '.join(moving)})")

    def _dof_names(self) -> list[str]:
        """A name for every free DOF: 'node N dir' or 'the released end of element E at node N'."""
        m = self.model
        names = [f"node {node} {d}" for node, d in m.dofs]
        names += [""] * (self.dofmap.n_total - self.dofmap.n_nodal)
        for (eid, node), dof in self.dofmap.hinges.items():
            names[dof] = f"the released end of element {eid} at node {node}"
        return [names[i] for i in self.dofmap.free]

    # -- parameter vectors ------------------------------------------------------------
    @property
    def n_params(self) -> int:
        """Number of parameters."""
        return len(self.parameters)

    @property
    def x0(self) -> np.ndarray:
        """Initial parameter values (p,), physical units."""
        return np.array([p.initial for p in self.parameters], dtype=float)

    @property
    def lower(self) -> np.ndarray:
        """Lower bounds (p,)."""
        return np.array([p.lower for p in self.parameters], dtype=float)

    @property
    def upper(self) -> np.ndarray:
        """Upper bounds (p,)."""
        return np.array([p.upper for p in self.parameters], dtype=float)

    # -- nodal DOFs -------------------------------------------------------------------
    def expand(self, phi_free: np.ndarray) -> np.ndarray:
        """Free-DOF shapes (..., n_free, m) to nodal-DOF shapes (..., n_nodal, m), zeros at supports."""
        shape = phi_free.shape[:-2] + (self.dofmap.n_total, phi_free.shape[-1])
        full = np.zeros(shape)
        full[..., self.dofmap.free, :] = phi_free
        return full[..., : self.dofmap.n_nodal, :]

    def nodal_rows(self, dofs) -> np.ndarray:
        """Row indices into the free-DOF vector for nodal DOFs [(node, dir), ...].

        A supported DOF has no row: -1 (its shape entry is zero)."""
        pos = {g: i for i, g in enumerate(self.dofmap.free)}
        return np.array([pos.get(self.model.dof_index(n, d), -1) for n, d in dofs], dtype=int)

    @staticmethod
    def at_rows(phi_free: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """Shapes (b, n_free, k) at the rows `nodal_rows` gave: (b, len(rows), k), zero where
        a DOF is supported (row -1)."""
        out = phi_free[:, np.clip(rows, 0, None), :]
        out[:, rows < 0, :] = 0.0
        return out


__all__ = ["AffineModel", "DofMap"]
