"""Hidden-effect cases for the diagnosis tests and the README's confusion matrix.

Each truth model is built differently from the candidate extensions that the diagnosis
fits, so the diagnosis is never checked against itself:

- crack: a rotational spring at a random point inside an element (the cracked-beam element,
  no new node); the candidates are a reduced modulus over the whole element, or a zone of
  reduced bending stiffness a section depth wide at one of seven fixed positions (never a
  point, never at the crack's own position).
- joint: the member's end moved to a second node at the same place, tied to the joint node
  by stiff x/y springs and a rotational spring; the candidate releases the element end.
- mass: a lumped mass with the rotary inertia of a 2 cm block, in the model file; the
  candidate is a mass parameter without rotary inertia.
- shear: Timoshenko elements with a shear coefficient set to give the size; the candidate
  scales the shear parameter of the section's nominal coefficient.

Sizes: the effect's magnitude is found by bisection so that the largest shift of the first
8 frequencies from the nominal model is a random target in [1.5 %, 6 %]. Places are random
(crack position uniform in [0.15, 0.85] of the element: a crack at an element's very end
is physically a joint, and its name would be a matter of taste). Effects stay physical: a
crack no deeper than 3/4 of the section (rotational stiffness >= CRACK_MIN_STIFFNESS) and a
mass of at most MAX_MASS_KG; a place where such an effect cannot reach the target size
(a crack next to a free end, a mass on a node that hardly moves) is drawn again.
Measurements: 8 modes, the 15 measured coordinates, 0.2 % frequency noise, 2 % shape noise
(of each mode's largest entry, the diagnosis's convention), random sign and scale.

The further classes (`MORE`, built the same way, each truth unlike its candidate):

- two_effects: a crack (as above) and a lumped mass with rotary inertia at a node at least
  0.3 m away, each sized to its own random shift in [1.5 %, 6 %].
- soft_support: the free frame hung on a soft rod: a new grounded node 5 cm away tied to a
  node by an axial bar of stiffness k (the candidate is a spring to ground); the suspension
  modes this creates are measured too, as a test would.
- spread_mass: the element split in four with a lumped mass (and rotary inertia) at each of
  its three inner points and half a share at its ends (the candidate scales its density);
  elements whose split alone moves a frequency by 0.5 % (elements 11 and 12 of the H-frame:
  5-9 %, the coarse mesh's own error) are not used.
- stiffer_member: one element's section inertia larger (a section drawn too thin; the
  candidate scales its modulus, axial stiffness too).
- sparse: a crack, mass or joint case measured at 8 of the 15 coordinates; sparse_none: no
  effect at 8 coordinates.
- portal: a user-written portal frame (two fixed columns, a beam, 4 elements per member)
  saved as a model file, data naming that file, a crack, mass or stiffer member in it;
  portal_none: no effect.
- cantilever: a clamped bar in 8 elements (no joint), a crack, mass or stiffer member;
  building: a three-storey one-bay laboratory shear building (`regular_frame`, members in two
  elements, floor masses, sensors at the floors), a crack, mass or flexible joint (a
  semi-rigid beam-column connection, built as above); `_none`: no effect. Each is saved as a
  model file that the data name, as the portal is.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

import fe_problem as fp
from fe_problem.diagnosis.candidates import joint_nodes
from fe_problem.model import Element, FrameModel, Material, Node, Section, Spring, Support

N_MODES = 8
FREQ_NOISE = 0.002
SHAPE_NOISE = 0.02
TRANSLATION_TIE = 1e12  # N/m: the joint truth's stiff x/y springs
# Local flexibility of an edge crack of depth ratio alpha (Dimarogonas & Paipetis):
# c = 5.346 h f(alpha) / (E I); for the H-frame (h = 32.2 mm) alpha = 0.5 (the paper's cuts)
# gives k = 1/c = 2.2e4 N m/rad and alpha = 0.75 gives 4.2e3 N m/rad.
CRACK_MIN_STIFFNESS = 4.0e3  # N m/rad: a crack through 3/4 of the section
MAX_MASS_KG = 0.3            # 17 % of the frame's 1.77 kg

HFRAME = fp.load_model("hframe")
NOMINAL_HZ = fp.modal_analysis(HFRAME, N_MODES).frequencies_hz


@dataclass(frozen=True)
class Case:
    """A hidden effect: what it is, where, how big, and the data it gives. `effects` lists every
    (kind, location) when there are several; `cls` is the table's class; `nominal` the model
    the diagnosis is given (None: the H-frame); `dofs` the measured coordinates (None: all)."""

    kind: str                 # one of the diagnosis kinds, or "none"
    location: dict | None     # {"element": id} or {"node": id} or None
    size_pct: float           # largest frequency shift from the nominal model, %
    truth: fp.FrameModel
    seed: int
    effects: tuple = ()
    cls: str = ""
    nominal: FrameModel | None = None
    dofs: tuple | None = None
    #: a fault of the data: ("reverse", channel) or ("swap", channel, channel), channels as (node, dir)
    fault: tuple = ()

    @property
    def truths(self) -> tuple:
        """Every hidden (kind, location)."""
        return self.effects or (() if self.kind == "none" else ((self.kind, self.location),))

    def data(self, model_name: str = "hframe") -> fp.ModalData:
        """8 modes with 0.2 % frequency noise and shape noise of 2 % of each mode's largest entry."""
        data = fp.synthetic_measurement(self.truth, N_MODES, dofs=self.dofs or (self.nominal or HFRAME).measured_dofs,
                                        freq_noise=FREQ_NOISE, shape_noise=SHAPE_NOISE, seed=self.seed,
                                        model_name=model_name)
        if not self.fault:
            return data
        shapes = data.shapes.copy()  # the fault made as a test makes it: on the data's columns
        rows = [data.dofs.index(tuple(c)) for c in self.fault[1:]]
        if self.fault[0] == "reverse":
            shapes[rows[0]] *= -1.0
        else:
            shapes[rows] = shapes[rows[::-1]]
        return dataclasses.replace(data, shapes=shapes)


