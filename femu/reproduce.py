"""`femu reproduce`: the paper's comparison under one identical budget, with a report.

Runs every available optimizer (the paper's methods: pymoo-ga / deap-ga for its GA,
scipy-sa for its SA, mlp-surrogate for its "PSO" response surface, pyswarms-pso for standard
PSO; plus random-search, cma-es and sensitivity, and any plugin) on the problem variant
'paper' (the paper's five measured frequencies, 12 element moduli, eq. 4 weights), the same
budget of FE evaluations and the same seeds for each (``--seeds``: a count N, the seeds
0..N-1, or a list as in `femu study`: 0-29, 0,3,7), into the resumable store OUT/store
(femu.studies.study.run_study: a second call runs only what is missing), then writes
OUT/report.md with its figures (femu.reports.study). The terminal table and the README's
Markdown table (``--markdown``) are rendered by femu.reports.reproduce.

Printed (and with --json as one JSON object on stdout):
``{"budget": B, "seeds": N, "seed_list": [...], "variant": "paper", "solvers": {name: {...}}, ...}``
(N the number of seeds) where every
number of a solver is the MEDIAN OVER ITS SEEDS: mean_abs_error_pct (%), frequencies_hz and
error_pct (per measured mode; of the model at each run's best point), n_evals, wall_s,
cpu_s, fe_s, overhead_s (seconds), best_f (eq. 4 objective), with the quartiles of best_f
and of the mean error, the status ("ok", or "mixed" with the count per status), the
number of runs, and `best_run`: the seed, J and point (the updated moduli, Pa) of its best run.
Beside them: the measured and initial frequencies, the paper's Table 1
frequencies and the mean errors its table implies (recomputed) and its text states; and
`provenance` (femu-bench version and git commit, suite version, host, date UTC, library
versions, and the hosts and versions the run records name: femu.reports.render.report_provenance).

The defaults (DEFAULT_SEEDS, DEFAULT_BUDGET) were chosen by timing the whole command on a
2-core machine shared with other jobs (load average 7-8), process start-up included: 5 seeds
x 1000 evaluations took 51 s, 5 x 2000 took 140 s (about 75 s of CPU in the runs, most of
it mlp-surrogate's network training). 1000 keeps the command under two minutes with room
to spare; `--budget 2000` is the better comparison when time allows.
"""

from __future__ import annotations

import contextlib
import sys
import time

from femu.studies.seeds import parse_seed_count

#: Seeds 0..DEFAULT_SEEDS-1 and FE evaluations per run when not given (see the module doc).
DEFAULT_SEEDS = 5
DEFAULT_BUDGET = 1000
VARIANT = "paper"
#: Wall-clock seconds a run may take (``--time-limit``): a run of the defaults takes seconds,
#: mlp-surrogate (the trust-region ensemble of issue 21) at 1000 evaluations 12.6 s of CPU, 79 s of
#: wall time at nice 19 on a 2-core machine at load 26 (medians of 5 seeds); a plugin that hangs
#: is stopped here.
DEFAULT_TIME_LIMIT_S = 300.0


def solvers(budget: int) -> tuple[list[str], dict[str, str]]:
    """The optimizers to run under `budget`: every name in `registry.available()` that loads
    and accepts the budget on the paper problem, and {name: why not} for the others."""
    from adapters.registry import available, missing_extra
    from adapters.sandbox import optimizer_facts
    from adapters.variants import make_problem

    names, left_out = [], {}
    n_var = make_problem(VARIANT).n_var
    for name in available():
        why = missing_extra(name)
        if why:  # a built-in whose extra is not installed: said, not tried
            left_out[name] = why
            continue
        try:  # a plugin is asked in a worker process: its code never runs in this one
            need = optimizer_facts(name, [n_var])["min_budget"][n_var]
        except Exception as exc:  # a broken plugin or a missing library must not stop the rest
            left_out[name] = f"cannot be loaded: {type(exc).__name__}: {exc}"
            continue
        if budget < need:
            left_out[name] = f"needs a budget of at least {need} evaluations"
            continue
        names.append(name)
    return names, left_out


def _median(spread) -> float | None:
    return spread.to_dict()["median"]


