"""Model files (format ``femu.model/1``, docs/model-format.md): reading, writing, and the
models that ship with the project (``hframe``), loaded by name."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

from ..dofs import LAYOUTS
from ..jsonutil import check_keys, dumps, read_json_file
from ..safe_files import write_text
from ..shipped import resolve, shipped_names
from .types import Element, FrameModel, LumpedMass, Material, Node, Section, Spring, Support
from .validate import ModelFileError, is_number, shown

MODEL_FORMAT = "femu.model/1"
MODEL_SUFFIX = ".model.json"

#: The keys a model file's objects may have (docs/model-format.md); any other key is refused with
#: the file, the path to it and the closest known key, never ignored (a 'suports' list would
#: otherwise leave a free-free structure without a word)
KEYS = {
    "model": ("format", "name", "dimension", "description", "materials", "sections", "nodes", "elements", "masses",
              "springs", "supports", "measured_dofs", "excitation", "meta"),
    "node": ("id", "x", "y", "z"),
    "element": ("id", "nodes", "section", "material", "formulation", "release_i", "release_j", "youngs_modulus_pa",
                "crack_position", "crack_stiffness", "weak_zone", "orientation", "releases_i", "releases_j"),
    "mass": tuple(f.name for f in dataclasses.fields(LumpedMass)),
    "spring": ("id", "dofs", "stiffness"),
    "support": ("node", "directions"),
    "materials": tuple(f.name for f in dataclasses.fields(Material)),
    "sections": tuple(f.name for f in dataclasses.fields(Section)),
}


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
    if not is_number(value):
        raise ModelFileError(f"{where}: must be a finite number, got {shown(value)}")
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
        check_keys(v, KEYS[key], f"{source}: {key}[{name!r}]", ModelFileError)
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


def _name(value: Any, where: str) -> str:
    """`value` if it is a string (a key of the sections or materials table)."""
    if not isinstance(value, str):
        raise ModelFileError(f"{where}: must be the name (a string) of an entry of the table, got {shown(value)}")
    return value


def model_from_dict(d: dict, source: str = "<memory>") -> FrameModel:
    """Build a model from the parsed JSON of a model file; errors name `source` and the field.

    ``"dimension"``: absent or 2, a planar model (`PLANAR_FRAME`); 3, a space model
    (`SPACE_FRAME`: nodes with z, sections with iy/iz/j, elements with an orientation)."""
    if _get(d, "format", source) != MODEL_FORMAT:
        raise ModelFileError(f"{source}: field 'format' must be {MODEL_FORMAT!r}, got {d.get('format')!r}")
    dimension = d.get("dimension", 2)
    if isinstance(dimension, bool) or dimension not in LAYOUTS:
        raise ModelFileError(f"{source}: field 'dimension' must be 2 (a planar frame) or 3 (a space frame), "
                             f"got {shown(dimension)}")
    layout = LAYOUTS[dimension]
    check_keys(d, KEYS["model"], source, ModelFileError)
    materials = _objects(d, "materials", source, Material)
    sections = _objects(d, "sections", source, Section)
    for key in ("nodes", "elements"):
        if not isinstance(_get(d, key, source), list):
            raise ModelFileError(f"{source}: field '{key}' must be a list")
    for key in ("masses", "springs", "supports", "measured_dofs"):
        if not isinstance(d.get(key, []), list):
            raise ModelFileError(f"{source}: field '{key}' must be a list, got {shown(d[key])}")
    for key, kind in (("nodes", "node"), ("elements", "element"), ("masses", "mass"), ("springs", "spring"),
                      ("supports", "support")):
        for i, item in enumerate(d.get(key, [])):
            if not isinstance(item, dict):
                raise ModelFileError(f"{source}: {key}[{i}] must be an object, got {shown(item)}")
            check_keys(item, KEYS[kind], f"{source}: {key}[{i}]", ModelFileError)
    nodes = []
    for i, n in enumerate(d["nodes"]):
        where = f"{source}: nodes[{i}]"
        nodes.append(Node(_int(_get(n, "id", where), f"{where} field 'id'"),
                          _number(_get(n, "x", where), f"{where} field 'x'"),
                          _number(_get(n, "y", where), f"{where} field 'y'"),
                          _number(_get(n, "z", where) if dimension == 3 else n.get("z", 0.0), f"{where} field 'z'")))
    elements = []
    for i, e in enumerate(_get(d, "elements", source)):
        where = f"{source}: elements[{i}]"
        ends = _get(e, "nodes", where)
        if not (isinstance(ends, list) and len(ends) == 2):
            raise ModelFileError(f"{where}: field 'nodes' must be [node_i, node_j]")
        elements.append(Element(
            id=_int(_get(e, "id", where), f"{where} field 'id'"), node_i=_int(ends[0], f"{where} field 'nodes'"),
            node_j=_int(ends[1], f"{where} field 'nodes'"),
            section=_name(_get(e, "section", where), f"{where} field 'section'"),
            material=_name(_get(e, "material", where), f"{where} field 'material'"),
            formulation=_get(e, "formulation", where, "euler-bernoulli"),
            release_i=_get(e, "release_i", where, None), release_j=_get(e, "release_j", where, None),
            youngs_modulus_pa=_get(e, "youngs_modulus_pa", where, None),
            crack_position=_get(e, "crack_position", where, None),
            crack_stiffness=_get(e, "crack_stiffness", where, None),
            weak_zone=_weak_zone(_get(e, "weak_zone", where, None), where),
            weak_zone_about=_zone_about(_get(e, "weak_zone", where, None), dimension, where),
            orientation=_vector(_get(e, "orientation", where, None), f"{where} field 'orientation'"),
            releases_i=_releases(_get(e, "releases_i", where, None), f"{where} field 'releases_i'"),
            releases_j=_releases(_get(e, "releases_j", where, None), f"{where} field 'releases_j'")))
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
                                 f"got {shown(directions)}")
        supports.append(Support(_int(_get(s, "node", where), f"{where} field 'node'"), tuple(directions)))
    measured = tuple(_dof(x, f"{source}: measured_dofs[{i}]") for i, x in enumerate(d.get("measured_dofs", [])))
    exc = d.get("excitation")
    name = d.get("name", Path(source).stem)
    if not isinstance(name, str) or not name.strip():
        raise ModelFileError(f"{source}: field 'name' must be a non-empty string, got {shown(name)}")
    meta = d.get("meta", {})
    if not isinstance(meta, dict):
        raise ModelFileError(f"{source}: field 'meta' must be an object, got {shown(meta)}")
    return FrameModel(
        name=name, nodes=tuple(nodes), materials=materials, sections=sections,
        elements=tuple(elements), masses=tuple(masses), springs=tuple(springs), supports=tuple(supports),
        measured_dofs=measured, excitation=_dof(exc, f"{source}: excitation") if exc is not None else None,
        description=str(d.get("description", "")), source=source, layout=layout, meta=meta)


def _vector(v, where: str):
    """(x, y, z) from a list of 3 numbers, or None."""
    if v is None:
        return None
    if not (isinstance(v, list) and len(v) == 3):
        raise ModelFileError(f"{where}: must be a vector of 3 numbers [x, y, z], got {shown(v)}")
    return tuple(_number(c, where) for c in v)


def _releases(r, where: str) -> tuple:
    """((rotation, stiffness), ...) from {"ry": 0.0, "rz": 1e5}, or ()."""
    if r is None:
        return ()
    if not isinstance(r, dict):
        raise ModelFileError(f"{where}: must be an object {{rotation: stiffness N m/rad}} such as "
                             f"{{\"ry\": 0, \"rz\": 0}}, got {shown(r)}")
    return tuple((str(k), v) for k, v in r.items())


def _weak_zone(z, where: str):
    """(start, end, modulus_ratio) from {"start": s, "end": e, "modulus_ratio": r} (a space
    model's may add "about", `_zone_about`), or None."""
    if z is None:
        return None
    keys = ("start", "end", "modulus_ratio")
    if not isinstance(z, dict) or not set(keys) <= set(z) <= {*keys, "about"}:
        raise ModelFileError(f"{where}: field 'weak_zone' must be {{\"start\": s, \"end\": e, \"modulus_ratio\": r}}"
                             f" (a space model's may add \"about\": [\"ry\", \"rz\"]), got {shown(z)}")
    return tuple(_number(z[k], f"{where} field 'weak_zone' '{k}'") for k in keys)


#: The bending rotations a space element's weak zone weakens when its file names none.
ZONE_ABOUT_DEFAULT = ("ry", "rz")


def _zone_about(z, dimension: int, where: str) -> tuple:
    """The local bending rotations of a weak zone's "about" (a list of names); a space model's
    zone without it weakens both (`ZONE_ABOUT_DEFAULT`); a planar zone names none (validate.py
    refuses an "about" there)."""
    if not isinstance(z, dict):
        return ()
    if "about" not in z:
        return ZONE_ABOUT_DEFAULT if dimension == 3 else ()
    about = z["about"]
    if not isinstance(about, list):
        raise ModelFileError(f"{where} field 'weak_zone' 'about': must be a list of rotations such as [\"ry\"], "
                             f"got {shown(about)}")
    return tuple(about)


def model_to_dict(model: FrameModel) -> dict:
    """The JSON-ready dictionary of a model file."""
    def element(e: Element) -> dict:
        out: dict[str, Any] = {"id": e.id, "nodes": [e.node_i, e.node_j], "section": e.section,
                               "material": e.material, "formulation": e.formulation}
        for k in ("release_i", "release_j", "youngs_modulus_pa", "crack_position", "crack_stiffness"):
            if getattr(e, k) is not None:
                out[k] = getattr(e, k)
        if e.weak_zone is not None:
            out["weak_zone"] = dict(zip(("start", "end", "modulus_ratio"), e.weak_zone))
            if e.weak_zone_about:
                out["weak_zone"]["about"] = list(e.weak_zone_about)
        if e.orientation is not None:
            out["orientation"] = list(e.orientation)
        for k in ("releases_i", "releases_j"):
            if getattr(e, k):
                out[k] = dict(getattr(e, k))
        return out

    def table(v) -> dict:
        # the optional fields of the other dimension (None) are left out: a planar file as before
        return {k: x for k, x in dataclasses.asdict(v).items() if x is not None}

    space = model.layout.dimension == 3
    head: dict[str, Any] = {"format": MODEL_FORMAT, "name": model.name}
    if space:
        head["dimension"] = 3
    tail = {"meta": model.meta} if model.meta else {}
    return {
        **head,
        "description": model.description,
        "materials": {k: table(v) for k, v in model.materials.items()},
        "sections": {k: table(v) for k, v in model.sections.items()},
        "nodes": [{"id": n.id, "x": n.x, "y": n.y, "z": n.z} if space else {"id": n.id, "x": n.x, "y": n.y}
                  for n in model.nodes],
        "elements": [element(e) for e in model.elements],
        "masses": [dataclasses.asdict(m) for m in model.masses],
        "springs": [{"id": s.id, "dofs": [list(s.dof_a)] + ([list(s.dof_b)] if s.dof_b else []),
                     "stiffness": s.stiffness} for s in model.springs],
        "supports": [{"node": s.node, "directions": list(s.directions)} for s in model.supports],
        "measured_dofs": [list(d) for d in model.measured_dofs],
        "excitation": list(model.excitation) if model.excitation else None,
        **tail,
    }


def shipped_models() -> tuple[str, ...]:
    """Names of the models that ship with the project."""
    return shipped_names(MODEL_SUFFIX)


def load_model(name_or_path: str | Path) -> FrameModel:
    """Load a shipped model by name (``"hframe"``) or a model file by path."""
    if isinstance(name_or_path, FrameModel):
        return name_or_path
    path = resolve(name_or_path, MODEL_SUFFIX, "model")
    return model_from_dict(read_json_file(path, ModelFileError), source=str(path))


def save_model(model: FrameModel, path: str | Path) -> Path:
    """Write `model` as a model file; returns the path."""
    path = Path(path)
    write_text(path, dumps(model_to_dict(model)) + "\n")
    return path
