"""The planar frame: nodes, elements, sections, materials, masses, springs, supports.

A `FrameModel` is a frozen value. It is read from and written to a JSON model file
(format ``femu.model/1``, documented in docs/model-format.md). Models that ship with the
project (``hframe``) are loaded by name.

Units are SI throughout: metres, pascals, kilograms, newtons per metre (translational
springs) and newton-metres per radian (rotational springs).
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

DIRECTIONS = ("x", "y", "rz")
FORMULATIONS = ("euler-bernoulli", "timoshenko")
MODEL_FORMAT = "femu.model/1"
DATA_DIR = Path(__file__).resolve().parent / "data"


class ModelFileError(ValueError):
    """A model file or model definition that breaks the format; the message names where."""


@dataclass(frozen=True)
class Node:
    """A node of the planar frame, coordinates in metres."""

    id: int
    x: float
    y: float


@dataclass(frozen=True)
class Material:
    """Isotropic linear elastic material: modulus (Pa), density (kg/m^3), Poisson's ratio."""

    youngs_modulus_pa: float
    density_kg_m3: float
    poisson_ratio: float = 0.3


@dataclass(frozen=True)
class Section:
    """Beam cross-section: area (m^2), second moment of area in the frame plane (m^4),
    and the shear coefficient kappa (shear area = kappa * area, Timoshenko elements only)."""

    area_m2: float
    inertia_m4: float
    shear_coefficient: float = 5.0 / 6.0


@dataclass(frozen=True)
class Element:
    """A 2-node frame element from node_i to node_j.

    ``release_i`` / ``release_j``: None for a rigid connection of the element end's rotation
    to its node; otherwise the element end gets a rotation of its own, tied to the node's
    rotation by a rotational spring of that stiffness (N m/rad; 0 is a pin).
    ``youngs_modulus_pa`` overrides the material's modulus for this element (an updated model).
    ``crack_position`` / ``crack_stiffness``: a crack as a rotational spring (N m/rad) at that
    fraction of the length from node_i, inside the element (flexibility formulation, no new
    node; Euler-Bernoulli only). The crack's stiffness scales with the element's modulus
    when that is updated, as a fracture-mechanics crack compliance (proportional to 1/E) does.
    """

    id: int
    node_i: int
    node_j: int
    section: str
    material: str
    formulation: str = "euler-bernoulli"
    release_i: float | None = None
    release_j: float | None = None
    youngs_modulus_pa: float | None = None
    crack_position: float | None = None
    crack_stiffness: float | None = None


@dataclass(frozen=True)
class LumpedMass:
    """A lumped mass (kg, acting in x and y) and rotary inertia (kg m^2) at a node."""

    node: int
    mass_kg: float
    inertia_kg_m2: float = 0.0


@dataclass(frozen=True)
class Spring:
    """A linear spring between two nodal DOFs, or from one DOF to ground (dof_b None).

    Stiffness in N/m for x/y, N m/rad for rz.
    """

    id: int
    dof_a: tuple[int, str]
    dof_b: tuple[int, str] | None
    stiffness: float


@dataclass(frozen=True)
class Support:
    """Directions fixed to ground at a node."""

    node: int
    directions: tuple[str, ...]


