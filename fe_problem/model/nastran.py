"""Nastran bulk data in and out (docs/import.md), read and written with pyNastran.

`read_bdf(path, units="SI", mass="deck")` makes a `FrameModel` of a deck whose cards femu can
represent exactly (`CARDS`); any other card is refused with one line listing the card types
and their counts. A deck whose nodes all lie in z = 0 with z, rx and ry fixed at every node
(SPC, SPC1 or GRID PS) becomes a planar model; any other a space model. `write_bdf(model,
path)` writes a model as a deck; `write_like(model, source, out)` writes the deck `source`
again with the model's material, property, CONM2 and CELAS values, every other card as it was.

A deck has no units: `units` names the consistent system it is written in (`UNITS`), and the
model is in SI. Nastran's mass is lumped unless PARAM COUPMASS > 0 (`mass="deck"`); PARAM
WTMASS multiplies every mass. An imported model's `meta["import"]` records the source path,
the units, the mass convention and what each model name stands for (`source_of(model)`).
"""

from __future__ import annotations

import contextlib
import io
import math
import re
from pathlib import Path

import numpy as np

from ..dofs import PLANAR_FRAME, SPACE_FRAME
from ..units import UNITS, Units
from .types import Element, FrameModel, LumpedMass, Material, Node, Section, Spring, Support
from .validate import ModelFileError


class NastranFileError(ModelFileError):
    """A deck femu cannot read or represent; the message names the file, the line and the card."""


#: The bulk-data cards read (with the deck's executive and case control, which are ignored
#: save SPC = n); PARAM other than WTMASS and COUPMASS and the eigenvalue requests are ignored.
CARDS = frozenset({"GRID", "CORD2R", "CORD1R", "CBAR", "CBEAM", "PBAR", "PBARL", "PBEAM", "CROD", "PROD", "CONROD",
                   "CELAS1", "CELAS2", "PELAS", "CONM2", "CMASS1", "CMASS2", "PMASS", "MAT1", "SPC", "SPC1",
                   "SPCADD", "PARAM", "EIGRL", "EIGR", "ENDDATA"})

_DIRS = ("x", "y", "z", "rx", "ry", "rz")
#: PBARL shapes whose torsion constant pyNastran computes exactly (circular: the polar moment).
_PBARL_TORSION = ("ROD", "TUBE", "TUBE2")
_TOL = 1e-9


#: How to install pyNastran (its 1.4.1 release pins numpy<2 but runs on numpy 2: without its pins).
PYNASTRAN_INSTALL = "pip install 'femu-bench[import]' && pip install --no-deps 'pyNastran==1.4.1'"


def _pynastran():
    """pyNastran's BDF class, imported when needed (the 'import' extra)."""
    try:
        import numpy
        shim = not hasattr(numpy, "in1d")  # pyNastran 1.4 binds numpy.in1d, gone in numpy 2.4
        if shim:
            numpy.in1d = lambda a, b, **kw: numpy.isin(numpy.ravel(a), b, **kw)
        try:
            from pyNastran.bdf.bdf import BDF
        finally:
            if shim:
                del numpy.in1d
    except ImportError:
        raise NastranFileError(f"reading or writing a Nastran deck needs the 'import' extra: {PYNASTRAN_INSTALL}") from None
    return BDF


def _new_bdf():
    """An empty pyNastran BDF (MSC dialect) that logs nothing below critical."""
    bdf = _pynastran()
    from cpylog import SimpleLogger  # pyNastran's own dependency: there when it imported
    return bdf(log=SimpleLogger(level="critical"), mode="msc")


# -- where a card is in the file ------------------------------------------------------------
def _fields(line: str) -> tuple[str, str]:
    """The first two fields of a bulk-data line (small, large or free field), upper case."""
    if "," in line[:16]:
        parts = line.split(",")
        return parts[0].strip().upper().rstrip("*"), (parts[1].strip() if len(parts) > 1 else "")
    name = line[:8].strip().upper()
    if name.endswith("*"):
        return name.rstrip("*"), line[8:24].strip()
    return name, line[8:16].strip()


def _lines(path: Path, card: str, card_id=None) -> list[int]:
    """The 1-based lines of `path` where a `card` (with that id, if given) starts."""
    out = []
    try:
        text = path.read_text(errors="replace").splitlines()
    except OSError:
        return out
    for k, line in enumerate(text, 1):
        name, first = _fields(line)
        if name == card and (card_id is None or first == str(card_id)):
            out.append(k)
    return out


def _where(path: Path, card: str, card_id=None, last: bool = False) -> str:
    """"FILE: line N: CARD ID" (the line left out when it cannot be found)."""
    lines = _lines(path, card, card_id)
    at = f" line {lines[-1 if last else 0]}:" if lines else ""
    return f"{path}:{at} {card}" + ("" if card_id is None else f" {card_id}")


def _fail(path: Path, card: str, card_id, problem: str, last: bool = False):
    raise NastranFileError(f"{_where(path, card, card_id, last)}: {problem}")


# -- reading ---------------------------------------------------------------------------------
def _read(path: Path):
    """The deck read by pyNastran, not cross-referenced; pyNastran's errors as one line."""
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    bdf = _new_bdf()
    try:
        with contextlib.redirect_stdout(io.StringIO()):  # pyNastran prints some of its errors
            bdf.read_bdf(str(path), xref=False, punch=not _has_begin_bulk(path))
    except Exception as exc:  # pyNastran raises SyntaxError, AssertionError, RuntimeError ...
        text = str(exc)
        m = re.search(r"card=\['(\w+)',\s*'(\w+)'", text)
        if m:
            _fail(path, m.group(1).upper(), m.group(2), text.splitlines()[0])
        m = re.search(r"new_\w+=\s*\n\s*(\w+)\*?\s+(\d+)", text)
        if m:
            _fail(path, m.group(1).upper(), m.group(2), f"a second {m.group(1).upper()} with id {m.group(2)}",
                  last=True)
        raise NastranFileError(f"{path}: pyNastran cannot read it: {' '.join(text.split())[:300]}") from None
    return bdf