def solver_record(s) -> dict:
    """The JSON record of one SolverSummary: medians over seeds (see the module doc)."""
    def med(a):
        return None if a is None else a.to_dict()["median"]

    return {"mean_abs_error_pct": _median(s.mean_abs_error_pct),
            "mean_abs_error_pct_q1_q3": [s.mean_abs_error_pct.to_dict()["q1"], s.mean_abs_error_pct.to_dict()["q3"]],
            "frequencies_hz": med(s.frequencies_hz), "error_pct": med(s.error_pct),
            "n_evals": _median(s.n_evals), "wall_s": _median(s.wall_s), "cpu_s": _median(s.cpu_s),
            "fe_s": _median(s.fe_s), "overhead_s": _median(s.overhead_s), "best_f": _median(s.best_f),
            "best_f_q1_q3": [s.best_f.to_dict()["q1"], s.best_f.to_dict()["q3"]],
            "status": s.status, "statuses": dict(s.statuses), "n_runs": s.n_runs,
            "best_run": {"seed": s.best_seed, "best_f": None if s.best_x is None else s.best_run_f,
                         "x": None if s.best_x is None else s.best_x.tolist()}}


def _seed_text(seeds: list[int]) -> str:
    """The --seeds argument that gives `seeds`: a count when they are 0..N-1."""
    return str(len(seeds)) if seeds == list(range(len(seeds))) else ",".join(map(str, seeds))


def reproduce(seeds=DEFAULT_SEEDS, budget: int = DEFAULT_BUDGET, out="femu-reproduce",
              workers: int | None = None, log=None, time_limit_s: float | None = DEFAULT_TIME_LIMIT_S,
              unconfined: bool = False) -> dict:
    """Run the comparison into OUT/store, write OUT/report.md, return the summary dict
    described in the module doc. `seeds`: a count N (seeds 0..N-1), a list of seeds or a
    spec such as "0-4,10". Progress goes to `log` (default: stderr; a progress bar when it is
    a terminal). time_limit_s: wall-clock seconds per run (None: none). Every optimizer runs in a
    worker process of its own (adapters.sandbox): what it prints is in its run record.
    unconfined: run even where the workers cannot be confined (run_study's)."""
    # the optimizers, the problem and the reports load here, not with the module (whose
    # defaults `femu reproduce --help` shows at once, issue 25)
    from adapters.budget import check_budget
    from femu.reports.render import make_out_dir, report_provenance
    from femu.reports.study import render_files, summarize

    log = sys.stderr if log is None else log
    seed_list = parse_seed_count(seeds)
    budget = check_budget(budget, "--budget")
    from femu.studies.study import check_workers, run_study

    check_workers(workers)
    names, left_out = solvers(budget)
    if not names:
        raise ValueError(f"--budget {budget}: no optimizer can run with this budget")
    out = make_out_dir(out)  # before the runs: an OUT that cannot be made fails at once
    for name, why in left_out.items():
        print(f"femu reproduce: leaving out {name}: {why}", file=log)
    print(f"femu reproduce: {len(names)} optimizers x {len(seed_list)} seeds, {budget} FE evaluations each, "
          f"variant {VARIANT!r}, store {out / 'store'}", file=log, flush=True)
    t0 = time.perf_counter()
    # the study's progress bar draws on stdout when stdout is a terminal: send it to `log`, so
    # that stdout carries only this command's result (the JSON); one BLAS thread per worker
    # comes from fe_problem._threads, imported with the packages
    with contextlib.redirect_stdout(log):
        study = run_study(names, seed_list, budget, out / "store", variants=(VARIANT,), workers=workers,
                          progress=True, time_limit_s=time_limit_s, unconfined=unconfined)
    print(study.summary(), file=log, flush=True)
    groups = summarize(list(study.runs))  # this reproduction's runs only, whatever else the store holds
    report = render_files(groups, out, f"store `{out / 'store'}`, the runs of `femu reproduce --seeds "
                          f"{_seed_text(seed_list)} --budget {budget}`", runs=list(study.runs))
    (group,) = groups
    p = group.paper
    return {
        "budget": budget, "seeds": len(seed_list), "seed_list": seed_list, "variant": VARIANT,
        "solvers": {s.optimizer: solver_record(s) for s in group.solvers},
        "left_out": left_out,
        "measured_hz": group.measured_hz.tolist(), "initial_hz": group.initial_hz.tolist(),
        "initial_mean_abs_error_pct": group.initial_mean_abs_error_pct,
        "paper": {"updated_hz": {k: v.tolist() for k, v in p.updated_hz.items()},
                  "mean_abs_error_pct_from_table": p.mean_abs_error_pct,
                  "mean_error_pct_text": p.mean_error_pct_text,
                  "text_disagrees_with_table": list(p.disagreements)},
        "store": str(out / "store"), "report": str(report), "wall_s": time.perf_counter() - t0,
        "provenance": report_provenance(list(study.runs)),
    }
