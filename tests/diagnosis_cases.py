"""Hidden-effect cases for the diagnosis tests and the README's confusion matrix.

Each truth model is built differently from the candidate extensions that the diagnosis
fits, so the diagnosis is never checked against itself:

- crack: a rotational spring at a random point inside an element (the cracked-beam element,
  no new node); the candidate is a reduced modulus over the whole element.
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
Measurements: 8 modes, the 15 measured coordinates, 0.2 % frequency noise, 2 % shape noise,
random sign and scale.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq

import fe_problem as fp
from fe_problem.model import Node, Spring

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
    """A hidden effect: what it is, where, how big, and the data it gives."""

    kind: str                 # one of the diagnosis kinds, or "none"
    location: dict | None     # {"element": id} or {"node": id} or None
    size_pct: float           # largest frequency shift from the nominal model, %
    truth: fp.FrameModel
    seed: int

    def data(self) -> fp.ModalData:
        return fp.synthetic_measurement(self.truth, N_MODES, freq_noise=FREQ_NOISE, shape_noise=SHAPE_NOISE,
                                        seed=self.seed, model_name="hframe")


def max_shift_pct(model: fp.FrameModel) -> float:
    return 100.0 * float(np.max(np.abs(fp.modal_analysis(model, N_MODES).frequencies_hz / NOMINAL_HZ - 1.0)))


def crack_truth(element: int, position: float, stiffness: float) -> fp.FrameModel:
    return fp.crack_element(HFRAME, element, position, stiffness)


def joint_truth(node: int, element: int, stiffness: float) -> fp.FrameModel:
    """The end of `element` at `node` re-attached to a twin node tied by springs."""
    twin = Node(max(HFRAME.node_ids) + 1, HFRAME.node(node).x, HFRAME.node(node).y)
    e = HFRAME.element(element)
    moved = dataclasses.replace(e, node_i=twin.id) if e.node_i == node else dataclasses.replace(e, node_j=twin.id)
    springs = (Spring(1, (node, "x"), (twin.id, "x"), TRANSLATION_TIE),
               Spring(2, (node, "y"), (twin.id, "y"), TRANSLATION_TIE),
               Spring(3, (node, "rz"), (twin.id, "rz"), stiffness))
    return HFRAME.replace(nodes=HFRAME.nodes + (twin,), springs=springs,
                          elements=tuple(moved if x.id == element else x for x in HFRAME.elements))


def mass_truth(node: int, mass_kg: float) -> fp.FrameModel:
    return fp.add_mass(HFRAME, node, mass_kg, inertia_kg_m2=mass_kg * 0.02**2 / 6.0)


def shear_truth(shear_coefficient: float) -> fp.FrameModel:
    sections = {k: dataclasses.replace(v, shear_coefficient=shear_coefficient) for k, v in HFRAME.sections.items()}
    return fp.with_formulation(HFRAME, "timoshenko").replace(sections=sections)


def _sized(build, target_pct: float, lo: float, hi: float):
    """The magnitude (searched in log space between lo and hi) giving the target shift."""
    g = lambda t: max_shift_pct(build(np.exp(t))) - target_pct  # noqa: E731
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


#: How many cases of each kind the suite runs (40 with an effect, 20 without).
PLAN = {"stiffness_loss": 12, "added_mass": 10, "joint_flexibility": 10, "shear_deformation": 8,
        "none": 10, "global": 10}


def cases(seed: int = 2026, plan: dict | None = None) -> list[Case]:
    rng = np.random.default_rng(seed)
    out = []
    for kind, n in (plan or PLAN).items():
        for _ in range(n):
            out.append(make_case(kind, rng, seed=int(rng.integers(2**31))))
    return out


def named_correctly(case: Case, cause: dict) -> bool:
    """Kind right and, for a placed effect, the place right (the truth's keys must match)."""
    if cause["kind"] != case.kind:
        return False
    if case.location is None:
        return cause["location"] is None
    loc = cause["location"] or {}
    return all(loc.get(k) == v for k, v in case.location.items())


def diagnose_through_cli(case: Case, directory) -> dict:
    """Write the case's data file and run `femu diagnose FILE --json` on it, as a user would."""
    import contextlib
    import io
    import json
    from pathlib import Path

    from femu.cli import main

    path = Path(directory) / f"case-{case.kind}-{case.seed}.json"
    fp.save_modal_data(case.data(), path)
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        code = main(["diagnose", str(path), "--json"])
    assert code == 0, f"femu diagnose {path} exited {code}"
    return json.loads(out.getvalue())


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


def run_cases(seed: int) -> tuple[list[tuple[str, str]], int]:
    """Diagnose every case of a seed through the CLI, with a progress bar on stderr; returns the
    (true kind, answered kind) pairs and how many had the right kind but the wrong place."""
    import tempfile

    from rich.console import Console
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

    pairs, places_wrong = [], 0
    columns = (TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(), TimeRemainingColumn())
    console = Console(stderr=True)
    with tempfile.TemporaryDirectory() as tmp, Progress(*columns, console=console) as progress:
        task = progress.add_task("building cases", total=None)
        all_cases = cases(seed)
        progress.update(task, total=len(all_cases), description=f"diagnosing (seed {seed})")
        for k, c in enumerate(all_cases, 1):
            cause = diagnose_through_cli(c, tmp)["cause"]
            pairs.append((c.kind, cause["kind"]))
            places_wrong += cause["kind"] == c.kind and not named_correctly(c, cause)
            progress.advance(task)
            if not console.is_terminal:  # a log gets one line per case instead of a bar
                console.print(f"{k}/{len(all_cases)}: {c.kind} -> {cause['kind']}", highlight=False)
    return pairs, places_wrong


def main(argv=None) -> int:
    """python tests/diagnosis_cases.py [SEED] [--markdown]: the README's confusion matrix."""
    import argparse
    import sys
    import time

    parser = argparse.ArgumentParser(description="Diagnose the hidden-effect cases of a seed and print the "
                                                 "confusion matrix (progress on stderr).")
    parser.add_argument("seed", nargs="?", type=int, default=2026, help="the cases' seed (default: %(default)s)")
    parser.add_argument("--markdown", action="store_true",
                        help="print only the Markdown table on stdout, exactly as in the README (the rest on stderr)")
    args = parser.parse_args(argv)
    t0 = time.perf_counter()
    pairs, places_wrong = run_cases(args.seed)
    tail = (f"{len(pairs)} cases (seed {args.seed}); right kind but wrong place: {places_wrong}; "
            f"{time.perf_counter() - t0:.0f} s")
    print(confusion(pairs))
    print(tail if args.markdown else "\n" + tail, file=sys.stderr if args.markdown else sys.stdout)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
