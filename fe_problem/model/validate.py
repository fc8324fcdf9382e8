"""Validation of a model: every rule a model file must obey, with messages that name the
file, the item and the field."""

from __future__ import annotations

import math
from collections import Counter
from typing import TYPE_CHECKING, Any

from ..elements import formulation, formulations

if TYPE_CHECKING:
    from .types import FrameModel


class ModelFileError(ValueError):
    """A model file or model definition that breaks the format; the message names where."""


def is_number(value: Any) -> bool:
    """A finite int or float that is not a bool (an integer too large for a float is not)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return False
    try:
        return math.isfinite(value)
    except OverflowError:  # an int of more than ~308 digits
        return False


def shown(value: Any, limit: int = 60) -> str:
    """`repr(value)` cut to `limit` characters, for one-line error messages."""
    text = repr(value) if not isinstance(value, int) or abs(value) < 10**limit else f"an integer of {len(str(abs(value)))} digits"
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _duplicates(ids: list) -> list:
    return sorted(i for i, n in Counter(ids).items() if n > 1)


#: The physical ranges a model's values must lie in (SI units): a value outside is a typo or a
#: unit error, and would leave the matrices too ill-conditioned to solve in double precision.
RANGES = {
    "coordinate": 1e6,                      # |x|, |y|, |z| in m
    "length": 1e-6,                         # the shortest element, m
    "youngs_modulus_pa": (1e3, 1e13), "density_kg_m3": (1e-3, 1e6),
    "area_m2": (1e-12, 1e3), "inertia_m4": (1e-24, 1e6), "iy_m4": (1e-24, 1e6), "iz_m4": (1e-24, 1e6),
    "j_m4": (1e-24, 1e6), "shear_modulus_pa": (1e3, 1e13),
    "mass_kg": 1e9, "inertia_kg_m2": 1e9, "stiffness": 1e15, "release": 1e15,
}


def _positive(value: Any, where: str, allow_zero: bool = False, field: str | None = None) -> None:
    """ModelFileError unless `value` is a finite number > 0 (>= 0 with `allow_zero`) within the
    range RANGES[field] (a (low, high) pair, or a high bound)."""
    ok = is_number(value) and (value >= 0 if allow_zero else value > 0)
    if not ok:
        need = "a finite number >= 0" if allow_zero else "a finite number > 0"
        raise ModelFileError(f"{where}: must be {need}, got {shown(value)}")
    bounds = RANGES.get(field)
    if bounds is not None:
        lo, hi = bounds if isinstance(bounds, tuple) else (0.0, bounds)
        if not (lo <= value <= hi) and not (allow_zero and value == 0):
            raise ModelFileError(f"{where}: {shown(value)} is outside the physical range [{lo:g}, {hi:g}] "
                                 "(SI units: Pa, kg/m^3, m^2, m^4, kg, N/m)")


def validate(m: FrameModel, base: FrameModel | None = None) -> None:
    """Raise ModelFileError (naming `m.source`, the item and the field) if `m` breaks a rule.

    `base`: a valid model `m` was copied from (`FrameModel.replace`). Where the two have the
    same layout, source and node ids (in order), a node object `base` holds at the same place is
    not checked again, nor a table (masses, springs, supports, measured DOFs) `m` shares with
    it, and an element object `base` holds with neither end at a node that changed is checked
    only for the section and material it names (nothing else of an element's rules depends on
    what a copy can change): a diagnosis builds hundreds of copies of a 1,000-element model
    that differ in a few elements, a section or a node. The outcome (error or not, and its
    message) is the full check's (tests/test_model_file.py)."""
    src = m.source
    moved = _moved_nodes(m, base)  # None: no base to rely on
    kept = moved is not None
    if not kept:
        _check_ids(src, "nodes", [n.id for n in m.nodes])
    for n in (m.nodes if not kept else [n for n in m.nodes if n.id in moved]):
        for v, name in ((n.x, "x"), (n.y, "y"), (n.z, "z")):
            if not (is_number(v) and abs(v) <= RANGES["coordinate"]):
                raise ModelFileError(f"{src}: node {n.id} field '{name}' must be a finite number of metres within "
                                     f"+-{RANGES['coordinate']:g}, got {shown(v)}")
        if m.layout.dimension == 2 and n.z != 0.0:
            raise ModelFileError(f"{src}: node {n.id} field 'z': a planar model's nodes lie in the x-y plane "
                                 f"(z = 0), got {shown(n.z)}; a space frame's file says \"dimension\": 3")
    _validate_tables(m)
    # the same elements on the same nodes, and every section and material name base had: each
    # element names a section and material m has, and nothing else of its rules can have changed
    same = kept and not moved and base.elements is m.elements and m.sections.keys() >= base.sections.keys() \
        and m.materials.keys() >= base.materials.keys()
    if not same:
        _check_ids(src, "elements", [e.id for e in m.elements])
        nodes = {n.id: n for n in m.nodes}
        known = formulations(m.layout)
        checked = {id(e) for e in base.elements if not (moved and (e.node_i in moved or e.node_j in moved))} \
            if kept else set()
        for e in m.elements:
            if id(e) not in checked or e.section not in m.sections or e.material not in m.materials:
                _validate_element(m, e, nodes, known)
    _validate_nodal(m, base if kept else None)
    if not (kept and base.elements is m.elements and base.springs is m.springs):
        _check_connected(m)


