"""list the benchmark suite: problem ids, sizes and known optimum values

Ids are family/dimension/instance (dimension = number of updating parameters). SPEC selects
ids or prefixes of whole id parts, comma-separated (paper, hframe-freq/48, frame-shape/12/3).
f_opt is exact (noise-free synthetic data of a truth inside the bounds), best known (proven by
the command in docs/suite.md) or a reference (noisy data: J at the hidden truth, known once the
problem is built; --build builds each selected problem to show it, slow at large sizes).
"""

from __future__ import annotations

from ._args import print_json


def add_arguments(p) -> None:
    p.add_argument("spec", nargs="?", default=None, help="ids or prefixes, comma-separated (default: all)")
    p.add_argument("--json", action="store_true", help="a JSON list of problems")
    p.add_argument("--build", action="store_true",
                   help="build each problem to fill in the f_opt of noisy instances (slow for large sizes)")


def _entries(args) -> list[dict]:
    from fe_problem.suite import select_suite, suite_entry, suite_ids, suite_problem

    ids = suite_ids() if args.spec is None else select_suite(args.spec)
    out = []
    for i in ids:
        e = suite_entry(i).to_dict()
        if args.build and e["f_opt"] is None:
            e["f_opt"] = suite_problem(i).f_opt
        out.append(e)
    return out


def run(args) -> int:
    """`femu suite [SPEC] [--json] [--build]`: the suite's problems as a table or JSON."""
    entries = _entries(args)
    if args.json:
        print_json(entries)
        return 0
    w = max(len("id"), *(len(e["id"]) for e in entries))
    head = f"{'id':<{w}} {'n_var':>5} {'n_dof':>5} {'f_opt':>22} {'f_opt known':<11}"
    print(head)
    print("-" * len(head))
    for e in entries:
        f = "(on build)" if e["f_opt"] is None else f"{e['f_opt']:.16g}"
        print(f"{e['id']:<{w}} {e['n_var']:>5} {e['n_dof']:>5} {f:>22} {e['f_opt_kind']:<11}")
    print(f"{len(entries)} problems")
    for kind in dict.fromkeys(e["f_opt_kind"] for e in entries):
        how = next(e["f_opt_how"] for e in entries if e["f_opt_kind"] == kind)
        print(f"  {kind}: {how}")
    return 0
