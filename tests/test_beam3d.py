"""The space frame element kernels (fe_problem/elements/beam3d.py) against OpenSeesPy and
closed forms.

Each frame is assembled here by a small plain loop over the kernels' element matrices (test
code; the library assembles without one) and solved with scipy's dense eigh; the same frame is
built in OpenSees with ``model('basic', '-ndm', 3, '-ndf', 6)``, one ``geomTransf Linear``
with the member's vecxz per element, and ``elasticBeamColumn ... -mass rho*A -cMass``
(Euler-Bernoulli) or ``ElasticTimoshenkoBeam ... -mass rho*A -cMass`` (Timoshenko).

Torsional inertia: OpenSees' consistent mass takes rho J (J the torsion constant) where the
model file form takes the section's polar moment rho (Iy + Iz) (beam3d.py's docstring). The
OpenSees elements are therefore given J' = Iy + Iz and G' = G J / J': the torsional stiffness
G'J' = G J is the same, the torsional mass is rho (Iy + Iz); for Timoshenko the shear areas
are scaled by G / G' so that G' A_v' = G kappa A keeps the shear ratios. This maps the same
structure into OpenSees exactly; `test_opensees_torsional_mass_is_rho_j` shows the mapping is
needed (without it the torsion-dominated frame differs).
"""

from __future__ import annotations

import os
import pathlib
import pickle
import subprocess
import sys
import tempfile
from dataclasses import dataclass

import numpy as np
import openseespy.opensees as ops
import pytest
import scipy.linalg

from fe_problem.elements import beam3d

N_MODES = 10


@dataclass(frozen=True)
class Prop:
    """Material and section of a member (SI)."""

    E: float
    G: float
    rho: float
    A: float
    Iy: float
    Iz: float
    J: float
    kappa: float = 5.0 / 6.0


@dataclass(frozen=True)
class Frame:
    nodes: dict  # id -> (x, y, z)
    members: list  # (id, node_i, node_j, Prop, vecxz)
    fixed: dict  # node id -> 6 ints (1 fixed)
    masses: dict  # node id -> kg (x, y, z)


STEEL_COL = Prop(E=2.0e11, G=7.69e10, rho=7850.0, A=1.133e-3, Iy=1.97e-6, Iz=0.664e-6, J=8.01e-9)
STEEL_BEAM = Prop(E=2.0e11, G=7.69e10, rho=7850.0, A=2.01e-3, Iy=8.69e-6, Iz=0.68e-6, J=3.6e-8)
# a stocky section, so that shear deformation and rotary inertia matter (Timoshenko)
STOCKY = Prop(E=3.0e10, G=1.25e10, rho=2400.0, A=0.09, Iy=0.3 * 0.3**3 / 12, Iz=0.3**3 * 0.3 / 12 * 0.6,
              J=0.141 * 0.3**4, kappa=5.0 / 6.0)


def _fixed_all(*nodes):
    return {n: (1, 1, 1, 1, 1, 1) for n in nodes}


def cantilever(n_el: int = 6, prop: Prop = STEEL_COL, vecxz=(0.0, 0.6, 0.8), length: float = 1.7) -> Frame:
    nodes = {k + 1: (length * k / n_el, 0.0, 0.0) for k in range(n_el + 1)}
    members = [(k + 1, k + 1, k + 2, prop, vecxz) for k in range(n_el)]
    return Frame(nodes, members, _fixed_all(1), {n_el + 1: 3.0})


def skewed(n_el: int = 5) -> Frame:
    """A cantilever along a direction that is no global axis, with a skew vecxz."""
    d = np.array([1.3, 0.7, 2.1])
    nodes = {k + 1: tuple(d * k / n_el) for k in range(n_el + 1)}
    members = [(k + 1, k + 1, k + 2, STEEL_BEAM, (0.3, -0.5, 0.8)) for k in range(n_el)]
    return Frame(nodes, members, _fixed_all(1), {n_el + 1: 5.0, 3: 2.0})