def _has_begin_bulk(path: Path) -> bool:
    try:
        return any(line.upper().startswith("BEGIN") for line in path.read_text(errors="replace").splitlines())
    except OSError:
        return False


def _scanned(path: Path) -> dict[str, int]:
    """{card name: count} of the bulk data of `path` itself (before pyNastran parses the cards:
    a card femu does not read is refused as such, not by what pyNastran makes of it)."""
    try:
        lines = path.read_text(errors="replace").splitlines()
    except OSError:
        return {}
    begin = [k for k, line in enumerate(lines) if line.upper().startswith("BEGIN")]
    counts: dict[str, int] = {}
    for line in lines[begin[0] + 1 if begin else 0:]:
        if not line.strip() or line[0] in "$+* \t,":
            continue
        name = _fields(line)[0]
        if name == "ENDDATA":
            break
        if name.isidentifier():
            counts[name] = counts.get(name, 0) + 1
    return counts


def _refuse_unknown(path: Path, bdf=None) -> None:
    """One line listing the card types femu does not read and their counts, if any."""
    counts = {k: v for k, v in _scanned(path).items() if k not in CARDS and k != "INCLUDE"}
    if bdf is None:
        if counts:
            _refuse_counts(path, counts)
        return
    counts.update({k: v for k, v in bdf.card_count.items() if k not in CARDS})
    for card in getattr(bdf, "reject_cards", None) or []:  # cards pyNastran does not know (an INCLUDEd file's)
        if isinstance(card, list) and card:
            name = str(card[0]).split(",")[0].strip().upper().rstrip("*")
            if name not in CARDS:
                counts[name] = counts.get(name, 0) + 1
    _refuse_counts(path, counts)


def _refuse_counts(path: Path, counts: dict) -> None:
    if counts:
        listed = ", ".join(f"{k} x{v}" for k, v in sorted(counts.items()))
        raise NastranFileError(f"{path}: cards femu's frames cannot represent: {listed}; give such a structure as "
                               "matrices (a matrix model, docs/import.md)")


def _param(bdf, key: str, default: float) -> float:
    p = bdf.params.get(key)
    return float(p.values[0]) if p is not None and p.values and p.values[0] is not None else default


def _check_refs(path: Path, bdf) -> None:
    """Every reference resolved, with the file, the line and the card of the first that is not."""
    for nid, g in bdf.nodes.items():
        for cid, what in ((g.cp, "CP"), (g.cd, "CD")):
            if cid and cid not in bdf.coords:
                _fail(path, "GRID", nid, f"field {what}: coordinate system {cid} is not defined in the deck")
        if g.cd:
            _fail(path, "GRID", nid, f"field CD = {g.cd}: displacements in a local coordinate system are not read "
                                     "(femu's DOFs are in the basic system)")
    for cid, c in bdf.coords.items():
        if cid and c.type not in ("CORD2R", "CORD1R"):
            _fail(path, c.type, cid, "only rectangular coordinate systems (CORD2R, CORD1R) are read")
        ref = getattr(c, "rid", 0)
        if ref and ref not in bdf.coords:
            _fail(path, c.type, cid, f"field RID: coordinate system {ref} is not defined in the deck")
    for eid, e in {**bdf.elements, **bdf.masses}.items():
        for nid in [n for n in e.node_ids if n]:
            if nid not in bdf.nodes:
                _fail(path, e.type, eid, f"GRID {nid} is not defined in the deck")
        pid = getattr(e, "pid", None)
        if e.type in ("CBAR", "CBEAM", "CROD", "CELAS1", "CMASS1") and pid not in bdf.properties \
                and pid not in bdf.properties_mass:
            _fail(path, e.type, eid, f"field PID: property {pid} is not defined in the deck")
        g0 = getattr(e, "g0", None)
        if g0 and g0 not in bdf.nodes:
            _fail(path, e.type, eid, f"field G0: GRID {g0} is not defined in the deck")
    for pid, p in bdf.properties.items():
        mid = getattr(p, "mid", None)
        if p.type in ("PBAR", "PBARL", "PBEAM", "PROD") and mid not in bdf.materials:
            _fail(path, p.type, pid, f"field MID: MAT1 {mid} is not defined in the deck")
    for e in bdf.elements.values():
        if e.type == "CONROD" and e.mid not in bdf.materials:
            _fail(path, "CONROD", e.eid, f"field MID: MAT1 {e.mid} is not defined in the deck")


def _spc_set(path: Path, bdf) -> int | None:
    """The SPC set in force: the case control's SPC = n, else the deck's only set (None: none)."""
    sets = sorted(set(bdf.spcs) | set(bdf.spcadds))
    cc = bdf.case_control_deck
    if cc is not None:
        for sub in [cc.subcases.get(0)] + [s for k, s in sorted(cc.subcases.items()) if k]:
            try:
                sid = int(sub.get_parameter("SPC")[0])
            except (KeyError, AttributeError, TypeError, ValueError):
                continue
            if sid not in sets:
                raise NastranFileError(f"{path}: case control SPC = {sid}: no SPC, SPC1 or SPCADD with that set id")
            return sid
    if len(sets) > 1:
        raise NastranFileError(f"{path}: SPC sets {sets} and no case control SPC = n choosing one")
    return sets[0] if sets else None


