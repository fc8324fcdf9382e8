"""`femu reproduce`: the paper's comparison under one identical budget, with a report.

Runs every available optimizer (the paper's methods: pymoo-ga / deap-ga for its GA,
scipy-sa for its SA, mlp-surrogate for its "PSO" response surface, pyswarms-pso for standard
PSO; plus random-search, cma-es and sensitivity, and any plugin) on the problem variant
'paper' (the paper's five measured frequencies, 12 element moduli, eq. 4 weights), the same
budget of FE evaluations and the same seeds 0..N-1 for each, into the resumable store
OUT/store (adapters.study.run_study: a second call runs only what is missing), then writes
OUT/report.md with its figures (adapters.report).

Printed (and with --json as one JSON object on stdout):
``{"budget": B, "seeds": N, "variant": "paper", "solvers": {name: {...}}, ...}`` where every
number of a solver is the MEDIAN OVER ITS SEEDS: mean_abs_error_pct (%), frequencies_hz and
error_pct (per measured mode; of the model at each run's best point), n_evals, wall_s,
cpu_s, fe_s, overhead_s (seconds), best_f (eq. 4 objective), with the quartiles of best_f
and of the mean error, the status ("ok", or "mixed" with the count per status) and the
number of runs. Beside them: the measured and initial frequencies, the paper's Table 1
frequencies and the mean errors its table implies (recomputed) and its text states.

The defaults (DEFAULT_SEEDS, DEFAULT_BUDGET) were chosen by timing the whole command on a
2-core machine shared with other jobs (load average 7-8), process start-up included: 5 seeds
x 1000 evaluations took 51 s, 5 x 2000 took 140 s (about 75 s of CPU in the runs, most of
it mlp-surrogate's network training). 1000 keeps the command under two minutes with room
to spare; `--budget 2000` is the better comparison when time allows.
"""

from __future__ import annotations

import contextlib
import json
import os
import sys
import time
from pathlib import Path

from adapters.registry import available, get
from femu.reports.study import render_files, summarize

#: Seeds 0..DEFAULT_SEEDS-1 and FE evaluations per run when not given (see the module doc).
DEFAULT_SEEDS = 5
DEFAULT_BUDGET = 1000
VARIANT = "paper"


def solvers(budget: int) -> tuple[list[str], dict[str, str]]:
    """The optimizers to run under `budget`: every name in `registry.available()` that loads
    and accepts the budget, and {name: why not} for the others."""
    names, left_out = [], {}
    for name in available():
        try:
            cls = get(name)
        except Exception as exc:  # a broken plugin or a missing library must not stop the rest
            left_out[name] = f"cannot be loaded: {type(exc).__name__}: {exc}"
            continue
        min_budget = int(getattr(cls, "min_budget", 1))
        if budget < min_budget:
            left_out[name] = f"needs a budget of at least {min_budget} evaluations"
            continue
        names.append(name)
    return names, left_out


@contextlib.contextmanager
def _single_threaded_blas():
    """One BLAS thread in the study's worker processes (started inside this block).

    The runs already fill the cores in parallel, and on the H-frame's small matrices a
    multi-threaded BLAS mostly spins: measured on 2 cores, one least-squares point of the
    paper's problem took 4-5 ms of CPU with OpenBLAS's default threads and 0.45 ms with one.
    Variables the user has set are kept."""
    names = ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")
    saved = {n: os.environ.get(n) for n in names}
    for n in names:
        os.environ.setdefault(n, "1")
    try:
        yield
    finally:
        for n, v in saved.items():
            if v is None:
                os.environ.pop(n, None)


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
            "status": s.status, "statuses": dict(s.statuses), "n_runs": s.n_runs}


