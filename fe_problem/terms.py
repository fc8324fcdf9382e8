"""The affine terms of K(theta) and M(theta) as sparse triplets, assembled once.

    K(theta) = K0 + sum_k theta_k dK_k,      M(theta) = M0 + sum_k theta_k dM_k

Every contribution (an element's stiffness or mass, a spring, a hinge, a lumped mass) is a
list of (row, column, value) triplets tagged with its term: -1 for K0 / M0, k for dK_k /
dM_k. Both solver paths read the same triplets: the dense path scatters them into
n x n arrays (solver.py), the sparse path into one fixed CSR pattern (sparse.py). So the
rules of what each parameter holds live here, once, and memory is O(number of triplets).

DOFs: the model's nodal DOFs (its `layout`, node-major), then one extra rotation per released
rotation of an element end (the element's own end rotation, tied to the node's rotation by a
rotational spring; a space element's release is named in its local axes, and acts on the
global rotation that local axis lies along). Supported DOFs are removed by `Terms.free`.

A release about a local axis along no global axis (a skew member's, `release_rotation`
refuses it) cannot take the place of one of the node's rotations: its extra DOF is the end's
rotation h relative to the node about that axis a, the element end turning by theta_node +
h a. The element's matrix then acts on its nodal DOFs and its h's through B = [I | E] (E
holds a in the end's rotation rows): B^T K_e B (`DofMap.element_block`), and the spring is
k h^2 / 2 on h alone. Both forms are exact; a release along a global axis keeps the first
(planar results unchanged).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from .elements import element_matrices, profile_stiffness
from .model import FrameModel
from .parameters import Parameter


#: The DOF maps of the last few models (nodes, elements, supports, layout, map), most recent
#: first: a diagnosis builds hundreds of systems of one model and of copies that keep its nodes,
#: elements and supports (a DOF map depends on nothing else), held so compared by identity.
_MAPS: list[tuple] = []
_KEEP_MAPS = 4


@dataclass(frozen=True)
class DofMap:
    """Where every element end, spring and mass sits in the global DOF vector."""

    n_nodal: int
    n_total: int
    element_dofs: np.ndarray          # (n_el, k) global DOF of each local DOF
    hinges: dict[tuple[int, int], dict[str, int]]  # (element id, node id) -> {node rotation: hinge DOF}
    free: np.ndarray                   # indices of unsupported DOFs
    node_dofs: dict[int, np.ndarray]   # node id -> its nodal DOFs (layout order)
    hinge_stiffness: dict[tuple[int, int], dict[str, float]]  # the same keys -> the release's N m/rad
    #: releases about a skew local axis: (element id, node id) -> {local rotation: (h DOF, N m/rad)}
    relative: dict[tuple[int, int], dict[str, tuple[int, float]]] = dataclasses.field(default_factory=dict)
    #: element row -> (its relative DOFs (m,), B (k, k + m)): its DOFs' values are B (nodal, h)
    extended: dict[int, tuple[np.ndarray, np.ndarray]] = dataclasses.field(default_factory=dict)
    #: `AffineModel.nodal_rows` of the last DOF lists asked (a tuple of (node, direction) -> rows)
    rows_kept: dict = dataclasses.field(default_factory=dict, compare=False, repr=False)

    @classmethod
    def of(cls, model: FrameModel) -> "DofMap":
        """The DOF map of `model`: nodal DOFs first, then one hinge DOF per released rotation
        of an element end. The same object for models that share their nodes, elements and
        supports (the same tuples: copies that differ in a section, a material, a spring or a
        mass; `_MAPS`). Treat it as read-only."""
        tables = (model.nodes, model.elements, model.supports, model.layout)
        for entry in _MAPS:
            if all(a is b for a, b in zip(entry[:4], tables)):
                return entry[4]
        like = next((entry for entry in _MAPS if entry[0] is model.nodes and entry[3] is model.layout
                     and len(entry[1]) == len(model.elements)), None)
        made, ends, released = cls._build(model, like)
        _MAPS.insert(0, tables + (made, ends, released))
        del _MAPS[_KEEP_MAPS:]
        return made

    @classmethod
    def _build(cls, model: FrameModel, like: tuple | None = None):
        """(the map, every element's end node positions (n_el, 2), the positions of the elements
        with a released end). `like`: a `_MAPS` entry on the same nodes (the same tuple) with as
        many elements: its node DOFs are taken, and its ends and released rows for the element
        objects it shares (a copy with an end released, a modulus, a support changed)."""
        lay = model.layout
        per = lay.per_node
        nxt = model.n_dof
        hinges: dict[tuple[int, int], dict[str, int]] = {}
        stiffness: dict[tuple[int, int], dict[str, float]] = {}
        relative: dict[tuple[int, int], dict[str, tuple[int, float]]] = {}
        extended: dict[int, tuple[np.ndarray, np.ndarray]] = {}
        pos = model._node_pos  # every element's nodal DOFs at once; the released ends below

        def has_release(e) -> bool:
            return e.release_i is not None or e.release_j is not None or bool(e.releases_i) or bool(e.releases_j)

        if like is None:
            node_dofs = {n.id: per * k + np.arange(per) for k, n in enumerate(model.nodes)}
            ends = np.array([[pos[e.node_i], pos[e.node_j]] for e in model.elements], dtype=int).reshape(-1, 2)
            released = [k for k, e in enumerate(model.elements) if has_release(e)]
        else:
            node_dofs, ends = like[4].node_dofs, like[5].copy()
            n_el = len(model.elements)
            same = np.fromiter((a is b for a, b in zip(like[1], model.elements)), bool, n_el)
            new = np.flatnonzero(~same)
            for k in new:
                e = model.elements[k]
                ends[k] = pos[e.node_i], pos[e.node_j]
            released = sorted([k for k in like[6] if same[k]] + [int(k) for k in new if has_release(model.elements[k])])
        ends.setflags(write=False)
        edofs = (per * ends[:, :, None] + np.arange(per)).reshape(len(model.elements), 2 * per)
        for k in released:
            e = model.elements[k]
            columns = []  # the skew releases' columns of E
            for o, node, rel in zip((0, per), (e.node_i, e.node_j), model.end_releases(e)):
                for local, value in rel.items():
                    axis = release_axis(model, e, local)
                    if axis is None:
                        rot = release_rotation(model, e, local)
                        hinges.setdefault((e.id, node), {})[rot] = edofs[k, o + lay.position(rot)] = nxt
                        stiffness.setdefault((e.id, node), {})[rot] = value
                    else:
                        relative.setdefault((e.id, node), {})[local] = (nxt, value)
                        col = np.zeros(2 * per)
                        col[[o + lay.position(r) for r in ("rx", "ry", "rz")]] = axis
                        columns.append((nxt, col))
                    nxt += 1
            if columns:
                b = np.hstack([np.eye(2 * per), np.stack([c for _, c in columns], axis=1)])
                extended[k] = (np.array([d for d, _ in columns]), b)
        fixed = np.zeros(nxt, dtype=bool)
        for s in model.supports:
            fixed[[node_dofs[s.node][lay.position(d)] for d in s.directions]] = True
        made = cls(model.n_dof, nxt, edofs, hinges, np.flatnonzero(~fixed), node_dofs, stiffness, relative, extended)
        return made, ends, released

    def dof(self, node: int, direction: str, model: FrameModel) -> int:
        """The global index of a nodal DOF."""
        return int(self.node_dofs[node][model.layout.position(direction)])

    def element_block(self, row: int, mats: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The DOFs and matrices (..., n, n) through which element matrices `mats` (..., k, k) of
        the element at `row` (its position in model.elements) act on the global DOF vector:
        its `element_dofs` and `mats` themselves, or, for an element with a skew release, those
        DOFs and its relative rotations h with B^T mats B (see the module docstring)."""
        if row not in self.extended:
            return self.element_dofs[row], mats
        return self.block_dofs(row), self.extended[row][1].T @ mats @ self.extended[row][1]

    def block_dofs(self, row: int) -> np.ndarray:
        """The DOFs of `element_block` of the element at `row`."""
        if row not in self.extended:
            return self.element_dofs[row]
        return np.concatenate([self.element_dofs[row], self.extended[row][0]])


