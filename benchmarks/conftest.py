"""Shared inputs of the benchmark suites, and the figures derived from one run of them.

The speed goals are ratios between benchmarks (the batched objective against the per-sample
loop and against a bare batched eigen-solve). The machine is shared and noisy, so a ratio
means something only when both sides were timed in the same session: each benchmark files
its per-item time here through the `record` fixture, and the session ends with a table of
the ratios (printed in the terminal summary and added to the JSON that --benchmark-json /
--benchmark-autosave write, under "femu_figures"). Nothing here asserts on a time.

Times are per item (per sample, per evaluation) in seconds, from the minimum over rounds
(the least disturbed round of a noisy machine) and, for reference, the median.
"""

from __future__ import annotations

import os

import fe_problem._threads  # noqa: F401  (one BLAS thread unless set: before numpy loads)
import numpy as np
import pytest

from adapters.variants import make_problem

#: The population every evaluation benchmark uses: this many points, uniform in the bounds.
N_POINTS = 2000
#: Fixes the population exactly (the same points in every run of the suite).
POINTS_SEED = 20240611

#: (label, slow key, fast key, goal): ratio = per-item time of `slow` / per-item time of
#: `fast`, so a ratio above 1 means `fast` is faster; the goal is the least acceptable ratio
#: (None: a figure without a goal).
RATIOS = (
    ("evaluate(paper) speed-up over the per-sample loop", "loop_paper", "evaluate_paper", 30.0),
    ("evaluate(paper) speed / bare batched eigvalsh speed", "eigvalsh_bare", "evaluate_paper", 0.5),
    ("evaluate(paper) speed / bare batched eigh speed", "eigh_bare", "evaluate_paper", 0.5),
    ("evaluate(synthetic, shapes) speed / bare batched eigh speed", "eigh_bare", "evaluate_synthetic", 0.5),
    ("evaluate, 300-DOF frame: speed-up over OpenSeesPy rebuild + eigen", "opensees_scale:300", "evaluate_scale:300",
     1.0),
    ("evaluate, 3,000-DOF frame: speed-up over OpenSeesPy", "opensees_scale:3000", "evaluate_scale:3000", 5.0),
    ("evaluate, 9,000-DOF frame: speed-up over OpenSeesPy", "opensees_scale:9000", "evaluate_scale:9000", 25.0),
    ("evaluate, 30,000-DOF frame: speed-up over OpenSeesPy", "opensees_scale:30000", "evaluate_scale:30000", 5.0),
    # issue 25: evaluate within 1.2x of the bare factor-then-eigensolve floor (speed ratio >= 1/1.2)
    ("evaluate, 3,000 DOFs: speed / the bare Cholesky + ARPACK floor's", "floor_scale:3000", "evaluate_scale:3000",
     1 / 1.2),
    ("evaluate, 9,000 DOFs: speed / the bare Cholesky + ARPACK floor's", "floor_scale:9000", "evaluate_scale:9000",
     1 / 1.2),
    ("evaluate, 30,000 DOFs: speed / the bare Cholesky + ARPACK floor's", "floor_scale:30000",
     "evaluate_scale:30000", 1 / 1.2),
    # issue 35: a model given as matrices (a third of its DOFs massless) within 1.3x of the same floor
    ("matrix model evaluate, 10,000 DOFs: speed / the bare Cholesky + ARPACK floor's", "matrix_floor:10000",
     "matrix_eval:10000", 1 / 1.3),
    ("matrix model evaluate, 100,000 DOFs: speed / the bare Cholesky + ARPACK floor's", "matrix_floor:100000",
     "matrix_eval:100000", 1 / 1.3),
    ("batch of 4 at 3,000 DOFs: 2 worker processes over 1", "batch_scale:3000:w1", "batch_scale:3000:w2", 1.0),
    ("diagnosis screen per candidate, 1,092 DOFs: first-order over one exact step", "screen_step:1092",
     "screen_first:1092", 1.0),
    # the sandbox's cost (issue 22): a run in the problem's process / the same run sandboxed
    ("sandboxed run, one point per call (scipy-sa, 1,000 evaluations): in-process / sandboxed time",
     "inproc:scipy-sa", "sandbox:scipy-sa", 1 / 1.5),
    ("sandboxed run, populations (pymoo-ga, 1,000 evaluations): in-process / sandboxed time",
     "inproc:pymoo-ga", "sandbox:pymoo-ga", 1 / 1.1),
    ("sandboxed run, populations (cma-es, 1,000 evaluations): in-process / sandboxed time",
     "inproc:cma-es", "sandbox:cma-es", 1 / 1.1),
    # the same runs' CPU (both processes of a sandboxed run): what the wall times follow on a
    # loaded machine; no goal of its own
    ("sandboxed run, one point per call (scipy-sa): in-process / sandboxed CPU", "inproc-cpu:scipy-sa",
     "sandbox-cpu:scipy-sa", None),
    ("sandboxed run, populations (pymoo-ga): in-process / sandboxed CPU", "inproc-cpu:pymoo-ga",
     "sandbox-cpu:pymoo-ga", None),
    ("sandboxed run, populations (cma-es): in-process / sandboxed CPU", "inproc-cpu:cma-es", "sandbox-cpu:cma-es",
     None),
    # issue 20: the certification's Jacobian, analytic over the central difference it replaced
    ("certify Jacobian, hframe-shape-noisy 48 parameters: analytic over central difference",
     "certify_jac_fd:48", "certify_jac_analytic:48", 5.0),
    ("certify Jacobian, hframe-shape-noisy 192 parameters: analytic over central difference",
     "certify_jac_fd:192", "certify_jac_analytic:192", 20.0),
)

