"""run a grid of optimizers x seeds into a store (resumable)"""

from __future__ import annotations

import sys


def add_arguments(s) -> None:
    """The arguments of `femu study`."""
    from adapters.registry import available
    from femu.studies import DEFAULT_TIME_LIMIT_S

    s.add_argument("--optimizers", required=True,
                   help="comma-separated registry names or package.module:Class paths (a path imports "
                        "that module, and so runs its top-level code, as any Python import does: name only "
                        "modules you trust); available: " + ", ".join(available()))
    s.add_argument("--seeds", required=True,
                   help="seeds and ranges, comma-separated: 0-29, 0,3,7 or 0-4,10 (5 is the seed 5; "
                        "`femu reproduce --seeds 5` is a count)")
    s.add_argument("--budget", type=int, required=True, help="FE evaluations per run")
    s.add_argument("--store", required=True, help="directory of the result store")
    s.add_argument("--workers", type=int, default=None,
                   help="local worker processes (default: every core). 0: run in this process (each optimizer "
                        "still runs in a worker process of its own, without the problem)")
    s.add_argument("--scheduler", default=None, help="address of a Dask scheduler (tcp://host:port) to run on instead of local processes")
    s.add_argument("--variants", default=None,
                   help="problem variants, comma-separated: paper, synthetic (default: paper, unless --suite)")
    s.add_argument("--suite", default=None,
                   help="suite problems, comma-separated ids or prefixes: hframe-freq/12, paper, frame-shape/24/1 "
                        "(`femu suite` lists them)")
    s.add_argument("--model", default=None,
                   help="a user's own problem: this model file (with --data, and --parameters or each element's "
                        "modulus within +-30 %%; or a matrix model's manifest, its own parameters), benchmarked with the objective of `femu update`; its f_opt is the "
                        "best J the study's runs found (best known, not certified)")
    s.add_argument("--data", default=None, help="the measured modes of --model (femu.modal-data/1)")
    s.add_argument("--parameters", default=None, help="the parameter file of --model (femu.parameters/1)")
    s.add_argument("--time-limit", type=float, default=DEFAULT_TIME_LIMIT_S,
                   help="wall-clock seconds per run before it is stopped, status timeout, its evaluations until "
                        "then kept (default: %(default)s)")
    s.add_argument("--no-progress", action="store_true", help="no progress bar (there is one only when stdout is a terminal)")
    s.add_argument("--x0", choices=("none", "all"), default="none",
                   help="what every solver is told of the start: none (each draws its own from its seed) or all "
                        "(each is given the model's initial parameters)")
    s.add_argument("--option", action="append", default=None, metavar="NAME.KEY=VALUE",
                   help="an option for optimizer NAME's minimize, VALUE in JSON (20, 0.5, true, \"text\", [1, 2]); "
                        "repeat for more (`femu optimizers` lists each one's options and defaults)")
    s.add_argument("--in-process", action="store_true",
                   help="debugging: run each optimizer in its run's own process (where a debugger or a breakpoint "
                        "reaches it) instead of a worker without the problem. The cost: a plugin there can reach "
                        "the problem behind its budget, so every such run is recorded as unverified and reports "
                        "say so; what it prints is not captured, and with --workers 0 its time limit is only checked when "
                        "it asks for an evaluation")
    s.add_argument("--unconfined", action="store_true",
                   help="run and rank plugins even where this machine cannot confine their workers (no Landlock, "
                        "or neither root nor Landlock's signal scope: docs/plugins.md); every such run's record "
                        "says what did not hold, and reports mark it")
    blind = s.add_mutually_exclusive_group()
    blind.add_argument("--blind", dest="blind", action="store_true", default=None,
                       help="run the blind instances of the suite problems (the default with --suite): each one's "
                            "hidden truth drawn from the store's secret (STORE/.blind), which no optimizer can read, so "
                            "a plugin that rebuilds the public instance from its id gains nothing (docs/plugins.md)")
    blind.add_argument("--no-blind", dest="blind", action="store_false",
                       help="run the suite's public instances (their truths fixed by their ids), recorded as such")
    s.add_argument("--retry-failed", action="store_true",
                   help="run again the runs stored as failed or timeout (they are kept otherwise)")


