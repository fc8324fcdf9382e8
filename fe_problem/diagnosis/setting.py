"""What every candidate of a diagnosis shares (`Setting`), a candidate (`Candidate`) and the solves
its forward is made of. The kinds of candidates are one module each in kinds/ (their registry,
kinds/__init__.py); candidates.py names them all for the code that imports them from there.

Every candidate maps an effect size ``a >= 0`` (0: the unextended model) to the modes of the
extended model. The global stiffness-to-mass scale every model is allowed multiplies all
eigenvalues and leaves shapes alone, so it is profiled out in closed form by the fit and is
not part of a candidate.
"""

from __future__ import annotations

import dataclasses
import functools
import weakref
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from ..modal import frequencies_hz
from ..model import FrameModel
from ..assembly import AffineModel, solver_path
from . import dropped
from .key import CandidateKey
from .local import LocalMatrices, Term
from .reduced import SharedBasis


def shared_grid(grid) -> np.ndarray:
    """A grid every candidate of a kind holds (one array, not one per candidate: 15,566 candidates
    at 3,024 DOFs), read-only so that none can change another's."""
    grid = np.array(grid, dtype=float)
    grid.setflags(write=False)
    return grid



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
    def memo(self) -> dict:
        """What a kind computes once per setting and keeps (its module names the entry: the joint
        kind's rotations per end, kinds/joint_flexibility.py)."""
        return {}

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
    def key(self) -> CandidateKey:
        """Its identity: kind, place and profile (kinds/spec.py)."""
        return CandidateKey.of(self.kind, self.location, self.meta.get("profile", "uniform"))

    @property
    def label(self) -> str:
        """Its label string (`key.label()`): ``kind@name=value,...(profile)``."""
        return self.key.label()


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