#: (label, figure key prefix, goal): the log-log slope of per-item time against DOFs over the
#: figures "<prefix>:<n_dof>"; the goal is the largest acceptable slope (None: no goal).
SLOPES = (
    ("evaluate cost vs DOFs, 300 to 30,000 (log-log slope)", "evaluate_scale", 1.1),
    ("bare Cholesky + ARPACK floor cost vs DOFs (log-log slope)", "floor_scale", None),
    ("OpenSeesPy rebuild + eigen cost vs DOFs (log-log slope)", "opensees_scale", None),
)

_FIGURES: dict[str, dict] = {}


@pytest.fixture(scope="session")
def points() -> np.ndarray:
    """N_POINTS parameter vectors (Pa), uniform inside the paper problem's bounds, fixed seed."""
    p = make_problem("paper")
    return np.random.default_rng(POINTS_SEED).uniform(p.xl, p.xu, size=(N_POINTS, p.n_var))


@pytest.fixture(scope="session")
def symmetric_stack() -> np.ndarray:
    """N_POINTS random symmetric matrices (fixed seed) the size of the H-frame's eigenproblem
    (39 x 39: 13 nodes x 3 DOF, free-free): the bare batched solver's input."""
    n_dof = make_problem("paper").system.n_free
    b = np.random.default_rng(0).standard_normal((N_POINTS, n_dof, n_dof))
    return b + np.swapaxes(b, 1, 2)


@pytest.fixture
def record(benchmark):
    """record(key, n_items, per_item_s=None, **info): file a per-item time under `key`.

    Without `per_item_s`, call it after the benchmark ran: the benchmark's round times
    divided by `n_items` are filed (under --benchmark-disable nothing was timed and nothing
    is filed). With `per_item_s`, a list of per-item times (s) measured otherwise (e.g. from
    run records) is filed. `info` goes to the benchmark's extra_info. Returns the filed
    {"min_s", "median_s", ...} or None.
    """

    def _record(key: str, n_items: int, per_item_s=None, **info):
        benchmark.extra_info.update(n_items=int(n_items), **info)
        if per_item_s is None:
            meta = benchmark.stats
            if meta is None or not meta.stats.data:
                return None
            per_item_s = [t / n_items for t in meta.stats.data]
        fig = {"min_s": float(np.min(per_item_s)), "median_s": float(np.median(per_item_s)),
               "rounds": len(per_item_s), "n_items": int(n_items), **info}
        benchmark.extra_info.update(per_item_min_s=fig["min_s"], per_item_median_s=fig["median_s"])
        _FIGURES[key] = fig
        return fig

    return _record