def _moved_nodes(m: FrameModel, base: FrameModel | None) -> set | None:
    """The ids of the nodes of `m` that are not `base`'s node objects at the same place, when
    `base` has the same layout, source and node ids in the same order (a copy: `validate`);
    else None."""
    if base is None or base.layout != m.layout or base.source != m.source:
        return None
    if base.nodes is m.nodes:
        return set()
    if len(base.nodes) != len(m.nodes):
        return None
    moved = set()
    for a, b in zip(base.nodes, m.nodes):
        if a is not b:
            if a.id != b.id:
                return None
            moved.add(b.id)
    return moved


def _check_connected(m: FrameModel) -> None:
    """Raise ModelFileError naming the first node that no element and no spring touches: it
    could only float freely (a typo in an element's nodes, a leftover node)."""
    used = {n for e in m.elements for n in (e.node_i, e.node_j)}
    used |= {d[0] for s in m.springs for d in (s.dof_a, s.dof_b) if d is not None}
    loose = [n for n in m.node_ids if n not in used]
    if loose:
        raise ModelFileError(f"{m.source}: node {loose[0]} is connected to no element and no spring"
                             + (f" (nor are nodes {loose[1:6]})" if len(loose) > 1 else "")
                             + ": remove it or connect it")


def _check_ids(src, field: str, ids: list) -> None:
    """Raise ModelFileError if the list `field` is empty or repeats an id."""
    if not ids:
        raise ModelFileError(f"{src}: '{field}' is empty")
    if len(set(ids)) != len(ids):
        raise ModelFileError(f"{src}: '{field}' has duplicate ids {_duplicates(ids)}")


def _validate_tables(m: FrameModel) -> None:
    src = m.source
    for name, mat in m.materials.items():
        _positive(mat.youngs_modulus_pa, f"{src}: material {name!r} 'youngs_modulus_pa'", field="youngs_modulus_pa")
        _positive(mat.density_kg_m3, f"{src}: material {name!r} 'density_kg_m3'", field="density_kg_m3")
        if not (is_number(mat.poisson_ratio) and -1.0 < mat.poisson_ratio < 0.5):
            raise ModelFileError(f"{src}: material {name!r} 'poisson_ratio' must be a number in (-1, 0.5), "
                                 f"got {mat.poisson_ratio!r}")
        if mat.shear_modulus_pa is not None:
            _positive(mat.shear_modulus_pa, f"{src}: material {name!r} 'shear_modulus_pa'", field="shear_modulus_pa")
    # a planar section bends in one plane (inertia_m4); a space section in two, and twists
    need, other = (("inertia_m4",), ("iy_m4", "iz_m4", "j_m4")) if m.layout.dimension == 2 else \
        (("iy_m4", "iz_m4", "j_m4"), ("inertia_m4",))
    for name, sec in m.sections.items():
        _positive(sec.area_m2, f"{src}: section {name!r} 'area_m2'", field="area_m2")
        for key in need:
            if getattr(sec, key) is None:
                raise ModelFileError(f"{src}: section {name!r}: missing field '{key}' (a {_kind(m)} model's section "
                                     f"has {', '.join(repr(k) for k in need)})")
            _positive(getattr(sec, key), f"{src}: section {name!r} '{key}'", field=key)
        for key in other:
            if getattr(sec, key) is not None:
                raise ModelFileError(f"{src}: section {name!r}: field '{key}' is not used in a {_kind(m)} model "
                                     f"(its section has {', '.join(repr(k) for k in need)})")
        _positive(sec.shear_coefficient, f"{src}: section {name!r} 'shear_coefficient'")


def _kind(m: FrameModel) -> str:
    return "planar" if m.layout.dimension == 2 else "space (\"dimension\": 3)"


