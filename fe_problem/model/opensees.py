"""OpenSeesPy scripts in and out (docs/import.md).

`read_script(path)` RUNS the script (as ``python SCRIPT`` would: import only scripts you trust)
with openseespy, and reads the model it built: nodes, masses and fixes from the OpenSees
domain (getNodeTags, nodeCoord, nodeMass, getFixedNodes, getFixedDOFs); elements, their
geometric transformations and uniaxial materials from the script's own calls, recorded by
wrapping those openseespy functions while it runs (OpenSees does not expose an element's
section). Read: ``model basic`` with -ndm 2 -ndf 3 (a planar model) or -ndm 3 -ndf 6 (space),
``elasticBeamColumn`` and ``ElasticTimoshenkoBeam`` (2-D and 3-D, ``-mass``, ``-cMass``),
``geomTransf Linear``, ``zeroLength`` with ``uniaxialMaterial Elastic`` (springs; one to a
fixed node that nothing else touches is a spring to ground); anything else is refused by name.
`write_script(model, path)` writes a script that builds the model.
"""

from __future__ import annotations

import contextlib
import os
import runpy
import sys
import tempfile
import traceback
from pathlib import Path

import numpy as np

from ..dofs import PLANAR_FRAME, SPACE_FRAME
from ..units import UNITS
from .types import Element, FrameModel, LumpedMass, Material, Node, Section, Spring, Support
from .validate import ModelFileError


class OpenSeesScriptError(ModelFileError):
    """A script femu cannot run or represent; the message names the script and the element or call."""


#: The openseespy functions whose calls are recorded while a script runs.
RECORDED = ("wipe", "model", "element", "geomTransf", "uniaxialMaterial", "section", "equalDOF", "rigidLink",
            "rigidDiaphragm", "nDMaterial", "beamIntegration")

_DOF_NAMES = {2: ("x", "y", "rz"), 3: ("x", "y", "z", "rx", "ry", "rz")}


def _ops():
    try:
        import openseespy.opensees as ops
    except ImportError:
        raise OpenSeesScriptError("reading an OpenSeesPy script needs the 'import' extra: "
                                  "pip install 'femu-bench[import]'") from None
    return ops


def _run(path: Path, ops) -> list[tuple]:
    """Run the script with the RECORDED functions wrapped; the calls (name, args) in order
    since its last wipe(). The script's output goes to stderr."""
    calls: list[tuple] = []
    saved = {name: getattr(ops, name) for name in RECORDED if hasattr(ops, name)}

    def wrap(name, func):
        def recorded(*args):
            if name == "wipe":
                calls.clear()
            else:
                calls.append((name, args))
            return func(*args)
        return recorded

    for name, func in saved.items():
        setattr(ops, name, wrap(name, func))
    ops.wipe()
    calls.clear()
    with tempfile.TemporaryFile(mode="w+b") as captured:
        try:
            with _output_to(captured):
                runpy.run_path(str(path), run_name="__main__")
        except SystemExit as exc:
            if exc.code not in (None, 0):
                raise OpenSeesScriptError(f"{path}: the script exited with {exc.code!r}") from None
        except Exception as exc:
            line = [f.lineno for f in traceback.extract_tb(exc.__traceback__) if Path(f.filename) == path]
            at = f" line {line[-1]}:" if line else ""
            said = _last_lines(captured)
            raise OpenSeesScriptError(f"{path}:{at} the script failed: {type(exc).__name__}: "
                                      f"{' '.join(str(exc).split())[:200]}" + (f" ({said})" if said else "")) from None
        finally:
            for name, func in saved.items():
                setattr(ops, name, func)
        captured.seek(0)
        sys.stderr.write(captured.read().decode(errors="replace"))  # what the script printed, on stderr
    return calls


