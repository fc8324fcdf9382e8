"""summary and first frequencies of a model: its size, the solver path and the time taken

A model is a shipped name (hframe, frame3d), a model file, a model given as matrices (a
femu.matrix-model/1 manifest, docs/matrix-model.md), or a regular frame generated with
--frame BAYSxSTOREYS (planar) or --frame BAYSxBAYSxSTOREYS (a space frame); --split N splits
every element of it into N equal parts, and --save writes the result as a model file. Examples:

  femu model hframe
  femu model bridge.matrix.json
  femu model hframe --split 64
  femu model --frame 10x50 --split 3 --save big.model.json
  femu model --frame 2x2x4 --floor-mass 5000
"""

from __future__ import annotations

import argparse
import re
import time

from fe_problem.paths import SOLVERS

from ._args import positive_int, print_json

def frame_size(text: str) -> tuple[int, ...]:
    """An argparse type: BAYSxSTOREYS (a planar frame, ``10x50``) or BAYSxBAYSxSTOREYS (a space
    frame: bays in x, bays in y, storeys, ``2x2x4``), whole numbers >= 1."""
    match = re.fullmatch(r"\s*(\d+)\s*[xX]\s*(\d+)\s*(?:[xX]\s*(\d+)\s*)?", text)
    numbers = tuple(int(g) for g in match.groups() if g is not None) if match else ()
    if not numbers or min(numbers) < 1:
        raise argparse.ArgumentTypeError("expected BAYSxSTOREYS (planar, such as 3x10) or BAYSxBAYSxSTOREYS "
                                         f"(a space frame, such as 2x2x4), whole numbers >= 1, got {text!r}")
    return numbers