def _validate_element(m: FrameModel, e, nodes: dict, known: tuple[str, ...]) -> None:
    where = f"{m.source}: element {e.id}"
    for n in (e.node_i, e.node_j):
        if n not in nodes:
            raise ModelFileError(f"{where}: field 'nodes': unknown node {n}")
    if e.node_i == e.node_j:
        raise ModelFileError(f"{where}: both ends at node {e.node_i}")
    if e.section not in m.sections:
        raise ModelFileError(f"{where}: field 'section': unknown section {e.section!r} "
                             f"(sections: {sorted(m.sections)})")
    if e.material not in m.materials:
        raise ModelFileError(f"{where}: field 'material': unknown material {e.material!r} "
                             f"(materials: {sorted(m.materials)})")
    if not known:
        raise ModelFileError(f"{where}: no element formulation is registered for {_kind(m)} models")
    if e.formulation not in known:
        raise ModelFileError(f"{where}: 'formulation' must be one of {known}, got {e.formulation!r}")
    for r, name in ((e.release_i, "release_i"), (e.release_j, "release_j")):
        if r is not None:
            if len(m.layout.hinges) != 1:
                raise ModelFileError(f"{where}: field '{name}' is a planar model's; a space model's element names "
                                     f"the released rotations: 'releases_{name[-1]}' {{rotation: stiffness}} with "
                                     f"rotations among {list(m.layout.hinges)}")
            _positive(r, f"{where} '{name}'", allow_zero=True, field="release")
    for rs, name in ((e.releases_i, "releases_i"), (e.releases_j, "releases_j")):
        if rs and len(m.layout.hinges) == 1:
            raise ModelFileError(f"{where}: field '{name}' is a space model's; a planar element's end is released "
                                 f"by 'release_{name[-1]}' (a stiffness)")
        names = [r for r, _ in rs]
        for r, k in rs:
            if r not in m.layout.hinges:
                raise ModelFileError(f"{where} '{name}': unknown rotation {shown(r)}; use one of "
                                     f"{list(m.layout.hinges)} (the element's local axes)")
            _positive(k, f"{where} '{name}' '{r}'", allow_zero=True, field="release")
        if len(set(names)) != len(names):
            raise ModelFileError(f"{where} '{name}': a rotation is released twice")
    if e.youngs_modulus_pa is not None:
        _positive(e.youngs_modulus_pa, f"{where} 'youngs_modulus_pa'", field="youngs_modulus_pa")
    if (e.crack_position is None) != (e.crack_stiffness is None):
        raise ModelFileError(f"{where}: 'crack_position' and 'crack_stiffness' go together")
    if e.crack_position is not None:
        if not (isinstance(e.crack_position, (int, float)) and 0.0 < e.crack_position < 1.0):
            raise ModelFileError(f"{where} 'crack_position': must be inside (0, 1), got {e.crack_position!r}")
        _positive(e.crack_stiffness, f"{where} 'crack_stiffness'", field="release")
        if not formulation(e.formulation, m.layout).supports_crack:
            cracked = [f for f in formulations(m.layout) if formulation(f, m.layout).supports_crack]
            raise ModelFileError(f"{where}: a crack needs formulation {' or '.join(map(repr, cracked))}")
    if e.weak_zone is not None:
        start, end, ratio = e.weak_zone
        if not 0.0 <= start < end <= 1.0:
            raise ModelFileError(f"{where} 'weak_zone': need 0 <= start < end <= 1, got start {start!r}, end {end!r}")
        if not 0.0 < ratio <= 1.0:
            raise ModelFileError(f"{where} 'weak_zone' 'modulus_ratio': must be in (0, 1], got {ratio!r}")
        if not formulation(e.formulation, m.layout).supports_weak_zone:
            zoned = [f for f in formulations(m.layout) if formulation(f, m.layout).supports_weak_zone]
            raise ModelFileError(f"{where}: a weak zone needs formulation {' or '.join(map(repr, zoned))}")
    _validate_zone_about(m, e, where)
    d = m.coordinates[m.node_position(e.node_j)] - m.coordinates[m.node_position(e.node_i)]
    length = math.hypot(*d)
    if length <= 0:
        raise ModelFileError(f"{where}: zero length (nodes {e.node_i} and {e.node_j} coincide)")
    if length < RANGES["length"]:
        raise ModelFileError(f"{where}: length {length:.3g} m (nodes {e.node_i} and {e.node_j}) is below the "
                             f"{RANGES['length']:g} m an element may have (coordinates are in metres)")
    _validate_orientation(m, e, where, d / length)


def _validate_zone_about(m: FrameModel, e, where: str) -> None:
    """A space element's weak zone names the bending rotations it weakens (local "ry", "rz",
    each once); a planar element's zone bends about rz, and names none."""
    about = e.weak_zone_about
    bending = tuple(h for h in m.layout.hinges if h != "rx")
    if m.layout.dimension == 2 or e.weak_zone is None:
        if about:
            raise ModelFileError(f"{where} 'weak_zone' 'about': " + (
                "a planar element's weak zone bends about rz only; leave 'about' out" if m.layout.dimension == 2
                else "given without a weak zone"))
        return
    if not (isinstance(about, tuple) and about and all(isinstance(r, str) and r in bending for r in about)
            and len(set(about)) == len(about)):
        raise ModelFileError(f"{where} 'weak_zone' 'about': must list the local bending rotations the zone "
                             f"weakens, each once, among {list(bending)}, got {shown(list(about) if isinstance(about, tuple) else about)}")