def portal() -> Frame:
    """A 2-storey 3-D portal, 4.0 m x 3.0 m in plan: columns along z (vecxz x, y and skew),
    beams along x and y (vecxz z and tilted), two members split in two, masses at floors."""
    plan = {1: (0.0, 0.0), 2: (4.0, 0.0), 3: (4.0, 3.0), 4: (0.0, 3.0)}
    heights = (0.0, 3.2, 6.0)
    nodes = {10 * s + c: (x, y, heights[s]) for s in range(3) for c, (x, y) in plan.items()}
    members = []
    eid = 1
    col_vec = {1: (1.0, 0.0, 0.0), 2: (0.0, 1.0, 0.0), 3: (1.0, 1.0, 0.0), 4: (-0.6, 0.8, 0.0)}
    for s in range(2):
        for c in plan:
            members.append((eid, 10 * s + c, 10 * (s + 1) + c, STEEL_COL, col_vec[c]))
            eid += 1
        for a, b, vec in ((1, 2, (0.0, 0.0, 1.0)), (2, 3, (0.0, 0.0, 1.0)), (3, 4, (0.0, 0.3, 1.0)),
                          (4, 1, (1.0, 0.0, 0.5))):
            members.append((eid, 10 * (s + 1) + a, 10 * (s + 1) + b, STEEL_BEAM, vec))
            eid += 1
    # split beam 1-2 of the top floor and column 3 of the ground storey at a mid node
    nodes[99] = (2.0, 0.0, 6.0)
    nodes[98] = (4.0, 3.0, 1.6)
    out = []
    for m in members:
        if (m[1], m[2]) == (21, 22):
            out += [(m[0], 21, 99, m[3], m[4]), (100, 99, 22, m[3], m[4])]
        elif (m[1], m[2]) == (3, 13):
            out += [(m[0], 3, 98, m[3], m[4]), (101, 98, 13, m[3], m[4])]
        else:
            out.append(m)
    masses = {11: 120.0, 12: 150.0, 13: 110.0, 14: 130.0, 21: 90.0, 22: 80.0, 23: 100.0, 24: 70.0}
    return Frame(nodes, out, _fixed_all(1, 2, 3, 4), masses)


def torsion_tee() -> Frame:
    """A vertical shaft of an open section (small J) with a cross arm at the top carrying
    masses: the lowest mode twists the shaft."""
    shaft = Prop(E=2.0e11, G=7.69e10, rho=7850.0, A=2.0e-3, Iy=2.0e-5, Iz=1.5e-5, J=4.0e-8)
    arm = Prop(E=2.0e11, G=7.69e10, rho=7850.0, A=3.0e-3, Iy=4.0e-5, Iz=3.0e-5, J=2.0e-5)
    nodes = {1: (0.0, 0.0, 0.0), 2: (0.0, 0.0, 1.0), 3: (0.0, 0.0, 2.0), 4: (-0.8, 0.0, 2.0), 5: (0.8, 0.0, 2.0)}
    members = [(1, 1, 2, shaft, (1.0, 0.0, 0.0)), (2, 2, 3, shaft, (1.0, 0.0, 0.0)),
               (3, 3, 4, arm, (0.0, 0.0, 1.0)), (4, 3, 5, arm, (0.0, 0.0, 1.0))]
    return Frame(nodes, members, _fixed_all(1), {4: 40.0, 5: 40.0})


# --- our side ---------------------------------------------------------------------------

def element_matrices(frame: Frame, timoshenko: bool):
    """Global stiffness and mass (n, 12, 12) of every member (vectorised kernels)."""
    xyz = frame.nodes
    p = [m[3] for m in frame.members]
    arr = {f: np.array([getattr(q, f) for q in p]) for f in ("E", "G", "rho", "A", "Iy", "Iz", "J", "kappa")}
    start = np.array([xyz[m[1]] for m in frame.members], dtype=float)
    end = np.array([xyz[m[2]] for m in frame.members], dtype=float)
    r = beam3d.rotation(start, end, np.array([m[4] for m in frame.members], dtype=float))
    length = beam3d.lengths(start, end)
    g_over_e = arr["G"] / arr["E"]
    if timoshenko:
        phi_y, phi_z = beam3d.shear_ratios(length, arr["Iy"], arr["Iz"], arr["kappa"] * arr["A"], g_over_e)
    else:
        phi_y = phi_z = np.zeros_like(length)
    kl = beam3d.local_stiffness(length, arr["A"], arr["Iy"], arr["Iz"], g_over_e * arr["J"], phi_y, phi_z)
    ml = beam3d.local_mass(length, arr["A"], arr["Iy"], arr["Iz"], arr["Iy"] + arr["Iz"], phi_y, phi_z,
                           rotary=timoshenko)
    t = beam3d.transformation(r)
    return (arr["E"][:, None, None] * beam3d.to_global(kl, t),
            arr["rho"][:, None, None] * beam3d.to_global(ml, t))