def release_axis(model: FrameModel, e, local: str) -> np.ndarray | None:
    """The unit axis (3,) in global components of an element end's release in local rotation
    `local`, when that axis lies along no global axis (a skew member's: the release gets a
    relative rotation DOF, see the module docstring); None when it lies along one (a planar
    element's always), where `release_rotation` names that global rotation."""
    if model.layout.dimension == 2:
        return None
    axis = model.local_axes(e.id)[("rx", "ry", "rz").index(local)]
    return None if abs(np.max(np.abs(axis)) - 1.0) <= 1e-9 else axis


def release_rotation(model: FrameModel, e, local: str) -> str:
    """The node rotation an element end's release in local rotation `local` acts on: the
    global rotation about the axis that local axis lies along (a planar element's rz is the
    global rz). ValueError naming the element when that axis is skew: such a release turns
    about no one node rotation (`release_axis`; the assembly gives it a relative rotation)."""
    if model.layout.dimension == 2:
        return local
    axis = model.local_axes(e.id)[("rx", "ry", "rz").index(local)]
    g = int(np.argmax(np.abs(axis)))
    if abs(abs(axis[g]) - 1.0) > 1e-9:
        raise ValueError(f"{model.source}: element {e.id}: its release in local {local!r} turns about "
                         f"{np.round(axis, 6).tolist()}, not along a global axis, so about no one node rotation")
    return ("rx", "ry", "rz")[g]