def _constraints(path: Path, bdf, sid: int | None) -> dict[int, set[int]]:
    """{GRID id: fixed components 1-6} from GRID PS and the SPC set `sid` (SPCADD expanded)."""
    fixed: dict[int, set[int]] = {}

    def add(nid, comps, card, cid):
        if nid not in bdf.nodes:
            _fail(path, card, cid, f"GRID {nid} is not defined in the deck")
        fixed.setdefault(nid, set()).update(int(c) for c in str(comps or "") if c in "123456")

    for nid, g in bdf.nodes.items():
        if g.ps:
            add(nid, g.ps, "GRID", nid)
    seen = set()

    def expand(s):
        if s in seen:
            return
        seen.add(s)
        for add_card in bdf.spcadds.get(s, []):
            for sub in add_card.sets:
                expand(int(sub))
        for card in bdf.spcs.get(s, []):
            if card.type == "SPC":
                for nid, comps, value in zip(card.nodes, card.components, card.enforced):
                    if value:
                        _fail(path, "SPC", s, f"an enforced displacement ({value:g}) is not a support")
                    add(nid, comps, "SPC", s)
            elif card.type == "SPC1":
                for nid in card.nodes:
                    add(nid, card.components, "SPC1", s)
            else:
                _fail(path, card.type, s, "only SPC, SPC1 and SPCADD constraints are read")
    if sid is not None:
        expand(sid)
    return fixed


