"""fit a model's parameters to measured modes and write the updated model

Fits the parameters (a femu.parameters/1 file, docs/parameters-format.md; without one each
element's modulus within +-30 %) to the measured modes of DATA (femu.modal-data/1, with the
per-mode deviations where stated) and writes into --out: updated-model.json (the model with the
estimates; a matrix model's manifest with its matrices copied; a model imported from Nastran also
as updated-model.bdf, its deck with the new values), update.json (format femu.update/1:
estimates, 95 % intervals, paired modes before and after, the misfit against the noise),
report.md and mac.png. Example:

  femu update frame.json measured.json --out updated/ --parameters params.json --hold-out 1

The objective weighs each kind of data (frequencies, shapes) by its stated noise and an error
scale estimated with the parameters; the default optimizer is `sensitivity` (bounded
Gauss-Newton on the analytic eigenvalue sensitivities, restarted from random starts until the
budget is spent). The method and how to read the report: docs/update.md.
"""

from __future__ import annotations

import sys


def add_arguments(s) -> None:
    """The arguments of `femu update`."""
    from femu.cli._args import directory, positive_int

    s.add_argument("model", help="the model file (femu.model/1 JSON, or a femu.matrix-model/1 manifest of matrices) "
                   "or a shipped model's name")
    s.add_argument("data", help="the measured modes (femu.modal-data/1 JSON or UFF dataset 55)")
    s.add_argument("--out", required=True, type=directory, help="directory for the updated model and the report")
    s.add_argument("--parameters", default=None,
                   help="a femu.parameters/1 file naming what may change (default: each element's modulus within "
                        "+-30 %% of the model's own; a matrix model takes its manifest's, and no file)")
    s.add_argument("--optimizer", default="sensitivity", help="a registered optimizer or package.module:Class "
                   "(`femu optimizers` lists them)")
    s.add_argument("--budget", type=positive_int, default=1000, help="FE evaluations the optimizer may spend")
    s.add_argument("--seed", type=int, default=0, help="the optimizer's seed")
    s.add_argument("--option", action="append", default=None, metavar="NAME.KEY=VALUE",
                   help="an option for optimizer NAME's minimize, VALUE in JSON; repeat for more")
    s.add_argument("--hold-out", type=int, default=0, metavar="K",
                   help="keep the last K measured modes out of the fit and report how the updated model predicts them")
    s.add_argument("--no-progress", action="store_true", help="no progress bar (there is one only when stderr is a terminal)")


def run(args) -> int:
    """`femu update`: fit, write the files, print the verdict and the files written."""
    from femu.cli.study import parse_options
    from femu.update import update

    options = parse_options(args.option or [])
    unknown = set(options) - {args.optimizer}
    if unknown:
        raise ValueError(f"--option {sorted(unknown)[0]}.KEY=VALUE: the optimizer is {args.optimizer!r}")
    result = update(args.model, args.data, args.out, parameters_path=args.parameters, optimizer=args.optimizer,
                    budget=args.budget, seed=args.seed, options=options.get(args.optimizer), hold_out=args.hold_out,
                    progress=not args.no_progress and sys.stderr.isatty())
    r = result.record
    e = r["mean_abs_frequency_error_pct"]
    print(r["verdict"])
    print(f"mean |frequency error| {e['initial']:.2f} % -> {e['updated']:.2f} %; objective "
          f"{r['objective']['initial']:.4g} -> {r['objective']['updated']:.4g}")
    for path in result.files.values():
        print(f"wrote {path}")
    return 0