def max_shift_pct(model: fp.FrameModel, nominal: FrameModel | None = None) -> float:
    """Largest shift (%) of the nominal model's first 8 modes, each paired by MAC (all of the
    nominal's measured coordinates) with the truth's modes (suspension modes pair with none)."""
    nominal = nominal or HFRAME
    ref = fp.modal_analysis(nominal, N_MODES)
    got = fp.modal_analysis(model, N_MODES + 3)
    mac = fp.mac(ref.at(nominal.measured_dofs), got.at(nominal.measured_dofs))
    return 100.0 * float(np.max(np.abs(got.frequencies_hz[mac.argmax(axis=1)] / ref.frequencies_hz - 1.0)))


def crack_truth(element: int, position: float, stiffness: float) -> fp.FrameModel:
    return fp.crack_element(HFRAME, element, position, stiffness)


def joint_truth(node: int, element: int, stiffness: float, model: FrameModel = HFRAME) -> fp.FrameModel:
    """The end of `element` at `node` re-attached to a twin node tied by springs."""
    twin = Node(max(model.node_ids) + 1, model.node(node).x, model.node(node).y)
    e = model.element(element)
    moved = dataclasses.replace(e, node_i=twin.id) if e.node_i == node else dataclasses.replace(e, node_j=twin.id)
    first = max((sp.id for sp in model.springs), default=0) + 1
    springs = (Spring(first, (node, "x"), (twin.id, "x"), TRANSLATION_TIE),
               Spring(first + 1, (node, "y"), (twin.id, "y"), TRANSLATION_TIE),
               Spring(first + 2, (node, "rz"), (twin.id, "rz"), stiffness))
    return model.replace(nodes=model.nodes + (twin,), springs=model.springs + springs,
                         elements=tuple(moved if x.id == element else x for x in model.elements))


def mass_truth(node: int, mass_kg: float) -> fp.FrameModel:
    return fp.add_mass(HFRAME, node, mass_kg, inertia_kg_m2=mass_kg * 0.02**2 / 6.0)


def shear_truth(shear_coefficient: float) -> fp.FrameModel:
    sections = {k: dataclasses.replace(v, shear_coefficient=shear_coefficient) for k, v in HFRAME.sections.items()}
    return fp.with_formulation(HFRAME, "timoshenko").replace(sections=sections)


def _sized(build, target_pct: float, lo: float, hi: float, nominal: FrameModel | None = None):
    """The magnitude (searched in log space between lo and hi) giving the target shift."""
    g = lambda t: max_shift_pct(build(np.exp(t)), nominal) - target_pct  # noqa: E731
    t = brentq(g, np.log(lo), np.log(hi), xtol=1e-6)
    return build(np.exp(t))


def make_case(kind: str, rng: np.random.Generator, seed: int) -> Case:
    """One random case of a kind ('none' and 'global' are the null cases)."""
    target = float(rng.uniform(1.5, 6.0))
    if kind == "stiffness_loss":
        while True:
            element = int(rng.choice(HFRAME.element_ids))
            pos = float(rng.uniform(0.15, 0.85))
            if max_shift_pct(crack_truth(element, pos, CRACK_MIN_STIFFNESS)) >= target:
                break
        truth = _sized(lambda k: crack_truth(element, pos, k), target, CRACK_MIN_STIFFNESS, 1e8)
        return Case(kind, {"element": element}, target, truth, seed)
    if kind == "joint_flexibility":
        node = int(rng.choice(HFRAME.joints()))
        members = [e.id for e in HFRAME.elements if node in (e.node_i, e.node_j)]
        element = int(rng.choice(members))
        truth = _sized(lambda k: joint_truth(node, element, k), target, 1e1, 1e9)
        return Case(kind, {"node": node}, target, truth, seed)
    if kind == "added_mass":
        while True:
            node = int(rng.choice(HFRAME.node_ids))
            if max_shift_pct(mass_truth(node, MAX_MASS_KG)) >= target:
                break
        truth = _sized(lambda m: mass_truth(node, m), target, 1e-4, MAX_MASS_KG)
        return Case(kind, {"node": node}, target, truth, seed)
    if kind == "shear_deformation":
        truth = _sized(shear_truth, target, 1e-3, 1e3)
        return Case(kind, None, target, truth, seed)
    if kind == "none":
        return Case("none", None, 0.0, HFRAME, seed)
    if kind == "global":  # only a global stiffness error: every model is allowed that
        factor = float(rng.uniform(0.85, 1.15))
        truth = HFRAME.with_element_moduli({e: factor * HFRAME.element_modulus_pa(e) for e in HFRAME.element_ids})
        return Case("none", None, 0.0, truth, seed)
    raise ValueError(kind)


def soft_support_truth(node: int, direction: str, stiffness: float) -> fp.FrameModel:
    """The frame hung at `node` on an axial rubber rod (length 5 cm, E = 1 MPa, the area giving
    `stiffness` N/m, nearly massless, no bending stiffness to speak of) from a grounded node.
    Every value is inside the model file's physical ranges."""
    n = HFRAME.node(node)
    ground = Node(max(HFRAME.node_ids) + 1, n.x - (0.05 if direction == "x" else 0.0),
                  n.y - (0.05 if direction == "y" else 0.0))
    youngs = 1e6
    area = stiffness * 0.05 / youngs
    rod = Material(youngs, 1e-3)
    eid = max(HFRAME.element_ids) + 1
    return HFRAME.replace(nodes=HFRAME.nodes + (ground,), materials={**HFRAME.materials, "rod": rod},
                          sections={**HFRAME.sections, "rod": Section(area, 1e-20)},
                          elements=HFRAME.elements + (Element(eid, ground.id, node, "rod", "rod"),),
                          supports=(Support(ground.id, ("x", "y", "rz")),))