class _Reader:
    """One deck read into a model (the state of one import)."""

    def __init__(self, path: Path, bdf, units: Units, mass: str):
        self.path, self.bdf, self.units = path, bdf, units
        self.wtmass = _param(bdf, "WTMASS", 1.0)
        deck = "consistent" if _param(bdf, "COUPMASS", -1.0) > 0 else "lumped"
        self.mass = deck if mass == "deck" else mass
        self.pos = {nid: np.asarray(g.get_position(), dtype=float) * units.length for nid, g in bdf.nodes.items()}
        self.sid = _spc_set(path, bdf)
        self.fixed = _constraints(path, bdf, self.sid)
        planar = all(abs(p[2]) <= _TOL * max(1.0, np.abs(p).max()) for p in self.pos.values()) and \
            all({3, 4, 5} <= self.fixed.get(nid, set()) for nid in bdf.nodes)
        self.layout = PLANAR_FRAME if planar else SPACE_FRAME
        self.materials: dict[str, Material] = {}
        self.sections: dict[str, Section] = {}
        self.elements: list[Element] = []
        self.springs: list[Spring] = []
        self.nodal_mass: dict[int, np.ndarray] = {}
        self.mass_cards: dict[int, list] = {}
        self.names: dict[str, dict] = {"materials": {}, "sections": {}, "springs": {}}

    def fail(self, card, cid, problem):
        _fail(self.path, card, cid, problem)

    # -- materials and sections ---------------------------------------------------------
    def material(self, mid: int, card: str, cid) -> str:
        mat = self.bdf.materials[mid]
        if mat.type != "MAT1":
            self.fail(card, cid, f"MAT1 {mid} is a {mat.type}: only MAT1 is read")
        name = f"MAT1 {mid}"
        if name not in self.materials:
            u = self.units
            if not mat.rho:
                _fail(self.path, "MAT1", mid, "field RHO is 0: femu's beams carry their own mass (density > 0); "
                                              "give the material its density and the masses as CONM2")
            e, g, nu = mat.e, mat.g, mat.nu
            if not e:
                _fail(self.path, "MAT1", mid, "field E is blank or 0")
            nu = nu if nu is not None else e / (2.0 * g) - 1.0
            self.materials[name] = Material(e * u.scale("pressure"), mat.rho * self.wtmass * u.scale("density"),
                                            nu, (g or e / (2.0 * (1.0 + nu))) * u.scale("pressure"))
            self.names["materials"][name] = {"card": "MAT1", "id": mid}
        return name

    def section(self, prop, eid, etype, axes) -> tuple[str, str]:
        """(section name, formulation) of a CBAR/CBEAM's property; `axes` its local axes."""
        p, u = prop, self.units
        where = (p.type, p.pid)
        if p.type == "PBAR":
            area, i1, i2, i12, j, nsm, k = p.A, p.i1, p.i2, p.i12, p.j, p.nsm, (p.k1, p.k2)
        elif p.type == "PBARL":
            try:
                area, i1, i2, i12, j = p.Area(), p.I11(), p.I22(), p.I12(), p.J()
            except Exception as exc:
                self.fail(*where, f"pyNastran computes no properties of a {p.beam_type} section ({exc})")
            nsm, k = p.nsm, (None, None)
            if self.layout is SPACE_FRAME and p.beam_type not in _PBARL_TORSION:
                self.fail(*where, f"a {p.beam_type} section in a space frame: pyNastran's torsion constant is exact "
                                  f"only for {', '.join(_PBARL_TORSION)} (J = I1 + I2); give a PBAR with J")
        elif p.type == "PBEAM":
            stations = {(a, b, c, d, e) for a, b, c, d, e in zip(p.A, p.i1, p.i2, p.i12, p.j)}
            if len(stations) > 1:
                self.fail(*where, "a tapered PBEAM (stations of different sections) is not read: "
                                  "femu's beams have a constant section")
            area, i1, i2, i12, j = stations.pop()
            nsm = max(abs(x) for x in p.nsm)
            if any(abs(getattr(p, k) or 0.0) > 0 for k in ("cwa", "cwb", "m1a", "m2a", "m1b", "m2b", "n1a", "n2a",
                                                            "n1b", "n2b", "s1", "s2", "nsia", "nsib")):
                self.fail(*where, "warping, offsets of the neutral or mass axis are not read")
            k = (p.k1, p.k2)
        else:
            self.fail(etype, eid, f"property {p.pid} is a {p.type}: a {etype} takes a PBAR, PBARL or PBEAM")
        area, i1, i2, i12, j = (float(x) for x in (area, i1, i2, i12, j or 0.0))
        if i12:
            self.fail(*where, f"I12 = {i12:g}: femu's sections have principal axes along the element's y and z")
        if nsm:
            self.fail(*where, f"NSM = {nsm:g}: non-structural mass is not read")
        shear = [x for x in k if x is not None and 0.0 < x < 1e8]
        if shear and (len(shear) < 2 or not math.isclose(shear[0], shear[1], rel_tol=1e-12)):
            self.fail(*where, f"K1 = {k[0]}, K2 = {k[1]}: femu's Timoshenko beams take one shear factor for "
                              "both planes")
        kappa = shear[0] if shear else 5.0 / 6.0
        formulation = ("timoshenko" if shear else "euler-bernoulli") + ("-lumped" if self.mass == "lumped" else "")
        L4, L2 = u.scale("inertia"), u.scale("area")
        if self.layout is PLANAR_FRAME:
            z = np.asarray(axes[2])
            if abs(abs(z[2]) - 1.0) <= 1e-9:
                which, inertia = "I1", i1
            elif abs(abs(axes[1][2]) - 1.0) <= 1e-9:
                which, inertia = "I2", i2
            elif math.isclose(i1, i2, rel_tol=1e-12):
                which, inertia = "I1", i1
            else:
                self.fail(etype, eid, "in a planar deck the element's plane 1 or plane 2 must be the x-y plane "
                                      "(orientation vector in or normal to it)")
            name = f"{p.type} {p.pid}" + ("" if which == "I1" else " I2")
            sec = Section(area * L2, inertia_m4=inertia * L4, shear_coefficient=kappa)
        else:
            if not j:
                self.fail(*where, "J = 0: a space frame's beams need a torsion constant")
            name, which = f"{p.type} {p.pid}", "I1"
            sec = Section(area * L2, shear_coefficient=kappa, iy_m4=i2 * L4, iz_m4=i1 * L4, j_m4=j * L4)
        if min(area, inertia if self.layout is PLANAR_FRAME else min(i1, i2)) <= 0:
            self.fail(*where, "A, I1 and I2 must be > 0")
        self.sections[name] = sec
        self.names["sections"][name] = {"card": p.type, "id": p.pid, "inertia": which}
        return name, formulation

    # -- elements ---------------------------------------------------------------------------
    def beam(self, e) -> None:
        if any(np.any(np.asarray(w, dtype=float)) for w in (e.wa, e.wb)):
            self.fail(e.type, e.eid, "offsets WA/WB are not read")
        if e.type == "CBEAM" and (getattr(e, "sa", 0) or getattr(e, "sb", 0)):
            self.fail(e.type, e.eid, "scalar points SA/SB (warping) are not read")
        if e.offt not in ("GGG", None, ""):
            self.fail(e.type, e.eid, f"OFFT = {e.offt}: only GGG is read")
        ga, gb = e.node_ids[:2]
        xa, xb = self.pos[ga], self.pos[gb]
        ex = (xb - xa) / np.linalg.norm(xb - xa)
        v = (self.pos[e.g0] - xa) if e.g0 else np.asarray(e.x, dtype=float)
        ez = np.cross(ex, v)
        if np.linalg.norm(ez) <= 1e-12 * np.linalg.norm(v):
            self.fail(e.type, e.eid, "the orientation vector is parallel to the element")
        ez /= np.linalg.norm(ez)
        ey = np.cross(ez, ex)
        prop = self.bdf.properties[e.pid]
        section, formulation = self.section(prop, e.eid, e.type, (ex, ey, ez))
        mat = self.material(prop.mid, prop.type, prop.pid)
        releases = []
        for flags in (e.pa, e.pb):
            digits = {int(c) for c in str(flags or "") if c.isdigit() and c != "0"}
            if digits & {1, 2, 3}:
                self.fail(e.type, e.eid, f"pin flags {flags}: femu releases rotations only (4, 5, 6)")
            releases.append(digits)
        if self.layout is PLANAR_FRAME:
            bend = 6 if self.names["sections"][section]["inertia"] == "I1" else 5
            for d in releases:
                if d - {bend}:
                    self.fail(e.type, e.eid, f"pin flags {sorted(d)}: in a planar deck only the in-plane "
                                             f"rotation ({bend}) is released")
            self.elements.append(Element(e.eid, ga, gb, section, mat, formulation,
                                         release_i=0.0 if releases[0] else None,
                                         release_j=0.0 if releases[1] else None))
        else:
            rel = [tuple((("rx", "ry", "rz")[c - 4], 0.0) for c in sorted(d)) for d in releases]
            self.elements.append(Element(e.eid, ga, gb, section, mat, formulation, orientation=tuple(map(float, ez)),
                                         releases_i=rel[0], releases_j=rel[1]))

    def rod(self, e) -> None:
        """A CROD or CONROD along a global axis: an axial spring EA/L and a torsion spring GJ/L
        between its nodes, its mass rho A L / 2 lumped at each (exact; any other rod is refused)."""
        if e.type == "CROD":
            p = self.bdf.properties[e.pid]
            if p.type != "PROD":
                self.fail("CROD", e.eid, f"property {e.pid} is a {p.type}: a CROD takes a PROD")
            mid, area, j, nsm = p.mid, p.A, p.j, p.nsm
        else:
            mid, area, j, nsm = e.mid, e.A, e.j, e.nsm
        if nsm:
            self.fail(e.type, e.eid, f"NSM = {nsm:g}: non-structural mass is not read")
        if self.mass == "consistent":
            self.fail(e.type, e.eid, "a rod's coupled mass (COUPMASS) has no exact femu counterpart: femu has no "
                                     "truss element (rods are read as springs with lumped mass)")
        ga, gb = e.node_ids[:2]
        d = self.pos[gb] - self.pos[ga]
        length = np.linalg.norm(d)
        axis = [k for k in range(3) if abs(d[k]) > _TOL * length]
        if len(axis) != 1:
            self.fail(e.type, e.eid, "a rod along no global axis: femu has no truss element (rods along x, y or z "
                                     "are read as springs)")
        name = self.material(mid, e.type, e.eid)
        mat = self.materials[name]
        area_m2 = area * self.units.scale("area")
        a = axis[0]
        dirs = [(_DIRS[a], mat.youngs_modulus_pa * area_m2 / length)]
        if j:
            dirs.append((_DIRS[a + 3], mat.shear_modulus * j * self.units.scale("inertia") / length))
        for k, (direction, stiffness) in enumerate(dirs):
            if direction in self.layout.names:
                sid = e.eid if k == 0 else -e.eid
                self.springs.append(Spring(sid, (ga, direction), (gb, direction), stiffness))
                self.names["springs"][str(sid)] = {"card": e.type, "id": e.eid}
        m = mat.density_kg_m3 * area_m2 * length / 2.0
        for nid in (ga, gb):
            self.add_mass(nid, [m, m, m, 0, 0, 0], None)

    def spring(self, e) -> None:
        if e.type == "CELAS1":
            p = self.bdf.properties[e.pid]
            if p.type != "PELAS":
                self.fail("CELAS1", e.eid, f"property {e.pid} is a {p.type}: a CELAS1 takes a PELAS")
            k = p.k
        else:
            k = e.k
        ends = []
        for nid, c in zip(e.node_ids, (e.c1, e.c2)):
            if not nid:
                continue
            if not c or int(c) not in range(1, 7):
                self.fail(e.type, e.eid, f"component {c!r} of GRID {nid}: expected 1-6")
            d = _DIRS[int(c) - 1]
            if d in self.layout.names:
                ends.append((nid, d))
        if not ends:
            return  # both ends on DOFs a planar deck fixes: it does nothing
        rot = ends[0][1].startswith("r")
        if len(ends) == 2 and ends[0][1].startswith("r") != ends[1][1].startswith("r"):
            self.fail(e.type, e.eid, "a spring between a translation and a rotation is not read")
        stiffness = k * self.units.scale("rotational_spring" if rot else "spring")
        self.springs.append(Spring(e.eid, ends[0], ends[1] if len(ends) == 2 else None, stiffness))
        self.names["springs"][str(e.eid)] = {"card": e.type, "id": e.eid, "pid": getattr(e, "pid", None)}

    def add_mass(self, nid, values, card) -> None:
        self.nodal_mass.setdefault(nid, np.zeros(6))
        self.nodal_mass[nid] += np.asarray(values, dtype=float)
        self.mass_cards.setdefault(nid, []).append(card)

    def conm2(self, e) -> None:
        if np.any(np.asarray(e.X, dtype=float)):
            self.fail("CONM2", e.eid, "an offset X1-X3 is not read: femu's masses sit at their node")
        i = np.asarray(e.I, dtype=float)  # I11, I21, I22, I31, I32, I33
        u, w = self.units, self.wtmass
        if self.layout is SPACE_FRAME:
            if np.any(i[[1, 3, 4]]) or not (i[0] == i[2] == i[5]):
                self.fail("CONM2", e.eid, "femu's masses have one rotary inertia about every axis: I11 = I22 = I33 "
                                          "and I21 = I31 = I32 = 0")
            if e.cid not in (0, -1) and i[0]:
                self.fail("CONM2", e.eid, f"CID = {e.cid}: only the basic system is read")
        m = e.mass * w * u.scale("mass")
        r = w * u.scale("rotary_inertia")
        self.add_mass(e.nid, [m, m, m, i[0] * r, i[2] * r, i[5] * r], ("CONM2", e.eid))

    def cmass(self, e) -> None:
        nids = [n for n in e.node_ids if n]
        if len(nids) != 1:
            self.fail(e.type, e.eid, "a scalar mass between two DOFs is not read (to ground only)")
        value = e.mass if e.type == "CMASS2" else self.bdf.properties_mass[e.pid].mass
        c = int(e.c1 or e.c2)
        values = np.zeros(6)
        values[c - 1] = value * self.wtmass * self.units.scale("mass" if c <= 3 else "rotary_inertia")
        self.add_mass(nids[0], values, (e.type, e.eid))

    def masses(self) -> tuple[LumpedMass, ...]:
        """One LumpedMass per node: equal mass in its free translations, equal inertia in its
        free rotations (what femu's lumped mass is), else refused naming a card."""
        out = []
        layout = self.layout
        for nid in sorted(self.nodal_mass):
            v = self.nodal_mass[nid]
            cards = [c for c in self.mass_cards[nid] if c]
            trans = [v[_DIRS.index(d)] for d in layout.translations]
            rots = [v[_DIRS.index(d)] for d in layout.rotations]
            if not (np.allclose(trans, trans[0], rtol=1e-12, atol=0) and np.allclose(rots, rots[0], rtol=1e-12, atol=0)):
                card = cards[0] if cards else ("GRID", nid)
                self.fail(*card, f"the masses at GRID {nid} differ between directions ({', '.join(f'{x:g}' for x in v)}): "
                                 "femu's lumped mass is the same in every translation and every rotation")
            out.append(LumpedMass(nid, float(trans[0]), float(rots[0])))
        return tuple(out)

    def model(self, name: str, units_name: str) -> FrameModel:
        bdf = self.bdf
        for eid in sorted(bdf.elements):
            e = bdf.elements[eid]
            if e.type in ("CBAR", "CBEAM"):
                self.beam(e)
            elif e.type in ("CROD", "CONROD"):
                self.rod(e)
            elif e.type in ("CELAS1", "CELAS2"):
                self.spring(e)
        for eid in sorted(bdf.masses):
            e = bdf.masses[eid]
            self.conm2(e) if e.type == "CONM2" else self.cmass(e)
        if not self.elements:
            raise NastranFileError(f"{self.path}: no CBAR or CBEAM: femu's models are frames")
        layout = self.layout
        nodes = tuple(Node(nid, *(self.pos[nid][:2] if layout is PLANAR_FRAME else self.pos[nid]))
                      for nid in sorted(bdf.nodes))
        supports = tuple(Support(nid, tuple(_DIRS[c - 1] for c in sorted(comps) if _DIRS[c - 1] in layout.names))
                         for nid, comps in sorted(self.fixed.items())
                         if any(_DIRS[c - 1] in layout.names for c in comps))
        masses = self.masses()
        meta = {"import": {
            "format": "nastran", "path": str(self.path.resolve()), "units": units_name, "mass": self.mass,
            "wtmass": self.wtmass, "spc_set": self.sid, "names": self.names,
            "masses": {str(nid): [list(c) for c in cards] for nid, cards in self.mass_cards.items()
                       if all(cards)}}}
        return FrameModel(name=name, nodes=nodes, materials=self.materials, sections=self.sections,
                          elements=tuple(self.elements), masses=masses, springs=tuple(self.springs),
                          supports=supports, description=f"imported from {self.path.name} ({units_name}, "
                          f"{self.mass} mass)", source=str(self.path), layout=layout, meta=meta)