class Triplets:
    """(row, col, value, term) lists of one matrix family (K or M) over all DOFs."""

    def __init__(self):
        self.parts: list[tuple[np.ndarray, np.ndarray, np.ndarray, int]] = []

    def add(self, term: int, rows, cols, vals) -> None:
        """Add values at (rows, cols) to term `term` (-1: the constant part)."""
        r, c, v = np.broadcast_arrays(np.asarray(rows), np.asarray(cols), np.asarray(vals, dtype=float))
        self.parts.append((r.ravel(), c.ravel(), v.ravel(), term))

    def blocks(self, term: int, dofs: np.ndarray, mats: np.ndarray) -> None:
        """Element matrices (e, k, k) on DOFs (e, k)."""
        self.add(term, dofs[:, :, None], dofs[:, None, :], mats)

    def two_dof(self, term: int, a: int, b: int | None, value: float) -> None:
        """A spring of `value` between DOFs a and b (b None: to ground)."""
        if b is None:
            self.add(term, [a], [a], [value])
        else:
            self.add(term, [a, b, a, b], [a, b, b, a], [value, value, -value, -value])

    def arrays(self, free: np.ndarray, n_total: int):
        """(rows, cols, vals, term) on the free DOFs (renumbered), triplets on a support dropped."""
        pos = np.full(n_total, -1)
        pos[free] = np.arange(len(free))
        if not self.parts:
            return np.zeros(0, int), np.zeros(0, int), np.zeros(0), np.zeros(0, int)
        r = pos[np.concatenate([p[0] for p in self.parts])]
        c = pos[np.concatenate([p[1] for p in self.parts])]
        v = np.concatenate([p[2] for p in self.parts])
        t = np.concatenate([np.full(len(p[0]), p[3]) for p in self.parts])
        keep = (r >= 0) & (c >= 0) & (v != 0.0)
        return r[keep], c[keep], v[keep], t[keep]


def _unknown(model: FrameModel, what: str, ident, par: Parameter):
    raise ValueError(f"parameter {par.label}: model {model.name!r} has no {what} {ident}")