def assemble(frame: Frame, timoshenko: bool):
    ids = list(frame.nodes)
    pos = {n: k for k, n in enumerate(ids)}
    n = 6 * len(ids)
    K, M = np.zeros((n, n)), np.zeros((n, n))
    ke, me = element_matrices(frame, timoshenko)
    for e, m in enumerate(frame.members):
        dofs = np.r_[6 * pos[m[1]]:6 * pos[m[1]] + 6, 6 * pos[m[2]]:6 * pos[m[2]] + 6]
        K[np.ix_(dofs, dofs)] += ke[e]
        M[np.ix_(dofs, dofs)] += me[e]
    for node, kg in frame.masses.items():
        for d in range(3):
            M[6 * pos[node] + d, 6 * pos[node] + d] += kg
    free = np.ones(n, dtype=bool)
    for node, fix in frame.fixed.items():
        free[6 * pos[node]:6 * pos[node] + 6] &= ~np.array(fix, dtype=bool)
    return K, M, free


def our_modes(frame: Frame, timoshenko: bool, n_modes: int = N_MODES):
    K, M, free = assemble(frame, timoshenko)
    lam, vec = scipy.linalg.eigh(K[np.ix_(free, free)], M[np.ix_(free, free)], subset_by_index=[0, n_modes - 1])
    shapes = np.zeros((len(free), n_modes))
    shapes[free] = vec
    return np.sqrt(lam) / (2 * np.pi), shapes


# --- OpenSees ---------------------------------------------------------------------------

def opensees_modes(frame: Frame, timoshenko: bool, n_modes: int = N_MODES, map_torsional_mass: bool = True,
                   releases: dict | None = None, inertia: dict | None = None):
    """The lowest modes of `frame` in OpenSees (Hz, shapes on the 6 DOFs of every frame node).

    inertia: {node id: kg m^2}, a lumped rotary inertia on that node's rx, ry and rz.

    releases: {(member id, node id): {global rotation 4 | 5 | 6: stiffness N m/rad}}: that end
    of the member is a second node at the joint, tied by ``equalDOF`` in the translations and
    the other rotations, and by a ``zeroLength`` element with an Elastic material in each
    released rotation (none for a stiffness of 0: a pin)."""
    ops.wipe()
    ops.model("basic", "-ndm", 3, "-ndf", 6)
    for nid, xyz in frame.nodes.items():
        ops.node(nid, *map(float, xyz))
    for nid, fix in frame.fixed.items():
        ops.fix(nid, *fix)
    for nid in dict.fromkeys([*frame.masses, *(inertia or {})]):
        kg, j = frame.masses.get(nid, 0.0), (inertia or {}).get(nid, 0.0)
        ops.mass(nid, kg, kg, kg, j, j, j)
    extra_node, extra_element = 10 * max(frame.nodes) + 1, 10 * max(m[0] for m in frame.members) + 1
    for eid, i, j, p, vec in frame.members:
        ends = []
        for node in (i, j):
            rel = (releases or {}).get((eid, node))
            if rel is None:
                ends.append(node)
                continue
            ops.node(extra_node, *map(float, frame.nodes[node]))
            ops.equalDOF(node, extra_node, *[d for d in range(1, 7) if d not in rel])
            for d, k in rel.items():
                if k > 0:
                    ops.uniaxialMaterial("Elastic", extra_element, k)
                    ops.element("zeroLength", extra_element, node, extra_node, "-mat", extra_element, "-dir", d)
                    extra_element += 1
            ends.append(extra_node)
            extra_node += 1
        i, j = ends
        ops.geomTransf("Linear", eid, *map(float, vec))
        if map_torsional_mass:
            j_os = p.Iy + p.Iz
            g_os = p.G * p.J / j_os
        else:
            j_os, g_os = p.J, p.G
        if timoshenko:
            av = p.kappa * p.A * p.G / g_os
            ops.element("ElasticTimoshenkoBeam", eid, i, j, p.E, g_os, p.A, j_os, p.Iy, p.Iz, av, av, eid,
                        "-mass", p.rho * p.A, "-cMass")
        else:
            ops.element("elasticBeamColumn", eid, i, j, p.A, p.E, g_os, j_os, p.Iy, p.Iz, eid,
                        "-mass", p.rho * p.A, "-cMass")
    ops.constraints("Transformation")
    lam = np.array(ops.eigen("-fullGenLapack", n_modes))
    ids = list(frame.nodes)
    shapes = np.array([[ops.nodeEigenvector(nid, k + 1, d + 1) for k in range(n_modes)]
                       for nid in ids for d in range(6)])
    ops.wipe()
    # a complex eigenvalue (a massless released rotation) comes back as minus its magnitude: NaN Hz
    with np.errstate(invalid="ignore"):
        return np.sqrt(lam) / (2 * np.pi), shapes