def reproduce(seeds: int = DEFAULT_SEEDS, budget: int = DEFAULT_BUDGET, out="femu-reproduce",
              workers: int | None = None, log=None) -> dict:
    """Run the comparison into OUT/store, write OUT/report.md, return the summary dict
    described in the module doc. Progress goes to `log` (default: stderr; a progress bar when
    it is a terminal)."""
    log = sys.stderr if log is None else log
    if isinstance(seeds, bool) or not isinstance(seeds, int) or seeds < 1:
        raise ValueError(f"--seeds: must be a number of seeds >= 1, got {seeds!r}")
    if isinstance(budget, bool) or not isinstance(budget, int) or budget < 1:
        raise ValueError(f"--budget: must be an integer >= 1 (FE evaluations per run), got {budget!r}")
    from femu.studies.study import run_study

    names, left_out = solvers(budget)
    for name, why in left_out.items():
        print(f"femu reproduce: leaving out {name}: {why}", file=log)
    if not names:
        raise ValueError(f"--budget {budget}: no optimizer can run with this budget")
    out = Path(out)
    print(f"femu reproduce: {len(names)} optimizers x {seeds} seeds, {budget} FE evaluations each, "
          f"variant {VARIANT!r}, store {out / 'store'}", file=log, flush=True)
    t0 = time.perf_counter()
    # the study's progress bar draws on stdout when stdout is a terminal: send it to `log`, so
    # that stdout carries only this command's result (the JSON)
    with contextlib.redirect_stdout(log), _single_threaded_blas():
        study = run_study(names, list(range(seeds)), budget, out / "store", variants=(VARIANT,), workers=workers,
                          progress=True)
    print(study.summary(), file=log, flush=True)
    groups = summarize(list(study.runs))  # this reproduction's runs only, whatever else the store holds
    report = render_files(groups, out, f"store `{out / 'store'}`, the runs of `femu reproduce --seeds {seeds} "
                          f"--budget {budget}`")
    (group,) = groups
    p = group.paper
    return {
        "budget": budget, "seeds": seeds, "variant": VARIANT,
        "solvers": {s.optimizer: solver_record(s) for s in group.solvers},
        "left_out": left_out,
        "measured_hz": group.measured_hz.tolist(), "initial_hz": group.initial_hz.tolist(),
        "initial_mean_abs_error_pct": group.initial_mean_abs_error_pct,
        "paper": {"updated_hz": {k: v.tolist() for k, v in p.updated_hz.items()},
                  "mean_abs_error_pct_from_table": p.mean_abs_error_pct,
                  "mean_error_pct_text": p.mean_error_pct_text,
                  "text_disagrees_with_table": list(p.disagreements)},
        "store": str(out / "store"), "report": str(report), "wall_s": time.perf_counter() - t0,
    }


def _fmt(x, spec) -> str:
    return format("n/a", ">" + spec.split(".")[0]) if x is None else format(x, spec)


def render_text(res: dict) -> str:
    """The result as a table for a terminal."""
    n_modes = len(res["measured_hz"])
    freq = "  ".join(f"{'f' + str(i + 1):>7}" for i in range(n_modes))
    lines = [f"The paper's comparison on variant {res['variant']!r}: {res['budget']} FE evaluations per run, "
             f"medians over {res['seeds']} seeds", "",
             f"{'':<22}{freq}  {'mean|err|%':>10}  {'best_f':>10}  {'n_evals':>7}  {'wall s':>7}  status"]

    def row(label, hz, err, best=None, n=None, wall=None, status=""):
        f = "  ".join(_fmt(v, "7.1f") for v in hz) if hz else "  ".join(f"{'n/a':>7}" for _ in range(n_modes))
        return (f"{label:<22}{f}  {_fmt(err, '10.2f')}  {_fmt(best, '10.3e')}  {_fmt(n, '7.0f')}  "
                f"{_fmt(wall, '7.2f')}  {status}")

    lines.append(row("measured", res["measured_hz"], None))
    lines.append(row("initial (ours)", res["initial_hz"], res["initial_mean_abs_error_pct"]))
    for name, s in res["solvers"].items():
        lines.append(row(name, s["frequencies_hz"], s["mean_abs_error_pct"], s["best_f"], s["n_evals"],
                         s["wall_s"], s["status"]))
    for k, hz in res["paper"]["updated_hz"].items():
        lines.append(row(f"paper {k} (Table 1)", hz, res["paper"]["mean_abs_error_pct_from_table"][k]))
    lines += ["", "Mean errors of the paper's methods are recomputed from its Table 1; its text states "
              + ", ".join(f"{k} {v} %" for k, v in res["paper"]["mean_error_pct_text"].items())
              + " (not all consistent with the table). The H-frame geometry is a reconstruction.",
              f"Report: {res['report']}   store: {res['store']}   ({res['wall_s']:.1f} s)"]
    return "\n".join(lines)