def read_bdf(path: str | Path, units: str = "SI", mass: str = "deck", name: str | None = None) -> FrameModel:
    """The model of a Nastran deck (bulk data, with or without executive and case control).

    `units`: the deck's unit system (`UNITS`); the model is in SI. `mass`: "deck" (lumped
    unless PARAM COUPMASS > 0), "lumped" or "consistent". NastranFileError (a ValueError)
    naming the file, the line and the card for anything it cannot represent exactly."""
    path = Path(path)
    if units not in UNITS:
        raise NastranFileError(f"units {units!r}: expected one of {', '.join(UNITS)}")
    if mass not in ("deck", "lumped", "consistent"):
        raise NastranFileError(f"mass {mass!r}: expected deck, lumped or consistent")
    _refuse_unknown(path)
    bdf = _read(path)
    _refuse_unknown(path, bdf)
    _check_refs(path, bdf)
    try:
        bdf.cross_reference()
    except Exception as exc:
        raise NastranFileError(f"{path}: {' '.join(str(exc).split())[:300]}") from None
    return _Reader(path, bdf, UNITS[units], mass).model(name or path.stem, units)


def source_of(model: FrameModel) -> str | None:
    """The path of the deck an imported model came from (``meta["import"]["path"]``), or None."""
    rec = model.meta.get("import", {})
    return rec.get("path") if rec.get("format") == "nastran" else None