def spread_mass_truth(model: FrameModel, element: int, mass_kg: float) -> fp.FrameModel:
    """`mass_kg` as lumped masses along the element: 1/4 at each of three inner points (the
    element split in four), 1/8 at each end, each with the rotary inertia of a 2 cm block."""
    e = model.element(element)
    out, ids = model, [element]
    for k in range(3):
        out = fp.split_element(out, ids[-1], 1.0 / (4 - k))
        ids.append(max(out.element_ids))
    inner = [out.element(i).node_j for i in ids[:-1]]
    for node, share in [(e.node_i, 0.125), (e.node_j, 0.125)] + [(n, 0.25) for n in inner]:
        out = fp.add_mass(out, node, share * mass_kg, inertia_kg_m2=share * mass_kg * 0.02**2 / 6.0)
    return out


def stiffer_truth(model: FrameModel, element: int, factor: float) -> fp.FrameModel:
    """One element's section inertia times `factor` (its area, so its mass, unchanged)."""
    e = model.element(element)
    sec = dataclasses.replace(model.sections[e.section], inertia_m4=factor * model.sections[e.section].inertia_m4)
    return model.replace(sections={**model.sections, f"thick{element}": sec},
                         elements=tuple(dataclasses.replace(x, section=f"thick{element}") if x.id == element else x
                                        for x in model.elements))


def portal_frame() -> FrameModel:
    """A portal frame a user might write: two 0.6 m columns fixed at the base, a 0.8 m beam,
    four elements per member, the H-frame's bar section, x and y measured at every free node."""
    pts = [(0.0, 0.15 * k) for k in range(5)] + [(0.2 * k, 0.6) for k in range(1, 5)] + \
          [(0.8, 0.6 - 0.15 * k) for k in range(1, 5)]
    nodes = tuple(Node(i + 1, x, y) for i, (x, y) in enumerate(pts))
    elements = tuple(Element(i + 1, i + 1, i + 2, "bar", "aluminium") for i in range(len(nodes) - 1))
    free = [n.id for n in nodes if n.id not in (1, len(nodes))]
    return FrameModel("portal", nodes, dict(HFRAME.materials), dict(HFRAME.sections), elements,
                      supports=(Support(1, ("x", "y", "rz")), Support(len(nodes), ("x", "y", "rz"))),
                      measured_dofs=tuple((n, d) for n in free for d in ("x", "y")),
                      description="a portal frame written for the diagnosis tests")


PORTAL = portal_frame()


def cantilever() -> FrameModel:
    """A cantilever a user might write: a 0.8 m aluminium bar of the H-frame's section clamped
    at one end, 8 elements, x and y measured at every free node (no joint anywhere)."""
    nodes = tuple(Node(i + 1, 0.1 * i, 0.0) for i in range(9))
    elements = tuple(Element(i + 1, i + 1, i + 2, "bar", "aluminium") for i in range(8))
    return FrameModel("cantilever", nodes, dict(HFRAME.materials), dict(HFRAME.sections), elements,
                      supports=(Support(1, ("x", "y", "rz")),),
                      measured_dofs=tuple((n.id, d) for n in nodes[1:] for d in ("x", "y")),
                      description="a clamped bar written for the diagnosis tests")


def shear_building() -> FrameModel:
    """A laboratory shear building: three 0.25 m storeys, one 0.3 m bay, the H-frame's bar as
    columns, floors 3 times as deep (stiff beams), a 0.2 kg floor mass at each floor node,
    fixed base, every member in two elements (`regular_frame`, `split_elements`), x and y
    measured at the floor nodes."""
    bar = HFRAME.sections["bar"]
    model = fp.regular_frame(1, 3, 0.3, 0.25, column=bar, beam=Section(3 * bar.area_m2, 27 * bar.inertia_m4),
                             material=HFRAME.materials["aluminium"], floor_mass_kg=0.2, name="building",
                             description="a shear building written for the diagnosis tests")
    return fp.split_elements(model, 2)


CANTILEVER, BUILDING = cantilever(), shear_building()
#: A user's model files (not the H-frame), each a class of cases with its null class `NAME_none`,
#: and the effects hidden in them.
USER_MODELS = {"portal": (PORTAL, ("stiffness_loss", "added_mass", "stiffness_gain")),
               "cantilever": (CANTILEVER, ("stiffness_loss", "added_mass", "stiffness_gain")),
               "building": (BUILDING, ("stiffness_loss", "added_mass", "joint_flexibility"))}


def _crack(rng, model: FrameModel, target: float) -> tuple[FrameModel, dict]:
    while True:
        element = int(rng.choice(model.element_ids))
        pos = float(rng.uniform(0.15, 0.85))
        if max_shift_pct(fp.crack_element(model, element, pos, CRACK_MIN_STIFFNESS), model) >= target:
            break
    build = lambda k: fp.crack_element(model, element, pos, k)  # noqa: E731
    return _sized(build, target, CRACK_MIN_STIFFNESS, 1e8, model), {"element": element}


def _mass(rng, model: FrameModel, target: float, base: FrameModel | None = None, far_from=None):
    base = base or model
    while True:
        node = int(rng.choice(model.node_ids))
        if far_from is not None and np.hypot(model.node(node).x - far_from[0], model.node(node).y - far_from[1]) < 0.3:
            continue
        if max_shift_pct(fp.add_mass(base, node, MAX_MASS_KG, MAX_MASS_KG * 0.02**2 / 6), base) >= target:
            break
    build = lambda m: fp.add_mass(base, node, m, inertia_kg_m2=m * 0.02**2 / 6.0)  # noqa: E731
    return _sized(build, target, 1e-4, MAX_MASS_KG, base), {"node": node}  # its own shift, from `base`