@dataclass(frozen=True)
class FrameModel:
    """A planar frame model. Node-major DOFs: (node 1 x, y, rz), (node 2 x, y, rz), ..."""

    name: str
    nodes: tuple[Node, ...]
    materials: dict[str, Material]
    sections: dict[str, Section]
    elements: tuple[Element, ...]
    masses: tuple[LumpedMass, ...] = ()
    springs: tuple[Spring, ...] = ()
    supports: tuple[Support, ...] = ()
    measured_dofs: tuple[tuple[int, str], ...] = ()
    excitation: tuple[int, str] | None = None
    description: str = ""
    source: str = field(default="<memory>", compare=False)

    def __post_init__(self) -> None:
        _validate(self)

    # -- lookups ---------------------------------------------------------------------
    @property
    def node_ids(self) -> tuple[int, ...]:
        return tuple(n.id for n in self.nodes)

    @property
    def element_ids(self) -> tuple[int, ...]:
        return tuple(e.id for e in self.elements)

    def node(self, node_id: int) -> Node:
        for n in self.nodes:
            if n.id == node_id:
                return n
        raise KeyError(f"model {self.name!r} has no node {node_id}")

    def element(self, element_id: int) -> Element:
        for e in self.elements:
            if e.id == element_id:
                return e
        raise KeyError(f"model {self.name!r} has no element {element_id}")

    @property
    def dofs(self) -> tuple[tuple[int, str], ...]:
        """All nodal DOFs in node-major order, one (node id, direction) per DOF."""
        return tuple((n.id, d) for n in self.nodes for d in DIRECTIONS)

    def dof_index(self, node_id: int, direction: str) -> int:
        """Position of a nodal DOF in `dofs`."""
        if direction not in DIRECTIONS:
            raise KeyError(f"unknown direction {direction!r}; use one of {DIRECTIONS}")
        ids = self.node_ids
        if node_id not in ids:
            raise KeyError(f"model {self.name!r} has no node {node_id}")
        return 3 * ids.index(node_id) + DIRECTIONS.index(direction)

    def element_length_m(self, element_id: int) -> float:
        e = self.element(element_id)
        a, b = self.node(e.node_i), self.node(e.node_j)
        return math.hypot(b.x - a.x, b.y - a.y)

    def element_modulus_pa(self, element_id: int) -> float:
        e = self.element(element_id)
        if e.youngs_modulus_pa is not None:
            return e.youngs_modulus_pa
        return self.materials[e.material].youngs_modulus_pa

    def total_mass_kg(self) -> float:
        """Mass of all elements and lumped masses (kg)."""
        m = 0.0
        for e in self.elements:
            m += (self.materials[e.material].density_kg_m3 * self.sections[e.section].area_m2
                  * self.element_length_m(e.id))
        return m + sum(lm.mass_kg for lm in self.masses)

    def joints(self) -> tuple[int, ...]:
        """Nodes where more than two element ends meet (where members join)."""
        count: dict[int, int] = {}
        for e in self.elements:
            for n in (e.node_i, e.node_j):
                count[n] = count.get(n, 0) + 1
        return tuple(n for n, c in count.items() if c > 2)

    def replace(self, **changes: Any) -> "FrameModel":
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def with_element_moduli(self, moduli_pa: dict[int, float]) -> "FrameModel":
        """A copy whose listed elements have their own modulus (an updated model)."""
        elements = tuple(
            dataclasses.replace(e, youngs_modulus_pa=float(moduli_pa[e.id])) if e.id in moduli_pa else e
            for e in self.elements
        )
        unknown = set(moduli_pa) - set(self.element_ids)
        if unknown:
            raise KeyError(f"model {self.name!r} has no element(s) {sorted(unknown)}")
        return self.replace(elements=elements)


# ---------------------------------------------------------------------------------------
# Model transformations used to build truths and extensions
# ---------------------------------------------------------------------------------------

def add_mass(model: FrameModel, node: int, mass_kg: float, inertia_kg_m2: float = 0.0) -> FrameModel:
    """A copy with a lumped mass added at `node`."""
    return model.replace(masses=model.masses + (LumpedMass(node, float(mass_kg), float(inertia_kg_m2)),))


def release_element_end(model: FrameModel, element_id: int, node: int, stiffness: float) -> FrameModel:
    """A copy where the end of `element_id` at `node` is tied to it by a rotational spring."""
    e = model.element(element_id)
    if node == e.node_i:
        new = dataclasses.replace(e, release_i=float(stiffness))
    elif node == e.node_j:
        new = dataclasses.replace(e, release_j=float(stiffness))
    else:
        raise KeyError(f"element {element_id} does not end at node {node}")
    return model.replace(elements=tuple(new if x.id == element_id else x for x in model.elements))