# -- writing ---------------------------------------------------------------------------------
def _mass_convention(model: FrameModel) -> str:
    lumped = {e.formulation.endswith("-lumped") for e in model.elements}
    if len(lumped) > 1:
        raise NastranFileError(f"{model.source}: lumped and consistent mass mixed: a deck has one convention "
                               "(PARAM COUPMASS)")
    return "lumped" if lumped.pop() else "consistent"


def _check_writable(model: FrameModel) -> None:
    for e in model.elements:
        if e.crack_position is not None or e.weak_zone is not None:
            raise NastranFileError(f"{model.source}: element {e.id}: a crack or weak zone has no Nastran card here")
        for end in model.end_releases(e):
            if any(k != 0.0 for k in end.values()):
                raise NastranFileError(f"{model.source}: element {e.id}: a semi-rigid end (release stiffness > 0) "
                                       "has no CBAR pin flag")


def _bulk(model: FrameModel, units: Units):
    """A pyNastran BDF holding `model`'s bulk data in `units`."""
    _check_writable(model)
    bdf = _new_bdf()
    planar = model.layout is PLANAR_FRAME
    if _mass_convention(model) == "consistent":
        bdf.add_param("COUPMASS", [1])
    bdf.add_eigrl(1, nd=20)
    L = units.length
    for n in model.nodes:
        bdf.add_grid(n.id, [n.x / L, n.y / L, n.z / L], ps="345" if planar else "")
    mids: dict[tuple, int] = {}
    pids: dict[tuple, int] = {}
    for e in model.elements:
        mat = model.materials[e.material]
        modulus = model.element_modulus_pa(e.id)
        mkey = (e.material, modulus)
        if mkey not in mids:
            mids[mkey] = len(mids) + 1
            g = mat.shear_modulus * modulus / mat.youngs_modulus_pa
            bdf.add_mat1(mids[mkey], modulus / units.scale("pressure"), g / units.scale("pressure"),
                         mat.poisson_ratio, rho=mat.density_kg_m3 / units.scale("density"))
        sec = model.sections[e.section]
        shear = not e.formulation.startswith("euler-bernoulli")
        pkey = (e.section, mkey, shear)
        if pkey not in pids:
            pids[pkey] = len(pids) + 1
            k = sec.shear_coefficient if shear else 1e8
            A, I4 = units.scale("area"), units.scale("inertia")
            if planar:
                i1 = i2 = sec.inertia_m4 / I4
                j = 0.0
            else:
                i1, i2, j = sec.iz_m4 / I4, sec.iy_m4 / I4, sec.j_m4 / I4
            bdf.add_pbar(pids[pkey], mids[mkey], A=sec.area_m2 / A, i1=i1, i2=i2, j=j, k1=k, k2=k)
        ex, ey, _ = model.local_axes(e.id)
        v = np.cross([0.0, 0.0, 1.0], ex) if planar else ey
        pins = []
        for end in model.end_releases(e):
            pins.append(int("".join(str(4 + ("rx", "ry", "rz").index(r)) for r in sorted(end)) or 0))
        bdf.add_cbar(e.id, pids[pkey], [e.node_i, e.node_j], [float(c) for c in v], None, pa=pins[0], pb=pins[1])
    eid = max(model.element_ids) + 1
    for m in model.masses:
        i = m.inertia_kg_m2 / units.scale("rotary_inertia")
        bdf.add_conm2(eid, m.node, m.mass_kg / units.scale("mass"),
                      I=[0.0, 0.0, 0.0, 0.0, 0.0, i] if planar else [i, 0.0, i, 0.0, 0.0, i])
        eid += 1
    for s in model.springs:
        kind = "rotational_spring" if s.dof_a[1].startswith("r") else "spring"
        ends = [s.dof_a] + ([s.dof_b] if s.dof_b else [])
        nids = [d[0] for d in ends] + [0] * (2 - len(ends))
        comps = [_DIRS.index(d[1]) + 1 for d in ends] + [0] * (2 - len(ends))
        bdf.add_celas2(eid, s.stiffness / units.scale(kind), nids, comps[0], comps[1])
        eid += 1
    for s in model.supports:
        bdf.add_spc1(1, "".join(str(_DIRS.index(d) + 1) for d in s.directions), [s.node])
    return bdf