def _stiffer(rng, model: FrameModel, target: float):
    while True:
        element = int(rng.choice(model.element_ids))
        if max_shift_pct(stiffer_truth(model, element, 4.0), model) >= target:
            break
    return _sized(lambda f: stiffer_truth(model, element, f), target, 1.0001, 4.0, model), {"element": element}


def _joint(rng, model: FrameModel, target: float):
    while True:  # joint_nodes: only where members meet; the truth is built unlike the candidate
        node = int(rng.choice(joint_nodes(model)))
        element = int(rng.choice([e.id for e in model.elements if node in (e.node_i, e.node_j)]))
        if max_shift_pct(joint_truth(node, element, 1e1, model), model) >= target:
            break
    return _sized(lambda k: joint_truth(node, element, k, model), target, 1e1, 1e9, model), {"node": node}


def make_more(cls: str, rng: np.random.Generator, seed: int) -> Case:
    """One random case of a further class (see the module docstring)."""
    target = float(rng.uniform(1.5, 6.0))
    if cls == "two_effects":
        cracked, place = _crack(rng, HFRAME, target)
        mid = HFRAME.node(cracked.element(place["element"]).node_i)
        both, node = _mass(rng, HFRAME, float(rng.uniform(1.5, 6.0)), base=cracked, far_from=(mid.x, mid.y))
        return Case("stiffness_loss", place, target, both, seed, (("stiffness_loss", place), ("added_mass", node)), cls)
    if cls == "soft_support":
        while True:  # a support where even a stiff rod cannot reach the target is drawn again
            node, direction = int(rng.choice(HFRAME.node_ids)), str(rng.choice(["x", "y"]))
            if max_shift_pct(soft_support_truth(node, direction, 1e7)) >= target:
                break
        truth = _sized(lambda k: soft_support_truth(node, direction, k), target, 1.0, 1e7)
        return Case("boundary_stiffness", {"node": node}, target, truth, seed, cls=cls)
    if cls == "spread_mass":
        while True:  # elements whose split alone moves a frequency by 0.5 % are left out (mesh error)
            element = int(rng.choice(HFRAME.element_ids))
            if max_shift_pct(spread_mass_truth(HFRAME, element, 1e-9)) < 0.5 and \
                    max_shift_pct(spread_mass_truth(HFRAME, element, MAX_MASS_KG)) >= target:
                break
        truth = _sized(lambda m: spread_mass_truth(HFRAME, element, m), target, 1e-4, MAX_MASS_KG)
        return Case("distributed_mass", {"element": element}, target, truth, seed, cls=cls)
    if cls == "stiffer_member":
        truth, place = _stiffer(rng, HFRAME, target)
        return Case("stiffness_gain", place, target, truth, seed, cls=cls)
    if cls in ("sparse", "sparse_none"):
        base = make_case(str(rng.choice(["stiffness_loss", "added_mass", "joint_flexibility"])) if cls == "sparse"
                         else "none", rng, seed)
        dofs = tuple(HFRAME.measured_dofs[i] for i in sorted(rng.choice(len(HFRAME.measured_dofs), 8, replace=False)))
        return dataclasses.replace(base, cls=cls, dofs=dofs)
    if cls in USER_MODELS:
        model, kinds = USER_MODELS[cls]
        pick = str(rng.choice(list(kinds)))
        build = {"stiffness_loss": _crack, "added_mass": _mass, "stiffness_gain": _stiffer, "joint_flexibility": _joint}
        truth, place = build[pick](rng, model, target)
        return Case(pick, place, target, truth, seed, cls=cls, nominal=model)
    if cls.endswith("_none") and cls[:-5] in USER_MODELS:
        model = USER_MODELS[cls[:-5]][0]
        return Case("none", None, 0.0, model, seed, cls=cls, nominal=model)
    raise ValueError(cls)


# == the classes of real structures (issue 19): patterns, model-form errors, data faults ========
def storey_gradient_truth(model: FrameModel, drop: float) -> FrameModel:
    """The columns of storey k (0 at the base, of n) with their moduli times 1 - drop (n - 1 - k) / (n - 1),
    written as element moduli in the model file: the bottom storey softest, the top one nominal."""
    floors = sorted({round(model.node(e.node_i).y, 9) for e in model.elements
                     if model.node(e.node_i).y == model.node(e.node_j).y})
    n = len(floors)
    moduli = {}
    for e in model.elements:
        a, b = model.node(e.node_i), model.node(e.node_j)
        if a.x != b.x:
            continue
        k = sum(f < 0.5 * (a.y + b.y) for f in floors)  # storeys below: 0 for the bottom storey
        moduli[e.id] = model.element_modulus_pa(e.id) * (1.0 - drop * (n - 1 - k) / max(n - 1, 1))
    return model.with_element_moduli(moduli)


def moved_node_truth(model: FrameModel, node: int, dx: float, dy: float) -> FrameModel:
    """A node `dx`, `dy` metres from where the model has it (the coordinates edited)."""
    return model.replace(nodes=tuple(dataclasses.replace(n, x=n.x + dx, y=n.y + dy) if n.id == node else n
                                     for n in model.nodes))


def thinner_truth(model: FrameModel, element: int, depth_factor: float) -> FrameModel:
    """One member's rectangular section `depth_factor` as deep: area (so mass) times f, inertia f^3."""
    e = model.element(element)
    sec = model.sections[e.section]
    thin = dataclasses.replace(sec, area_m2=depth_factor * sec.area_m2, inertia_m4=depth_factor**3 * sec.inertia_m4)
    return model.replace(sections={**model.sections, f"thin{element}": thin},
                         elements=tuple(dataclasses.replace(x, section=f"thin{element}") if x.id == element else x
                                        for x in model.elements))