def opensees_modes_fresh(frame: Frame, timoshenko: bool, n_modes: int = N_MODES, **options):
    """`opensees_modes` run in a fresh Python process: the same numbers whatever ran before in
    this one. OpenSees' -fullGenLapack modes of one structure differ by up to 3e-14 in
    frequency, 1e-13 in shape and in the sign of some modes with the state of the process that
    calls it (the frame3d with a corner-column zone after a modal analysis of the H-frame in the
    same process, or a 12-entry dict made first; tests/test_space_zones.py,
    test_truth_does_not_depend_on_what_ran_before). The signs once changed the noise drawn on
    those modes (test_frame3d.measured now fixes them).

    Being the same in any process, the modes of one structure are solved once per test process
    (`_FRESH`, keyed by the pickled arguments; a copy returned): test_frame3d and
    test_space_zones read the same truths in several tests."""
    key = pickle.dumps((frame, timoshenko, n_modes, sorted(options.items())))
    if key not in _FRESH:
        _FRESH[key] = _opensees_modes_in_a_new_process(frame, timoshenko, n_modes, **options)
    f, shapes = _FRESH[key]
    return f.copy(), shapes.copy()


#: opensees_modes_fresh's results in this process, by its pickled arguments
_FRESH: dict[bytes, tuple[np.ndarray, np.ndarray]] = {}


def _opensees_modes_in_a_new_process(frame: Frame, timoshenko: bool, n_modes: int, **options):
    code = ("import pickle, sys\n"
            "import numpy as np\n"
            "from test_beam3d import opensees_modes\n"
            "args, kw, out = pickle.load(sys.stdin.buffer)\n"
            "f, shapes = opensees_modes(*args, **kw)\n"
            "np.savez(out, f=f, shapes=shapes)\n")
    with tempfile.TemporaryDirectory() as tmp:
        out = pathlib.Path(tmp) / "modes.npz"
        env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(pathlib.Path(__file__).parent), *sys.path]))
        subprocess.run([sys.executable, "-c", code], input=pickle.dumps(((frame, timoshenko, n_modes), options, out)),
                       env=env, check=True, capture_output=True)
        with np.load(out) as d:
            return d["f"], d["shapes"]


