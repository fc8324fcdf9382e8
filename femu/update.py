"""`femu update`: fit a model's parameters to measured modes and write the updated model, the
record `update.json` (format ``femu.update/1``, shared/formats/update-result.md) and a report.

The model is read through `fe_problem.user_problem.load_update_model` and the updated model
written through `write_updated_model`, each the one place that dispatches on the model's type (a frame model
today, `femu.model/1` JSON), so that another model type is one branch in each. The objective
is the balanced one (`UpdatingProblem(objective="balanced")`, docs/update.md); the optimizer
runs through `adapters.run` (sandboxed as in studies) from the model's own parameters; the
statistics of the estimate come from `fe_problem.estimate`.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fe_problem.user_problem import file_hash, load_update_model, model_hash, user_problem

#: The format tag of update.json.
UPDATE_FORMAT = "femu.update/1"
DEFAULT_OPTIMIZER, DEFAULT_BUDGET = "sensitivity", 1000


def write_updated_model(model, parameters, x, out_dir: Path) -> dict:
    """Write `model` with its parameters at x into `out_dir`, in the format it was read in; returns
    {"model": path} (and "deck": path for a model imported from Nastran). A frame model:
    updated-model.json (`femu.model/1`), and when it was imported from a Nastran deck
    (`nastran.source_of`) also updated-model.bdf, that deck with the changed values
    (`nastran.write_like`); a matrix model: updated-model.json, its manifest with each parameter's
    `initial` at its estimate and its matrix files copied beside it."""
    from fe_problem.matrix_model import MatrixModel, save_matrix_model
    from fe_problem.model import FrameModel, save_model
    from fe_problem.model.nastran import source_of, write_like
    from fe_problem.parameters import model_with

    out_dir = Path(out_dir)
    if isinstance(model, MatrixModel):
        updated = model.with_initials({p.name: float(v) for p, v in zip(parameters, x)})
        return {"model": save_matrix_model(updated, out_dir / "updated-model.json", copy_files=True)}
    if isinstance(model, FrameModel):
        updated = model_with(model, parameters, x)
        files = {"model": save_model(updated, out_dir / "updated-model.json")}
        deck = source_of(model)
        if deck is not None:
            if not Path(deck).is_file():
                raise ValueError(f"{model.source}: its source deck {deck} (meta 'import' 'path') is not there: "
                                 f"updated-model.bdf not written (updated-model.json is)")
            files["deck"] = write_like(updated, deck, out_dir / "updated-model.bdf")
        return files
    raise TypeError(f"cannot write a model of type {type(model).__name__}")


@dataclass(frozen=True, eq=False)
class UpdateResult:
    """What `update` found: the record (update.json's content), the estimate's statistics, the
    MAC matrices before and after (measured x model) and the files written."""

    record: dict
    mac_initial: np.ndarray | None
    mac_updated: np.ndarray | None
    files: dict


def _modes_at(problem, x, data, n_modes):
    """Model frequencies (n,) and shapes at the measured DOFs (n_dofs, n) at x, and the pairing
    of every measured mode with them (by MAC where shapes exist)."""
    from fe_problem.correlation import mac, pair_modes
    from fe_problem.modal import frequencies_hz

    lam, phi = problem.system.eigen(np.asarray(x, dtype=float)[None], n_modes, vectors=True, rows=problem.rows)
    f, phi = frequencies_hz(lam[0]), phi[0]
    pairing = pair_modes(data.frequencies_hz, f, data.shapes, phi, data.has_shape)
    macs = None
    if data.has_shape.any():  # measured x model, NaN rows where no shape was measured
        macs = np.full((data.n_modes, len(f)), np.nan)
        macs[data.has_shape] = mac(data.shapes[:, data.has_shape], phi)
    return f, phi, pairing, macs


def _progress(problem, budget: int, enabled: bool):
    """A rich progress bar of the evaluations spent, polled from the problem's counter while the
    run goes on (the run's evaluating side is this process); a context manager."""
    import contextlib

    if not enabled:
        return contextlib.nullcontext()
    from femu.studies.progress import has_rich

    if not has_rich():  # the core install: one line when the run ends
        @contextlib.contextmanager
        def plain():
            import sys

            start = problem.points_evaluated
            try:
                yield
            finally:
                print(f"evaluations {min(budget, problem.points_evaluated - start)}/{budget}", file=sys.stderr,
                      flush=True)
        return plain()

    @contextlib.contextmanager
    def bar():
        from rich.console import Console
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

        start = problem.points_evaluated
        stop = threading.Event()
        with Progress(TextColumn("evaluations"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                      transient=True, console=Console(stderr=True)) as p:  # stdout keeps the results
            task = p.add_task("update", total=budget)

            def poll():
                while not stop.wait(0.2):
                    p.update(task, completed=min(budget, problem.points_evaluated - start))
            t = threading.Thread(target=poll, daemon=True)
            t.start()
            try:
                yield
            finally:
                stop.set()
                t.join()
    return bar()


def update(model_path, data_path, out, parameters_path=None, optimizer: str = DEFAULT_OPTIMIZER,
           budget: int = DEFAULT_BUDGET, seed: int = 0, options: dict | None = None, hold_out: int = 0,
           progress: bool = False) -> UpdateResult:
    """Fit the model's parameters to the data with `optimizer` (through adapters.run, from the
    model's own values where the optimizer takes a start) and write updated-model.json,
    update.json and report.md (with its figures) into `out`."""
    from adapters import run as run_optimizer
    from adapters.capabilities import capabilities
    from adapters.registry import get
    from fe_problem.estimate import estimate_of, frequency_ranges
    from fe_problem.jsonutil import dumps
    from fe_problem.safe_files import write_text
    from femu.reports.render import make_out_dir
    from femu.reports.update import write_update_report

    problem, data, held, note = user_problem(model_path, data_path, parameters_path, hold_out)
    out = make_out_dir(out)
    cls = get(optimizer)
    x0_mode = "all" if capabilities(cls)["supports_x0"] else "none"
    with _progress(problem, budget, progress):
        run = run_optimizer(optimizer, problem, budget, seed, x0=x0_mode, **(options or {}))
    if run.status not in ("ok", "stopped") or not len(run.best_x):
        why = (run.error or "no point evaluated").strip().splitlines()[-1]
        raise ValueError(f"optimizer {optimizer!r} ended with status {run.status} ({why}); nothing was written")
    x0 = problem.x0
    x = np.asarray(run.best_x, dtype=float)
    j0, j1 = (float(v) for v in problem.objective_from_modes(*_paired(problem, np.vstack([x0, x]))))
    if j0 < j1:  # the optimizer found nothing better than the start: the start is the estimate
        x, j1 = x0.copy(), j0
    est = estimate_of(problem, x)
    n_modes = problem.n_model_modes
    f0, _, p0, mac0 = _modes_at(problem, x0, data, n_modes)
    f1, _, p1, mac1 = _modes_at(problem, x, data, n_modes)
    ranges = frequency_ranges(problem, est, n_modes)
    modes, sigma_hz = [], data.noise()[0]
    for i in range(data.n_modes):
        def at(f, p, macs):
            k = int(p.model_index[i]) if p.paired[i] else None
            return (None if k is None else float(f[k]), None if k is None else k + 1,
                    None if k is None or macs is None or not data.has_shape[i] else float(macs[i, k]))
        hz0, k0, m0 = at(f0, p0, mac0)
        hz1, k1, m1 = at(f1, p1, mac1)
        modes.append({"measured_hz": float(data.frequencies_hz[i]), "initial_hz": hz0, "updated_hz": hz1,
                      "model_mode_initial": k0, "model_mode_updated": k1, "mac_initial": m0, "mac_updated": m1,
                      "updated_hz_range_95": (None if k1 is None or np.isnan(ranges[k1 - 1]).any()
                                              else [float(v) for v in ranges[k1 - 1]]),
                      "frequency_std_hz": float(sigma_hz[i]), "stated_std": bool(data.has_frequency_std[i]),
                      "held_out": bool(i in held)})

    def mean_err(key, which):
        errs = [abs(r[key] - r["measured_hz"]) / r["measured_hz"] * 100 for r in modes
                if (r["held_out"] == which) and r[key] is not None]
        return float(np.mean(errs)) if errs else None

    params = []
    for k, p in enumerate(problem.parameters):
        iv = est.interval_95[k]
        params.append({"name": p.label, "kind": p.kind, "targets": list(p.targets), "initial": p.initial,
                       "estimate": float(x[k]), "lower": p.lower, "upper": p.upper, "at_bound": bool(est.at_bound[k]),
                       "interval_95": None if np.isnan(iv).any() else [float(iv[0]), float(iv[1])],
                       "identifiable": bool(est.identifiable[k]),
                       "std": None if np.isnan(est.std[k]) else float(est.std[k])})
    record = {
        "format": UPDATE_FORMAT, "model": str(model_path), "data": str(data_path),
        "model_sha256": model_hash(model_path), "data_sha256": file_hash(data_path),
        "parameters_file": None if parameters_path is None else str(parameters_path),
        "parameters_note": note, "optimizer": optimizer, "budget": int(budget), "seed": int(seed),
        "options": options or {}, "status": run.status, "n_evals": int(run.n_evals),
        "parameters": params, "modes": modes,
        "objective": {"kind": "balanced", "initial": j0, "updated": j1},
        "mean_abs_frequency_error_pct": {"initial": mean_err("initial_hz", False), "updated": mean_err("updated_hz", False)},
        "held_out_mean_abs_frequency_error_pct": ({"initial": mean_err("initial_hz", True),
                                                   "updated": mean_err("updated_hz", True)} if len(held) else None),
        "noise": {"chi2": est.chi2, "n": est.n, "scale": est.scale, "chi2_total": est.chi2_total, "dof": est.dof,
                  "reduced_chi2": est.reduced_chi2, "p_value": est.p_value, "fits_noise": est.fits_noise,
                  "stated": {"frequencies": int(data.has_frequency_std.sum()),
                             "shapes": int(data.has_shape_std.sum()), "modes": int(data.n_modes)}},
        "correlation": [[None if np.isnan(v) else float(v) for v in row] for row in est.correlation],
        "verdict": verdict(est, data),
    }
    files = write_updated_model(problem.model, problem.parameters, x, out)
    files["update"] = write_text(out / "update.json", dumps(record) + "\n")
    files.update(write_update_report(record, mac0, mac1, out))
    return UpdateResult(record, mac0, mac1, files)


def _paired(problem, X):
    """(paired frequencies, shapes at the measured DOFs) of the problem at the rows of X: not
    counted as evaluations."""
    from fe_problem.modal import frequencies_hz

    lam, phi = problem.system.eigen(X, problem.n_model_modes, vectors=True, rows=problem.rows)
    return frequencies_hz(lam)[:, problem.model_index], phi


def verdict(est, data) -> str:
    """The misfit against the noise in words."""
    from fe_problem.estimate import FIT_LEVEL

    kinds = ", ".join(f"{k} {est.chi2[k] / est.n[k]:.2f} over {est.n[k]} entries" for k in est.chi2)
    stated = "the stated deviations" if data.has_frequency_std.any() or data.has_shape_std.any() else \
        "the default noise (no deviations stated: 0.2 % of each frequency, 2 % of each shape's peak)"
    if est.dof < 1:
        return (f"No verdict: {sum(est.n.values())} data entries for {len(est.x)} parameters leave no degree of "
                "freedom to judge the misfit.")
    if est.fits_noise:
        low = ("; the misfit is far below that noise (the noise is overstated, or the data are not a "
               "measurement)") if est.p_value > 1 - FIT_LEVEL else ""
        return (f"The updated model fits the data within their noise: reduced chi^2 {est.reduced_chi2:.3g} "
                f"(p = {est.p_value:.2g}) with {stated} (chi^2 per entry: {kinds}){low}.")
    worst = max(est.scale, key=est.scale.get)
    return (f"The model cannot fit the data within their noise: reduced chi^2 {est.reduced_chi2:.2f} "
            f"(p = {est.p_value:.2g}) with {stated} (chi^2 per entry: {kinds}); the {worst} misfit is "
            f"{est.scale[worst]:.1f} times their noise. The intervals use each kind's misfit as its error scale; "
            "a misfit this size points at what the parameters cannot represent (model form, pairing, or "
            "understated deviations).")


__all__ = ["DEFAULT_BUDGET", "DEFAULT_OPTIMIZER", "UPDATE_FORMAT", "UpdateResult", "file_hash", "load_update_model",
           "update", "user_problem", "write_updated_model"]
