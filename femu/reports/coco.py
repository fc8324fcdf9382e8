"""COCO data (for cocopp, COCO's post-processing) of finished runs: `femu report --coco`.

COCO's single-objective format as its bbob logger writes it (data format ``bbob-new2``) and
`cocopp.pproc.DataSet` reads it. Per algorithm folder OUT/<algorithm>/ (the optimizer, with
_b<budget> when the runs hold several budgets of it, as the IOH export names them):

- ``femuexp_f<id>.info``: per dimension three lines: the header (``suite``, ``funcId``,
  ``DIM``, ``Precision``, ``algId``, ``logger``, ``data_format``), a comment line (``%``),
  and the data line: the .dat file, then ``instance:evaluations|final f - Fopt`` per run;
- ``data_f<id>/femuexp_f<id>_DIM<n>.dat``: target-triggered records, per run a ``%`` header
  and a line at each improvement of the best-so-far (the first evaluation is one) and at the
  run's last evaluation;
- ``data_f<id>/femuexp_f<id>_DIM<n>.tdat``: evaluation-triggered records, the best-so-far at
  the first evaluation of every step of 10^(1/20) in evaluations and at the last evaluation.

Columns: f evaluations, g evaluations (0: no constraints), best f - Fopt, f of the recorded
point, best f. Here f = J / target_scale: COCO's fixed targets 1e2 ... 1e-8 on f - Fopt are
then the report's targets on J - f_opt (`femu.reports.stats.fixed_targets`: 1e2 ... 1e-8
times the family's TARGET_SCALE; a variant without one, its top target over 100), so cocopp's
ERT at target 10^(2 - k/5) is the report's ERT at target level k. Function ids are the IOH
export's less 20000 (`function_ids`), instances the suite's (1 for a variant), the dimension
n_var. The trace keeps the best-so-far, not every point: the recorded f is the best
f at that evaluation, and no x is written. Runs without an evaluation are left out and listed
in OUT/femu-coco.json.

cocopp knows its own suites only: `cocopp_testbed()` registers ours (suite ``femu-bench``) as
a testbed of COCO's single-objective kind, without a reference algorithm, before cocopp
reads the files.
"""

from __future__ import annotations

import math
import shutil
from pathlib import Path

import numpy as np

from fe_problem.jsonutil import dumps
from fe_problem.safe_files import write_text
from .render import make_out_dir

SUITE = "femu-bench"
MARKER = "femu-coco.json"
#: COCO's finest target on f - Fopt (the report's 1e-8 times the target scale).
PRECISION = 1e-8
#: Steps of the .tdat's evaluation triggers per decade (COCO's bbob logger: 20).
TDAT_PER_DECADE = 20
_HEADER = ("% f evaluations | g evaluations | best noise-free fitness - Fopt ({fopt:.12e}) + sum g_i+ | "
           "measured fitness | best measured fitness or single-digit g-values | {note}")


def _line(n: int, best: float, f_opt: float, scale: float) -> str:
    return f"{n:d} 0 {(best - f_opt) / scale:+.15e} {best / scale:+.15e} {best / scale:+.15e}"


def _dat(run, f_opt: float, scale: float) -> list[str]:
    """The target-triggered lines of one run: every improvement and the last evaluation."""
    from .ioh import improvements

    imp = improvements(run)
    lines = [_line(k, f, f_opt, scale) for k, f in imp]
    if imp[-1][0] != run.n_evals:
        lines.append(_line(run.n_evals, imp[-1][1], f_opt, scale))
    return lines


def tdat_evaluations(n_evals: int) -> np.ndarray:
    """The evaluation triggers of a run of n_evals evaluations: the first integer evaluation
    at or above each 10^(i / TDAT_PER_DECADE), and n_evals."""
    grid = np.ceil(10.0 ** (np.arange(int(TDAT_PER_DECADE * math.log10(max(n_evals, 1))) + 1) / TDAT_PER_DECADE))
    return np.unique(np.append(grid[grid <= n_evals], n_evals)).astype(int)


def _tdat(run, f_opt: float, scale: float) -> list[str]:
    from .stats import RunTrace

    at = tdat_evaluations(run.n_evals)
    best = RunTrace.of(run).best_at(at)
    return [_line(int(n), float(b), f_opt, scale) for n, b in zip(at, best) if math.isfinite(b)]


def _scales(runs) -> dict[str, tuple[float, float]]:
    """{problem: (f_opt, scale)} with scale the report's top target / 100 (`targets_of`)."""
    from .benchmark import targets_of

    return {pid: (t.f_opt, t.deltas[0] / 100.0) for pid, t in targets_of(runs).items()}


def function_ids() -> dict[str, int]:
    """COCO function ids of the families: the IOH export's less 20000 (paper 1, synthetic 2,
    hframe-freq 11 ... frame3d-shape 17). A COCO suite numbers its functions from 1 (the suite
    name, ``femu-bench``, keeps them apart from bbob's), and cocopp groups functions by ranges
    of small ids (1-92 single-objective)."""
    from .ioh import FUNCTION_IDS

    return {family: fid - 20000 for family, fid in FUNCTION_IDS.items()}


def _function(variant: str) -> tuple[int, int]:
    """(COCO function id, instance) of a problem: `function_ids`, the suite instance."""
    from femu.studies.tasks import is_suite_id

    family, instance = (variant.split("/")[0], int(variant.split("/")[2])) if is_suite_id(variant) else (variant, 1)
    return function_ids()[family], instance