def springs_truth(model: FrameModel, places, stiffness) -> FrameModel:
    """Springs to ground at (node, direction) `places`, each of its stiffness (N/m), as model springs
    to a new grounded node each."""
    out = model
    for (node, d), k in zip(places, stiffness):
        ground = Node(max(out.node_ids) + 1, out.node(node).x, out.node(node).y)
        sid = max((sp.id for sp in out.springs), default=0) + 1
        out = out.replace(nodes=out.nodes + (ground,), springs=out.springs + (Spring(sid, (node, d), (ground.id, d), k),),
                          supports=out.supports + (Support(ground.id, ("x", "y", "rz")),))
    return out


def make_real(cls: str, rng: np.random.Generator, seed: int) -> Case:
    """One case of a class of `REAL` (the truth built by editing the model file or the data)."""
    target = float(rng.uniform(1.5, 6.0))
    if cls == "storey_gradient":
        truth = _sized(lambda g: storey_gradient_truth(BUILDING, g), target, 1e-3, 0.6, BUILDING)
        return Case("distributed", {"group": "storeys"}, target, truth, seed, cls=cls, nominal=BUILDING)
    if cls == "moved_node":
        node = int(rng.choice([n for n in HFRAME.joints()]))
        dist = float(rng.uniform(0.005, 0.02))
        d = ("x", "y")[int(rng.integers(2))]
        truth = moved_node_truth(HFRAME, node, dist if d == "x" else 0.0, dist if d == "y" else 0.0)
        return Case("model_form", {"node": node}, max_shift_pct(truth), truth, seed, cls=cls)
    if cls == "thinner_member":
        element = int(rng.choice(HFRAME.element_ids))
        truth = thinner_truth(HFRAME, element, 1.0 - float(rng.uniform(0.02, 0.06)))
        return Case("model_form", {"element": element}, max_shift_pct(truth), truth, seed, cls=cls)
    if cls == "two_springs":
        while True:
            nodes = [int(n) for n in rng.choice(HFRAME.node_ids, 2, replace=False)]
            dirs = [str(rng.choice(["x", "y"])) for _ in nodes]
            if all(max_shift_pct(springs_truth(HFRAME, [(n, d)], [1e6])) >= 3.0 for n, d in zip(nodes, dirs)):
                break
        first = _sized(lambda k: springs_truth(HFRAME, [(nodes[0], dirs[0])], [k]), target, 1.0, 1e6)
        k0 = first.springs[-1].stiffness
        second = _sized(lambda k: springs_truth(HFRAME, list(zip(nodes, dirs)), [k0, k]), float(rng.uniform(1.5, 6.0)),
                        1.0, 1e6, first)
        return Case("boundary_stiffness", {"node": nodes[0]}, target, second, seed,
                    (("boundary_stiffness", {"node": nodes[0]}), ("boundary_stiffness", {"node": nodes[1]})), cls)
    if cls == "separated_members":
        # 2 or 3 members, no two sharing a node, each one's section inertia times a factor in [0.7, 0.85]
        # (the bending stiffness alone; the sparse class scales each member's modulus)
        while True:
            chosen = [int(e) for e in rng.choice(HFRAME.element_ids, int(rng.integers(2, 4)), replace=False)]
            nodes = [n for e in chosen for n in (HFRAME.element(e).node_i, HFRAME.element(e).node_j)]
            if len(set(nodes)) == len(nodes):
                break
        truth = HFRAME
        for e in chosen:
            truth = stiffer_truth(truth, e, float(rng.uniform(0.7, 0.85)))
        return Case("stiffness_loss", {"element": chosen[0]}, max_shift_pct(truth), truth, seed,
                    tuple(("stiffness_loss", {"element": e}) for e in chosen), cls)
    if cls in ("reversed_channel", "swapped_channels"):
        channels = [tuple(HFRAME.measured_dofs[i]) for i in rng.choice(len(HFRAME.measured_dofs), 2, replace=False)]
        fault = ("reverse", channels[0]) if cls == "reversed_channel" else ("swap", *channels)
        return Case("data_fault", {"channels": [list(c) for c in fault[1:]]}, 0.0, HFRAME, seed, cls=cls, fault=fault)
    raise ValueError(cls)


#: The classes of real structures and how many cases of each the tables use.
REAL = {"storey_gradient": 4, "moved_node": 4, "thinner_member": 4, "two_springs": 4, "reversed_channel": 4,
        "swapped_channels": 4, "separated_members": 4}


#: A truth's member is required of the answer when its own effect on the data reaches Currie's
#: detection limit for one parameter (a chi^2 test at alpha = 0.05 finds it in 1 - beta = 95 % of
#: noise draws): noncentrality (z_0.975 + z_0.95)^2 = (1.960 + 1.645)^2 = 13.0.
DETECTABLE = 13.0


def detection_limit(dof: int) -> float:
    """Currie's detection limit for `dof` parameters: the noncentrality lambda at which a chi^2 test
    of `dof` degrees of freedom at alpha = 0.05 finds the effect in 95 % of noise draws
    (scipy's noncentral chi^2; 12.99 for one, `DETECTABLE`)."""
    from scipy.optimize import brentq
    from scipy.stats import chi2, ncx2

    critical = chi2.ppf(0.95, dof)
    return float(brentq(lambda lam: ncx2.sf(critical, dof, lam) - 0.95, 1e-6, 1e3))


def without_change(case: Case, *elements: int) -> FrameModel:
    """The case's truth with these members' sections put back to the nominal model's."""
    nominal = case.nominal or HFRAME
    return case.truth.replace(elements=tuple(
        dataclasses.replace(x, section=nominal.element(x.id).section) if x.id in elements else x
        for x in case.truth.elements))


def own_effect(case: Case, *elements: int) -> float:
    """Truth members' own effect on the data, measured with the truth model alone: chi^2 of the
    truth's noise-free modes (the case's modes, coordinates and noise levels) against the truth
    with those members' sections put back to the nominal model's (`without_change`), the global
    stiffness-to-mass scale fitted (`calibrate`: no candidate of the diagnosis is fitted). It is the
    noncentrality of the chi^2 by which the data can show the members."""
    from fe_problem.diagnosis.core import calibrate

    clean = fp.synthetic_measurement(case.truth, N_MODES, dofs=case.dofs or (case.nominal or HFRAME).measured_dofs,
                                     freq_noise=0.0, shape_noise=0.0, seed=case.seed, model_name="truth")
    return float(calibrate(without_change(case, *elements), clean, FREQ_NOISE, SHAPE_NOISE).base.chi2)