@contextlib.contextmanager
def _output_to(file):
    """The process's stdout and stderr (OpenSees writes to them from C++) into `file`."""
    sys.stdout.flush(), sys.stderr.flush()
    saved = os.dup(1), os.dup(2)
    try:
        os.dup2(file.fileno(), 1), os.dup2(file.fileno(), 2)
        yield
    finally:
        sys.stdout.flush(), sys.stderr.flush()
        os.dup2(saved[0], 1), os.dup2(saved[1], 2)
        os.close(saved[0]), os.close(saved[1])


def _last_lines(file, n: int = 2) -> str:
    """The last `n` non-empty lines `file` holds, joined: what OpenSees said before failing."""
    file.seek(0)
    lines = [line.strip() for line in file.read().decode(errors="replace").splitlines() if line.strip()]
    return " / ".join(lines[-n:])[:300]


def _options(args: tuple, flags: dict, where: str) -> tuple[list, dict]:
    """Positional values and {flag: values} of an element call's arguments; `flags` the known
    flags and how many values each takes; any other string flag is refused."""
    pos, opts = [], {}
    k = 0
    while k < len(args):
        a = args[k]
        if isinstance(a, str) and a.startswith("-"):
            if a not in flags:
                raise OpenSeesScriptError(f"{where}: option {a} is not read")
            opts[a] = list(args[k + 1:k + 1 + flags[a]])
            k += 1 + flags[a]
        else:
            pos.append(a)
            k += 1
    return pos, opts