_EXECUTIVE = "SOL 103\nCEND\nTITLE = {title}\n{spc}METHOD = 1\nBEGIN BULK\n"


def write_bdf(model: FrameModel, path: str | Path, units: str = "SI") -> Path:
    """Write `model` as a Nastran deck (SOL 103, METHOD = 1, SPC = 1 if it has supports) in `units` (`UNITS`): GRID
    (PS 345 at every node of a planar model), MAT1 (one per material and modulus), PBAR, CBAR
    with its orientation vector and pin flags, CONM2, CELAS2, SPC1, PARAM COUPMASS 1 for
    consistent mass. A crack, a weak zone or a semi-rigid end is refused (no card for it)."""
    if units not in UNITS:
        raise NastranFileError(f"units {units!r}: expected one of {', '.join(UNITS)}")
    path = Path(path)
    bdf = _bulk(model, UNITS[units])
    buf = io.StringIO()
    # large-field double precision: every value to 16 significant digits, frequencies kept to 1e-10
    bdf.write_bdf(buf, size=16, is_double=True, enddata=True, close=False, write_header=False)
    spc = "SPC = 1\n" if model.supports else ""
    path.write_text(_EXECUTIVE.format(title=model.name[:60], spc=spc) + buf.getvalue())
    return path


def _same(a: float, b: float) -> bool:
    return a == b or abs(a - b) <= 1e-13 * max(abs(a), abs(b))


def _large_field(card) -> None:
    """Have `card` written in large fields (16 characters): pyNastran writes CELAS2 and PELAS in
    small fields whatever the deck's size, which keeps 7 significant digits of a changed K."""
    from pyNastran.bdf.field_writer_16 import print_card_16

    card.write_card = lambda size=8, is_double=False: card.comment + print_card_16(card.repr_fields())


def write_like(model: FrameModel, source: str | Path, out_path: str | Path) -> Path:
    """Write the deck `source` again as `out_path` with `model`'s values, every other card as
    it was: `model` is `read_bdf(source)` with changed values (an updated model; its
    ``meta["import"]`` gives the units, WTMASS and which card each name stands for).

    Written back: MAT1 E, G, RHO (a material whose elements now have different moduli is
    copied, one MAT1 and one property per modulus, and their CBAR/CBEAM point to the copies);
    PBAR A, I1, I2, J and PBEAM A, I1, I2, J (every station); CONM2 mass and inertias (a node's
    mass from one CONM2); CELAS2 K, PELAS K. A change with no card to hold it (a moved node, an
    added element, a changed PBARL, support or rod) is refused naming it."""
    source = Path(source)
    rec = model.meta.get("import", {})
    if rec.get("format") != "nastran":
        raise NastranFileError(f"{model.source}: the model was not imported from a Nastran deck (meta 'import')")
    units = UNITS[rec.get("units", "SI")]
    original = read_bdf(source, units=rec.get("units", "SI"), mass=rec.get("mass", "deck"))
    bdf = _read(source)
    names = rec.get("names", {})
    where = f"{model.source}: written like {source}"

    def refuse(what):
        raise NastranFileError(f"{where}: {what} has no card to hold the change; write the model with "
                               "`femu export --to bdf` without --like")

    if original.layout != model.layout or [(n.id, n.x, n.y, n.z) for n in original.nodes] != \
            [(n.id, n.x, n.y, n.z) for n in model.nodes]:
        refuse("the nodes differ from the deck's: a moved, added or removed node")
    if [(e.id, e.node_i, e.node_j, e.formulation, e.orientation, model.end_releases(e)) for e in model.elements] != \
            [(e.id, e.node_i, e.node_j, e.formulation, e.orientation, original.end_releases(e))
             for e in original.elements]:
        refuse("the elements (ids, nodes, formulation, orientation, releases) differ from the deck's")
    if any(e.crack_position is not None or e.weak_zone is not None for e in model.elements):
        refuse("a crack or weak zone")
    if set(map(tuple, [(s.node, s.directions) for s in model.supports])) != \
            set(map(tuple, [(s.node, s.directions) for s in original.supports])):
        refuse("the supports")
    P, D = units.scale("pressure"), units.scale("density") * rec.get("wtmass", 1.0)
    # materials: E, G, RHO; an element's own modulus moves its MAT1 (all its elements alike) or a copy
    for name, mat in model.materials.items():
        ref = names.get("materials", {}).get(name)
        old = original.materials.get(name)
        if ref is None or old is None:
            refuse(f"material {name!r}")
        if old != mat:
            card = bdf.materials[ref["id"]]
            card.e, card.g = mat.youngs_modulus_pa / P, mat.shear_modulus / P
            card.nu, card.rho = mat.poisson_ratio, mat.density_kg_m3 / D
    _write_moduli(model, bdf, names, P, refuse)
    A_, I4 = units.scale("area"), units.scale("inertia")
    for name, sec in model.sections.items():
        ref, old = names.get("sections", {}).get(name), original.sections.get(name)
        if ref is None or old is None:
            refuse(f"section {name!r}")
        if old == sec:
            continue
        card = bdf.properties[ref["id"]]
        if card.type not in ("PBAR", "PBEAM"):
            refuse(f"section {name!r} ({card.type} {card.pid}: its dimensions, not its properties)")
        if model.layout is PLANAR_FRAME:
            values = {"A": sec.area_m2 / A_, ("i1" if ref["inertia"] == "I1" else "i2"): sec.inertia_m4 / I4}
        else:
            values = {"A": sec.area_m2 / A_, "i1": sec.iz_m4 / I4, "i2": sec.iy_m4 / I4, "j": sec.j_m4 / I4}
        if sec.shear_coefficient != old.shear_coefficient:
            refuse(f"section {name!r}'s shear coefficient")
        for key, value in values.items():
            if card.type == "PBEAM":
                setattr(card, key, [value] * len(getattr(card, key)))
            else:
                setattr(card, key, value)
    _write_masses(model, original, bdf, rec, units, refuse)
    old_springs = {s.id: s for s in original.springs}
    for s in model.springs:
        o = old_springs.get(s.id)
        if o is None or (o.dof_a, o.dof_b) != (s.dof_a, s.dof_b):
            refuse(f"spring {s.id} (added or moved)")
        if _same(o.stiffness, s.stiffness):
            continue
        ref = names["springs"][str(s.id)]
        value = s.stiffness / units.scale("rotational_spring" if s.dof_a[1].startswith("r") else "spring")
        if ref["card"] == "CELAS2":
            bdf.elements[ref["id"]].k = value
            _large_field(bdf.elements[ref["id"]])
        elif ref["card"] == "CELAS1":
            users = [r["id"] for r in names["springs"].values() if r.get("pid") == ref["pid"]]
            if len({model_spring.stiffness for model_spring in model.springs if model_spring.id in users}) > 1:
                refuse(f"spring {s.id} (its PELAS {ref['pid']} is shared by springs now of different stiffness)")
            bdf.properties[ref["pid"]].k = value
            _large_field(bdf.properties[ref["pid"]])
        else:
            refuse(f"spring {s.id} (from a rod)")
    if len(model.springs) != len(original.springs):
        refuse("the springs (one removed)")
    out_path = Path(out_path)
    with contextlib.redirect_stdout(io.StringIO()):
        bdf.write_bdf(str(out_path), size=16, is_double=True, enddata=True)
    return out_path


