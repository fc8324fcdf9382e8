"""Candidate extensions of a model: each a physical effect with a place and one magnitude.

Every candidate maps an effect size ``a >= 0`` (0: the unextended model) to the modes of the
extended model. The global stiffness-to-mass scale every model is allowed multiplies all
eigenvalues and leaves shapes alone, so it is profiled out in closed form by the fit and is
not part of a candidate.

Kinds (the set is open: add a function to `CANDIDATE_KINDS` that yields Candidates):

- ``stiffness_loss`` at an element: its modulus times (1 - a), a in [0, 0.9]; or a weak zone
  about a section depth wide at one of seven positions along it, its bending stiffness times
  (1 - a), a in [0, 0.99] (a crack; zones.py); on a space frame in each bending plane (local
  ry, rz), each its own candidate.
- ``added_mass`` at a node: a lumped mass of a kg (x and y), a up to half the model's mass.
- ``joint_flexibility`` at a node where members meet: one element end released and tied to
  the node by a rotational spring k = (E I / L)_element / a (a: the joint's compliance
  relative to the element's own bending compliance); on a space frame about each bending
  axis and in torsion (k = (G J / L)_element / a), the member's local axes, skew or not (a
  skew axis' release is a relative rotation, terms.py).
- ``shear_deformation`` (no place): every element Timoshenko, with shear parameter
  phi = a * phi_nominal (a = 1: the section's own shear coefficient).
- ``stiffness_gain`` at an element: its modulus times (1 + a), a in [0, 3] (a member stiffer
  than its model; the estimate gives the modulus ratio 1 + a).
- ``boundary_stiffness`` at a node and direction (x or y): a spring to ground of stiffness
  a * k_ref, k_ref = total mass * (2 pi f_1)^2 of the nominal model (a soft support, a
  suspension, a base that is not rigid).
- ``distributed_mass`` along an element: the element's density times (1 + a) (mass spread
  over it; the estimate gives the added mass in kg).

Joints are found from the model's topology (`joint_nodes`): every node where three or more
element ends meet, or two that are not in line (a corner), so any frame has its joints.
"""

from __future__ import annotations

import collections
import contextlib
import dataclasses
import functools
import gc
import weakref
from dataclasses import dataclass, field
from typing import Callable, Iterator

import numpy as np
from scipy.linalg import orth

from ..modal import frequencies_hz
from ..model import FrameModel, Spring, add_mass, release_element_end, with_formulation
from ..model.edits import bending_hinges
from ..assembly import AffineModel, solver_path
from ..elements import formulation, formulations
from ..parameters import Parameter
from . import dropped, zones
from .local import LocalMatrices, Term
from .reduced import SharedBasis, reduced_joint

KINDS = ("stiffness_loss", "added_mass", "joint_flexibility", "shear_deformation", "stiffness_gain",
         "boundary_stiffness", "distributed_mass")


def _shared(grid) -> np.ndarray:
    """A grid every candidate of a kind holds (one array, not one per candidate: 15,566 candidates
    at 3,024 DOFs), read-only so that none can change another's."""
    grid = np.array(grid, dtype=float)
    grid.setflags(write=False)
    return grid


#: The effect sizes each kind tries (`Candidate.grid`); added mass and distributed mass scale
#: theirs by the model's mass and the element's `upper`.
LOSS_GRID = _shared([0.0, 0.005, 0.01, 0.02, 0.04, 0.07, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9])
JOINT_GRID = _shared(np.concatenate([[0.0], np.geomspace(1e-3, 50.0, 18)]))
GAIN_GRID = _shared([0.0, 0.01, 0.02, 0.05, 0.1, 0.2, 0.35, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0])
BOUNDARY_GRID = _shared(np.concatenate([[0.0], np.geomspace(1e-4, 100.0, 16)]))
_MASS_STEPS = np.geomspace(1e-3, 0.5, 15)          # added mass / the model's mass
_DISTRIBUTED_STEPS = np.geomspace(1e-3, 1.0, 14)   # distributed mass / the element's upper