class _Reader:
    def __init__(self, path: Path, ops, calls: list[tuple], units: str):
        self.path, self.ops, self.units = path, ops, UNITS[units]
        models = [a for n, a in calls if n == "model"]
        if not models:
            raise OpenSeesScriptError(f"{path}: the script calls no ops.model(...)")
        args = [str(a) for a in models[-1]]
        try:
            ndm, ndf = int(args[args.index("-ndm") + 1]), int(args[args.index("-ndf") + 1]) if "-ndf" in args else None
        except (ValueError, IndexError):
            raise OpenSeesScriptError(f"{path}: model{tuple(models[-1])}: expected 'basic', '-ndm', N, '-ndf', M") \
                from None
        if (ndm, ndf) not in ((2, 3), (3, 6)):
            raise OpenSeesScriptError(f"{path}: model -ndm {ndm} -ndf {ndf}: femu reads planar frames (-ndm 2 "
                                      "-ndf 3) and space frames (-ndm 3 -ndf 6)")
        self.ndm = ndm
        self.layout = PLANAR_FRAME if ndm == 2 else SPACE_FRAME
        others = sorted({n for n, _ in calls if n not in ("model", "element", "geomTransf", "uniaxialMaterial")})
        if others:
            raise OpenSeesScriptError(f"{path}: {', '.join(others)}: not read (femu reads nodes, masses, fixes, "
                                      "elasticBeamColumn, ElasticTimoshenkoBeam, geomTransf Linear, zeroLength "
                                      "with uniaxialMaterial Elastic)")
        self.transf = {int(a[1]): a for n, a in calls if n == "geomTransf"}
        self.uniaxial = {int(a[1]): a for n, a in calls if n == "uniaxialMaterial"}
        self.elements = {int(a[1]): a for n, a in calls if n == "element"}
        self.materials: dict[tuple, str] = {}
        self.sections: dict[tuple, str] = {}
        self.conventions: set[str] = set()

    def where(self, tag) -> str:
        return f"{self.path}: element {tag}"

    def material(self, E, G, rho) -> str:
        key = (E, G, rho)
        if key not in self.materials:
            self.materials[key] = f"material {len(self.materials) + 1}"
        return self.materials[key]

    def section(self, key) -> str:
        if key not in self.sections:
            self.sections[key] = f"section {len(self.sections) + 1}"
        return self.sections[key]

    def orientation(self, tag, transf_tag):
        t = self.transf.get(int(transf_tag))
        if t is None:
            raise OpenSeesScriptError(f"{self.where(tag)}: geomTransf {transf_tag} is not defined")
        if t[0] != "Linear":
            raise OpenSeesScriptError(f"{self.where(tag)}: geomTransf {t[0]} {transf_tag}: only Linear is read")
        rest = list(t[2:])
        if any(isinstance(a, str) for a in rest):
            raise OpenSeesScriptError(f"{self.where(tag)}: geomTransf Linear {transf_tag}: joint offsets are not read")
        if self.ndm == 3:
            if len(rest) != 3:
                raise OpenSeesScriptError(f"{self.where(tag)}: geomTransf Linear {transf_tag}: expected vecxz")
            return tuple(float(x) for x in rest)
        return None

    def beam(self, args):
        kind, tag = args[0], int(args[1])
        where = self.where(tag)
        pos, opts = _options(args[2:], {"-mass": 1, "-cMass": 0, "-lMass": 0}, where)
        if any(isinstance(a, str) for a in pos):
            raise OpenSeesScriptError(f"{where}: {kind} with a section or beam integration is not read")
        u = self.units
        P, A_, I_ = u.scale("pressure"), u.scale("area"), u.scale("inertia")
        v = [float(x) for x in pos]
        i, j = int(v[0]), int(v[1])
        timo = kind == "ElasticTimoshenkoBeam"
        expect = {("elasticBeamColumn", 2): 6, ("elasticBeamColumn", 3): 9,
                  ("ElasticTimoshenkoBeam", 2): 8, ("ElasticTimoshenkoBeam", 3): 11}[(kind, self.ndm)]
        if len(v) != expect:
            raise OpenSeesScriptError(f"{where}: {kind} in {self.ndm}-D: expected {expect} numbers after "
                                      f"the tag (nodes, properties, transformation), got {len(v)}")
        G = J = iy = None
        kappa = 5.0 / 6.0
        if kind == "elasticBeamColumn" and self.ndm == 2:
            A, E, iz, t = v[2:6]
        elif kind == "elasticBeamColumn":
            A, E, G, J, iy, iz, t = v[2:9]
        elif self.ndm == 2:
            E, G, A, iz, avy, t = v[2:8]
            kappa = avy / A
        else:
            E, G, A, J, iy, iz, avy, avz, t = v[2:11]
            if abs(avy - avz) > 1e-12 * abs(avy):
                raise OpenSeesScriptError(f"{where}: Avy = {avy:g}, Avz = {avz:g}: femu's Timoshenko beams take "
                                          "one shear area for both planes")
            kappa = avy / A
        mass = float(opts.get("-mass", [0.0])[0])
        if mass <= 0:
            raise OpenSeesScriptError(f"{where}: no -mass: femu's beams carry their own mass (density > 0)")
        consistent = "-cMass" in opts
        if consistent and self.ndm == 3 and abs(J - (iy + iz)) > 1e-12 * (iy + iz):
            raise OpenSeesScriptError(f"{where}: -cMass in 3-D: OpenSees' torsional inertia rho J differs from "
                                      "femu's rho (Iy + Iz) (docs/model-format.md): give J = Iy + Iz with "
                                      "G J kept, or use lumped mass")
        self.conventions.add("consistent" if consistent else "lumped")
        rho = mass * u.mass / u.length / (A * A_)
        mat = self.material(E * P, None if G is None else G * P, rho)
        if self.ndm == 2:
            sec = self.section((A * A_, iz * I_, kappa))
        else:
            sec = self.section((A * A_, kappa, iy * I_, iz * I_, J * I_))
        form = ("timoshenko" if timo else "euler-bernoulli") + ("" if consistent else "-lumped")
        return Element(tag, i, j, sec, mat, form, orientation=self.orientation(tag, t))

    def zero_length(self, args) -> list[Spring]:
        tag = int(args[1])
        where = self.where(tag)
        i, j = int(args[2]), int(args[3])
        rest = list(args[4:])
        mats, dirs = [], []
        k = 0
        while k < len(rest):
            flag = rest[k]
            k += 1
            vals = []
            while k < len(rest) and not (isinstance(rest[k], str) and rest[k].startswith("-")):
                vals.append(rest[k])
                k += 1
            if flag == "-mat":
                mats = [int(x) for x in vals]
            elif flag == "-dir":
                dirs = [int(x) for x in vals]
            elif flag == "-orient":
                axes = np.array([float(x) for x in vals], dtype=float)
                if axes.size not in (3, 6) or not np.allclose(axes[:3], [1, 0, 0]) or \
                        (axes.size == 6 and not np.allclose(axes[3:], [0, 1, 0])):
                    raise OpenSeesScriptError(f"{where}: zeroLength -orient other than the global axes is not read")
            elif flag != "-doRayleigh":
                raise OpenSeesScriptError(f"{where}: zeroLength option {flag} is not read")
        if len(mats) != len(dirs) or not mats:
            raise OpenSeesScriptError(f"{where}: zeroLength needs as many -mat as -dir")
        names = _DOF_NAMES[self.ndm]
        out = []
        for m, d in zip(mats, dirs):
            mat = self.uniaxial.get(m)
            if mat is None or mat[0] != "Elastic" or len(mat) != 3:
                raise OpenSeesScriptError(f"{where}: uniaxialMaterial {m}: only 'Elastic' tag E (no damping) is read")
            if not 1 <= d <= len(names):
                raise OpenSeesScriptError(f"{where}: zeroLength -dir {d}: expected 1 to {len(names)}")
            name = names[d - 1]
            kind = "rotational_spring" if name.startswith("r") else "spring"
            out.append(Spring(tag * 10 + len(out), (i, name), (j, name), float(mat[2]) * self.units.scale(kind)))
        return out

    def model(self, name: str, units: str) -> FrameModel:
        ops, u = self.ops, self.units
        tags = [int(t) for t in ops.getNodeTags()]
        known = {"elasticBeamColumn", "ElasticTimoshenkoBeam", "zeroLength"}
        for tag in [int(t) for t in ops.getEleTags()]:
            if tag not in self.elements:
                raise OpenSeesScriptError(f"{self.where(tag)}: built by no recorded ops.element call")
        odd = sorted({a[0] for a in self.elements.values() if a[0] not in known})
        if odd:
            raise OpenSeesScriptError(f"{self.path}: element types not read: {', '.join(odd)} (femu reads "
                                      "elasticBeamColumn, ElasticTimoshenkoBeam, zeroLength)")
        elements, springs = [], []
        for tag in sorted(self.elements):
            a = self.elements[tag]
            if a[0] == "zeroLength":
                springs.extend(self.zero_length(a))
            else:
                elements.append(self.beam(a))
        fixed = {int(n): [int(d) for d in ops.getFixedDOFs(int(n))] for n in ops.getFixedNodes()}
        names = _DOF_NAMES[self.ndm]
        # a spring to a fully fixed node that nothing else touches is a spring to ground
        beam_nodes = {n for e in elements for n in (e.node_i, e.node_j)}
        ground = {n for n in tags if n not in beam_nodes and len(set(fixed.get(n, []))) == len(names)}
        springs = [Spring(s.id, s.dof_a if s.dof_a[0] not in ground else s.dof_b,
                          None if ground & {s.dof_a[0], s.dof_b[0]} else s.dof_b, s.stiffness)
                   for s in springs if not {s.dof_a[0], s.dof_b[0]} <= ground]
        nodes = []
        masses = []
        for n in sorted(tags):
            if n in ground:
                continue
            xyz = [float(c) * u.length for c in ops.nodeCoord(n)]
            nodes.append(Node(n, *xyz))
            m = [float(x) for x in ops.nodeMass(n)]
            if any(m):
                t, r = m[:self.ndm], m[self.ndm:]
                if not (np.allclose(t, t[0], rtol=1e-12, atol=0) and np.allclose(r, r[0], rtol=1e-12, atol=0)):
                    raise OpenSeesScriptError(f"{self.path}: mass at node {n} {m}: femu's lumped mass is the same in "
                                              "every translation and every rotation")
                masses.append(LumpedMass(n, t[0] * u.mass, r[0] * u.scale("rotary_inertia")))
        supports = tuple(Support(n, tuple(names[d - 1] for d in sorted(set(ds))))
                         for n, ds in sorted(fixed.items()) if n not in ground)
        materials = {}
        for (E, G, rho), mname in self.materials.items():
            nu = 0.3 if G is None else E / (2.0 * G) - 1.0
            materials[mname] = Material(E, rho, nu if -1.0 < nu < 0.5 else 0.3, G)
        sections = {}
        for key, sname in self.sections.items():
            if self.ndm == 2:
                sections[sname] = Section(key[0], inertia_m4=key[1], shear_coefficient=key[2])
            else:
                sections[sname] = Section(key[0], shear_coefficient=key[1], iy_m4=key[2], iz_m4=key[3], j_m4=key[4])
        convention = "mixed" if len(self.conventions) > 1 else (self.conventions.pop() if self.conventions else "none")
        meta = {"import": {"format": "opensees", "path": str(self.path.resolve()), "units": units, "mass": convention}}
        return FrameModel(name=name, nodes=tuple(nodes), materials=materials, sections=sections,
                          elements=tuple(elements), masses=tuple(masses), springs=tuple(springs), supports=supports,
                          description=f"imported from {self.path.name} ({units}, {convention} mass)",
                          source=str(self.path), layout=self.layout, meta=meta)