def split_element(model: FrameModel, element_id: int, fraction: float,
                  rotational_stiffness: float | None = None) -> FrameModel:
    """A copy with element `element_id` split at `fraction` of its length from node_i.

    The first part keeps the element id, the second gets a new id (max + 1), the new node
    gets id max + 1. With `rotational_stiffness` the two parts are joined through a
    rotational spring (N m/rad): the model of a crack at that point.
    """
    if not 0.0 < fraction < 1.0:
        raise ValueError(f"fraction must be inside (0, 1), got {fraction}")
    e = model.element(element_id)
    a, b = model.node(e.node_i), model.node(e.node_j)
    new_node = Node(max(model.node_ids) + 1, a.x + fraction * (b.x - a.x), a.y + fraction * (b.y - a.y))
    first = dataclasses.replace(e, node_j=new_node.id, release_j=None)
    second = dataclasses.replace(e, id=max(model.element_ids) + 1, node_i=new_node.id,
                                 release_i=rotational_stiffness, release_j=e.release_j)
    elements = []
    for x in model.elements:
        elements.extend([first, second] if x.id == element_id else [x])
    return model.replace(nodes=model.nodes + (new_node,), elements=tuple(elements))


def crack_element(model: FrameModel, element_id: int, position: float, stiffness: float) -> FrameModel:
    """A copy with a crack (rotational spring of `stiffness` N m/rad at `position`, a fraction
    of the length from node_i) inside element `element_id`, without remeshing."""
    e = model.element(element_id)
    new = dataclasses.replace(e, crack_position=float(position), crack_stiffness=float(stiffness))
    return model.replace(elements=tuple(new if x.id == element_id else x for x in model.elements))


def with_formulation(model: FrameModel, formulation: str) -> FrameModel:
    """A copy with every element using `formulation` ('euler-bernoulli' or 'timoshenko').
    Cracked elements stay Euler-Bernoulli (a crack needs that formulation)."""
    return model.replace(elements=tuple(e if e.crack_position is not None else dataclasses.replace(e, formulation=formulation)
                                        for e in model.elements))


# ---------------------------------------------------------------------------------------
# Validation
# ---------------------------------------------------------------------------------------

def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _duplicates(ids: list) -> list:
    return sorted({i for i in ids if ids.count(i) > 1})


def _positive(value: Any, where: str, allow_zero: bool = False) -> None:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
    ok = ok and (value >= 0 if allow_zero else value > 0)
    if not ok:
        need = "a finite number >= 0" if allow_zero else "a finite number > 0"
        raise ModelFileError(f"{where}: must be {need}, got {value!r}")


