"""The `femu` command. Each subcommand parses its arguments here and hands them to the module
that does the work, imported only when that subcommand runs (so `femu model` stays fast)."""

from __future__ import annotations

import argparse
import json
import os
import sys

import numpy as np


def _print_json(obj) -> None:
    json.dump(obj, sys.stdout, indent=1, default=_jsonable)
    sys.stdout.write("\n")


def _jsonable(o):
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    raise TypeError(f"not JSON serialisable: {type(o).__name__}")


# -- femu model -----------------------------------------------------------------------------
def cmd_model(args) -> int:
    from fe_problem import load_model, modal_analysis

    model = load_model(args.model)
    res = modal_analysis(model, args.modes)
    summary = {
        "name": model.name, "source": model.source, "description": model.description,
        "n_nodes": len(model.nodes), "n_elements": len(model.elements), "n_dofs": 3 * len(model.nodes),
        "total_mass_kg": model.total_mass_kg(), "supports": len(model.supports),
        "masses": len(model.masses), "springs": len(model.springs),
        "formulations": sorted({e.formulation for e in model.elements}),
        "measured_dofs": [list(d) for d in model.measured_dofs],
        "excitation": list(model.excitation) if model.excitation else None,
        "n_rigid_modes": res.n_rigid, "frequencies_hz": res.frequencies_hz.tolist(),
    }
    if args.json:
        _print_json(summary)
        return 0
    print(f"model {model.name}  ({model.source})")
    if model.description:
        print(f"  {model.description}")
    print(f"  {summary['n_nodes']} nodes, {summary['n_elements']} elements ({', '.join(summary['formulations'])}), "
          f"{summary['n_dofs']} DOFs, mass {summary['total_mass_kg']:.4f} kg")
    print(f"  {len(model.supports)} supports, {len(model.masses)} lumped masses, {len(model.springs)} springs, "
          f"{res.n_rigid} rigid-body modes dropped")
    print(f"  {len(model.measured_dofs)} measured DOFs; excitation {model.excitation}")
    print("  mode  frequency (Hz)")
    for i, f in enumerate(res.frequencies_hz, 1):
        print(f"  {i:4d}  {f:14.3f}")
    return 0


def _study(args) -> int:
    from .study import cli_study
    return cli_study(args)


def _results(args) -> int:
    from .study import cli_results
    return cli_results(args)


def _report(args) -> int:
    from .report import cli_report
    return cli_report(args)


def _reproduce(args) -> int:
    from .reproduce import cli_reproduce
    return cli_reproduce(args)


def _diagnose(args) -> int:
    from .diagnose_cli import cli_diagnose
    return cli_diagnose(args)


def _positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a whole number, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be at least 1, got {value}")
    return value


def build_parser() -> argparse.ArgumentParser:
    from .registry import available

    p = argparse.ArgumentParser(prog="femu", description="FE model updating of planar frames: models, "
                                "optimizer benchmarks, studies, reports and diagnosis.")
    sub = p.add_subparsers(dest="command", required=True)

    m = sub.add_parser("model", help="summary and first frequencies of a model")
    m.add_argument("model", help="a shipped model name (hframe) or a model file")
    m.add_argument("--modes", type=_positive_int, default=10, help="how many elastic modes (default 10)")
    m.add_argument("--json", action="store_true", help="machine-readable output")
    m.set_defaults(func=cmd_model)

    s = sub.add_parser("study", help="run a grid of optimizers x seeds into a store (resumable)")
    s.add_argument("--optimizers", required=True, help="comma-separated names: " + ", ".join(available()))
    s.add_argument("--seeds", required=True, help="e.g. 0-29 or 0,1,5")
    s.add_argument("--budget", type=int, required=True, help="FE evaluations per run")
    s.add_argument("--store", required=True, help="directory of the result store")
    s.add_argument("--workers", type=int, default=None, help="local processes (default: all cores)")
    s.add_argument("--scheduler", default=None, help="address of a Dask scheduler (tcp://host:port)")
    s.add_argument("--variants", default="paper", help="problem variants, comma-separated (paper, synthetic)")
    s.add_argument("--time-limit", type=float, default=None, help="seconds per run before it is stopped")
    s.add_argument("--no-progress", action="store_true", help="no progress bar")
    s.add_argument("--retry-failed", action="store_true",
                   help="run again the runs stored as failed or timeout (they are kept otherwise)")
    s.set_defaults(func=_study)

    r = sub.add_parser("results", help="print the runs in a store")
    r.add_argument("store")
    r.add_argument("--json", action="store_true", help="a JSON list of runs")
    r.set_defaults(func=_results)

    rp = sub.add_parser("report", help="Markdown report with figures from a store")
    rp.add_argument("store")
    rp.add_argument("--out", required=True, help="output directory")
    rp.add_argument("--ioh", action="store_true", help="also export IOHprofiler files")
    rp.set_defaults(func=_report)

    rr = sub.add_parser("reproduce", help="the paper's comparison under one identical budget, with a report")
    rr.add_argument("--seeds", type=int, default=None, help="number of seeds")
    rr.add_argument("--budget", type=int, default=None, help="FE evaluations per run")
    rr.add_argument("--out", default="femu-reproduce", help="output directory (store and report)")
    rr.add_argument("--workers", type=int, default=None)
    rr.add_argument("--json", action="store_true")
    rr.set_defaults(func=_reproduce)

    d = sub.add_parser("diagnose", help="find the physics the model is missing from measured data")
    d.add_argument("data", help="a modal-data file (JSON or UFF 55) or a shipped dataset (paper)")
    d.add_argument("--model", default=None, help="model name or file (default: the data's model)")
    d.add_argument("--out", default=None, help="directory for the extended model and a report")
    d.add_argument("--json", action="store_true")
    d.add_argument("--freq-noise", type=float, default=0.002,
                   help="std of a measured frequency, relative (default 0.002 = 0.2 %%)")
    d.add_argument("--shape-noise", type=float, default=0.02,
                   help="std of a measured shape entry, relative to the mode's RMS (default 0.02 = 2 %%)")
    d.set_defaults(func=_diagnose)
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except BrokenPipeError:  # `femu results ... | head`: the reader left; not an error of ours
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except (ValueError, FileNotFoundError, KeyError) as exc:
        msg = exc.args[0] if isinstance(exc, KeyError) and exc.args else exc
        print(f"femu {args.command}: error: {msg}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