def read_script(path: str | Path, units: str = "SI", name: str | None = None) -> FrameModel:
    """The model an OpenSeesPy script builds. RUNS the script. `units`: its consistent unit
    system (fe_problem.units.UNITS); the model is in SI. OpenSeesScriptError (a ValueError) naming the
    script and the element or call femu cannot represent."""
    path = Path(path)
    if units not in UNITS:
        raise OpenSeesScriptError(f"units {units!r}: expected one of {', '.join(UNITS)}")
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no such file")
    ops = _ops()
    calls = _run(path, ops)
    try:
        return _Reader(path, ops, calls, units).model(name or path.stem, units)
    finally:
        ops.wipe()


def write_script(model: FrameModel, path: str | Path, units: str = "SI") -> Path:
    """Write an OpenSeesPy script that builds `model` (in `units`) and prints its first
    frequencies (Hz) when run. 3-D consistent mass: the element gets J' = Iy + Iz and G' = G J / J'
    (the same torsional stiffness, OpenSees' rho J' then femu's torsional inertia; Timoshenko's
    shear areas scaled by G / G'). A crack, a weak zone, a released end or a spring between two
    nodes at different places is refused (no such element written here)."""
    if units not in UNITS:
        raise OpenSeesScriptError(f"units {units!r}: expected one of {', '.join(UNITS)}")
    u = UNITS[units]
    P, A_, I_, L = u.scale("pressure"), u.scale("area"), u.scale("inertia"), u.length
    space = model.layout is SPACE_FRAME
    ndm, ndf = (3, 6) if space else (2, 3)
    names = _DOF_NAMES[ndm]
    lines = ["# written by femu export (fe_problem/model/opensees.py)", "import openseespy.opensees as ops", "",
             "ops.wipe()", f"ops.model('basic', '-ndm', {ndm}, '-ndf', {ndf})"]
    for n in model.nodes:
        xyz = (n.x, n.y, n.z) if space else (n.x, n.y)
        lines.append(f"ops.node({n.id}, {', '.join(repr(c / L) for c in xyz)})")
    for m in model.masses:
        t, r = m.mass_kg / u.mass, m.inertia_kg_m2 / u.scale("rotary_inertia")
        lines.append(f"ops.mass({m.node}, {', '.join([repr(t)] * ndm + [repr(r)] * (ndf - ndm))})")
    for s in model.supports:
        lines.append(f"ops.fix({s.node}, {', '.join('1' if d in s.directions else '0' for d in names)})")
    extra = max(model.node_ids) + 1
    for e in model.elements:
        if e.crack_position is not None or e.weak_zone is not None or any(model.end_releases(e)):
            raise OpenSeesScriptError(f"{model.source}: element {e.id}: a crack, weak zone or released end is not "
                                      "written to OpenSees here")
        mat, sec = model.materials[e.material], model.sections[e.section]
        E = model.element_modulus_pa(e.id)
        G = mat.shear_modulus * E / mat.youngs_modulus_pa
        lumped = e.formulation.endswith("-lumped")
        timo = e.formulation.startswith("timoshenko")
        rho_a = mat.density_kg_m3 * sec.area_m2 / (u.mass / u.length)
        tail = f", '-mass', {rho_a!r}" + ("" if lumped else ", '-cMass'")
        if space:
            lines.append(f"ops.geomTransf('Linear', {e.id}, {', '.join(repr(float(c)) for c in e.orientation)})")
            J, g = sec.j_m4, G
            if not lumped:
                J = sec.iy_m4 + sec.iz_m4
                g = G * sec.j_m4 / J
            av = sec.shear_coefficient * sec.area_m2 * G / g
            if timo:
                args = (E / P, g / P, sec.area_m2 / A_, J / I_, sec.iy_m4 / I_, sec.iz_m4 / I_, av / A_, av / A_)
            else:
                args = (sec.area_m2 / A_, E / P, g / P, J / I_, sec.iy_m4 / I_, sec.iz_m4 / I_)
        else:
            lines.append(f"ops.geomTransf('Linear', {e.id})")
            if timo:
                args = (E / P, G / P, sec.area_m2 / A_, sec.inertia_m4 / I_, sec.shear_coefficient * sec.area_m2 / A_)
            else:
                args = (sec.area_m2 / A_, E / P, sec.inertia_m4 / I_)
        kind = "ElasticTimoshenkoBeam" if timo else "elasticBeamColumn"
        lines.append(f"ops.element('{kind}', {e.id}, {e.node_i}, {e.node_j}, {', '.join(repr(float(a)) for a in args)}, "
                     f"{e.id}{tail})")
    tag = max(model.element_ids) + 1
    for s in model.springs:
        kind = "rotational_spring" if s.dof_a[1].startswith("r") else "spring"
        lines.append(f"ops.uniaxialMaterial('Elastic', {tag}, {s.stiffness / u.scale(kind)!r})")
        a = s.dof_a[0]
        if s.dof_b is None:
            node = model.node(a)
            xyz = (node.x, node.y, node.z) if space else (node.x, node.y)
            lines.append(f"ops.node({extra}, {', '.join(repr(c / L) for c in xyz)})")
            lines.append(f"ops.fix({extra}, {', '.join(['1'] * ndf)})")
            b, extra = extra, extra + 1
        else:
            b = s.dof_b[0]
            if s.dof_b[1] != s.dof_a[1] or np.any(model.coordinates[model.node_position(a)]
                                                  != model.coordinates[model.node_position(b)]):
                raise OpenSeesScriptError(f"{model.source}: spring {s.id}: only springs between one direction of two "
                                          "nodes at one place (zeroLength) are written")
        lines.append(f"ops.element('zeroLength', {tag}, {b}, {a}, '-mat', {tag}, '-dir', {names.index(s.dof_a[1]) + 1})")
        tag += 1
    lines += ["", "if __name__ == '__main__':", "    import math",
              "    print([math.sqrt(max(w, 0.0)) / (2 * math.pi) for w in ops.eigen('-fullGenLapack', 12)])", ""]
    path = Path(path)
    path.write_text("\n".join(lines))
    return path