def _validate(m: FrameModel) -> None:
    src = m.source
    ids = [n.id for n in m.nodes]
    if not m.nodes:
        raise ModelFileError(f"{src}: 'nodes' is empty")
    if len(set(ids)) != len(ids):
        raise ModelFileError(f"{src}: 'nodes' has duplicate ids {_duplicates(ids)}")
    for n in m.nodes:
        for v, name in ((n.x, "x"), (n.y, "y")):
            if not (isinstance(v, (int, float)) and math.isfinite(v)):
                raise ModelFileError(f"{src}: node {n.id} field '{name}' must be a finite number, got {v!r}")
    for name, mat in m.materials.items():
        _positive(mat.youngs_modulus_pa, f"{src}: material {name!r} 'youngs_modulus_pa'")
        _positive(mat.density_kg_m3, f"{src}: material {name!r} 'density_kg_m3'")
        if not (_is_number(mat.poisson_ratio) and -1.0 < mat.poisson_ratio < 0.5):
            raise ModelFileError(f"{src}: material {name!r} 'poisson_ratio' must be a number in (-1, 0.5), "
                                 f"got {mat.poisson_ratio!r}")
    for name, sec in m.sections.items():
        _positive(sec.area_m2, f"{src}: section {name!r} 'area_m2'")
        _positive(sec.inertia_m4, f"{src}: section {name!r} 'inertia_m4'")
        _positive(sec.shear_coefficient, f"{src}: section {name!r} 'shear_coefficient'")
    eids = [e.id for e in m.elements]
    if not m.elements:
        raise ModelFileError(f"{src}: 'elements' is empty")
    if len(set(eids)) != len(eids):
        raise ModelFileError(f"{src}: 'elements' has duplicate ids {_duplicates(eids)}")
    idset = set(ids)
    for e in m.elements:
        where = f"{src}: element {e.id}"
        for n in (e.node_i, e.node_j):
            if n not in idset:
                raise ModelFileError(f"{where}: field 'nodes': unknown node {n}")
        if e.node_i == e.node_j:
            raise ModelFileError(f"{where}: both ends at node {e.node_i}")
        if e.section not in m.sections:
            raise ModelFileError(f"{where}: field 'section': unknown section {e.section!r} "
                                 f"(sections: {sorted(m.sections)})")
        if e.material not in m.materials:
            raise ModelFileError(f"{where}: field 'material': unknown material {e.material!r} "
                                 f"(materials: {sorted(m.materials)})")
        if e.formulation not in FORMULATIONS:
            raise ModelFileError(f"{where}: 'formulation' must be one of {FORMULATIONS}, got {e.formulation!r}")
        for r, name in ((e.release_i, "release_i"), (e.release_j, "release_j")):
            if r is not None:
                _positive(r, f"{where} '{name}'", allow_zero=True)
        if e.youngs_modulus_pa is not None:
            _positive(e.youngs_modulus_pa, f"{where} 'youngs_modulus_pa'")
        if (e.crack_position is None) != (e.crack_stiffness is None):
            raise ModelFileError(f"{where}: 'crack_position' and 'crack_stiffness' go together")
        if e.crack_position is not None:
            if not (isinstance(e.crack_position, (int, float)) and 0.0 < e.crack_position < 1.0):
                raise ModelFileError(f"{where} 'crack_position': must be inside (0, 1), got {e.crack_position!r}")
            _positive(e.crack_stiffness, f"{where} 'crack_stiffness'")
            if e.formulation != "euler-bernoulli":
                raise ModelFileError(f"{where}: a crack needs formulation 'euler-bernoulli'")
        a = next(n for n in m.nodes if n.id == e.node_i)
        b = next(n for n in m.nodes if n.id == e.node_j)
        if math.hypot(b.x - a.x, b.y - a.y) <= 0:
            raise ModelFileError(f"{where}: zero length (nodes {e.node_i} and {e.node_j} coincide)")

    def check_dof(dof: Any, where: str) -> None:
        if not (isinstance(dof, tuple) and len(dof) == 2):
            raise ModelFileError(f"{where}: a DOF is [node id, direction], got {dof!r}")
        if dof[0] not in idset:
            raise ModelFileError(f"{where}: unknown node {dof[0]!r}")
        if dof[1] not in DIRECTIONS:
            raise ModelFileError(f"{where}: unknown direction {dof[1]!r}; use one of {DIRECTIONS}")

    for lm in m.masses:
        if lm.node not in idset:
            raise ModelFileError(f"{src}: mass at unknown node {lm.node}")
        _positive(lm.mass_kg, f"{src}: mass at node {lm.node} 'mass_kg'", allow_zero=True)
        _positive(lm.inertia_kg_m2, f"{src}: mass at node {lm.node} 'inertia_kg_m2'", allow_zero=True)
    for s in m.springs:
        check_dof(s.dof_a, f"{src}: spring {s.id}")
        if s.dof_b is not None:
            check_dof(s.dof_b, f"{src}: spring {s.id}")
        _positive(s.stiffness, f"{src}: spring {s.id} 'stiffness'", allow_zero=True)
    for sup in m.supports:
        if sup.node not in idset:
            raise ModelFileError(f"{src}: support at unknown node {sup.node}")
        for d in sup.directions:
            if d not in DIRECTIONS:
                raise ModelFileError(f"{src}: support at node {sup.node}: unknown direction {d!r}")
    for i, dof in enumerate(m.measured_dofs):
        check_dof(dof, f"{src}: measured_dofs[{i}]")
    if len(set(m.measured_dofs)) != len(m.measured_dofs):
        raise ModelFileError(f"{src}: 'measured_dofs' lists a DOF twice")
    if m.excitation is not None:
        check_dof(m.excitation, f"{src}: excitation")