def parse_options(items: list[str]) -> dict[str, dict]:
    """{optimizer: {key: value}} from --option NAME.KEY=VALUE items (VALUE in JSON); ValueError
    naming the item otherwise. NAME may be a package.module:Class path (the key follows its
    last dot)."""
    import json

    out: dict[str, dict] = {}
    for item in items:
        left, eq, text = item.partition("=")
        name, dot, key = left.rpartition(".")
        if not eq or not dot or not name or not key.isidentifier():
            raise ValueError(f"--option {item!r}: expected NAME.KEY=VALUE, e.g. cma-es.sigma0=0.2")
        try:
            value = json.loads(text)
        except ValueError:
            raise ValueError(f"--option {item!r}: the value {text!r} is not JSON (a text is written with "
                             f"quotes: {name}.{key}='\"{text}\"')") from None
        if key in out.setdefault(name, {}):
            raise ValueError(f"--option {item!r}: {name}.{key} is given twice")
        out[name][key] = value
    return out


def seeds_warning(optimizers, seeds, variants, suite, alpha: float = 0.05) -> str | None:
    """The warning `femu study` prints when its seeds are too few for any per-problem pairwise
    test (Mann-Whitney U, Holm over every pair and problem) to separate two solvers at alpha;
    None when they suffice, or when the arguments are bad (the study says why)."""
    from fe_problem.suite import select_suite
    from femu.reports.stats import seeds_can_separate, smallest_p
    from femu.studies.seeds import parse_names, parse_seeds

    try:
        n_seeds = len(parse_seeds(seeds))
        n_opt = len(parse_names(optimizers, "optimizers"))
        problems = (len(parse_names(variants, "variants")) if variants else (0 if suite else 1))
        problems += len(select_suite(suite)) if suite else 0
    except ValueError:
        return None
    if n_opt < 2 or seeds_can_separate(n_seeds, n_opt, problems, alpha):
        return None
    m = n_opt * (n_opt - 1) // 2 * problems
    return (f"femu study: warning: with {n_seeds} seed(s) per solver no pairwise test can separate two solvers: "
            f"the smallest Mann-Whitney p is {smallest_p('mannwhitneyu', n_seeds, n_seeds):.2g}, "
            f"{smallest_p('mannwhitneyu', n_seeds, n_seeds, n_tests=m):.2g} after Holm over {m} tests "
            f"(alpha {alpha}); use more seeds")


def run(args) -> int:
    """`femu study`: run the grid into the store, print a one-line summary."""
    from femu.studies.study import run_study

    options = parse_options(getattr(args, "option", []) or [])

    warning = seeds_warning(args.optimizers, args.seeds, args.variants, args.suite)
    if warning:
        print(warning, file=sys.stderr)

    try:
        result = run_study(args.optimizers, args.seeds, args.budget, args.store, variants=args.variants,
                           workers=args.workers, scheduler=args.scheduler, time_limit_s=args.time_limit, suite=args.suite,
                           progress=not args.no_progress, retry_failed=getattr(args, "retry_failed", False),
                           x0=getattr(args, "x0", "none"), options=options or None,
                           isolated=not getattr(args, "in_process", False), model=getattr(args, "model", None),
                           data=getattr(args, "data", None), parameters=getattr(args, "parameters", None),
                           unconfined=getattr(args, "unconfined", False), blind=getattr(args, "blind", None))
    except KeyboardInterrupt:
        print(f"femu study: interrupted; the finished runs are in {args.store}: the same command resumes the study",
              file=sys.stderr)
        return 130
    print(result.summary())
    return 0