def _write_moduli(model, bdf, names, P, refuse) -> None:
    """Elements with their own modulus: their MAT1 takes it when every element of the material
    has the same one (G scaled alike), else a copy of MAT1 and property per modulus."""
    by_material: dict[str, dict[float, list]] = {}
    for e in model.elements:
        by_material.setdefault(e.material, {}).setdefault(model.element_modulus_pa(e.id), []).append(e)
    rods = {r["id"] for r in names.get("springs", {}).values() if r["card"] in ("CROD", "CONROD")}
    next_mid = max(bdf.materials) + 1
    next_pid = max(bdf.properties) + 1
    for name, groups in by_material.items():
        mat = model.materials[name]
        if list(groups) == [mat.youngs_modulus_pa]:
            continue
        mid = names["materials"][name]["id"]
        card = bdf.materials[mid]
        ratio = card.g / card.e if card.g else None
        if len(groups) == 1 and not rods:
            (modulus,) = groups
            card.e = modulus / P
            if ratio is not None:
                card.g = ratio * card.e
            continue
        for modulus, elements in groups.items():
            if modulus == mat.youngs_modulus_pa:
                continue
            copy = _copy_card(bdf, card, next_mid)
            copy.e = modulus / P
            if ratio is not None:
                copy.g = ratio * copy.e
            props: dict[int, int] = {}
            for e in elements:
                nastran = bdf.elements[e.id]
                if nastran.pid not in props:
                    prop = _copy_card(bdf, bdf.properties[nastran.pid], next_pid)
                    prop.mid = next_mid
                    props[nastran.pid] = next_pid
                    next_pid += 1
                nastran.pid = props[nastran.pid]
            next_mid += 1


def _copy_card(bdf, card, new_id):
    """A copy of a MAT1 or property card under `new_id`, added to the deck."""
    import copy as _copy
    new = _copy.deepcopy(card)
    if card.type == "MAT1":
        new.mid = new_id
        bdf.materials[new_id] = new
    else:
        new.pid = new_id
        bdf.properties[new_id] = new
    new.comment = ""
    return new


def _write_masses(model, original, bdf, rec, units, refuse) -> None:
    old = {m.node: m for m in original.masses}
    new = {m.node: m for m in model.masses}
    if set(old) != set(new):
        refuse("the lumped masses (one added or removed)")
    w = rec.get("wtmass", 1.0)
    for node, m in new.items():
        o = old[node]
        if _same(o.mass_kg, m.mass_kg) and _same(o.inertia_kg_m2, m.inertia_kg_m2):
            continue
        cards = rec.get("masses", {}).get(str(node), [])
        if len(cards) != 1 or cards[0][0] != "CONM2":
            refuse(f"the mass at node {node} (not one CONM2)")
        card = bdf.masses[cards[0][1]]
        card.mass = m.mass_kg / (w * units.scale("mass"))
        i = m.inertia_kg_m2 / (w * units.scale("rotary_inertia"))
        inertia = np.asarray(card.I, dtype=float).copy()
        if model.layout is PLANAR_FRAME:
            inertia[5] = i
        else:
            inertia[[0, 2, 5]] = i
        card.I = inertia