@dataclass(frozen=True)
class Setting:
    """What every candidate of one diagnosis shares: the model, the measured coordinates and
    how many model modes to compute."""

    model: FrameModel
    coords: tuple[tuple[int, str], ...]
    n_modes: int
    #: the user's model, when `model` is it extended by causes already found: effect sizes are
    #: scaled by it, so that a size means the same effect on every base (None: `model`)
    reference: FrameModel | None = None

    @property
    def nominal(self) -> FrameModel:
        """The model whose properties scale the effect sizes."""
        return self.model if self.reference is None else self.reference

    @functools.cached_property
    def local(self) -> LocalMatrices:
        """The model's element matrices and DOFs, for the candidates' first-order terms."""
        return LocalMatrices(self.model)

    @functools.cached_property
    def system(self) -> AffineModel:
        """The model's own system (no parameter), built once for every step that solves the model
        itself: the calibration, the first-order screen's baseline, the shared basis and the
        candidates' size a = 0 (`calibrate` hands over the one it built)."""
        return AffineModel(self.model)

    @functools.cached_property
    def _modes0(self):
        return solve(self.system, np.zeros((1, 0)), self.coords, self.n_modes)

    @property
    def modes0(self) -> tuple[np.ndarray, np.ndarray]:
        """`solve` of the model itself (frequencies (1, k) Hz, shapes (1, n_coord, k)), solved once
        and copied out: the calibration's modes and every candidate's size a = 0 that is the
        model unextended (a rigid joint, no shear deformation, no spring)."""
        hz, shapes = self._modes0
        return hz.copy(), shapes.copy()

    @functools.cached_property
    def baselines(self) -> dict:
        """The first-order screen's baselines of `system` (screening.baseline), by the modes they
        cover: the first screen and the model-form screen (both on the calibrated model's
        pairing) share one, its eigen-solve and one bordered factorisation per mode."""
        return {}

    @functools.cached_property
    def joint_rotations(self) -> dict:
        """How many joint-flexibility candidates `joint_flexibility` builds at each (node, element):
        on a space frame up to its 3 hinges, fewer at an end already released about one, at a
        corner's second end or at the last rigid end (the variants a joint row is charged for,
        `evidence.label_variants`)."""
        return dict(collections.Counter((c.location["node"], c.location["element"]) for c in joint_flexibility(self)))

    @functools.cached_property
    def basis(self) -> SharedBasis | None:
        """The reduced basis the candidates' searches share (reduced.py), or None where it does
        not apply: a model on the dense path, or one with zero-energy modes."""
        if solver_path(len(self.local.dofmap.free)) != "sparse":
            return None
        system = self.system
        return None if system.n_rigid else SharedBasis(system, self.coords, self.n_modes)


class _Once:
    """`build()` on the first call, the same object after (a plain closure: an `lru_cache` per
    candidate was a third of building 15,566 candidates)."""

    __slots__ = ("build", "made")

    def __init__(self, build: Callable[[], object]):
        self.build, self.made = build, None

    def __call__(self):
        if self.build is not None:
            self.made, self.build = self.build(), None
        return self.made


def lazy_system(build: Callable[[], AffineModel]) -> Callable[[], AffineModel]:
    """`build()` on the first call, the same system after: a candidate's own system is
    assembled only if it is solved (on a large model most candidates are only screened)."""
    return _Once(build)


def solve(system: AffineModel, theta: np.ndarray, coords, n_modes: int):
    """Frequencies (b, k) in Hz and shapes at `coords` (b, n_coord, k) for theta (b, p)."""
    lam, phi = system.eigen(theta, min(n_modes, system.n_elastic), vectors=True)
    return frequencies_hz(lam), system.at_rows(phi, system.nodal_rows(coords))


def solve_model(model: FrameModel, st: Setting, elements=None):
    """`solve` of one model at its own properties (a size of a candidate that builds a model per
    size): frequencies (1, k) Hz, shapes (1, n_coord, k); its zero-energy count and its modes
    from one eigen-solve on the sparse path (`AffineModel`'s `x0_modes`). `elements`: the ids of
    the only elements whose matrices differ from `st.model`'s (a member's depth, the elements at
    a moved node): on the sparse path the model is then built from `st.system` with only those
    replaced (`AffineModel.edited`; the same modes to rounding); None: built afresh."""
    if elements is not None and st.system.path == "sparse":
        system = st.system.edited(model, elements, x0_modes=st.n_modes)
    else:
        system = AffineModel(model, x0_modes=st.n_modes)
    return solve(system, np.zeros((1, 0)), st.coords, st.n_modes)


@dataclass(eq=False)
class Candidate:
    """One extension. `forward(a)` gives the modes for effect sizes a (b,)."""

    kind: str
    location: dict | None
    upper: float
    grid: np.ndarray
    forward: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]
    estimate: Callable[[float, float], dict]
    extend: Callable[[float], FrameModel]
    step: float                        # a small effect size for first-order sensitivities
    meta: dict = field(default_factory=dict)
    term: Callable[[], Term] | None = None  # dK/da, dM/da at a = 0 (local.py); None: a global effect
    #: () -> the reduced forward (reduced.py: the modes from the diagnosis's shared basis, for the
    #: fit's search only; built on each call), or None where the basis does not apply; None: no
    #: reduced form
    reduced: Callable[[], Callable | None] | None = None
    #: () -> the reduced forward of a change spread over many members (`SharedBasis.spread`), for
    #: ranking the distributed classes (`fit.class_promises`) and searching their fits
    #: (`fit._search_forward`; the answer confirmed by full solves), or None where the basis does
    #: not apply; None: no such form
    reduced_screen: Callable[[], Callable | None] | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.forward, _Remembered):  # a copy (dataclasses.replace) shares the kept sizes
            self.forward = _Remembered(self.forward)
        if self.forward.owner is None:  # whose failure a failing solve records (dropped.py); no cycle
            self.forward.owner = weakref.ref(self)

    @property
    def label(self) -> str:
        where = "" if self.location is None else "@" + ",".join(f"{k}={v}" for k, v in self.location.items())
        profile = self.meta.get("profile", "uniform")
        return self.kind + where + ("" if profile == "uniform" else f"({profile})")