def mac_diagonal(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    num = np.abs(np.sum(a * b, axis=0)) ** 2
    return num / (np.sum(a * a, axis=0) * np.sum(b * b, axis=0))


FRAMES = {"cantilever": cantilever, "skewed": skewed, "portal": portal, "torsion_tee": torsion_tee,
          "stocky_cantilever": lambda: cantilever(8, STOCKY, (0.2, 1.0, 0.3), 2.5)}


@pytest.mark.parametrize("timoshenko", [False, True], ids=["euler-bernoulli", "timoshenko"])
@pytest.mark.parametrize("name", list(FRAMES))
def test_frequencies_and_shapes_match_opensees(name, timoshenko):
    frame = FRAMES[name]()
    f_ours, s_ours = our_modes(frame, timoshenko)
    f_os, s_os = opensees_modes(frame, timoshenko)
    np.testing.assert_allclose(f_ours, f_os, rtol=1e-8, atol=0)
    mac = mac_diagonal(s_ours, s_os)
    assert mac.min() > 1 - 1e-10, mac
    # the lowest modes are well separated (else the MAC of a degenerate pair would mean nothing)
    assert np.min(np.diff(f_ours) / f_ours[1:]) > 1e-4


def test_timoshenko_differs_where_it_should():
    """Guards the Timoshenko cases against testing the Euler-Bernoulli element twice."""
    f_eb, _ = our_modes(FRAMES["stocky_cantilever"](), False)
    f_ti, _ = our_modes(FRAMES["stocky_cantilever"](), True)
    assert np.all(f_ti <= f_eb * (1 + 1e-12))
    assert np.max(1 - f_ti / f_eb) > 0.02


def test_torsion_tee_is_torsion_dominated():
    """The tee's lowest mode twists the shaft: rz at the top dominates, the arm tips move
    in opposite y directions."""
    frame = torsion_tee()
    _, shapes = our_modes(frame, False, 1)
    top = list(frame.nodes).index(3)
    tip_a, tip_b = list(frame.nodes).index(4), list(frame.nodes).index(5)
    u = shapes[:, 0].reshape(-1, 6)
    assert abs(u[top, 5]) * 0.8 == pytest.approx(abs(u[tip_a, 1]), rel=0.05)
    assert u[tip_a, 1] * u[tip_b, 1] < 0
    assert abs(u[top, 0]) < 0.05 * abs(u[tip_a, 1]) and abs(u[top, 1]) < 0.05 * abs(u[tip_a, 1])


def test_opensees_torsional_mass_is_rho_j():
    """Without the J' = Iy + Iz mapping OpenSees' frequencies of the tee differ (its torsional
    mass is rho J): the mapping in `opensees_modes` is needed, and the kernels do use the polar
    moment."""
    frame = torsion_tee()
    f_ours, _ = our_modes(frame, False)
    f_os, _ = opensees_modes(frame, False, map_torsional_mass=False)
    assert np.max(np.abs(f_os / f_ours - 1)) > 1e-3


# --- closed forms -----------------------------------------------------------------------

BETA_1 = 1.8751040687119611  # first root of cos(b) cosh(b) = -1


@pytest.mark.parametrize("vecxz", [(0.0, 0.0, 1.0), (0.0, 1.0, 0.0), (0.0, 0.6, 0.8)])
def test_cantilever_bending_both_axes(vecxz):
    """A 24-element Euler-Bernoulli cantilever along x: its two lowest modes bend about the
    strong and the weak axis, at beta_1^2 sqrt(E I / (rho A L^4)) / 2 pi (to 1e-6: the cubic
    element's discretisation error), each in the plane its inertia says."""
    L, p = 2.0, STEEL_COL
    frame = Frame({k + 1: (L * k / 24, 0.0, 0.0) for k in range(25)},
                  [(k + 1, k + 1, k + 2, p, vecxz) for k in range(24)], _fixed_all(1), {})
    f, shapes = our_modes(frame, False, 6)
    r = beam3d.rotation(np.zeros((1, 3)), np.array([[1.0, 0.0, 0.0]]), np.array([vecxz]))[0]
    tip = r @ shapes[-6:-3]  # tip translations in local axes
    # bending modes: no twist (the section is open, so a torsion mode comes between them);
    # the eigensolver leaves a few 1e-9 of the neighbouring modes in each
    bending = np.flatnonzero(np.abs(shapes[3::6]).max(axis=0) < 1e-6 * np.abs(shapes).max(axis=0))[:2]
    f_iz = BETA_1**2 * np.sqrt(p.E * p.Iz / (p.rho * p.A * L**4)) / (2 * np.pi)
    f_iy = BETA_1**2 * np.sqrt(p.E * p.Iy / (p.rho * p.A * L**4)) / (2 * np.pi)
    np.testing.assert_allclose(f[bending], [f_iz, f_iy], rtol=1e-6)
    # the weak-axis mode (Iz) moves along local y, the strong-axis mode (Iy) along local z
    first, second = tip[:, bending[0]], tip[:, bending[1]]
    np.testing.assert_allclose(np.abs(first) / np.linalg.norm(first), [0, 1, 0], atol=1e-7)
    np.testing.assert_allclose(np.abs(second) / np.linalg.norm(second), [0, 0, 1], atol=1e-7)


def test_torsion_of_a_shaft():
    """A fixed-free circular shaft (J = Iy + Iz) of n equal elements: its torsional modes are
    those of the discrete rod with consistent mass, omega^2 = 6 (G / rho) / h^2 (1 - cos k h) /
    (2 + cos k h) with k = (2 m - 1) pi / (2 L) (to 1e-8), and they tend to the continuous
    (2 m - 1) / (4 L) sqrt(G / rho) Hz (the first to 2e-5 with 100 elements)."""
    L, d, n_el = 1.5, 0.04, 100
    ip = np.pi * d**4 / 32
    p = Prop(E=2.0e11, G=7.69e10, rho=7850.0, A=np.pi * d**2 / 4, Iy=ip / 2, Iz=ip / 2, J=ip)
    frame = Frame({k + 1: (0.0, 0.0, L * k / n_el) for k in range(n_el + 1)},
                  [(k + 1, k + 1, k + 2, p, (1.0, 0.0, 0.0)) for k in range(n_el)], _fixed_all(1), {})
    f, shapes = our_modes(frame, False, 30)
    twist = np.abs(shapes.reshape(-1, 6, 30)[:, 5, :]).sum(axis=0)
    total = np.abs(shapes.reshape(-1, 6, 30)).sum(axis=(0, 1))
    torsional = np.flatnonzero(twist > 0.99 * total)[:3]
    assert len(torsional) == 3
    kh = (2 * np.arange(1, 4) - 1) * np.pi / (2 * L) * (L / n_el)
    discrete = np.sqrt(6 * p.G / p.rho / (L / n_el) ** 2 * (1 - np.cos(kh)) / (2 + np.cos(kh))) / (2 * np.pi)
    np.testing.assert_allclose(f[torsional], discrete, rtol=1e-8)  # the dense solver: ~1e-9
    continuous = (2 * np.arange(1, 4) - 1) / (4 * L) * np.sqrt(p.G / p.rho)
    # the discretisation error (k h)^2 / 24: 1e-5 for the first mode
    assert np.all(np.abs(f[torsional] / continuous - 1) < 1.1 * kh**2 / 24)
    assert abs(f[torsional[0]] / continuous[0] - 1) < 2e-5


def test_axial_and_torsion_of_one_element_exactly():
    """One element, fixed at node i: the axial and torsional frequencies are sqrt(3 E / rho) / L
    and sqrt(3 G J / (rho Ip)) / L rad/s (the element's own closed forms)."""
    p, L = STEEL_BEAM, 0.9
    frame = Frame({1: (0.0, 0.0, 0.0), 2: (0.0, L, 0.0)}, [(1, 1, 2, p, (0.0, 0.0, 1.0))], _fixed_all(1), {})
    f, _ = our_modes(frame, False, 6)
    omega = 2 * np.pi * f
    axial = np.sqrt(3 * p.E / p.rho) / L
    torsion = np.sqrt(3 * p.G * p.J / (p.rho * (p.Iy + p.Iz))) / L
    assert np.min(np.abs(omega / axial - 1)) < 1e-12
    assert np.min(np.abs(omega / torsion - 1)) < 1e-12


# --- element properties -----------------------------------------------------------------

def _random_members(n: int, seed: int = 3):
    rng = np.random.default_rng(seed)
    start = rng.normal(size=(n, 3))
    end = start + rng.normal(size=(n, 3))
    vec = rng.normal(size=(n, 3))
    return start, end, vec, rng


def test_rotation_is_orthonormal_right_handed_and_follows_vecxz():
    start, end, vec, _ = _random_members(50)
    r = beam3d.rotation(start, end, vec)
    np.testing.assert_allclose(r @ np.swapaxes(r, 1, 2), np.broadcast_to(np.eye(3), r.shape), atol=1e-14)
    np.testing.assert_allclose(np.linalg.det(r), 1.0, atol=1e-14)
    d = end - start
    np.testing.assert_allclose(r[:, 0], d / np.linalg.norm(d, axis=1)[:, None], atol=1e-15)
    # vecxz lies in the local x-z plane, on the positive z side
    np.testing.assert_allclose(np.einsum("ij,ij->i", r[:, 1], vec), 0.0, atol=1e-13)
    assert np.all(np.einsum("ij,ij->i", r[:, 2], vec) > 0)


def test_rotation_rejects_vecxz_parallel_to_the_member():
    with pytest.raises(ValueError, match=r"parallel to the member .* position\(s\) \[1\]"):
        beam3d.rotation(np.zeros((2, 3)), np.array([[0, 0, 1.0], [0, 0, 2.0]]), np.array([[1.0, 0, 0], [0, 0, -3.0]]))
    with pytest.raises(ValueError, match="zero-length"):
        beam3d.rotation(np.zeros((1, 3)), np.zeros((1, 3)), np.array([[1.0, 0, 0]]))


def _rigid_motions(start, end):
    """The 6 rigid-body motions of each element's 12 end DOFs (n, 12, 6)."""
    n = start.shape[0]
    out = np.zeros((n, 12, 6))
    for node, at in ((0, start), (6, end)):
        for a in range(3):
            out[:, node + a, a] = 1.0  # translations
            out[:, node + 3 + a, 3 + a] = 1.0  # rotation about global axis a
        # translation from a small rotation theta about the origin: theta x r
        for a in range(3):
            e = np.zeros(3)
            e[a] = 1.0
            out[:, node:node + 3, 3 + a] = np.cross(e, at)
    return out


@pytest.mark.parametrize("timoshenko", [False, True])
def test_rigid_body_motions_cost_nothing_and_mass_is_right(timoshenko):
    start, end, vec, rng = _random_members(20)
    n = 20
    length = beam3d.lengths(start, end)
    area, iy, iz = rng.uniform(1e-3, 1e-2, n), rng.uniform(1e-6, 1e-5, n), rng.uniform(1e-6, 1e-5, n)
    phi_y, phi_z = (beam3d.shear_ratios(length, iy, iz, 0.8 * area, np.full(n, 0.4)) if timoshenko
                    else (np.zeros(n), np.zeros(n)))
    t = beam3d.transformation(beam3d.rotation(start, end, vec))
    k = beam3d.to_global(beam3d.local_stiffness(length, area, iy, iz, 0.4 * 0.5 * (iy + iz), phi_y, phi_z), t)
    m = beam3d.to_global(beam3d.local_mass(length, area, iy, iz, iy + iz, phi_y, phi_z, timoshenko), t)
    rigid = _rigid_motions(start, end)
    scale = np.abs(k).max(axis=(1, 2))[:, None, None]
    np.testing.assert_allclose(k @ rigid / scale, 0.0, atol=1e-12)
    np.testing.assert_allclose(k, np.swapaxes(k, 1, 2), rtol=0, atol=1e-12 * scale.max())
    assert np.all(np.linalg.eigvalsh(m) > 0)
    # a unit translation in any direction carries the member's mass rho A L
    for a in range(3):
        np.testing.assert_allclose(np.einsum("ei,eij,ej->e", rigid[:, :, a], m, rigid[:, :, a]), area * length,
                                   rtol=1e-12)


def test_timoshenko_with_no_shear_and_no_rotary_inertia_is_euler_bernoulli():
    start, end, vec, rng = _random_members(10)
    length = beam3d.lengths(start, end)
    a, iy, iz = rng.uniform(1e-3, 1e-2, 10), rng.uniform(1e-6, 1e-5, 10), rng.uniform(1e-6, 1e-5, 10)
    zero = np.zeros(10)
    # huge shear area: phi -> 0
    phi_y, phi_z = beam3d.shear_ratios(length, iy, iz, a * 1e12, np.full(10, 0.4))
    assert np.all(phi_y < 1e-12)
    k_t = beam3d.local_stiffness(length, a, iy, iz, iy, phi_y, phi_z)
    k_e = beam3d.local_stiffness(length, a, iy, iz, iy, zero, zero)
    np.testing.assert_allclose(k_t, k_e, rtol=1e-10, atol=1e-10 * np.abs(k_e).max())
    m_t = beam3d.local_mass(length, a, iy, iz, iy + iz, phi_y, phi_z, rotary=False)
    m_e = beam3d.local_mass(length, a, iy, iz, iy + iz, zero, zero, rotary=False)
    np.testing.assert_allclose(m_t, m_e, rtol=1e-10, atol=1e-10 * np.abs(m_e).max())


def test_weighted_stiffness_is_the_planar_one_in_each_plane():
    """A modulus profile: w = (1, 1, 1) is the uniform element; otherwise each bending plane
    is beam2d.weighted_stiffness of its inertia (the x-z plane with its rotations negated),
    the axial bar that of the area, torsion G J / L times the mean of w."""
    from fe_problem.elements import beam2d

    start, end, vec, rng = _random_members(8)
    length = beam3d.lengths(start, end)
    a, iy, iz, tj = (rng.uniform(1e-3, 1e-2, 8), rng.uniform(1e-6, 1e-5, 8), rng.uniform(1e-6, 1e-5, 8),
                     rng.uniform(1e-7, 1e-6, 8))
    zero = np.zeros(8)
    np.testing.assert_allclose(beam3d.weighted_stiffness(length, a, iy, iz, tj, (1.0, 1.0, 1.0)),
                               beam3d.local_stiffness(length, a, iy, iz, tj, zero, zero), rtol=1e-12, atol=1e-9)
    w = (0.2, 0.7, 1.0)
    k = beam3d.weighted_stiffness(length, a, iy, iz, tj, w)
    xy, xz = beam2d.weighted_stiffness(length, a, iz, w), beam2d.weighted_stiffness(length, a, iy, w)
    bend = [1, 2, 4, 5]
    np.testing.assert_allclose(k[:, beam3d.PLANE_XY[:, None], beam3d.PLANE_XY], xy[:, np.ix_(bend, bend)[0], bend])
    sign = np.array([1, -1, 1, -1])
    np.testing.assert_allclose(k[:, beam3d.PLANE_XZ[:, None], beam3d.PLANE_XZ],
                               sign[:, None] * sign * xz[:, np.ix_(bend, bend)[0], bend])
    np.testing.assert_allclose(k[:, 0, 0], xy[:, 0, 0])
    np.testing.assert_allclose(k[:, 3, 3], 0.65 * tj / length)
    np.testing.assert_allclose(k[:, 3, 9], -0.65 * tj / length)


def test_interpolation_reproduces_ends_rigid_motions_and_bending_shapes():
    start, end, vec, rng = _random_members(15)
    r = beam3d.rotation(start, end, vec)
    length = beam3d.lengths(start, end)
    xi = np.linspace(0, 1, 7)
    smooth = np.ones(15, dtype=bool)
    # end values are reproduced
    ends = rng.normal(size=(15, 12))
    for s in (smooth, ~smooth):
        d = beam3d.interpolate(length, r, ends, s, xi)
        np.testing.assert_allclose(d[:, 0], ends[:, 0:3], atol=1e-14)
        np.testing.assert_allclose(d[:, -1], ends[:, 6:9], atol=1e-14)
    # a small rigid rotation theta about the origin: theta x position all along
    rigid = _rigid_motions(start, end)
    theta = rng.normal(size=(15, 3))
    ends = np.einsum("eij,ej->ei", rigid[:, :, 3:], theta)
    along = start[:, None, :] + xi[None, :, None] * (end - start)[:, None, :]
    np.testing.assert_allclose(beam3d.interpolate(length, r, ends, smooth, xi), np.cross(theta[:, None, :], along),
                               atol=1e-13)
    # a cantilever tip rotation theta_y alone at node j (local): w = L (xi^3 - xi^2) (-theta_y)
    local_end = np.zeros((15, 12))
    local_end[:, 10] = 1e-3
    ends = np.einsum("eki,ek->ei", beam3d.transformation(r), local_end)  # T^T local
    d = beam3d.interpolate(length, r, ends, smooth, xi)
    w = np.einsum("epb,eb->ep", d, r[:, 2])
    np.testing.assert_allclose(w, -1e-3 * length[:, None] * (xi**3 - xi**2), atol=1e-15)
    np.testing.assert_allclose(np.einsum("epb,eb->ep", d, r[:, 1]), 0.0, atol=1e-15)


# --- the shipped example, read as plain JSON ----------------------------------------------

def frame_from_file(path) -> Frame:
    """A model file of the 3-D form (docs/model-format.md), read here without fe_problem's
    reader: nodes, elements with their orientation, lumped masses and supports."""
    import json

    d = json.loads(open(path).read())
    assert d["dimension"] == 3
    props = {}
    for e in d["elements"]:
        mat, sec = d["materials"][e["material"]], d["sections"][e["section"]]
        props[e["id"]] = Prop(E=mat["youngs_modulus_pa"], G=mat["shear_modulus_pa"], rho=mat["density_kg_m3"],
                              A=sec["area_m2"], Iy=sec["iy_m4"], Iz=sec["iz_m4"], J=sec["j_m4"])
    names = ("x", "y", "z", "rx", "ry", "rz")
    return Frame({n["id"]: (n["x"], n["y"], n["z"]) for n in d["nodes"]},
                 [(e["id"], *e["nodes"], props[e["id"]], tuple(e["orientation"])) for e in d["elements"]],
                 {s["node"]: tuple(int(k in s["directions"]) for k in names) for s in d["supports"]},
                 {m["node"]: m["mass_kg"] for m in d["masses"]})


def test_shipped_frame3d_file_matches_opensees():
    """The shipped 2 x 2-bay, 4-storey steel frame, read from its file: the kernels and
    OpenSees agree on its 10 lowest modes, which lie where a building of this size has them
    (first mode 1-3 Hz)."""
    from fe_problem.shipped import SHIPPED_DIR

    frame = frame_from_file(SHIPPED_DIR / "frame3d.model.json")
    f_ours, s_ours = our_modes(frame, False)
    f_os, s_os = opensees_modes(frame, False)
    np.testing.assert_allclose(f_ours, f_os, rtol=1e-8, atol=0)
    assert mac_diagonal(s_ours, s_os).min() > 1 - 1e-10
    assert 1.0 < f_ours[0] < 3.0