def export_coco(runs, out_dir) -> Path:
    """Write COCO data for `runs` (RunResults, a Store or a store path) under OUT_DIR,
    replacing a previous export there (ValueError for a directory that holds anything else).
    Returns OUT_DIR."""
    from femu.studies.store import Store, safe_name

    from .ioh import algorithm_names

    if isinstance(runs, (str, Path, Store)):
        runs = (runs if isinstance(runs, Store) else Store(runs)).runs()
    out = Path(out_dir)
    if out.exists():
        if (out / MARKER).exists():
            shutil.rmtree(out)
        elif not out.is_dir() or any(out.iterdir()):
            raise ValueError(f"{out}: exists and is not a femu COCO export; choose an empty or new directory")
    make_out_dir(out, "--out")
    usable = [r for r in runs if r.n_evals > 0 and r.trace]
    skipped = [r for r in runs if not (r.n_evals > 0 and r.trace)]
    scales = _scales(usable) if usable else {}
    for alg, rs in algorithm_names(usable).items():
        folder = out / safe_name(alg)
        by_fun: dict[int, dict[int, list]] = {}
        for r in rs:
            fid, _ = _function(r.variant)
            by_fun.setdefault(fid, {}).setdefault(len(r.best_x) or _n_var(r.variant), []).append(r)
        for fid, dims in sorted(by_fun.items()):
            info = []
            for dim, drs in sorted(dims.items()):
                drs = sorted(drs, key=lambda r: (_function(r.variant)[1], r.seed))
                rel = f"data_f{fid}/femuexp_f{fid}_DIM{dim}"
                dat, tdat, entries = [], [], []
                for r in drs:
                    f_opt, scale = scales[r.variant]
                    inst = _function(r.variant)[1]
                    head = _HEADER.format(fopt=f_opt / scale, note=f"problem {r.variant}, seed {r.seed}, "
                                                                   f"f = J / {scale:.6g}")
                    dat += [head, *_dat(r, f_opt, scale)]
                    tdat += [head, *_tdat(r, f_opt, scale)]
                    entries.append(f"{inst}:{r.n_evals}|{(r.best_f - f_opt) / scale:.1e}")
                (folder / f"data_f{fid}").mkdir(parents=True, exist_ok=True)
                write_text(folder / f"{rel}.dat", "\n".join(dat) + "\n")
                write_text(folder / f"{rel}.tdat", "\n".join(tdat) + "\n")
                info += [f"suite = '{SUITE}', funcId = {fid}, DIM = {dim}, Precision = {PRECISION:.3e}, "
                         f"algId = '{alg}', coco_version = '', logger = '{SUITE}', data_format = 'bbob-new2'",
                         f"% femu-bench runs of {drs[0].optimizer}, budget {drs[0].budget}; f = J / target scale",
                         ", ".join([f"{rel}.dat", *entries])]
            write_text(folder / f"femuexp_f{fid}.info", "\n".join(info) + "\n")
    write_text(out / MARKER, dumps({
        "format": "femu.coco-export/1", "suite": SUITE,
        "f": "J / scale; Fopt = f_opt / scale; COCO's targets 1e2 ... 1e-8 on f - Fopt are the report's",
        "problems": {pid: {"function_id": _function(pid)[0], "instance": _function(pid)[1], "f_opt": fo, "scale": s}
                     for pid, (fo, s) in scales.items()},
        "skipped": [{"optimizer": r.optimizer, "variant": r.variant, "seed": r.seed, "status": r.status}
                    for r in skipped]}))
    return out


def _n_var(variant: str) -> int:
    from .benchmark import problem_facts

    return problem_facts(variant)["n_var"]


def cocopp_testbed():
    """Register the suite ``femu-bench`` with cocopp (which reads only the suites it knows) as a
    testbed of COCO's single-objective kind: its targets, 5 per decade from 1e2 to 1e-8, no
    reference algorithm, our function ids and dimensions. Returns the testbed class. Needs
    cocopp (the 'test' extra)."""
    try:
        from cocopp import testbedsettings as tb
    except ImportError:
        raise ValueError("reading the COCO export with cocopp needs the 'test' extra: pip install 'femu-bench[test]'") from None
    from fe_problem.suite import FAMILIES

    ids = function_ids()
    name = "FemuBenchTestbed"
    if name not in vars(tb):
        dims = tuple(sorted({d for f in FAMILIES.values() for d in f.dimensions}))
        # cocopp's captions name six dimensions: a doubled largest one pads ours
        dims = (dims + tuple(dims[-1] * 2 ** k for k in range(1, 7)))[:max(6, len(dims))]
        settings = dict(tb.GECCOBBOBTestbed.settings, name=SUITE, dimensions_to_display=dims,
                        goto_dimension=dims[0], rldDimsOfInterest=dims[:2], tabDimsOfInterest=dims[:2],
                        short_names={fid: f"femu_{fam}" for fam, fid in ids.items()},
                        functions_with_legend=(min(ids.values()), max(ids.values())),
                        first_function_number=min(ids.values()), last_function_number=max(ids.values()),
                        reference_algorithm_filename=None, reference_algorithm_displayname=None,
                        plots_on_main_html_page=[f"pprldmany_{d:02d}D_noiselessall.svg" for d in dims])

        class FemuBenchTestbed(tb.GECCOBBOBTestbed):
            """femu-bench's suite: structural-dynamics model updating (femu.reports.coco)."""

            def __init__(self, target_values):
                for key, val in settings.items():
                    setattr(self, key, val)
                self.instantiate_attributes(target_values)

            def filter(self, dsl):  # GECCOBBOBTestbed's accepts bbob suites only
                return dsl

            def info(self, fun_number=None):
                return self.__doc__ if fun_number is None else settings["short_names"].get(fun_number, "")

        tb.FemuBenchTestbed = FemuBenchTestbed
    tb.suite_to_testbed[SUITE] = name
    return vars(tb)[name]