class Terms:
    """The affine terms of one model and parameter set, as triplets on all DOFs: `k`, `m`."""

    def __init__(self, model: FrameModel, parameters: tuple[Parameter, ...]):
        self.model, self.dofmap = model, DofMap.of(model)
        self.n_params = len(parameters)
        self.k, self.m = Triplets(), Triplets()
        self.k_el, self.m_el = element_matrices(model)
        mats = model.materials
        self.modulus = np.array([e.youngs_modulus_pa if e.youngs_modulus_pa is not None
                                 else mats[e.material].youngs_modulus_pa for e in model.elements])
        self.k_weight = self.modulus.copy()
        self.m_weight = np.array([mats[e.material].density_kg_m3 for e in model.elements])
        self.index = model._element_pos  # element id -> position, built once per model
        self.taken: dict[str, set] = {"spring": set(), "release": set(), "mass": set()}
        for i, par in enumerate(parameters):
            self._term(i, par)
        self._constant()

    def _dof(self, node: int, direction: str) -> int:
        return self.dofmap.dof(node, direction, self.model)

    def _spring(self, term: int, s, value: float) -> None:
        self.k.two_dof(term, self._dof(*s.dof_a), self._dof(*s.dof_b) if s.dof_b else None, value)

    def _hinge(self, term: int, element_id: int, node: int, rotation: str, value: float) -> None:
        self.k.two_dof(term, self._dof(node, rotation), self.dofmap.hinges[(element_id, node)][rotation], value)

    def _relative(self, term: int, key: tuple[int, int], value: float | None) -> None:
        """The springs k h^2 / 2 of an element end's skew releases (`value` None: each its own k)."""
        for dof, k in self.dofmap.relative.get(key, {}).values():
            self.k.two_dof(term, dof, None, k if value is None else value)

    def _blocks(self, fam: Triplets, term: int, rows, mats: np.ndarray) -> None:
        """Element matrices `mats` (e, k, k) of the elements at `rows` into `fam`, each through
        its `DofMap.element_block` (an element with a skew release on its relative DOFs too)."""
        edofs, ext = self.dofmap.element_dofs, self.dofmap.extended
        rows = np.arange(len(edofs)) if rows is None else np.asarray(rows)
        special = [j for j, r in enumerate(rows) if int(r) in ext] if ext else []
        if not special:
            fam.blocks(term, edofs[rows], mats)
            return
        plain = np.setdiff1d(np.arange(len(rows)), special)
        fam.blocks(term, edofs[rows[plain]], mats[plain])
        for j in special:
            dofs, m = self.dofmap.element_block(int(rows[j]), mats[j])
            fam.blocks(term, dofs[None], m[None])

    def _translations(self, node: int) -> list[int]:
        return [self._dof(node, d) for d in self.model.layout.translations]

    def _term(self, p: int, par: Parameter) -> None:
        """The triplets of dK_p / dM_p of parameter `par`; its share taken out of K0 / M0."""
        model, edofs = self.model, self.dofmap.element_dofs
        if par.kind in ("modulus", "density"):
            rows = [self.index[t] if t in self.index else _unknown(model, "element", t, par) for t in par.targets]
            if par.kind == "modulus" and par.profile != "uniform":
                try:
                    k_w = profile_stiffness(model, model.element(par.targets[0]), par.profile)
                except ValueError as exc:
                    raise ValueError(f"parameter {par.label}: {exc}") from None
                self._blocks(self.k, p, rows, k_w)
                self._blocks(self.k, -1, rows, -self.modulus[rows[0]] * k_w)
            elif par.kind == "modulus":
                self.k_weight[rows] = 0.0
                self._blocks(self.k, p, rows, self.k_el[rows])
            else:
                self.m_weight[rows] = 0.0
                self._blocks(self.m, p, rows, self.m_el[rows])
        elif par.kind == "mass":
            for node in par.targets:
                if node not in self.dofmap.node_dofs:
                    _unknown(model, "node", node, par)
                t = self._translations(node)
                self.m.add(p, t, t, 1.0)
                self.taken["mass"].add(node)
        elif par.kind == "spring":
            springs = {s.id: s for s in model.springs}
            for sid in par.targets:
                self._spring(p, springs[sid] if sid in springs else _unknown(model, "spring", sid, par), 1.0)
                self.taken["spring"].add(sid)
        elif par.kind == "release":
            key = tuple(par.targets)
            if key not in self.dofmap.hinges and key not in self.dofmap.relative:
                raise ValueError(f"parameter {par.label}: element end {key} is not released in the model")
            for rot in self.dofmap.hinges.get(key, {}):  # every released rotation of that end
                self._hinge(p, key[0], key[1], rot, 1.0)
            self._relative(p, key, 1.0)
            self.taken["release"].add(key)

    def _constant(self) -> None:
        """K0, M0: everything no parameter holds."""
        model = self.model
        self._blocks(self.k, -1, None, self.k_el * self.k_weight[:, None, None])
        self._blocks(self.m, -1, None, self.m_el * self.m_weight[:, None, None])
        # the lumped masses in one part, mass by mass its translations (unless a parameter holds
        # that node's mass) then its rotations: the order one part per mass gave (the same triplets)
        if model.masses:
            lay = model.layout
            at = np.array([model._node_pos[lm.node] for lm in model.masses])
            where = [lay.position(d) for d in lay.translations + lay.rotations]
            dofs = lay.per_node * at[:, None] + np.array(where, dtype=int)
            n_t = len(lay.translations)
            values = np.empty(dofs.shape)
            values[:, :n_t] = np.array([lm.mass_kg for lm in model.masses])[:, None]
            values[:, n_t:] = np.array([lm.inertia_kg_m2 for lm in model.masses])[:, None]
            keep = np.ones(dofs.shape, dtype=bool)
            keep[:, :n_t] = np.array([lm.node not in self.taken["mass"] for lm in model.masses])[:, None]
            if keep.any():
                self.m.add(-1, dofs[keep], dofs[keep], values[keep])
        for s in model.springs:
            if s.id not in self.taken["spring"]:
                self._spring(-1, s, s.stiffness)
        for key, released in self.dofmap.hinge_stiffness.items():
            if key not in self.taken["release"]:
                for rot, value in released.items():
                    self._hinge(-1, key[0], key[1], rot, value)
        for key in self.dofmap.relative:
            if key not in self.taken["release"]:
                self._relative(-1, key, None)

    def free_arrays(self):
        """The K and M triplets on the free DOFs: ((rows, cols, vals, term), (...))."""
        f, n = self.dofmap.free, self.dofmap.n_total
        return self.k.arrays(f, n), self.m.arrays(f, n)


def dense_terms(trip, n: int, p: int) -> tuple[np.ndarray, np.ndarray]:
    """The constant (n, n) and per-parameter (p, n, n) dense matrices of triplets `trip`."""
    r, c, v, t = trip
    out = np.zeros((p + 1, n, n))
    np.add.at(out, (t + 1, r, c), v)
    return out[0], out[1:]


__all__ = ["DofMap", "Terms", "Triplets", "dense_terms", "release_axis", "release_rotation"]