def required_members(case: Case) -> list[int]:
    """The truth's members whose own effect reaches `DETECTABLE` (`own_effect`). Members below it
    are excused only together: when their joint effect (all of them undone at once) reaches the
    detection limit for as many parameters (`detection_limit`), every one of them is required."""
    members = sorted(loc["element"] for _, loc in case.truths)
    below = [e for e in members if own_effect(case, e) < DETECTABLE]
    if len(below) > 1 and own_effect(case, *below) >= detection_limit(len(below)):
        below = []
    return [e for e in members if e not in below]


def classify_real(case: Case, record: dict) -> str:
    """'right', 'honest', 'missed' or 'wrong' for a class of `REAL`:
    - a data fault: right when `data_checks` names it with its channels; otherwise wrong when a
      confident (adequate, identifiable) cause is named, else missed;
    - a storey pattern: right when the best class by evidence is a distributed one that includes the
      softest storey's columns, or "every storey free"; honest when the answer is not adequate, or
      the record says the change may be spread over members; else wrong;
    - a model-form error (a moved node, a thinner member): right when the answer (the best class
      by evidence) is that model-form class at the truth's node or element; a model-form answer
      elsewhere is wrong when adequate and decisive, else honest; otherwise honest when the answer
      is none, not adequate, not identifiable, flagged implausible, or the record says a model-form
      class explains the data as well ("model form: ..."); a confident local cause without that is
      wrong;
    - separated members (2-3 members softer): right when the best class by evidence is the sparse
      class whose members, or the causes named (each a stiffness loss, confident), are truth
      members and include every required one (`required_members`: those whose own effect on the
      data reaches Currie's detection limit, `DETECTABLE`; a member below it cannot be shown by
      these data and is not required, but a named member outside the truth is never excused);
      else honest when not confident; else wrong;
    - two springs: as `classify`.
    A storey pattern is right too when the best class is the sparse one and its members include
    every column of the softest storey."""
    confident = record["adequate"] and record["cause"]["kind"] not in ("none", "undetermined") and all(
        c["identifiable"] and c.get("plausible", True) for c in record["causes"])
    if case.kind == "data_fault":
        kind = "channel_polarity" if case.fault[0] == "reverse" else "channel_swap"
        hit = any(c["kind"] == kind and sorted(map(tuple, c["where"]["channels"])) == sorted(case.fault[1:])
                  for c in record["data_checks"])
        return "right" if hit else ("wrong" if confident else "missed")
    if case.kind == "distributed":
        best = record["evidence"]["classes"][0]
        if best["family"] == "distributed" and "storey1" in best["label"] + str(best["estimate"].get("members")) \
                and "loss" in best["label"]:
            return "right"
        if best["family"] == "distributed" and best["label"].startswith("stiffness_trend@trend=linear_height+"):
            return "right"
        if best["family"] == "distributed" and best["label"].startswith("every_storey_free@"):
            return "right"  # every storey's stiffness fitted: the gradient itself
        if best["family"] == "sparse" and set(_softest_storey(case.nominal)) <= set(best["estimate"]["members"]):
            return "right"
        spread = any("spread over several members" in w for w in record["warnings"])
        return "honest" if not confident or spread else "wrong"
    if case.cls == "separated_members":
        best = record["evidence"]["classes"][0]
        members, required = {loc["element"] for _, loc in case.truths}, set(required_members(case))

        def names(found) -> bool:  # the truth's members, each once, every required one among them
            return len(set(found)) == len(found) and required <= set(found) <= members

        if best["family"] == "sparse" and names(best["estimate"]["members"]):
            return "right"
        if confident and names([(c["location"] or {}).get("element", -1) for c in record["causes"]]) \
                and all(c["kind"] == "stiffness_loss" for c in record["causes"]):
            return "right"
        return "wrong" if confident else "honest"
    if case.kind == "model_form":
        answer = record.get("answer") or {}
        if answer.get("family") == "model_form":
            kind = "node_position" if case.cls == "moved_node" else "member_depth"
            (_, place), = case.truths
            at = answer["kind"] == kind and all((answer["location"] or {}).get(k) == v for k, v in place.items())
            if at:
                return "right"
            return "wrong" if record["adequate"] and answer["decisive"] else "honest"
        flagged = any(w.startswith("model form:") for w in record["warnings"])
        return "wrong" if confident and record["causes"] and not flagged else "honest"
    return classify(case, record)


def _softest_storey(model: FrameModel) -> list[int]:
    """The columns of the bottom storey (`storey_gradient_truth`'s softest)."""
    floors = sorted({round(model.node(e.node_i).y, 9) for e in model.elements
                     if model.node(e.node_i).y == model.node(e.node_j).y})
    return [e.id for e in model.elements if model.node(e.node_i).x == model.node(e.node_j).x
            and 0.5 * (model.node(e.node_i).y + model.node(e.node_j).y) < floors[0]]


#: How many cases of each kind the suite runs (40 with an effect, 20 without).
PLAN = {"stiffness_loss": 12, "added_mass": 10, "joint_flexibility": 10, "shear_deformation": 8,
        "none": 10, "global": 10}
#: The further classes and how many cases of each the README's tables use.
MORE = {"two_effects": 10, "soft_support": 8, "spread_mass": 8, "stiffer_member": 8, "sparse": 10,
        "sparse_none": 20, "portal": 8, "portal_none": 4, "cantilever": 6, "cantilever_none": 4, "building": 6,
        "building_none": 4}