def _number(text: str, ok, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number, got {text!r}") from None
    if not (ok(value) and value < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a finite number {what}, got {text!r}")
    return value


def positive_float(text: str) -> float:
    """An argparse type: a finite number > 0."""
    return _number(text, lambda v: v > 0, "> 0")


def non_negative_float(text: str) -> float:
    """An argparse type: a finite number >= 0."""
    return _number(text, lambda v: v >= 0, ">= 0")


def add_arguments(p) -> None:
    """The arguments of `femu model`."""
    p.add_argument("model", nargs="?", help="a shipped model name (hframe, frame3d), a model file or a "
                                            "matrix-model manifest (or give --frame)")
    g = p.add_argument_group("generated frames")
    g.add_argument("--frame", type=frame_size, metavar="BAYSxSTOREYS",
                   help="a regular steel frame instead of MODEL: planar BAYSxSTOREYS (fe_problem.regular_frame, "
                        "e.g. 3x10) or a space frame BAYSxBAYSxSTOREYS (fe_problem.regular_frame_3d, e.g. 2x2x4)")
    g.add_argument("--bay-width", type=positive_float, metavar="M",
                   help="bay width of --frame, m (default 6; a space frame's bays in x and y alike)")
    g.add_argument("--storey-height", type=positive_float, metavar="M",
                   help="storey height of --frame, m (default 3)")
    g.add_argument("--base", choices=("fixed", "pinned"), help="the base nodes of --frame (default fixed)")
    g.add_argument("--floor-mass", type=non_negative_float, metavar="KG",
                   help="a lumped mass at every node of --frame above the base, kg (default 0: none)")
    p.add_argument("--split", type=positive_int, default=1, metavar="N",
                   help="split every element into N equal parts (fe_problem.split_elements)")
    p.add_argument("--save", metavar="PATH", help="write the model (generated, split) to this model file")
    p.add_argument("--solver", choices=SOLVERS, default="auto",
                   help="the solver path: auto chooses dense or sparse by the number of free DOFs")
    p.add_argument("--modes", type=positive_int, default=10, help="how many elastic modes (default 10; all the model has if fewer)")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object instead of text")


def build_model(args):
    """The model the arguments name: loaded or generated, then split."""
    import fe_problem as fp

    if (args.model is None) == (args.frame is None):
        raise ValueError("give a MODEL (a shipped name or a model file) or --frame BAYSxSTOREYS, "
                         + ("not both" if args.model is not None else "got neither"))
    frame_options = {"--bay-width": args.bay_width, "--storey-height": args.storey_height, "--base": args.base,
                     "--floor-mass": args.floor_mass}
    if args.frame is not None:
        width = 6.0 if args.bay_width is None else args.bay_width
        height = 3.0 if args.storey_height is None else args.storey_height
        common = {"base": args.base or "fixed", "floor_mass_kg": args.floor_mass or 0.0}
        if len(args.frame) == 3:
            model = fp.regular_frame_3d(*args.frame, width, width, height, **common)
        else:
            model = fp.regular_frame(*args.frame, width, height, **common)
    elif any(v is not None for v in frame_options.values()):
        given = next(k for k, v in frame_options.items() if v is not None)
        raise ValueError(f"{given} describes a generated frame: give --frame BAYSxSTOREYS with it, or leave it out")
    else:
        model = fp.load_any_model(args.model)
    if isinstance(model, fp.MatrixModel):
        if args.split > 1:
            raise ValueError(f"{model.source}: --split splits a frame's elements; a model given as matrices has none")
        return model
    if args.split > 1:
        model = fp.split_elements(model, args.split).replace(
            name=f"{model.name}-split{args.split}",
            description=f"{model.description} (every element split in {args.split})".lstrip())
    return model


def run(args) -> int:
    """`femu model`: the model's summary, size, solver path, timings and first frequencies."""
    import fe_problem as fp
    from fe_problem import AffineModel, save_model
    from fe_problem.modal import frequencies_hz

    t0 = time.perf_counter()
    model = build_model(args)
    t1 = time.perf_counter()
    if isinstance(model, fp.MatrixModel):
        return _run_matrix(args, model, t0, t1)
    system = AffineModel(model, solver=args.solver)
    t2 = time.perf_counter()
    if system.n_elastic == 0:
        raise ValueError(f"{model.source or model.name}: the model has no elastic mode: every motion strains "
                         "nothing (check its stiffness values and connections)")
    # with the shapes, as modal_analysis solves: LAPACK's values-only driver differs from it in
    # the last digits (1e-11 of the first frequency of a Timoshenko H-frame), and the frequencies
    # `femu model` prints are the ones the library gives
    lam, _ = system.eigen(system.x0[None, :], min(args.modes, system.n_elastic), vectors=True)
    t3 = time.perf_counter()
    saved = str(save_model(model, args.save)) if args.save else None
    summary = {
        "name": model.name, "source": model.source, "description": model.description,
        "dimension": model.layout.dimension, "node_dofs": list(model.layout.names),
        "n_nodes": len(model.nodes), "n_elements": len(model.elements), "n_dofs": model.n_dof,
        "n_free_dofs": system.n_free, "solver_path": system.path,
        "build_s": t1 - t0, "assemble_s": t2 - t1, "solve_s": t3 - t2,
        "total_mass_kg": model.total_mass_kg(), "supports": len(model.supports),
        "masses": len(model.masses), "springs": len(model.springs),
        "formulations": sorted({e.formulation for e in model.elements}),
        "measured_dofs": [list(d) for d in model.measured_dofs],
        "excitation": list(model.excitation) if model.excitation else None,
        "n_rigid_modes": system.n_rigid, "mechanism": system.mechanism,
        "frequencies_hz": frequencies_hz(lam[0]).tolist(), "saved": saved,
    }
    if args.json:
        print_json(summary)
        return 0
    _print(summary, model, args.modes)
    return 0


def _print(s: dict, model, asked: int) -> None:
    print(f"model {s['name']}  ({s['source']})")
    if s["description"]:
        print(f"  {s['description']}")
    kind = "planar frame" if s["dimension"] == 2 else "space frame"
    print(f"  {kind} ({s['dimension']}-D): {len(s['node_dofs'])} DOFs per node ({', '.join(s['node_dofs'])})")
    print(f"  {s['n_nodes']} nodes, {s['n_elements']} elements ({', '.join(s['formulations'])}), "
          f"{s['n_dofs']} DOFs, mass {s['total_mass_kg']:.4f} kg")
    print(f"  {s['supports']} supports, {s['masses']} lumped masses, {s['springs']} springs, "
          f"{s['n_rigid_modes']} rigid-body modes dropped")
    if s["mechanism"]:
        print(f"  of the dropped zero-energy modes, {s['mechanism']}")
    measured = len(model.measured_dofs)
    print(f"  {measured} measured DOFs; excitation {model.excitation}")
    print(f"  {s['n_free_dofs']} free DOFs, {s['solver_path']} solver; built in {s['build_s']:.3f} s, "
          f"assembled in {s['assemble_s']:.3f} s, {len(s['frequencies_hz'])} modes in {s['solve_s']:.3f} s")
    if s["saved"]:
        print(f"  saved to {s['saved']}")
    if len(s["frequencies_hz"]) < asked:
        print(f"  the model has only {len(s['frequencies_hz'])} elastic modes (asked for {asked})")
    print("  mode  frequency (Hz)")
    for i, f in enumerate(s["frequencies_hz"], 1):
        print(f"  {i:4d}  {f:14.3f}")


def _run_matrix(args, model, t0: float, t1: float) -> int:
    """`femu model MANIFEST`: a matrix model's summary, its solve and first frequencies."""
    from fe_problem import MatrixSystem, save_matrix_model
    from fe_problem.modal import frequencies_hz

    system = MatrixSystem(model, solver=args.solver)
    t2 = time.perf_counter()
    if system.n_elastic == 0:
        raise ValueError(f"{model.source or model.name}: the model has no elastic mode")
    lam, _ = system.eigen(system.x0[None, :], min(args.modes, system.n_elastic), vectors=True)
    t3 = time.perf_counter()
    saved = str(save_matrix_model(model, args.save)) if args.save else None
    summary = {
        "name": model.name, "source": model.source, "description": model.description, "kind": "matrix",
        "n_dofs": model.n_dof, "labelled_dofs": model.labelled, "n_massless_dofs": system.n_massless,
        "stiffness_terms": [t.name for t in model.stiffness], "mass_terms": [t.name for t in model.mass],
        "parameters": [{"name": p.name, "kind": p.kind, "initial": p.initial, "lower": p.lower, "upper": p.upper}
                       for p in system.parameters],
        "nnz": int(system.k0.nnz), "solver_path": system.path,
        "build_s": t1 - t0, "assemble_s": t2 - t1, "solve_s": t3 - t2,
        "n_rigid_modes": system.n_rigid, "frequencies_hz": frequencies_hz(lam[0]).tolist(), "saved": saved,
    }
    if args.json:
        print_json(summary)
        return 0
    s = summary
    print(f"model {s['name']}  ({s['source']})")
    if s["description"]:
        print(f"  {s['description']}")
    print(f"  given as matrices: {s['n_dofs']} DOFs ({'labelled [node, direction]' if s['labelled_dofs'] else 'rows 1..n'}), "
          f"{s['n_massless_dofs']} without mass, {s['nnz']} stored entries")
    print(f"  stiffness terms: {', '.join(s['stiffness_terms'])}; mass terms: {', '.join(s['mass_terms'])}")
    params = ", ".join(f"{p['name']} [{p['lower']:g}, {p['upper']:g}]" for p in s["parameters"]) or "none"
    print(f"  parameters (multipliers): {params}")
    print(f"  {s['n_rigid_modes']} rigid-body modes dropped")
    print(f"  {s['solver_path']} solver; read in {s['build_s']:.3f} s, assembled in {s['assemble_s']:.3f} s, "
          f"{len(s['frequencies_hz'])} modes in {s['solve_s']:.3f} s")
    if s["saved"]:
        print(f"  saved to {s['saved']}")
    if len(s["frequencies_hz"]) < args.modes:
        print(f"  the model has only {len(s['frequencies_hz'])} elastic modes (asked for {args.modes})")
    print("  mode  frequency (Hz)")
    for i, f in enumerate(s["frequencies_hz"], 1):
        print(f"  {i:4d}  {f:14.3f}")
    return 0
