"""The benchmark suite: updating problems with stable ids ``family/dimension/instance`` and a
known optimum value f_opt.

Families (dimension = n_var, the number of updating parameters):

- ``paper/12/1``: the published H-frame data (5 frequencies, 12 moduli, eq. 4 weights);
  f_opt is ``PAPER_F_OPT``, certified by a reference solve (below) and by
  ``benchmarks/suite_fopt.py`` (docs/suite.md).
- ``hframe-freq``, ``hframe-shape``: the H-frame with each of its 12 elements split into 1, 2,
  4, 8 or 16 equal parts, one modulus per part in [6e10, 8e10] Pa (n_var 12, 24, 48, 96, 192);
  8 modes "measured" on a hidden truth drawn per instance inside the bounds, frequencies only
  or with shapes at the 15 measured coordinates, no noise: J >= 0 and J(truth) = 0, so
  f_opt = 0 exactly.
- ``hframe-freq-noisy``, ``hframe-shape-noisy``: as above with 0.2 % frequency and 2 % shape
  noise. The minimum is then below J(truth); f_opt is the minimum certified by a reference
  solve (`fe_problem.certify`: multi-start bounded least squares to machine precision),
  stored with its precision in ``suite_fopt.json`` beside this module (written by
  ``python benchmarks/suite_fopt.py --certify``). An instance not yet certified there falls
  back to the reference J(truth), an upper bound on the minimum (f_opt_kind "reference").
- ``frame-shape``: a one-bay multi-storey steel frame fixed at its base, 4, 8, 16, 32 or 64
  storeys (3 elements each: n_var 12 to 192), moduli within +-15 % of 210 GPa, 8 modes with
  shapes at the storey nodes (x, y), noise-free: f_opt = 0 exactly.
- ``frame3d-freq``, ``frame3d-shape``: space frames of the shipped ``frame3d``'s plan (2 x 2
  bays of 6 m x 5 m, 3.5 m storeys, HEB 300 columns, IPE 400 beams, tributary floor masses,
  fixed base), 4, 8 or 16 storeys (4 is the shipped example); one modulus per storey for its
  9 columns, its 6 beams along x and its 6 beams along y (n_var 12, 24, 48), within +-15 % of
  210 GPa; 8 modes (bending in x and y, torsion) measured in x and y at the 4 floor corners of
  every storey, frequencies only or with shapes, noise-free: f_opt = 0 exactly.

Every instance's truth and noise come from a seed derived from its id alone (SHA-256), so an
id means the same problem on every machine and in every version that keeps this module.
A blind instance (`suite_problem(id, blind=key)`, `femu study --blind`) is the same family,
size, bounds and start with its truth and noise drawn from seeds derived from the id and a
secret key instead (`blind_seed`): its id stays public, its truth cannot be rebuilt from it.
Noise-free, its f_opt is 0 exactly (J(truth) = 0 is checked as for the public instance); noisy,
it is certified when the study asks for it (`blind_certificate`, the reference solve of
``benchmarks/suite_fopt.py --certify``), or else is the reference J(truth).
Problems are built only when asked for (`suite_problem`): listing the suite (`suite_entry`)
builds no FE system, since large sizes are slow to assemble.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .correlation import pair_modes
from .modal_data import ModalData, synthetic_measurement
from .modal import modal_analysis
from .model import FrameModel, LumpedMass, load_model, regular_frame, regular_frame_3d, split_elements
from .parameters import Parameter, element_moduli
from .problem import UpdatingProblem
from ._threads import blas_pinned

#: The suite's version: a new one with any change of any problem's data, bounds or f_opt (its
#: definition: `suite_fingerprint`). Recorded in every run record (RunResult.suite_version).
SUITE_VERSION = "1.0"
#: The fingerprint (`suite_fingerprint`) of each version's definitions. Add a line for a new
#: version, never edit one: tests/test_suite_version.py fails when the definitions' fingerprint is
#: not the current version's, so a changed problem cannot ship under an old version.
SUITE_FINGERPRINTS = {"1.0": "4b2b582f180abd0c901be07136103891912d05548344e6af1d7fcffacba263b9"}

#: The minimum J of the paper problem (see docs/suite.md for the commands that certify it).
PAPER_F_OPT = 5.4136727410825565e-06
PAPER_F_OPT_HOW = ("inverse eigensensitivity (10 seeds, restarts) and CMA-ES (10 seeds) agree to a "
                   "relative 1e-10 (proof: python benchmarks/suite_fopt.py), and the reference solve "
                   "fe_problem.certify.certify_minimum (4 starts) to 3e-12")
#: Its precision: the relative 1e-10 the two methods agree to.
PAPER_F_OPT_PRECISION = 1e-10 * PAPER_F_OPT

#: How f_opt is known: exact (J >= 0 and J(truth) = 0), certified (the minimum of a reference
#: solve, stored with its precision), reference (J at the hidden truth of a noisy instance not
#: yet certified: an upper bound on the minimum).
F_OPT_KINDS = ("exact", "certified", "reference")
CERTIFIED_HOW = ("minimum of multi-start bounded least squares (fe_problem.certify; python benchmarks/"
                 "suite_fopt.py --certify), stored in fe_problem/suite_fopt.json with its precision")
#: A certified minimum below this is 0: J >= 0, and it lies 10 decades below every target.
ZERO_BELOW = 1e-20

#: The fixed normalisation of each family's targets (femu.reports.stats.fixed_targets): targets
#: 1e2 ... 1e-8 times it on J - f_opt, the same on every instance and dimension. Fixed once
#: (docs/suite.md): 1e-2 times the power of ten at or above the median J(x0) - f_opt of the
#: family's instances at its smallest dimension, so the top target sits near J(x0).
TARGET_SCALE = {"paper": 1e-5, "hframe-freq": 1e-4, "hframe-shape": 1e-3, "hframe-freq-noisy": 1e-4,
                "hframe-shape-noisy": 1e-3, "frame-shape": 1e-2, "frame3d-freq": 1e-5, "frame3d-shape": 1e-4}

H_FRAME_SPLITS = (1, 2, 4, 8, 16)
FRAME_STOREYS = (4, 8, 16, 32, 64)
#: Storeys of the space-frame families (3 parameters each: n_var 12, 24, 48); 4 is the shipped frame3d.
FRAME3D_STOREYS = (4, 8, 16)
#: The space frames' moduli bounds (Pa): +-15 % of steel's 210 GPa, as ``frame-shape``.
STEEL_E_PA, STEEL_BOUNDS = 2.1e11, (0.85 * 2.1e11, 1.15 * 2.1e11)
N_INSTANCES = 5
N_MODES = 8
FREQ_NOISE, SHAPE_NOISE = 0.002, 0.02
MAX_DRAWS = 200
#: |J(truth)| allowed on a noise-free instance: the round-off of 1 - MAC (a few 1e-16 per mode).
ROUND_OFF = 1e-12


@dataclass(frozen=True)
class Family:
    """A family of suite problems: its structure, what is measured, and its sizes (n_var)."""

    name: str
    structure: str          # "paper", "hframe", "frame" or "frame3d"
    shapes: bool
    noisy: bool
    dimensions: tuple[int, ...]
    instances: int
    description: str


FAMILIES = {f.name: f for f in (
    Family("paper", "paper", False, False, (12,), 1, "published H-frame data, 5 frequencies, eq. 4 weights"),
    Family("hframe-freq", "hframe", False, False, tuple(12 * s for s in H_FRAME_SPLITS), N_INSTANCES,
           "split H-frame, 8 frequencies of a hidden truth, noise-free"),
    Family("hframe-shape", "hframe", True, False, tuple(12 * s for s in H_FRAME_SPLITS), N_INSTANCES,
           "split H-frame, 8 frequencies and shapes of a hidden truth, noise-free"),
    Family("hframe-freq-noisy", "hframe", False, True, tuple(12 * s for s in H_FRAME_SPLITS), N_INSTANCES,
           "split H-frame, 8 frequencies of a hidden truth, 0.2 % noise"),
    Family("hframe-shape-noisy", "hframe", True, True, tuple(12 * s for s in H_FRAME_SPLITS), N_INSTANCES,
           "split H-frame, 8 frequencies and shapes of a hidden truth, 0.2 % / 2 % noise"),
    Family("frame-shape", "frame", True, False, tuple(3 * s for s in FRAME_STOREYS), N_INSTANCES,
           "multi-storey one-bay frame, 8 frequencies and shapes of a hidden truth, noise-free"),
    # new families go at the end: suite_ids() keeps every earlier id in its place
    Family("frame3d-freq", "frame3d", False, False, tuple(3 * s for s in FRAME3D_STOREYS), N_INSTANCES,
           "2 x 2-bay space frame, storey moduli, 8 frequencies of a hidden truth, noise-free"),
    Family("frame3d-shape", "frame3d", True, False, tuple(3 * s for s in FRAME3D_STOREYS), N_INSTANCES,
           "2 x 2-bay space frame, storey moduli, 8 frequencies and corner shapes (x, y) of a hidden truth, noise-free"),
)}


@dataclass(frozen=True)
class SuiteEntry:
    """What the suite says about one problem without building it.

    n_dof: free DOFs of the FE model; f_opt: None where it is known only once the problem is
    built (an uncertified noisy instance's reference J(truth)); f_opt_kind: one of
    `F_OPT_KINDS`; f_opt_precision: how far the true minimum may lie below f_opt (0 where
    exact); target_scale: the family's fixed target normalisation (`TARGET_SCALE`).
    """

    id: str
    family: str
    n_var: int
    instance: int
    n_dof: int
    f_opt: float | None
    f_opt_kind: str
    f_opt_how: str
    description: str
    f_opt_precision: float | None = 0.0
    target_scale: float = 1.0

    def to_dict(self) -> dict:
        return {"id": self.id, "family": self.family, "n_var": self.n_var, "instance": self.instance,
                "n_dof": self.n_dof, "f_opt": self.f_opt, "f_opt_kind": self.f_opt_kind,
                "f_opt_how": self.f_opt_how, "f_opt_precision": self.f_opt_precision,
                "target_scale": self.target_scale, "description": self.description}


class SuiteProblem(UpdatingProblem):
    """An `UpdatingProblem` of the suite: its id, `f_opt` (float), how f_opt is known
    (`f_opt_kind`, `f_opt_how`, `f_opt_precision`), the family's `target_scale`, and the hidden
    `truth` (Pa, (n_var,); None for ``paper``); `blind`: whether it is a blind instance (its
    truth and data from a secret key, `suite_problem`'s `blind`)."""

    suite_id: str
    f_opt: float
    f_opt_kind: str
    f_opt_how: str
    f_opt_precision: float
    target_scale: float
    truth: np.ndarray | None
    blind: bool


def suite_ids() -> tuple[str, ...]:
    """Every problem id of the suite, in a fixed order (family, dimension, instance)."""
    return tuple(f"{f.name}/{d}/{i}" for f in FAMILIES.values() for d in f.dimensions
                 for i in range(1, f.instances + 1))


def select_suite(spec: str | list[str] | tuple[str, ...]) -> list[str]:
    """The ids selected by ``spec``: ids or prefixes of whole id parts, comma-separated or a list
    (``paper``, ``hframe-freq/48``, ``frame-shape/12/3``), in suite order, each once.

    A part that selects nothing raises ValueError naming it and the families."""
    parts = [s.strip().strip("/") for s in (spec.split(",") if isinstance(spec, str) else spec)]
    parts = [p for p in parts if p]
    if not parts:
        raise ValueError(f"empty suite selection; families: {', '.join(FAMILIES)}")
    ids, chosen = suite_ids(), set()
    for p in parts:
        key = p.split("/")
        hit = {i for i in ids if i.split("/")[:len(key)] == key}
        if not hit:
            raise ValueError(f"suite selection {p!r} matches no problem; ids are family/dimension/instance "
                             f"with families {', '.join(FAMILIES)} (`femu suite` lists them)")
        chosen |= hit
    return [i for i in ids if i in chosen]


def _parse(problem_id: str) -> tuple[Family, int, int]:
    if problem_id not in set(suite_ids()):
        raise ValueError(f"unknown suite problem {problem_id!r}; ids are family/dimension/instance, "
                         f"families {', '.join(FAMILIES)} (`femu suite` lists them)")
    name, dim, inst = problem_id.split("/")
    return FAMILIES[name], int(dim), int(inst)


def id_seed(problem_id: str, purpose: str) -> int:
    """A seed fixed by the id and a purpose ("truth", "noise"): the first 8 bytes of SHA-256."""
    return int.from_bytes(hashlib.sha256(f"femu-suite:{problem_id}:{purpose}".encode()).digest()[:8], "big")


def blind_seed(problem_id: str, purpose: str, key: str) -> int:
    """The seed of a blind instance: fixed by the id, the purpose and the secret `key` (text,
    e.g. the hex HMAC a study derives from its store's secret): the first 8 bytes of SHA-256."""
    return int.from_bytes(hashlib.sha256(f"femu-blind:{key}:{problem_id}:{purpose}".encode()).digest()[:8], "big")


def _check_blind(problem_id: str, blind: str | None) -> Family:
    """The id's family; ValueError for a blind key that is not text, or for the paper problem
    (published measurements: no hidden truth to draw)."""
    family = _parse(problem_id)[0]
    if blind is not None:
        if not isinstance(blind, str) or not blind:
            raise ValueError(f"suite problem {problem_id}: a blind key must be non-empty text, got {blind!r}")
        if family.structure == "paper":
            raise ValueError(f"suite problem {problem_id}: published data, it has no blind instance")
    return family


# -- structures ------------------------------------------------------------------------------

def split_hframe(parts: int) -> FrameModel:
    """The H-frame with every element split into `parts` equal elements (`split_elements`);
    ``parts = 1`` is the shipped model."""
    model = split_elements(load_model("hframe"), parts)
    return model.replace(name=f"hframe-split{parts}") if parts > 1 else model


def storey_frame(storeys: int, storey_height_m: float = 3.0, bay_m: float = 6.0) -> FrameModel:
    """A one-bay planar steel frame of `storeys` storeys fixed at its base (`regular_frame`'s
    defaults): per storey two columns (A 1.0e-2 m^2, I 1.0e-4 m^4) and a beam (A 8.0e-3 m^2,
    I 2.0e-4 m^4), E 210 GPa, density 7850 kg/m^3, and 2000 kg floor mass at each storey node.
    Measured: x and y at every storey node."""
    return regular_frame(1, storeys, bay_m, storey_height_m, floor_mass_kg=2000.0, name=f"frame{storeys}",
                         description=f"one-bay {storeys}-storey steel frame, fixed base (femu suite)")


def space_storey_frame(storeys: int) -> FrameModel:
    """A space frame of the shipped ``frame3d``'s plan with `storeys` storeys (4: the shipped
    example's nodes, members, sections, masses and supports; tests/test_suite3d.py).

    `regular_frame_3d(2, 2, storeys, 6.0, 5.0, 3.5)` (HEB 300 columns, IPE 400 beams, steel,
    fixed base) with the shipped example's floor masses lumped at the nodes by tributary area,
    400 kg/m^2 on floors and 300 kg/m^2 on the roof (a corner node carries 3 m x 2.5 m, an edge
    node twice that, the middle node 6 m x 5 m). Measured: x and y at the 4 corners of every
    floor, as accelerometers on a test frame are placed (the corners see both bending planes
    and torsion; vertical motion of a sway frame is axial column strain, below a sensor's
    noise)."""
    bay_x, bay_y, height = 6.0, 5.0, 3.5
    model = regular_frame_3d(2, 2, storeys, bay_x, bay_y, height, name=f"frame3d-{storeys}storey",
                             description=f"2 x 2-bay {storeys}-storey steel space frame (frame3d's plan), fixed "
                                         "base, tributary floor masses (femu suite)")
    width_x, width_y, roof = 2 * bay_x, 2 * bay_y, storeys * height

    def tributary(v: float, width: float, bay: float) -> float:  # the node's share of its floor along one axis
        return bay / 2 if v in (0.0, width) else bay

    upper = model.nodes[9:]
    masses = tuple(LumpedMass(n.id, (300.0 if n.z == roof else 400.0) * tributary(n.x, width_x, bay_x)
                              * tributary(n.y, width_y, bay_y)) for n in upper)
    corners = [n.id for n in upper if n.x in (0.0, width_x) and n.y in (0.0, width_y)]
    return model.replace(masses=masses, measured_dofs=tuple((c, d) for c in corners for d in ("x", "y")))


def storey_moduli(model: FrameModel) -> tuple[Parameter, ...]:
    """Three modulus parameters per storey of a `space_storey_frame`: its columns, its beams
    along x, its beams along y (`regular_frame_3d`'s element order: per storey the 9 columns,
    the 6 beams along x, the 6 along y), each within `STEEL_BOUNDS` (Pa), starting at 210 GPa."""
    per_storey, groups = 21, (("columns", 0, 9), ("beams-x", 9, 15), ("beams-y", 15, 21))
    ids = model.element_ids
    return tuple(Parameter("modulus", tuple(ids[s * per_storey + a: s * per_storey + b]), *STEEL_BOUNDS, STEEL_E_PA,
                           name=f"E-{what}-{s + 1}")
                 for s in range(len(ids) // per_storey) for what, a, b in groups)


@lru_cache(maxsize=16)
def _structure(family: Family, n_var: int) -> tuple[FrameModel, tuple]:
    """The nominal model and its modulus parameters for a family at size n_var."""
    if family.structure == "frame3d":
        model = space_storey_frame(n_var // 3)
        return model, storey_moduli(model)
    if family.structure == "frame":
        model = storey_frame(n_var // 3)
        return model, element_moduli(model, lower=0.85 * 2.1e11, upper=1.15 * 2.1e11)
    model = split_hframe(n_var // 12)
    return model, element_moduli(model)


def _n_dof(model: FrameModel) -> int:
    return model.n_dof - sum(len(s.directions) for s in model.supports)


@lru_cache(maxsize=32)
@blas_pinned  # the synthetic data: the same on any thread count
def _truth_and_data(problem_id: str, blind: str | None = None) -> tuple[np.ndarray, ModalData]:
    """The hidden truth (Pa) and the synthetic data of a synthetic instance.

    The problem pairs measured with model modes once, at x0, and keeps that pairing; a truth
    whose lowest modes change order (or shape) so much that measured mode i would pair with a
    model mode other than the i-th at x0 would have J(truth) > 0. Such draws are rejected: the
    next draw of the same generator is taken, so the truth is still fixed by the id (and, for a
    blind instance, its key: `blind_seed`)."""
    family, n_var, _ = _parse(problem_id)
    seed = (lambda purpose: id_seed(problem_id, purpose)) if blind is None else \
        (lambda purpose: blind_seed(problem_id, purpose, blind))
    model, params = _structure(family, n_var)
    lo, hi = np.array([p.lower for p in params]), np.array([p.upper for p in params])
    rng = np.random.default_rng(seed("truth"))
    noise = (FREQ_NOISE, SHAPE_NOISE if family.shapes else 0.0) if family.noisy else (0.0, 0.0)
    nominal = modal_analysis(model, N_MODES + 4)
    for _ in range(MAX_DRAWS):
        truth = rng.uniform(lo, hi)
        truth_model = model.with_element_moduli({e: float(v) for p, v in zip(params, truth) for e in p.targets})
        data = synthetic_measurement(truth_model, n_modes=N_MODES, freq_noise=noise[0], shape_noise=noise[1],
                                     seed=seed("noise") % 2**32, with_shapes=family.shapes,
                                     model_name=model.name)
        pairing = pair_modes(data.frequencies_hz, nominal.frequencies_hz, data.shapes, nominal.at(data.dofs),
                             data.has_shape)
        if np.array_equal(pairing.model_index, np.arange(N_MODES)):
            meta = dict(data.meta, source=problem_id, suite_id=problem_id,
                        **({"blind": True} if blind is not None else {}))
            return truth, ModalData(data.model, data.dofs, data.frequencies_hz, data.shapes, meta,
                                    frequency_std_hz=data.frequency_std_hz, shape_std=data.shape_std)
    raise RuntimeError(f"suite problem {problem_id}: no truth in {MAX_DRAWS} draws keeps the mode pairing of x0")


@lru_cache(maxsize=1)
def certificates() -> dict:
    """The certified minima of the suite (``suite_fopt.json`` beside this module): {id: {"f_opt",
    "precision", "starts", "ends"}}; empty if the file is absent."""
    import json
    from pathlib import Path

    path = Path(__file__).with_name("suite_fopt.json")
    return json.loads(path.read_text())["problems"] if path.exists() else {}


def target_scale(problem_id: str) -> float:
    """The fixed target normalisation of a suite id's family (`TARGET_SCALE`)."""
    return TARGET_SCALE[_parse(problem_id)[0].name]


def suite_entry(problem_id: str) -> SuiteEntry:
    """What the suite knows about `problem_id` without building the problem (cheap)."""
    family, n_var, inst = _parse(problem_id)
    scale = TARGET_SCALE[family.name]
    if family.structure == "paper":
        return SuiteEntry(problem_id, family.name, n_var, inst, _n_dof(load_model("hframe")), PAPER_F_OPT,
                          "certified", PAPER_F_OPT_HOW, family.description, PAPER_F_OPT_PRECISION, scale)
    model, _ = _structure(family, n_var)
    cert = certificates().get(problem_id)
    if family.noisy and cert is not None:
        f_opt, prec, kind, how = cert["f_opt"], cert["precision"], "certified", CERTIFIED_HOW
    elif family.noisy:
        f_opt, prec, kind, how = None, None, "reference", ("J at the hidden truth, computed when the problem is "
                                                             "built (an upper bound on the minimum; not yet certified)")
    else:
        f_opt, prec, kind, how = 0.0, 0.0, "exact", "0: noise-free data of a truth inside the bounds, J >= 0 and J(truth) = 0"
    return SuiteEntry(problem_id, family.name, n_var, inst, _n_dof(model), f_opt, kind, how, family.description,
                      prec, scale)


def suite_problem(problem_id: str, solver: str = "auto", blind: str | None = None,
                  certificate: tuple[float, float] | None = None) -> SuiteProblem:
    """A fresh `SuiteProblem` (its own evaluation counter) for a suite id; builds the FE system
    (slow for the largest sizes until assembly scales). ValueError for an unknown id.
    `solver`: the eigen-solver path (`UpdatingProblem`'s; "auto", the default, is the suite's:
    a forced path is the same problem up to the sparse path's ARPACK tolerance, J within a
    relative 1e-9 at 96 parameters; the reference solve of sparse instances uses "dense").

    `blind`: a secret key (text): the blind instance of the id (`blind_seed`: its truth and
    noise from the key; ValueError for ``paper``). Its f_opt: 0 exactly when noise-free; when
    noisy, `certificate` = (f_opt, precision) from `blind_certificate` on the same key
    (f_opt_kind "certified"), else the reference J(truth). The problem's `blind` says which."""
    family = _check_blind(problem_id, blind)
    entry = suite_entry(problem_id)
    if family.structure == "paper":
        p = SuiteProblem("hframe", "paper", name=problem_id, solver=solver)
        truth = None
    else:
        model, params = _structure(family, entry.n_var)
        truth, data = _truth_and_data(problem_id, blind)
        p = SuiteProblem(model, data, parameters=params, weights="unit",
                         shape_weight=1.0 if family.shapes else 0.0, name=problem_id, solver=solver)
    f_opt, precision, kind, how = entry.f_opt, entry.f_opt_precision, entry.f_opt_kind, entry.f_opt_how
    if blind is not None and family.noisy:  # the public certificate is not this instance's
        if certificate is not None:
            f_opt, precision, kind, how = float(certificate[0]), float(certificate[1]), "certified", BLIND_CERTIFIED_HOW
        else:
            f_opt, precision, kind = None, None, "reference"
            how = "J at the blind instance's hidden truth (an upper bound on the minimum; not certified)"
    if truth is not None:  # not counted as an evaluation
        at_truth = float(p.evaluate(truth)[0])
        p.n_evals = 0
        if f_opt is None:  # an uncertified noisy instance: the reference J(truth)
            f_opt, precision = at_truth, None
        elif not family.noisy and abs(at_truth) > ROUND_OFF:  # a guard: the claim f_opt = 0 must hold for this id
            raise RuntimeError(f"suite problem {problem_id}: J(truth) = {at_truth:.3g}, not 0 within round-off")
    p.suite_id, p.f_opt, p.f_opt_kind, p.f_opt_how, p.truth = problem_id, f_opt, kind, how, truth
    p.f_opt_precision, p.target_scale, p.blind = precision, entry.target_scale, blind is not None
    return p


#: How a blind noisy instance's f_opt is known (`blind_certificate`).
BLIND_CERTIFIED_HOW = ("minimum of multi-start bounded least squares (fe_problem.certify) on the blind instance, "
                       "certified on the evaluating side when its study ran")
#: The reference solve of a blind noisy instance: seeded starts and perturbed truths, as
#: ``benchmarks/suite_fopt.py --certify``'s defaults.
BLIND_STARTS, BLIND_PERTURBED = 3, 2


def blind_certificate(problem_id: str, blind: str) -> tuple[float, float]:
    """(f_opt, precision) of the noisy blind instance of `problem_id` under key `blind`: the
    reference solve `fe_problem.certify.certify_minimum` from x0, its truth, `BLIND_PERTURBED`
    perturbed truths and `BLIND_STARTS` seeded draws (on the dense twin where the suite's path is
    sparse), with the certificates' zero rule (a minimum below `ZERO_BELOW` is 0, its precision
    then at least that minimum). CPU: 1.8-3.0 s at 12 parameters, 3-4 s at 24, 16 s at 48."""
    from .certify import certify_minimum

    p = suite_problem(problem_id, blind=blind)
    twin = suite_problem(problem_id, solver="dense", blind=blind) if p.system.path == "sparse" else None
    c = certify_minimum(p if twin is None else twin, starts=BLIND_STARTS, seed=0, truth=p.truth,
                        perturbed=BLIND_PERTURBED, reported=None if twin is None else p)
    if c.f_min < ZERO_BELOW:
        return 0.0, float(max(c.precision, c.f_min))
    return float(c.f_min), float(c.precision)


def _digits(values) -> list[str]:
    """Numbers to 9 significant digits: the same on every machine (round-off is far below)."""
    return [f"{v:.9e}" for v in np.asarray(values, dtype=float).ravel()]


def suite_definition() -> dict:
    """What defines the suite's problems, as plain data (`suite_fingerprint` hashes it): the
    constants of the synthetic data; per id its entry (n_var, n_dof, f_opt, how it is known,
    precision, target scale), its seeds, its parameters' bounds and start (Pa); the paper's data;
    and per family and dimension the hidden truth and data of instance 1, which exercise the
    code that makes every instance's data from its seeds. Builds 31 small data sets (seconds)."""
    out = {"constants": {"n_modes": N_MODES, "freq_noise": FREQ_NOISE, "shape_noise": SHAPE_NOISE,
                         "max_draws": MAX_DRAWS, "target_scale": TARGET_SCALE, "paper_f_opt": _digits([PAPER_F_OPT]),
                         "families": {f.name: [f.structure, f.shapes, f.noisy, list(f.dimensions), f.instances]
                                      for f in FAMILIES.values()}},
           "problems": {}, "data": {}}
    for pid in suite_ids():
        entry = suite_entry(pid).to_dict()
        family, n_var, inst = _parse(pid)
        if family.structure == "paper":
            params = UpdatingProblem("hframe", "paper").parameters
        else:
            params = _structure(family, n_var)[1]
        entry.update({k: _digits([entry[k]]) if isinstance(entry[k], float) else entry[k]
                      for k in ("f_opt", "f_opt_precision", "target_scale")})
        entry["seeds"] = [id_seed(pid, "truth"), id_seed(pid, "noise")]
        entry["bounds"] = [_digits([q.lower for q in params]), _digits([q.upper for q in params]),
                           _digits([q.initial for q in params])]
        out["problems"][pid] = entry
        if family.structure != "paper" and inst == 1:
            truth, data = _truth_and_data(pid)
            out["data"][pid] = {"truth": _digits(truth), "frequencies_hz": _digits(data.frequencies_hz),
                                "shapes": _digits(np.abs(data.shapes)) if data.shapes is not None else None,
                                "dofs": [list(map(str, d)) for d in data.dofs]}
    paper = UpdatingProblem("hframe", "paper").data
    out["data"]["paper/12/1"] = {"frequencies_hz": _digits(paper.frequencies_hz)}
    return out


def suite_fingerprint() -> str:
    """SHA-256 of `suite_definition` (canonical JSON): equal for equal problems on any machine."""
    import json

    text = json.dumps(suite_definition(), sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()