class _Remembered:
    """A candidate's forward that solves each effect size once: the diagnosis asks for the same
    size again (a look along's sizes in the fit's grid, a fit's answer in the evidence and the
    held-out error: 10 % of a 1,080-DOF diagnosis's solves). A size's modes do not depend on
    its batch (a fixed start vector, sparse.py), so an answer kept is the answer solved again,
    bit for bit (tests/test_reduced_basis.py). Keeps the last `SIZE` sizes (each the
    frequencies in Hz and the shapes at the measured coordinates)."""

    SIZE = 48

    def __init__(self, forward: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray]]):
        self.solve = forward
        self.kept: dict[float, tuple[np.ndarray, np.ndarray]] = {}
        self.owner = None  # a weak reference to the candidate (`Candidate.__post_init__`)

    def _solved(self, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The solve of sizes `a`; a numerical failure, or non-finite modes, recorded under the
        candidate's label (dropped.py) and given as non-finite modes (which pair with nothing)."""
        try:
            hz, shapes = self.solve(a)
        except Exception as exc:  # noqa: BLE001 - only numerical failures are caught (is_numerical)
            if not dropped.is_numerical(exc):
                raise
            owner = self.owner() if self.owner is not None else None
            if owner is not None:
                dropped.note(owner.label, f"its solve failed ({dropped.reason_of(exc)})")
            kept = next(iter(self.kept.values()), None)
            out = dropped.failed_modes(len(a), None if kept is None else (kept[0].shape, kept[1].shape))
            if out is None:
                raise
            return out
        if np.isfinite(hz).all() and np.isfinite(shapes).all():
            dropped.solved(hz, shapes)
        else:
            owner = self.owner() if self.owner is not None else None
            if owner is not None:
                dropped.note(owner.label, "its solve gave non-finite modes")
        return hz, shapes

    def __call__(self, a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        a = np.asarray(a, dtype=float)
        if a.size == 0 or not np.isfinite(a).all():  # a NaN is no dict key (hash(nan) is per object)
            return self._solved(a)
        new = list(dict.fromkeys(float(v) for v in a if float(v) not in self.kept))
        if new:
            hz, shapes = self._solved(np.array(new))
            for k, v in enumerate(new):
                self.kept[v] = (hz[k], shapes[k])
        rows = [self.kept[float(v)] for v in a]
        out = np.stack([r[0] for r in rows]), np.stack([r[1] for r in rows])
        while len(self.kept) > self.SIZE:
            del self.kept[next(iter(self.kept))]
        return out


def reduced_linear(st: Setting, term: Callable[[], Term]) -> Callable[[], Callable | None]:
    """The reduced-forward factory (`Candidate.reduced`) of a change linear in a with the term
    `term()` (K0 + a dk, M0 + a dm on the term's DOFs: exact for a modulus, a density, a mass, a
    spring). Each call builds the forward afresh (a few solves with the shared factor): kept, the
    bases of every candidate searched would hold n_free x ~70 floats each."""
    def make():
        if st.basis is None:
            return None
        t = term()
        dm = t.dm if np.any(t.dm) else None
        return st.basis.local(t.dofs, lambda a: (a[:, None, None] * t.dk,
                                                 None if dm is None else a[:, None, None] * dm))
    return make


def scale_stiffness(model: FrameModel, s: float) -> FrameModel:
    """A copy whose every stiffness (moduli, springs, releases) is multiplied by s."""
    elements = tuple(dataclasses.replace(
        e, youngs_modulus_pa=s * model.element_modulus_pa(e.id),
        release_i=None if e.release_i is None else s * e.release_i,
        release_j=None if e.release_j is None else s * e.release_j,
        releases_i=tuple((r, s * k) for r, k in e.releases_i),
        releases_j=tuple((r, s * k) for r, k in e.releases_j)) for e in model.elements)
    springs = tuple(dataclasses.replace(sp, stiffness=s * sp.stiffness) for sp in model.springs)
    return model.replace(elements=elements, springs=springs)


def _bending_compliance_ref(model: FrameModel, element_id: int, rotation: str = "rz") -> float:
    """The element's own end stiffness about its local axis `rotation`, N m/rad: E I / L for
    bending (ry, rz), G J / L for torsion (rx; G scales with the element's modulus, the
    material's G / E fixed as the space element takes it): the scale of a joint spring at its end."""
    e = model.element(element_id)
    modulus = model.element_modulus_pa(element_id)
    if rotation == "rx":
        mat = model.materials[e.material]
        modulus *= mat.shear_modulus / mat.youngs_modulus_pa
    return modulus * model.sections[e.section].inertia_about(rotation) / model.element_length_m(element_id)


def stiffness_loss(st: Setting) -> Iterator[Candidate]:
    """A loss of modulus in one element, spread uniformly over it, or concentrated in a weak
    zone about a section depth wide at one of seven positions along it (a crack; zones.py);
    the place is the element either way."""
    shared: dict = {}
    abouts = zones.bending_rotations(st.model)
    for e in st.model.elements:
        e0 = st.model.element_modulus_pa(e.id)
        system = lazy_system(lambda e=e, e0=e0: AffineModel(
            st.model, (Parameter("modulus", (e.id,), 1e-3 * e0, e0, e0),), like=st.system))

        def forward(a, system=system, e0=e0):
            return solve(system(), (e0 * (1.0 - np.asarray(a)))[:, None], st.coords, st.n_modes)

        def estimate(a, s, e0=e0):
            return {"stiffness_loss_pct": 100.0 * a, "modulus_ratio": 1.0 - a, "profile": "uniform",
                    "modulus_pa": s * e0 * (1.0 - a)}

        yield Candidate("stiffness_loss", {"element": e.id}, 0.9, LOSS_GRID, forward, estimate,
                        lambda a, e=e, e0=e0: st.model.with_element_moduli({e.id: e0 * (1.0 - a)}),
                        step=0.01, meta={"profile": "uniform"},
                        term=lambda e=e, e0=e0: st.local.stiffness(e.id, -e0, "uniform"),
                        reduced=reduced_linear(st, lambda e=e, e0=e0: st.local.stiffness(e.id, -e0, "uniform")))
        # a weak zone is built by the beam's flexibility formulation (zones.py), in each bending plane
        if (not formulation(e.formulation, st.model.layout).supports_weak_zone
                or e.crack_position is not None or e.weak_zone is not None):
            continue
        for about in abouts:
            yield from _zone_candidates(st, e, e0, shared, about=about)


def zone_candidate(st: Setting, element_id: int, centre: float, shared: dict | None = None,
                   about: str = "rz") -> Candidate:
    """The weak-zone loss of one element centred at `centre` (a fraction of its length),
    bending about `about`, at any position, not only the grid's: the crack's position is
    refined once the element is chosen. `shared`: the solver cache of zones.zone_forwards, to
    share among positions."""
    e = st.model.element(element_id)
    place = zones.zone_place(st.model, element_id, centre, about)
    return next(_zone_candidates(st, e, st.model.element_modulus_pa(element_id), {} if shared is None else shared,
                                 [place], about))


def zone_profile(centre: float, about: str | None = None) -> str:
    """The profile of a zone candidate's label: 'zone 0.30' on the grid, 'zone 0.353' refined;
    a space frame's names its bending rotation too: 'zone 0.30 ry'."""
    at = f"zone {centre:.2f}" if abs(centre - round(centre, 2)) < 1e-9 else f"zone {centre:.3f}"
    return at if about is None else f"{at} {about}"


def _zone_candidates(st: Setting, e, e0: float, shared: dict, places=None, about: str = "rz") -> Iterator[Candidate]:
    """The weak-zone losses of element e (see zones.py) bending about `about`, at the grid's
    places or at `places`; a: the zone's loss of bending stiffness. Each forward is
    `zones.zone_forwards`' for its place, made when it is first called (most zones are only
    screened: making every zone's forward, each with the element's nominal stiffness, was a
    sixth of building the candidates)."""
    space = st.model.layout.dimension == 3
    for start, end in zones.zone_places(st.model, e.id, about) if places is None else places:
        centre = round(0.5 * (start + end), 6)

        made = _Once(lambda start=start, end=end: next(zones.zone_forwards(
            st.model, e.id, st.coords, st.n_modes, shared, [(start, end)], about))[2])

        def forward(a, made=made):
            return made()(a)

        def estimate(a, s, start=start, end=end, centre=centre):
            ei = s * e0 * st.model.sections[e.section].inertia_about(about)
            width = (end - start) * st.model.element_length_m(e.id)
            out = {"stiffness_loss_pct": 100.0 * a, "modulus_ratio": 1.0 - a, "profile": "zone",
                   "zone_position": centre, "zone_start": start, "zone_end": end,
                   "modulus_pa": s * e0 * (1.0 - a),
                   "equivalent_crack_stiffness_nm_per_rad": ei * (1.0 - a) / (a * width) if a > 0 else float("inf")}
            return {**out, "zone_about": about} if space else out

        def extend(a, start=start, end=end):
            return zones.with_zone(st.model, e.id, start, end, 1.0 - a, about)

        def reduced(start=start, end=end):
            if st.basis is None:
                return None
            row, dofmap = st.local.row[e.id], st.local.dofmap
            nominal = zones.zone_stiffness(st.model, e.id, 0.0, 1.0, np.ones(1), about)[0]

            def change(a):
                dk = zones.zone_stiffness(st.model, e.id, start, end, 1.0 - np.clip(a, 0.0, zones.UPPER), about)
                return dofmap.element_block(row, dk - nominal)[1], None
            return st.basis.local(dofmap.block_dofs(row), change)

        yield Candidate("stiffness_loss", {"element": e.id}, zones.UPPER, zones.GRID, forward, estimate, extend,
                        step=0.01, meta={"profile": zone_profile(centre, about if space else None)},
                        term=lambda start=start, end=end: st.local.zone(e.id, start, end, about),
                        reduced=reduced)


def added_mass(st: Setting) -> Iterator[Candidate]:
    """A lumped mass of a kg added at a node, to what the node already carries (a floor's mass,
    a mass found before): a `mass` parameter is the node's whole lumped mass, so it is set to
    m0 + a."""
    total = st.model.total_mass_kg()
    grid = _shared(np.concatenate([[0.0], total * _MASS_STEPS]))
    for node in st.model.node_ids:
        m0 = sum(lm.mass_kg for lm in st.model.masses if lm.node == node)
        system = lazy_system(lambda node=node, m0=m0: AffineModel(
            st.model, (Parameter("mass", (node,), 0.0, m0 + total, m0),), like=st.system))

        def forward(a, system=system, m0=m0):
            return solve(system(), m0 + np.asarray(a, dtype=float)[:, None], st.coords, st.n_modes)

        def estimate(a, s, node=node):
            return {"mass_kg": a, "mass_ratio": a / total}

        def extend(a, node=node):
            return add_mass(st.model, node, a)

        yield Candidate("added_mass", {"node": node}, 0.5 * total,
                        grid, forward, estimate, extend, step=0.005 * total,
                        term=lambda node=node: st.local.node_mass(node),
                        reduced=reduced_linear(st, lambda node=node: st.local.node_mass(node)))


def joint_nodes(model: FrameModel) -> tuple[int, ...]:
    """Nodes where members join: three or more element ends, or two ends not in line (cosine
    of the angle between the members, seen from the node, above -0.999: a corner)."""
    ends: dict[int, list[np.ndarray]] = {}
    at, pos = model.coordinates, model._node_pos
    for e in model.elements:
        for a, b in ((e.node_i, e.node_j), (e.node_j, e.node_i)):
            d = at[pos[b]] - at[pos[a]]
            ends.setdefault(a, []).append(d / np.linalg.norm(d))
    return tuple(n for n, ds in ends.items()
                 if len(ds) > 2 or (len(ds) == 2 and float(ds[0] @ ds[1]) > -0.999))


def _rotation_axis(model: FrameModel, e, local: str):
    """The rotation an end of element `e` turns in when released in its rotation `local`: the
    planar frame's rotation name; on a space frame the local axis as a global unit vector (3,)
    (along a global axis or skew: a brace's, an inclined rafter's)."""
    if len(model.layout.hinges) == 1:
        return local
    return np.asarray(model.local_axes(e.id)[("rx", "ry", "rz").index(local)], dtype=float)


def _frees(axes: list, axis) -> bool:
    """Whether rotations about `axes` (names, or global unit vectors) let a rotation about `axis`
    (the same form) happen: the name among them; the vector in their span."""
    if isinstance(axis, str):
        return axis in axes
    if not axes:
        return False
    a = np.array(axes, dtype=float)
    coef = np.linalg.lstsq(a.T, axis, rcond=None)[0]
    return float(np.linalg.norm(a.T @ coef - axis)) <= 1e-9


def _released(model: FrameModel, e, node: int, axis) -> bool:
    """Whether the end of element `e` at `node` is released about `axis` (`_rotation_axis`'s
    form): its released rotations free that rotation."""
    releases = model.end_releases(e)[0 if node == e.node_i else 1]
    return _frees([_rotation_axis(model, e, r) for r in releases], axis)


def _last_rigid_end(model: FrameModel, node: int, axis, element=None) -> bool:
    """Whether releasing the end of `element` at `node` about `axis` (`_rotation_axis`'s form)
    would leave a rotation of the node that no element end, support or rotary inertia holds
    (the others released by joints already found): a rotation with no mass, an invalid model;
    at a corner, releasing either end is one and the same joint. Planar: one element end at most
    is still rigidly tied to the node's rotation. Space: the rotations every end leaves free
    (each the span of its released axes, `element`'s with `axis`) meet in more than zero."""
    if any(m.node == node and m.inertia_kg_m2 > 0 for m in model.masses):
        return False
    ends = model.elements_at(node)
    if isinstance(axis, str):
        rigid = sum(1 for e in ends if not _released(model, e, node, axis))
        return rigid <= 1 and not any(s.node == node and axis in s.directions for s in model.supports)
    held = np.zeros((3, 3))
    for e in ends:
        free = [_rotation_axis(model, e, r) for r in model.end_releases(e)[0 if node == e.node_i else 1]]
        free += [axis] if e is element else []
        q = orth(np.array(free).T) if free else np.zeros((3, 0))
        held += np.eye(3) - q @ q.T  # the rotations this end ties to the node
    for s in model.supports:
        if s.node == node:
            held += sum((np.outer(u, u) for d, u in zip(("rx", "ry", "rz"), np.eye(3)) if d in s.directions),
                        np.zeros((3, 3)))
    return float(np.linalg.eigvalsh(held).min()) <= 1e-9


def joint_flexibility(st: Setting) -> Iterator[Candidate]:
    """A rotational spring between an element end and its joint node, at every element end of
    every joint, in each rotation the end may turn in apart from the node: the planar frame's
    rz; a space frame's two bending planes (local ry, rz) and its torsion (local rx, a member
    twisting in a connection that does not hold it: a spring of G J / L / a), each its own
    candidate, about the member's local axis whether it lies along a global axis or not (an
    inclined rafter's, a brace's: the release is the end's rotation relative to the node about
    that axis, terms.py). At a corner (two ends) one candidate per axis: releasing either end
    about the same axis is the same model (the first end's; the second's only about an axis
    along none of the first's, as at a gable's ridge)."""
    planar = len(st.model.layout.hinges) == 1
    bending = bending_hinges(st.model)
    rotations = bending + tuple(r for r in st.model.layout.hinges if r not in bending)
    for node in joint_nodes(st.model):
        ends = st.model.elements_at(node)
        first = [_rotation_axis(st.model, ends[0], r) for r in rotations]
        for e, local in ((e, r) for e in ends for r in rotations):
            axis = _rotation_axis(st.model, e, local)  # a skew member's: a relative rotation (terms.py)
            if len(ends) == 2 and e is not ends[0] and any(_frees([a], axis) for a in first):
                continue  # at a corner, the first end's joint about the same axis
            if _released(st.model, e, node, axis) or _last_rigid_end(st.model, node, axis, e):
                continue
            ref = _bending_compliance_ref(st.model, e.id, local)
            system = lazy_system(lambda e=e, node=node, ref=ref, local=local: AffineModel(
                release_element_end(st.model, e.id, node, ref, None if planar else (local,)),
                (Parameter("release", (e.id, node), 0.0, 1e12 * ref, ref),)))

            def extend(a, e=e, node=node, ref=ref, local=local):
                return (release_element_end(st.model, e.id, node, ref / a, None if planar else (local,)) if a > 0
                        else st.model)

            # an end released in other rotations already (a joint found before): a `release`
            # parameter would vary those too (terms.py), so each size is its own model
            alone = not any(st.model.end_releases(e)[0 if node == e.node_i else 1])

            def forward(a, system=system, ref=ref, extend=extend, alone=alone):
                a = np.asarray(a, dtype=float)
                if not alone:
                    out = [solve_model(extend(v), st) for v in a]
                    return np.concatenate([o[0] for o in out]), np.concatenate([o[1] for o in out])
                hz, shapes = solve(system(), (ref / np.maximum(a, 1e-12))[:, None], st.coords, st.n_modes)
                rigid = a <= 0.0
                if rigid.any():  # a = 0 is the rigid joint: the unextended model itself
                    hz0, sh0 = st.modes0
                    hz[rigid], shapes[rigid] = hz0[0], sh0[0]
                return hz, shapes

            def estimate(a, s, ref=ref):
                k = s * ref / a if a > 0 else float("inf")
                return {"rotational_stiffness_nm_per_rad": k, "compliance_ratio": a}

            place = {"node": node, "element": e.id} if planar else {"node": node, "element": e.id, "rotation": local}
            yield Candidate("joint_flexibility", place, 50.0,
                            JOINT_GRID, forward, estimate, extend, step=0.01,
                            term=lambda e=e, node=node, ref=ref, axis=axis: st.local.joint(e.id, node, ref, axis),
                            reduced=reduced_joint(st, e.id, node, ref, axis) if alone else None)


def shear_deformation(st: Setting) -> Iterator[Candidate]:
    if all(e.formulation == "timoshenko" for e in st.model.elements):
        return
    if "timoshenko" not in formulations(st.model.layout):  # no shear-deformable element of this layout
        return
    # the Timoshenko copy once (a copy of every element: 45 ms at 3,000 DOFs), each size's sections on it
    timoshenko = functools.lru_cache(maxsize=1)(lambda: with_formulation(st.model, "timoshenko"))

    def model_at(a: float) -> FrameModel:
        sections = {k: dataclasses.replace(v, shear_coefficient=v.shear_coefficient / a)
                    for k, v in st.model.sections.items()}
        return timoshenko().replace(sections=sections)

    def forward(a):
        a = np.atleast_1d(np.asarray(a, dtype=float))
        out = [solve_model(model_at(v), st) if v > 0 else st.modes0 for v in a]
        return np.concatenate([o[0] for o in out]), np.concatenate([o[1] for o in out])

    def estimate(a, s):
        kappa = {k: v.shear_coefficient / a if a > 0 else float("inf") for k, v in st.model.sections.items()}
        return {"shear_factor": a, "effective_shear_coefficient": kappa}

    yield Candidate("shear_deformation", None, 30.0, np.concatenate([[0.0], np.geomspace(0.02, 30.0, 14)]),
                    forward, estimate, lambda a: model_at(a) if a > 0 else st.model, step=0.05)


def stiffness_gain(st: Setting) -> Iterator[Candidate]:
    """A member stiffer than its model: its modulus times (1 + a), uniform over the element."""
    for e in st.model.elements:
        e0 = st.model.element_modulus_pa(e.id)
        system = lazy_system(lambda e=e, e0=e0: AffineModel(
            st.model, (Parameter("modulus", (e.id,), 1e-3 * e0, 10 * e0, e0),), like=st.system))

        def forward(a, system=system, e0=e0):
            return solve(system(), (e0 * (1.0 + np.asarray(a)))[:, None], st.coords, st.n_modes)

        def estimate(a, s, e0=e0):
            return {"stiffness_gain_pct": 100.0 * a, "modulus_ratio": 1.0 + a, "modulus_pa": s * e0 * (1.0 + a)}

        yield Candidate("stiffness_gain", {"element": e.id}, 3.0,
                        GAIN_GRID, forward, estimate,
                        lambda a, e=e, e0=e0: st.model.with_element_moduli({e.id: e0 * (1 + a)}),
                        step=0.01, term=lambda e=e, e0=e0: st.local.stiffness(e.id, e0),
                        reduced=reduced_linear(st, lambda e=e, e0=e0: st.local.stiffness(e.id, e0)))


def _reference_stiffness(st: Setting) -> float:
    """total mass * (2 pi f_1)^2 (N/m) of the user's model: a spring this stiff moves the first mode
    by about its size."""
    f1 = float(solve(st.system if st.reference is None else AffineModel(st.nominal), np.zeros((1, 0)),
                     st.coords, 1)[0][0, 0])
    return st.nominal.total_mass_kg() * (2.0 * np.pi * f1) ** 2


def boundary_stiffness(st: Setting) -> Iterator[Candidate]:
    """A spring to ground at a node, in each translation (the planar frame's x and y; a space
    frame's x, y and z): soft supports, suspensions, bases."""
    k_ref = _reference_stiffness(st)
    baseline = lazy_system(lambda: st.system)
    sid = max((sp.id for sp in st.model.springs), default=0) + 1
    fixed = {(sup.node, d) for sup in st.model.supports for d in sup.directions}
    for node in st.model.node_ids:
        for direction in st.model.layout.translations:
            if (node, direction) in fixed:
                continue
            # the zero-frequency modes are counted with the spring in place (initial k_ref): a
            # suspension mode is a mode of the extended model, not a rigid-body one to drop
            system = lazy_system(lambda node=node, direction=direction: AffineModel(
                st.model.replace(springs=st.model.springs + (Spring(sid, (node, direction), None, 0.0),)),
                (Parameter("spring", (sid,), 0.0, 1e3 * k_ref, k_ref),)))

            def forward(a, system=system):
                system = system()
                a = np.asarray(a, dtype=float)
                hz, shapes = solve(system, (k_ref * np.maximum(a, 1e-12))[:, None], st.coords, st.n_modes)
                # the modes the spring adds (the lowest while it is soft) come last, so that every
                # mode of the model keeps its index as the spring grows from zero (the first-order
                # screen holds the pairing by index)
                new = system.n_elastic - baseline().n_elastic
                hz, shapes = np.roll(hz, -new, axis=1), np.roll(shapes, -new, axis=2)
                if (a <= 0.0).any():  # no spring: the unextended model itself
                    hz0, sh0 = st.modes0
                    hz[a <= 0.0], shapes[a <= 0.0] = hz0[0], sh0[0]
                return hz, shapes

            def estimate(a, s):
                return {"stiffness_n_per_m": s * k_ref * a, "stiffness_ratio": a}

            def extend(a, node=node, direction=direction):
                return st.model.replace(springs=st.model.springs + (Spring(sid, (node, direction), None, k_ref * a),))

            yield Candidate("boundary_stiffness", {"node": node, "direction": direction}, 100.0,
                            BOUNDARY_GRID, forward, estimate, extend,
                            step=1e-3, term=lambda node=node, direction=direction:
                            st.local.ground_spring(node, direction, k_ref),
                            reduced=reduced_linear(st, lambda node=node, direction=direction:
                                                   st.local.ground_spring(node, direction, k_ref)))


def distributed_mass(st: Setting) -> Iterator[Candidate]:
    """Mass spread evenly along an element: its density times (1 + a)."""
    total = st.model.total_mass_kg()
    for e in st.model.elements:
        rho0 = st.model.materials[e.material].density_kg_m3
        m_e = rho0 * st.model.sections[e.section].area_m2 * st.model.element_length_m(e.id)
        upper = max(0.5 * total / m_e, 0.1)
        system = lazy_system(lambda e=e, rho0=rho0, upper=upper: AffineModel(
            st.model, (Parameter("density", (e.id,), 0.0, rho0 * (1 + upper), rho0),), like=st.system))

        def forward(a, system=system, rho0=rho0):
            return solve(system(), (rho0 * (1.0 + np.asarray(a)))[:, None], st.coords, st.n_modes)

        def estimate(a, s, m_e=m_e, e=e):
            return {"mass_kg": a * m_e, "mass_per_length_kg_m": a * m_e / st.model.element_length_m(e.id),
                    "mass_ratio": a}

        def extend(a, e=e, rho0=rho0):
            name = f"{e.material}+mass@{e.id}"
            material = dataclasses.replace(st.model.materials[e.material], density_kg_m3=rho0 * (1.0 + a))
            return st.model.replace(materials={**st.model.materials, name: material},
                                    elements=tuple(dataclasses.replace(x, material=name) if x.id == e.id else x
                                                   for x in st.model.elements))

        yield Candidate("distributed_mass", {"element": e.id}, upper,
                        np.concatenate([[0.0], upper * _DISTRIBUTED_STEPS]), forward, estimate, extend,
                        step=0.01 * upper, term=lambda e=e, rho0=rho0: st.local.density_change(e.id, rho0),
                        reduced=reduced_linear(st, lambda e=e, rho0=rho0: st.local.density_change(e.id, rho0)))


#: kind -> function(Setting) yielding Candidates. Extend this to add a kind.
CANDIDATE_KINDS: dict[str, Callable[[Setting], Iterator[Candidate]]] = {
    "stiffness_loss": stiffness_loss,
    "added_mass": added_mass,
    "joint_flexibility": joint_flexibility,
    "shear_deformation": shear_deformation,
    "stiffness_gain": stiffness_gain,
    "boundary_stiffness": boundary_stiffness,
    "distributed_mass": distributed_mass,
}


def all_candidates(st: Setting, kinds=None) -> list[Candidate]:
    """Every candidate of the given kinds (default: all registered) for this setting. Built with
    the cyclic garbage collector paused (`_collector_paused`): the candidates are a few closures
    each, all kept, and at 3,024 DOFs the collections their 15,566 sets of objects set off, each
    a pass over the whole heap, were two thirds of building them."""
    with _collector_paused():
        return list(iter_candidates(st, kinds))


@contextlib.contextmanager
def _collector_paused():
    """The cyclic garbage collector off inside, as it was after (nothing is freed any later than
    the next collection: reference counting frees what is not in a cycle as before)."""
    was = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was:
            gc.enable()


def iter_candidates(st: Setting, kinds=None) -> Iterator[Candidate]:
    """`all_candidates` one at a time, each built when it is reached: a search for one label
    stops there (a 3,024-DOF frame has 15,566 candidates, 9,408 of them weak zones)."""
    for kind in (kinds or CANDIDATE_KINDS):
        if kind not in CANDIDATE_KINDS:
            raise ValueError(f"unknown candidate kind {kind!r}; known: {', '.join(CANDIDATE_KINDS)}")
        yield from CANDIDATE_KINDS[kind](st)