def cases(seed: int = 2026, plan: dict | None = None) -> list[Case]:
    """The cases of a seed: `plan` maps a kind of `PLAN` or a class of `MORE` to a count."""
    rng = np.random.default_rng(seed)
    out = []
    for kind, n in (plan or PLAN).items():
        for _ in range(n):
            sub = int(rng.integers(2**31))
            out.append(make_real(kind, rng, sub) if kind in REAL else
                       make_more(kind, rng, sub) if kind in MORE else make_case(kind, rng, seed=sub))
    return out


def named_correctly(case: Case, cause: dict) -> bool:
    """Kind right and, for a placed effect, the place right (the truth's keys must match)."""
    if cause["kind"] != case.kind:
        return False
    if case.location is None:
        return cause["location"] is None
    loc = cause["location"] or {}
    return all(loc.get(k) == v for k, v in case.location.items())


def _matches(truth: tuple, kind: str, location: dict | None) -> bool:
    """A found (kind, location) names the truth (kind, location): same kind, the truth's keys equal."""
    if kind != truth[0]:
        return False
    return truth[1] is None if location is None else all((location or {}).get(k) == v for k, v in truth[1].items())


def _from_label(label: str) -> tuple[str, dict | None]:
    """('added_mass', {'node': 4}) from 'added_mass@node=4'; profiles ignored."""
    kind, _, where = label.partition("@")
    where = where.split("(")[0]
    return kind, ({k: (int(v) if v.isdigit() else v) for k, v in (p.split("=") for p in where.split(","))}
                  if where else None)


def classify(case: Case, record: dict) -> str:
    """'right' (every hidden effect named with its place, nothing else), 'honest' (undetermined,
    none or not adequate, every hidden effect among the causes, the tied or the alternatives),
    'missed' (none with an adequate fit: nothing claimed) or 'wrong' (a confident claim that is
    not the truth)."""
    named = [(c["kind"], c["location"]) for c in record["causes"] if c["identifiable"]]
    if not case.truths:
        return "right" if record["cause"]["kind"] == "none" and not named else "wrong"
    every = all(any(_matches(t, *n) for n in named) for t in case.truths)
    if every and all(any(_matches(t, *n) for t in case.truths) for n in named):
        return "right"
    unsure = record["cause"]["kind"] in ("none", "undetermined") or not record["cause"]["identifiable"] \
        or not record["adequate"] or any(not c["identifiable"] for c in record["causes"])
    listed = named + [_from_label(lab) for c in record["causes"] for lab in c.get("indistinguishable", [])] \
        + [_from_label(lab) for lab in record["cause"].get("indistinguishable", [])] \
        + [(a["kind"], a["location"]) for a in record["alternatives"][:5]]
    if unsure and all(any(_matches(t, *n) for n in listed) for t in case.truths):
        return "honest"
    return "missed" if record["cause"]["kind"] == "none" and record["adequate"] else "wrong"


def diagnose_through_cli(case: Case, directory, extra=()) -> dict:
    """Write the case's data file and run `femu diagnose FILE --json` on it, as a user would; a
    case on a user's model writes that model file too and passes it with --model."""
    import contextlib
    import io
    import json
    from pathlib import Path

    from femu.cli import main

    directory = Path(directory)
    argv = []
    name = "hframe"
    if case.nominal is not None:
        model_file = fp.save_model(case.nominal, directory / f"{case.nominal.name}.model.json")
        name, argv = model_file.name, ["--model", str(model_file)]
    path = directory / f"case-{case.cls or case.kind}-{case.seed}.json"
    fp.save_modal_data(case.data(name), path)
    args = ["diagnose", str(path), "--json", *argv, *map(str, extra)]
    cached = _cache_path(directory, args)
    if cached is not None and cached.exists():
        return json.loads(cached.read_text().replace(_DIR_MARK, json.dumps(str(directory))[1:-1]))
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(args)
    assert code == 0, f"femu diagnose {path} exited {code}"
    if cached is not None:
        _atomic_write(cached, out.getvalue().replace(json.dumps(str(directory))[1:-1], _DIR_MARK))
    return json.loads(out.getvalue())


# -- the answers cached by content: a second run of the tests on unchanged code reads them ----------
_DIR_MARK = "@@femu-case-dir@@"  # the case's directory in a cached answer (a fresh tmp dir each run)
_CODE: list[str] = []


def _code_hash() -> str:
    """SHA-256 of everything a diagnosis's answer depends on: the source and data files of the three
    packages, this file, and the versions of Python, numpy and scipy. Any change: another key."""
    if not _CODE:
        import hashlib
        import platform
        import sys
        from pathlib import Path

        import scipy

        root = Path(__file__).resolve().parents[1]
        h = hashlib.sha256(f"{sys.version}|{platform.machine()}|{np.__version__}|{scipy.__version__}".encode())
        files = [Path(__file__).resolve()] + sorted(
            f for pkg in ("fe_problem", "femu", "adapters") for f in (root / pkg).rglob("*")
            if f.suffix in (".py", ".json") and "__pycache__" not in f.parts)
        for f in files:
            h.update(str(f.relative_to(root)).encode() + b"\0" + f.read_bytes() + b"\0")
        _CODE.append(h.hexdigest())
    return _CODE[0]


def _cache_path(directory, args: list[str]):
    """Where the answer of `femu diagnose` with `args` is kept, keyed by the code and by the
    contents of the files it reads (data, model), not their paths; None when caching is off
    (FEMU_TEST_CACHE=0)."""
    import hashlib
    import os
    from pathlib import Path

    if os.environ.get("FEMU_TEST_CACHE", "1") == "0":
        return None
    h = hashlib.sha256(_code_hash().encode())
    for a in args:
        p = Path(a)
        h.update((p.name.encode() + b"\0" + p.read_bytes()) if p.is_file() else a.encode())
        h.update(b"\0")
    return Path(__file__).resolve().parents[1] / ".pytest_cache" / "femu-diagnoses" / f"{h.hexdigest()}.json"


