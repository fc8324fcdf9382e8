"""summary and first frequencies of a model"""

from __future__ import annotations

from ._args import positive_int, print_json


def add_arguments(p) -> None:
    """The arguments of `femu model`."""
    p.add_argument("model", help="a shipped model name (hframe) or a model file")
    p.add_argument("--modes", type=positive_int, default=10, help="how many elastic modes (default 10; all the model has if fewer)")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object instead of text")


def run(args) -> int:
    """`femu model`: the model's summary and first frequencies, as text or JSON."""
    from fe_problem import load_model, modal_analysis

    model = load_model(args.model)
    res = modal_analysis(model, args.modes, at_most=True)
    summary = {
        "name": model.name, "source": model.source, "description": model.description,
        "n_nodes": len(model.nodes), "n_elements": len(model.elements), "n_dofs": model.n_dof,
        "total_mass_kg": model.total_mass_kg(), "supports": len(model.supports),
        "masses": len(model.masses), "springs": len(model.springs),
        "formulations": sorted({e.formulation for e in model.elements}),
        "measured_dofs": [list(d) for d in model.measured_dofs],
        "excitation": list(model.excitation) if model.excitation else None,
        "n_rigid_modes": res.n_rigid, "mechanism": res.mechanism, "frequencies_hz": res.frequencies_hz.tolist(),
    }
    if args.json:
        print_json(summary)
        return 0
    print(f"model {model.name}  ({model.source})")
    if model.description:
        print(f"  {model.description}")
    print(f"  {summary['n_nodes']} nodes, {summary['n_elements']} elements ({', '.join(summary['formulations'])}), "
          f"{summary['n_dofs']} DOFs, mass {summary['total_mass_kg']:.4f} kg")
    print(f"  {len(model.supports)} supports, {len(model.masses)} lumped masses, {len(model.springs)} springs, "
          f"{res.n_rigid} rigid-body modes dropped")
    if res.mechanism:
        print(f"  of the dropped zero-energy modes, {res.mechanism}")
    print(f"  {len(model.measured_dofs)} measured DOFs; excitation {model.excitation}")
    if len(res.frequencies_hz) < args.modes:
        print(f"  the model has only {len(res.frequencies_hz)} elastic modes (asked for {args.modes})")
    print("  mode  frequency (Hz)")
    for i, f in enumerate(res.frequencies_hz, 1):
        print(f"  {i:4d}  {f:14.3f}")
    return 0