# ---------------------------------------------------------------------------------------
# Files
# ---------------------------------------------------------------------------------------

def _dof(value: Any, where: str) -> tuple[int, str]:
    if not (isinstance(value, (list, tuple)) and len(value) == 2 and isinstance(value[0], int)
            and isinstance(value[1], str)):
        raise ModelFileError(f"{where}: a DOF is [node id, direction], got {value!r}")
    return (int(value[0]), str(value[1]))


def _int(value: Any, where: str) -> int:
    """An id read from a file: a JSON integer (not a bool, not 3.5)."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise ModelFileError(f"{where}: must be an integer id, got {value!r}")
    return value


def _number(value: Any, where: str) -> float:
    if not _is_number(value):
        raise ModelFileError(f"{where}: must be a finite number, got {value!r}")
    return float(value)


def _objects(d: dict, key: str, source: str, kind: type) -> dict:
    """The 'materials' or 'sections' table: name -> object of the dataclass `kind`'s fields."""
    table = _get(d, key, source)
    if not isinstance(table, dict):
        raise ModelFileError(f"{source}: field '{key}' must be an object of name -> properties")
    out = {}
    for name, v in table.items():
        if not isinstance(v, dict):
            raise ModelFileError(f"{source}: field '{key}' entry {name!r} must be an object")
        try:
            out[name] = kind(**v)
        except TypeError as exc:
            raise ModelFileError(f"{source}: field '{key}' entry {name!r}: {exc}") from None
    return out


def _get(obj: dict, key: str, where: str, default: Any = ...) -> Any:
    if not isinstance(obj, dict):
        raise ModelFileError(f"{where}: expected an object, got {type(obj).__name__}")
    if key in obj:
        return obj[key]
    if default is ...:
        raise ModelFileError(f"{where}: missing field '{key}'")
    return default


def model_from_dict(d: dict, source: str = "<memory>") -> FrameModel:
    """Build a model from the parsed JSON of a model file; errors name `source` and the field."""
    if _get(d, "format", source) != MODEL_FORMAT:
        raise ModelFileError(f"{source}: field 'format' must be {MODEL_FORMAT!r}, got {d.get('format')!r}")
    materials = _objects(d, "materials", source, Material)
    sections = _objects(d, "sections", source, Section)
    for key in ("nodes", "elements"):
        if not isinstance(_get(d, key, source), list):
            raise ModelFileError(f"{source}: field '{key}' must be a list")
    nodes = []
    for i, n in enumerate(d["nodes"]):
        where = f"{source}: nodes[{i}]"
        nodes.append(Node(_int(_get(n, "id", where), f"{where} field 'id'"),
                          _number(_get(n, "x", where), f"{where} field 'x'"),
                          _number(_get(n, "y", where), f"{where} field 'y'")))
    elements = []
    for i, e in enumerate(_get(d, "elements", source)):
        where = f"{source}: elements[{i}]"
        ends = _get(e, "nodes", where)
        if not (isinstance(ends, list) and len(ends) == 2):
            raise ModelFileError(f"{where}: field 'nodes' must be [node_i, node_j]")
        elements.append(Element(
            id=_int(_get(e, "id", where), f"{where} field 'id'"), node_i=_int(ends[0], f"{where} field 'nodes'"),
            node_j=_int(ends[1], f"{where} field 'nodes'"),
            section=_get(e, "section", where), material=_get(e, "material", where),
            formulation=_get(e, "formulation", where, "euler-bernoulli"),
            release_i=_get(e, "release_i", where, None), release_j=_get(e, "release_j", where, None),
            youngs_modulus_pa=_get(e, "youngs_modulus_pa", where, None),
            crack_position=_get(e, "crack_position", where, None),
            crack_stiffness=_get(e, "crack_stiffness", where, None)))
    masses = []
    for i, m in enumerate(d.get("masses", [])):
        where = f"{source}: masses[{i}]"
        masses.append(LumpedMass(_int(_get(m, "node", where), f"{where} field 'node'"), _get(m, "mass_kg", where),
                                 _get(m, "inertia_kg_m2", where, 0.0)))
    springs = []
    for i, s in enumerate(d.get("springs", [])):
        where = f"{source}: springs[{i}]"
        dofs = _get(s, "dofs", where)
        if not (isinstance(dofs, list) and len(dofs) in (1, 2)):
            raise ModelFileError(f"{where}: field 'dofs' must list one DOF (to ground) or two")
        springs.append(Spring(_int(_get(s, "id", where, i + 1), f"{where} field 'id'"), _dof(dofs[0], where),
                              _dof(dofs[1], where) if len(dofs) == 2 else None, _get(s, "stiffness", where)))
    supports = []
    for i, s in enumerate(d.get("supports", [])):
        where = f"{source}: supports[{i}]"
        directions = _get(s, "directions", where)
        if not isinstance(directions, list):
            raise ModelFileError(f"{where}: field 'directions' must be a list such as [\"x\", \"y\"], "
                                 f"got {directions!r}")
        supports.append(Support(_int(_get(s, "node", where), f"{where} field 'node'"), tuple(directions)))
    measured = tuple(_dof(x, f"{source}: measured_dofs[{i}]") for i, x in enumerate(d.get("measured_dofs", [])))
    exc = d.get("excitation")
    return FrameModel(
        name=str(d.get("name", Path(source).stem)), nodes=tuple(nodes), materials=materials, sections=sections,
        elements=tuple(elements), masses=tuple(masses), springs=tuple(springs), supports=tuple(supports),
        measured_dofs=measured, excitation=_dof(exc, f"{source}: excitation") if exc is not None else None,
        description=str(d.get("description", "")), source=source)