def _atomic_write(path, text: str) -> None:
    import os
    import tempfile

    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-")
    with os.fdopen(fd, "w") as f:
        f.write(text)
    os.replace(tmp, path)


#: The confusion matrix's row labels, as the README shows them.
ROW_LABELS = {"stiffness_loss": "stiffness_loss (crack)",
              "none": f"none ({PLAN['none']} noise only, {PLAN['global']} global stiffness error)"}


def confusion(pairs) -> str:
    """Markdown confusion matrix of (true kind, answered kind) pairs, as in the README."""
    kinds = ["stiffness_loss", "added_mass", "joint_flexibility", "shear_deformation", "none"]
    answered = kinds + sorted({a for _, a in pairs} - set(kinds))
    rows = ["| truth \\ answer | " + " | ".join(answered) + " |", "|---" * (len(answered) + 1) + "|"]
    for t in kinds:
        rows.append(f"| {ROW_LABELS.get(t, t)} | "
                    + " | ".join(str(sum(1 for x, a in pairs if x == t and a == c)) for c in answered) + " |")
    return "\n".join(rows)


OUTCOMES = ("right", "honest", "missed", "wrong")


def row(cls: str, case: Case, record: dict) -> tuple:
    """(class, outcome, adequate, a further effect reported but not placed) of one answer."""
    unplaced = len(record["causes"]) > 1 and not record["causes"][-1]["identifiable"]
    return cls, classify(case, record), record["adequate"], unplaced


def outcome_table(rows) -> str:
    """Markdown table of `row`s: counts per class and outcome, how many wrong answers came with
    adequate: true, how many were adequate, how many reported a further effect not placed."""
    classes = list(dict.fromkeys(r[0] for r in rows))
    out = ["| class | cases | " + " | ".join(OUTCOMES) + " | wrong with adequate: true | adequate "
           "| a further effect not placed |", "|---" * (len(OUTCOMES) + 5) + "|"]
    for cls in classes:
        mine = [(o, a, u) for c, o, a, u in rows if c == cls]
        out.append(f"| {cls} | {len(mine)} | " + " | ".join(str(sum(o == k for o, _, _ in mine)) for k in OUTCOMES)
                   + f" | {sum(o == 'wrong' and a for o, a, _ in mine)} | {sum(bool(a) for _, a, _ in mine)} "
                   f"| {sum(u for _, _, u in mine)} |")
    return "\n".join(out)


def run_cases(seed: int, plan: dict | None = None) -> list[tuple[Case, dict]]:
    """Diagnose every case of a seed through the CLI, with a progress bar on stderr (one line
    per case when stderr is not a terminal); returns (case, record) pairs."""
    import tempfile

    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    done = []
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn())
    console = Console(stderr=True)
    with tempfile.TemporaryDirectory() as tmp, Progress(*columns, console=console) as progress:
        task = progress.add_task("building cases", total=None)
        all_cases = cases(seed, plan)
        progress.update(task, total=len(all_cases), description=f"diagnosing (seed {seed})")
        for k, c in enumerate(all_cases, 1):
            record = diagnose_through_cli(c, tmp)
            done.append((c, record))
            progress.advance(task)
            if not console.is_terminal:
                console.print(f"{k}/{len(all_cases)}: {c.cls or c.kind} {c.truths} -> "
                              f"{classify_real(c, record) if c.cls in REAL else classify(c, record)} "
                              f"{[(x['kind'], x['location']) for x in record['causes']] or record['cause']['kind']} "
                              f"adequate={record['adequate']}", highlight=False)
    return done


def main(argv=None) -> int:
    """python tests/diagnosis_cases.py [SEED] [--markdown]: the README's confusion tables."""
    import argparse
    import sys
    import time

    parser = argparse.ArgumentParser(description="Diagnose the hidden-effect cases of a seed and print the "
                                                 "confusion tables (progress on stderr).")
    parser.add_argument("seed", nargs="?", type=int, default=2026, help="the cases' seed (default: %(default)s)")
    parser.add_argument("--markdown", action="store_true",
                        help="print only the Markdown tables on stdout, exactly as in the README (the rest on stderr)")
    parser.add_argument("--only", choices=["standard", "more", "real"], default=None, help="run one group of classes")
    parser.add_argument("--per-class", type=int, default=None, metavar="N",
                        help="at most N cases of each class (a reduced run; default: the full plan)")
    args = parser.parse_args(argv)

    def plan(full: dict) -> dict:
        return full if args.per_class is None else {k: min(v, args.per_class) for k, v in full.items()}

    t0 = time.perf_counter()
    tables = []
    if args.only in (None, "standard"):
        done = run_cases(args.seed, plan(PLAN))
        pairs = [(c.kind, r["cause"]["kind"]) for c, r in done]
        wrong_place = sum(r["cause"]["kind"] == c.kind and not named_correctly(c, r["cause"]) for c, r in done)
        rows = [row("standard: " + c.kind, c, r) for c, r in done]
        tables += [confusion(pairs), outcome_table(rows)]
        print(f"standard: right kind but wrong place: {wrong_place}", file=sys.stderr)
    if args.only in (None, "more"):
        done = run_cases(args.seed, plan(MORE))
        tables.append(outcome_table([row(c.cls, c, r) for c, r in done]))
    if args.only in (None, "real"):
        done = run_cases(args.seed, plan(REAL))
        tables.append(outcome_table([(c.cls, classify_real(c, r), r["adequate"],
                                      len(r["causes"]) > 1 and not r["causes"][-1]["identifiable"]) for c, r in done]))
    tail = f"seed {args.seed}; {time.perf_counter() - t0:.0f} s"
    print("\n\n".join(tables))
    print(tail if args.markdown else "\n" + tail, file=sys.stderr if args.markdown else sys.stdout)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
