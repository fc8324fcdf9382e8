"""What can be updated, and K(theta), M(theta) as affine sums built once.

Every updating parameter enters the stiffness or the mass matrix linearly:

    K(theta) = K0 + sum_k theta_k dK_k,      M(theta) = M0 + sum_k theta_k dM_k

with theta in physical units (an element modulus in Pa, a lumped mass in kg, a spring
stiffness in N m/rad). `AffineModel` assembles K0, M0, dK_k, dM_k once; evaluating a whole
population is then one tensor contraction and one batched eigen-solve, with no Python loop
per sample or per element.

DOFs: the model's nodal DOFs (node-major x, y, rz), then one extra rotation per released
element end (the element's own end rotation, tied to the node by a rotational spring).
Supported DOFs are removed before solving.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import elements as el
from .model import DIRECTIONS, FrameModel

PARAMETER_KINDS = ("modulus", "density", "mass", "spring", "release")


@dataclass(frozen=True)
class Parameter:
    """One updating parameter.

    kind: ``modulus`` (Pa, shared by the elements in `targets`), ``density`` (kg/m^3, elements),
    ``mass`` (kg, a lumped translational mass at the node in `targets`), ``spring`` (the
    stiffness of the model's spring with id in `targets`), ``release`` (N m/rad, the rotational
    spring at element end ``targets = (element id, node id)``, which must be released in the
    model).

    ``profile`` (modulus of one Euler-Bernoulli element only): how a change of the modulus is
    spread along the element. With value E' the element's modulus becomes
    E(xi) = E - (E - E') w(xi), w from `elements.PROFILES`: ``uniform`` (w = 1, the whole
    element), ``toward_i`` / ``toward_j`` (w linear, 1 at that end, 0 at the other),
    ``middle`` (w a hat: 1 at mid-length, 0 at both ends).
    """

    kind: str
    targets: tuple[int, ...]
    lower: float
    upper: float
    initial: float
    name: str = ""
    profile: str = "uniform"

    def __post_init__(self) -> None:
        if self.kind not in PARAMETER_KINDS:
            raise ValueError(f"parameter kind must be one of {PARAMETER_KINDS}, got {self.kind!r}")
        if not (np.isfinite(self.lower) and np.isfinite(self.upper) and self.lower < self.upper):
            raise ValueError(f"parameter {self.label}: need finite lower < upper, got [{self.lower}, {self.upper}]")
        if not self.lower <= self.initial <= self.upper:
            raise ValueError(f"parameter {self.label}: initial {self.initial} outside [{self.lower}, {self.upper}]")
        if self.profile not in el.PROFILES:
            raise ValueError(f"parameter {self.label}: profile must be one of {list(el.PROFILES)}, got {self.profile!r}")
        if self.profile != "uniform" and (self.kind != "modulus" or len(self.targets) != 1):
            raise ValueError(f"parameter {self.label}: a profile applies to the modulus of one element")

    @property
    def label(self) -> str:
        return self.name or f"{self.kind}{list(self.targets)}"


def element_moduli(model: FrameModel, element_ids=None, lower: float = 6.0e10, upper: float = 8.0e10,
                   initial: float | None = None) -> tuple[Parameter, ...]:
    """One modulus parameter per element (default: every element, the paper's 12 moduli)."""
    ids = model.element_ids if element_ids is None else tuple(element_ids)
    return tuple(Parameter("modulus", (e,), lower, upper,
                           model.element_modulus_pa(e) if initial is None else initial, name=f"E{e}")
                 for e in ids)


@dataclass(frozen=True)
class DofMap:
    """Where every element end, spring and mass sits in the global DOF vector."""

    n_nodal: int
    n_total: int
    element_dofs: np.ndarray          # (n_el, 6) global DOF of each local DOF
    hinges: dict[tuple[int, int], int]  # (element id, node id) -> hinge DOF
    free: np.ndarray                   # indices of unsupported DOFs

    @classmethod
    def of(cls, model: FrameModel) -> "DofMap":
        n_nodal = 3 * len(model.nodes)
        nxt = n_nodal
        hinges: dict[tuple[int, int], int] = {}
        edofs = np.zeros((len(model.elements), 6), dtype=int)
        for k, e in enumerate(model.elements):
            for o, node, rel in ((0, e.node_i, e.release_i), (3, e.node_j, e.release_j)):
                base = model.dof_index(node, "x")
                edofs[k, o:o + 3] = (base, base + 1, base + 2)
                if rel is not None:
                    hinges[(e.id, node)] = edofs[k, o + 2] = nxt
                    nxt += 1
        fixed = {model.dof_index(s.node, d) for s in model.supports for d in s.directions}
        free = np.array([i for i in range(nxt) if i not in fixed], dtype=int)
        return cls(n_nodal, nxt, edofs, hinges, free)


def element_matrices(model: FrameModel) -> tuple[np.ndarray, np.ndarray]:
    """Global-axis element stiffness per unit modulus (E = 1) and mass per unit density.

    Both (n_el, 6, 6). Timoshenko's shear ratio phi = 24 (1 + nu) I / (kappa A L^2) does not
    depend on E (G = E / 2(1 + nu)), so the stiffness stays linear in E.
    """
    els = model.elements
    xi = np.array([[model.node(e.node_i).x, model.node(e.node_i).y] for e in els])
    xj = np.array([[model.node(e.node_j).x, model.node(e.node_j).y] for e in els])
    d = xj - xi
    length = np.hypot(d[:, 0], d[:, 1])
    area = np.array([model.sections[e.section].area_m2 for e in els])
    inertia = np.array([model.sections[e.section].inertia_m4 for e in els])
    kappa = np.array([model.sections[e.section].shear_coefficient for e in els])
    nu = np.array([model.materials[e.material].poisson_ratio for e in els])
    timo = np.array([e.formulation == "timoshenko" for e in els])
    phi = np.where(timo, 24.0 * (1.0 + nu) * inertia / (kappa * area * length**2), 0.0)
    t = el.rotation(d[:, 0] / length, d[:, 1] / length)
    k_local = el.local_stiffness(length, area, inertia, phi)
    cracked = np.array([e.crack_position is not None for e in els])
    if cracked.any():
        # per unit modulus: the crack compliance is c * E (the crack scales with E, see Element)
        c = np.array([model.element_modulus_pa(e.id) / e.crack_stiffness for e in els if e.crack_position is not None])
        pos = np.array([e.crack_position for e in els if e.crack_position is not None])
        bend = el.cracked_bending_stiffness(length[cracked], inertia[cracked], pos, c)
        axial = el.local_stiffness(length[cracked], area[cracked], np.zeros(int(cracked.sum())), phi[cracked])
        k_local[cracked] = bend + axial
    k = el.to_global(k_local, t)
    m = el.to_global(el.local_mass(length, area, np.where(timo, inertia, 0.0), phi), t)
    return k, m


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


class AffineModel:
    """K(theta), M(theta) of a model over a parameter set, reduced to the free DOFs.

    Built once; `eigen(theta)` solves a whole population. Rigid-body modes (zero
    eigenvalues of the unconstrained structure, counted at the initial parameters) are
    dropped, and the `n_modes` lowest elastic modes are returned.
    """

    RIGID_TOL = 1e-12  # eigenvalue / largest eigenvalue below this is a rigid-body mode

    def __init__(self, model: FrameModel, parameters: tuple[Parameter, ...] = ()):
        self.model = model
        self.parameters = tuple(parameters)
        self.dofmap = dm = DofMap.of(model)
        n = dm.n_total
        k_el, m_el = element_matrices(model)
        modulus = np.array([model.element_modulus_pa(e.id) for e in model.elements])
        density = np.array([model.materials[e.material].density_kg_m3 for e in model.elements])
        index = {e.id: i for i, e in enumerate(model.elements)}

        k_weight, m_weight = modulus.copy(), density.copy()
        dk = np.zeros((len(self.parameters), n, n))
        dm_ = np.zeros((len(self.parameters), n, n))
        taken_springs: set[int] = set()
        taken_releases: set[tuple[int, int]] = set()
        taken_masses: set[int] = set()
        k_extra = np.zeros((n, n))
        for p, par in enumerate(self.parameters):
            if par.kind in ("modulus", "density"):
                rows = [index[t] if t in index else _unknown(model, "element", t, par) for t in par.targets]
                w = np.zeros(len(model.elements))
                w[rows] = 1.0
                if par.kind == "modulus" and par.profile != "uniform":
                    k_w = _profile_stiffness(model, par)
                    one = dm.element_dofs[rows]
                    dk[p] = _scatter(n, one, k_w)
                    k_extra -= modulus[rows[0]] * dk[p]
                elif par.kind == "modulus":
                    k_weight[rows] = 0.0
                    dk[p] = _scatter(n, dm.element_dofs, k_el * w[:, None, None])
                else:
                    m_weight[rows] = 0.0
                    dm_[p] = _scatter(n, dm.element_dofs, m_el * w[:, None, None])
            elif par.kind == "mass":
                for node in par.targets:
                    base = model.dof_index(node, "x") if node in model.node_ids else _unknown(model, "node", node, par)
                    dm_[p, base, base] += 1.0
                    dm_[p, base + 1, base + 1] += 1.0
                    taken_masses.add(node)
            elif par.kind == "spring":
                springs = {s.id: s for s in model.springs}
                for sid in par.targets:
                    s = springs[sid] if sid in springs else _unknown(model, "spring", sid, par)
                    dk[p] += _two_dof(n, model.dof_index(*s.dof_a),
                                      model.dof_index(*s.dof_b) if s.dof_b else None, 1.0)
                    taken_springs.add(sid)
            elif par.kind == "release":
                key = tuple(par.targets)
                if key not in dm.hinges:
                    raise ValueError(f"parameter {par.label}: element end {key} is not released in the model")
                dk[p] = _two_dof(n, model.dof_index(key[1], "rz"), dm.hinges[key], 1.0)
                taken_releases.add(key)

        k0 = _scatter(n, dm.element_dofs, k_el * k_weight[:, None, None]) + k_extra
        m0 = _scatter(n, dm.element_dofs, m_el * m_weight[:, None, None])
        for lm in model.masses:
            b = model.dof_index(lm.node, "x")
            if lm.node not in taken_masses:
                m0[b, b] += lm.mass_kg
                m0[b + 1, b + 1] += lm.mass_kg
            m0[b + 2, b + 2] += lm.inertia_kg_m2
        for s in model.springs:
            if s.id not in taken_springs:
                k0 += _two_dof(n, model.dof_index(*s.dof_a), model.dof_index(*s.dof_b) if s.dof_b else None,
                               s.stiffness)
        for e in model.elements:
            for node, rel in ((e.node_i, e.release_i), (e.node_j, e.release_j)):
                if rel is not None and (e.id, node) not in taken_releases:
                    k0 += _two_dof(n, model.dof_index(node, "rz"), dm.hinges[(e.id, node)], rel)

        f = dm.free
        self.k0, self.m0 = k0[np.ix_(f, f)], m0[np.ix_(f, f)]
        self.dk, self.dm = dk[:, f][:, :, f], dm_[:, f][:, :, f]
        self.n_free = len(f)
        self.mass_constant = not np.any(self.dm)
        n_fixed_null = 0
        if self.mass_constant:
            # Work in mass-normalised coordinates once: A = L^-1 K L^-T with M0 = L L^T.
            self._linv = np.linalg.inv(_cholesky(self.m0, model))
            a0 = self._linv @ self.k0 @ self._linv.T
            da = np.einsum("ij,pjk,lk->pil", self._linv, self.dk, self._linv)
            # Motions that no parameter can strain (the rigid-body modes of a free structure)
            # are eigenvectors of eigenvalue 0 for every theta: project them out once, exactly,
            # so each solve is smaller (39 -> 36 DOFs for the free-free H-frame).
            # Each term normalised by its own size (dA_k is per unit of theta_k, whose range can
            # be anything): a direction is dropped only if every term is zero on it.
            terms = [t / np.linalg.norm(t) for t in (a0, *da) if np.linalg.norm(t) > 0]
            _, sv, vt = np.linalg.svd(np.vstack(terms))
            keep = sv > 1e-10 * sv[0]
            self._q = vt[keep].T                       # (n_free, n_kept) orthonormal
            n_fixed_null = self.n_free - self._q.shape[1]
            self._a0 = self._q.T @ a0 @ self._q
            k = self._q.shape[1]
            self._da_flat = np.einsum("ji,pjk,kl->pil", self._q, da, self._q).reshape(len(self.parameters), k * k)
        lam = np.linalg.eigvalsh(self._operator(self.x0[None, :]))[0]
        self._skip = int(np.sum(lam < self.RIGID_TOL * lam.max()))  # zero modes left in the solve
        self.n_rigid = self._skip + n_fixed_null                      # rigid-body modes dropped
        self.n_elastic = self.n_free - self.n_rigid

    # -- parameter vectors ------------------------------------------------------------
    @property
    def n_params(self) -> int:
        return len(self.parameters)

    @property
    def x0(self) -> np.ndarray:
        return np.array([p.initial for p in self.parameters], dtype=float)

    @property
    def lower(self) -> np.ndarray:
        return np.array([p.lower for p in self.parameters], dtype=float)

    @property
    def upper(self) -> np.ndarray:
        return np.array([p.upper for p in self.parameters], dtype=float)

    # -- matrices ---------------------------------------------------------------------
    def stiffness(self, theta: np.ndarray) -> np.ndarray:
        """K(theta) on the free DOFs, (b, n, n) for theta (b, p)."""
        return self.k0 + np.einsum("bp,pij->bij", theta, self.dk)

    def mass(self, theta: np.ndarray) -> np.ndarray:
        """M(theta) on the free DOFs, (b, n, n) for theta (b, p)."""
        return self.m0 + np.einsum("bp,pij->bij", theta, self.dm)

    def _operator(self, theta: np.ndarray) -> np.ndarray:
        """The symmetric operator whose eigenvalues are omega^2, and L^-T for the vectors."""
        if self.mass_constant:
            n = self._a0.shape[0]
            # A stacked (b, 1, p) @ (p, n*n) product computes every row by the same routine, so
            # f(x) does not depend on the batch x comes in (a plain (b, p) @ (p, n*n) does, in
            # the last bits: gemv for one row, gemm tiles for many).
            rows = np.matmul(theta[:, None, :], self._da_flat)[:, 0, :]
            return self._a0 + rows.reshape(theta.shape[0], n, n)
        linv = np.linalg.inv(_cholesky(self.mass(theta), self.model))
        return linv @ self.stiffness(theta) @ np.swapaxes(linv, 1, 2)

    def _linv_batch(self, theta: np.ndarray) -> np.ndarray:
        if self.mass_constant:
            return np.broadcast_to(self._linv, (theta.shape[0],) + self._linv.shape)
        return np.linalg.inv(_cholesky(self.mass(theta), self.model))

    def eigen(self, theta: np.ndarray, n_modes: int, vectors: bool = False):
        """Lowest `n_modes` elastic eigenpairs for a population theta (b, p).

        Returns eigenvalues omega^2 (b, n_modes) in (rad/s)^2 and, with `vectors`, mass-
        normalised shapes on the free DOFs (b, n_free, n_modes), each signed so that its
        largest-magnitude entry is positive. Without `vectors` only eigenvalues are computed
        (the fast path of the frequency objective).
        """
        theta = np.atleast_2d(np.asarray(theta, dtype=float))
        if n_modes > self.n_elastic:
            raise ValueError(f"model {self.model.name!r} has only {self.n_elastic} elastic modes, "
                             f"asked for {n_modes}")
        sl = slice(self._skip, self._skip + n_modes)
        a = self._operator(theta)
        if not vectors:
            return np.linalg.eigvalsh(a)[:, sl], None
        lam, y = np.linalg.eigh(a)
        y = y[:, :, sl]
        if self.mass_constant:
            y = self._q @ y
        phi = np.swapaxes(self._linv_batch(theta), 1, 2) @ y
        big = np.take_along_axis(phi, np.abs(phi).argmax(axis=1)[:, None, :], axis=1)
        return lam[:, sl], phi * np.where(big < 0, -1.0, 1.0)

    def eigen_sensitivities(self, theta: np.ndarray, n_modes: int):
        """Eigenvalues, shapes and d(omega^2)/d(theta) (b, n_modes, p) for theta (b, p).

        For mass-normalised phi: d lambda / d theta_k = phi^T (dK_k - lambda dM_k) phi.
        """
        lam, phi = self.eigen(theta, n_modes, vectors=True)
        dk = np.einsum("bim,pij,bjm->bmp", phi, self.dk, phi)
        dm = np.einsum("bim,pij,bjm->bmp", phi, self.dm, phi)
        return lam, phi, dk - lam[:, :, None] * dm

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


def _profile_stiffness(model: FrameModel, par: Parameter) -> np.ndarray:
    """Global-axis stiffness per unit modulus of one element weighted by a profile, (1, 6, 6)."""
    e = model.element(par.targets[0])
    if e.formulation != "euler-bernoulli" or e.crack_position is not None:
        raise ValueError(f"parameter {par.label}: a modulus profile needs an uncracked Euler-Bernoulli element")
    a, b = model.node(e.node_i), model.node(e.node_j)
    length = np.array([np.hypot(b.x - a.x, b.y - a.y)])
    sec = model.sections[e.section]
    k = el.weighted_stiffness(length, np.array([sec.area_m2]), np.array([sec.inertia_m4]), el.PROFILES[par.profile])
    t = el.rotation(np.array([(b.x - a.x) / length[0]]), np.array([(b.y - a.y) / length[0]]))
    return el.to_global(k, t)


def _unknown(model: FrameModel, what: str, ident, par: Parameter):
    raise ValueError(f"parameter {par.label}: model {model.name!r} has no {what} {ident}")


def _cholesky(m: np.ndarray, model: FrameModel) -> np.ndarray:
    try:
        return np.linalg.cholesky(m)
    except np.linalg.LinAlgError:
        raise ValueError(f"model {model.name!r}: the mass matrix is not positive definite "
                         "(a DOF with no mass: a released end of a massless element, or a zero density)") from None


__all__ = ["Parameter", "AffineModel", "DofMap", "element_moduli", "element_matrices", "DIRECTIONS"]