def model_to_dict(model: FrameModel) -> dict:
    """The JSON-ready dictionary of a model file."""
    def element(e: Element) -> dict:
        out: dict[str, Any] = {"id": e.id, "nodes": [e.node_i, e.node_j], "section": e.section,
                               "material": e.material, "formulation": e.formulation}
        for k in ("release_i", "release_j", "youngs_modulus_pa", "crack_position", "crack_stiffness"):
            if getattr(e, k) is not None:
                out[k] = getattr(e, k)
        return out

    return {
        "format": MODEL_FORMAT,
        "name": model.name,
        "description": model.description,
        "materials": {k: dataclasses.asdict(v) for k, v in model.materials.items()},
        "sections": {k: dataclasses.asdict(v) for k, v in model.sections.items()},
        "nodes": [{"id": n.id, "x": n.x, "y": n.y} for n in model.nodes],
        "elements": [element(e) for e in model.elements],
        "masses": [dataclasses.asdict(m) for m in model.masses],
        "springs": [{"id": s.id, "dofs": [list(s.dof_a)] + ([list(s.dof_b)] if s.dof_b else []),
                     "stiffness": s.stiffness} for s in model.springs],
        "supports": [{"node": s.node, "directions": list(s.directions)} for s in model.supports],
        "measured_dofs": [list(d) for d in model.measured_dofs],
        "excitation": list(model.excitation) if model.excitation else None,
    }


def shipped_models() -> tuple[str, ...]:
    """Names of the models that ship with the project."""
    return tuple(sorted(p.name[: -len(".model.json")] for p in DATA_DIR.glob("*.model.json")))


def load_model(name_or_path: str | Path) -> FrameModel:
    """Load a shipped model by name (``"hframe"``) or a model file by path."""
    if isinstance(name_or_path, FrameModel):
        return name_or_path
    path = Path(name_or_path)
    if not path.suffix and str(name_or_path) in shipped_models():
        path = DATA_DIR / f"{name_or_path}.model.json"
    if not path.exists():
        raise FileNotFoundError(
            f"no model file {str(name_or_path)!r} and no shipped model of that name "
            f"(shipped: {', '.join(shipped_models())})")
    try:
        d = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ModelFileError(f"{path}: not valid JSON ({exc})") from None
    return model_from_dict(d, source=str(path))


def save_model(model: FrameModel, path: str | Path) -> Path:
    """Write `model` as a model file; returns the path."""
    path = Path(path)
    path.write_text(json.dumps(model_to_dict(model), indent=1) + "\n")
    return path