def _validate_orientation(m: FrameModel, e, where: str, axis) -> None:
    """A space element needs an orientation vector not parallel to its axis (`axis`, unit);
    a planar element has none (its local z is the global z)."""
    v = e.orientation
    if m.layout.dimension == 2:
        if v is not None:
            raise ModelFileError(f"{where}: field 'orientation' is a space model's (\"dimension\": 3); a planar "
                                 "element bends in the x-y plane")
        return
    if v is None:
        raise ModelFileError(f"{where}: missing field 'orientation' (a vector in the element's local x-z plane, "
                             "OpenSees' vecxz, e.g. [0, 0, 1] for a beam, [1, 0, 0] for a column)")
    if not (isinstance(v, tuple) and len(v) == 3 and all(is_number(c) for c in v)):
        raise ModelFileError(f"{where}: field 'orientation' must be 3 finite numbers [x, y, z], got {shown(v)}")
    norm = math.sqrt(sum(c * c for c in v))
    if norm == 0.0:
        raise ModelFileError(f"{where}: field 'orientation' is the zero vector")
    cross = [axis[1] * v[2] - axis[2] * v[1], axis[2] * v[0] - axis[0] * v[2], axis[0] * v[1] - axis[1] * v[0]]
    if math.sqrt(sum(c * c for c in cross)) <= 1e-6 * norm:
        raise ModelFileError(f"{where}: field 'orientation' {list(v)} is parallel to the element (nodes "
                             f"{e.node_i} -> {e.node_j}), so it fixes no local y axis: choose a vector "
                             "across the member")


def _check_dof(m: FrameModel, dof: Any, where: str) -> None:
    if not (isinstance(dof, tuple) and len(dof) == 2):
        raise ModelFileError(f"{where}: a DOF is [node id, direction], got {shown(dof)}")
    try:
        known = dof[0] in m._node_pos  # a dict: linear time over many measured DOFs
    except TypeError:  # an unhashable node id read from a file
        known = False
    if not known:
        raise ModelFileError(f"{where}: unknown node {dof[0]!r}")
    if dof[1] not in m.layout.names:
        raise ModelFileError(f"{where}: unknown direction {dof[1]!r}; use one of {m.layout.names}")


def _validate_nodal(m: FrameModel, base: FrameModel | None = None) -> None:
    """Masses, springs, supports, measured DOFs and the excitation. `base`: a valid model with
    the same nodes and layout (`validate`'s kept case): a table `m` shares with it (the same
    tuple) holds what it held there, so it is not checked again."""
    src, idset = m.source, m._node_pos  # a dict of the node ids, built once per model

    def fresh(name: str) -> bool:
        return base is None or getattr(base, name) is not getattr(m, name)

    for lm in (m.masses if fresh("masses") else ()):
        if lm.node not in idset:
            raise ModelFileError(f"{src}: mass at unknown node {lm.node}")
        _positive(lm.mass_kg, f"{src}: mass at node {lm.node} 'mass_kg'", allow_zero=True, field="mass_kg")
        _positive(lm.inertia_kg_m2, f"{src}: mass at node {lm.node} 'inertia_kg_m2'", allow_zero=True, field="inertia_kg_m2")
    for s in (m.springs if fresh("springs") else ()):
        _check_dof(m, s.dof_a, f"{src}: spring {s.id}")
        if s.dof_b is not None:
            _check_dof(m, s.dof_b, f"{src}: spring {s.id}")
            if tuple(s.dof_b) == tuple(s.dof_a):
                raise ModelFileError(f"{src}: spring {s.id} joins DOF {list(s.dof_a)} to itself: it does nothing; "
                                     "a spring to ground lists one DOF")
        _positive(s.stiffness, f"{src}: spring {s.id} 'stiffness'", allow_zero=True, field="stiffness")
    for sup in (m.supports if fresh("supports") else ()):
        if sup.node not in idset:
            raise ModelFileError(f"{src}: support at unknown node {sup.node}")
        for d in sup.directions:
            if d not in m.layout.names:
                raise ModelFileError(f"{src}: support at node {sup.node}: unknown direction {d!r}; use one of "
                                     f"{m.layout.names}")
    if fresh("measured_dofs"):
        for i, dof in enumerate(m.measured_dofs):
            _check_dof(m, dof, f"{src}: measured_dofs[{i}]")
        if len(set(m.measured_dofs)) != len(m.measured_dofs):
            raise ModelFileError(f"{src}: 'measured_dofs' lists a DOF twice")
    if m.excitation is not None:
        _check_dof(m, m.excitation, f"{src}: excitation")