def _time(seconds: float) -> str:
    for unit, scale in (("s", 1.0), ("ms", 1e-3), ("us", 1e-6)):
        if seconds >= scale:
            return f"{seconds / scale:.2f} {unit}"
    return f"{seconds / 1e-9:.0f} ns"


def _ratios() -> list[dict]:
    out = []
    for label, slow, fast, goal in RATIOS:
        if slow in _FIGURES and fast in _FIGURES:
            s, f = _FIGURES[slow], _FIGURES[fast]
            ratio = s["min_s"] / f["min_s"]
            out.append({"label": label, "slow": slow, "fast": fast, "ratio_min": ratio,
                        "ratio_median": s["median_s"] / f["median_s"], "goal": goal,
                        "met": None if goal is None else ratio >= goal})
    return out


def _slopes() -> list[dict]:
    out = []
    for label, prefix, goal in SLOPES:
        pts = sorted((int(k.split(":")[1]), f["min_s"]) for k, f in _FIGURES.items() if k.split(":")[0] == prefix)
        if len(pts) >= 2:
            n, t = np.log([p[0] for p in pts]), np.log([p[1] for p in pts])
            slope = float(np.polyfit(n, t, 1)[0])
            out.append({"label": label, "prefix": prefix, "n_dof": [p[0] for p in pts], "slope": slope, "goal": goal,
                        "met": None if goal is None else slope <= goal})
    return out


def pytest_terminal_summary(terminalreporter):
    """Print the per-item figures and the ratios of this session."""
    if not _FIGURES:
        return
    tr = terminalreporter
    tr.section("femu-bench figures (this run)")
    tr.write_line(f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS', '(unset)')}")
    if hasattr(os, "getloadavg"):  # the machine's load: wall-time figures of a shared machine depend on it
        tr.write_line("load average (1, 5, 15 min) at the end: " + ", ".join(f"{v:.2f}" for v in os.getloadavg()))
    tr.write_line(f"{'figure':<34}{'per item, min':>16}{'per item, median':>19}{'items':>7}")
    for key, fig in sorted(_FIGURES.items()):
        tr.write_line(f"{key:<34}{_time(fig['min_s']):>16}{_time(fig['median_s']):>19}{fig['n_items']:>7}")
    ratios = _ratios()
    if ratios:
        tr.write_line("")
        tr.write_line(f"{'ratio (per-item time slow / fast)':<62}{'min':>8}{'median':>8}{'goal':>7}")
        for r in ratios:
            goal = "" if r["goal"] is None else f"{'>= ' + format(r['goal'], 'g'):>7}  {'met' if r['met'] else 'NOT MET'}"
            tr.write_line(f"{r['label']:<62}{r['ratio_min']:>8.2f}{r['ratio_median']:>8.2f}{goal}")
    for r in _slopes():
        goal = "" if r["goal"] is None else f"<= {r['goal']:g}  {'met' if r['met'] else 'NOT MET'}"
        tr.write_line(f"{r['label']:<62}{r['slope']:>8.2f}{'':>8}{goal:>7}")


@pytest.hookimpl(optionalhook=True)
def pytest_benchmark_update_json(config, benchmarks, output_json):
    """Add the figures and ratios to the JSON of --benchmark-json / --benchmark-autosave."""
    output_json["femu_figures"] = {"per_item": dict(_FIGURES), "ratios": _ratios(), "slopes": _slopes(),
                                   "OPENBLAS_NUM_THREADS": os.environ.get("OPENBLAS_NUM_THREADS"),
                                   "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None}
