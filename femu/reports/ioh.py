"""IOHprofiler files (for IOHanalyzer) written by the `ioh` package's own Analyzer logger.

Two ways in, one file format:

- `run_logged(...)` runs an optimizer on a problem wrapped as an ioh problem
  (`IOHLoggedProblem`), so ioh's Analyzer logs every real evaluation as it happens.
- `export_runs(runs, out_dir)` exports finished runs of a store after the fact. A RunResult
  keeps its best-so-far trace, not every evaluation, so each run is replayed through the same
  ioh problem, `n_evals` calls: the best-so-far value at each, NaN (never an improvement for
  ioh) before the first recorded point. ioh logs the improvements and a run's last
  evaluation; the replay gives that one the best value (its raw value is not stored), where
  live logging writes its raw value. Within a batch of evaluations the harness keeps only the
  batch's best, so an improvement is dated at that best's evaluation, never earlier.

raw_y is the precision J - f_opt, as ioh's own Analyzer logs its BBOB problems (f - f_opt,
0 at the optimum), in units of the family's top target (`IOHTerms.scale`: 100 times the
family's fixed `fe_problem.suite.TARGET_SCALE`, the same on every instance and dimension of a
function id, so that a target in IOHanalyzer means one precision per function; a family with
no fixed scale, the ``synthetic`` variant, the power of ten at or above J(x0) - f_opt), at full
precision: ioh's Analyzer writes its raw_y column with 10
fixed decimals (1e-14 would read 0), so ioh's own RawY property is logged a second time with
17 significant digits and put in raw_y's place when the logger closes (`full_precision`).
f_opt is the suite's (the paper's certified minimum for ``paper``); a problem without a known optimum (the ``synthetic``
variant) logs J itself in the same kind of units, f_opt 0. f_opt, the scale and how f_opt is
known are in OUT/femu-ioh.json. The ioh problem's optimum is (x*, 0) where x* is known.

x is in the problem's declared search space [0, 1]^n: (x - xl) / (xu - xl), xl and xu the
parameter bounds (Pa). Function ids are ours (`FUNCTION_IDS`, never ioh's registration order),
one per problem family, from 20001: clear of BBOB's 1-24 and of ioh's other suites (the first
exports used 1, 2, 11-15, `OLD_FUNCTION_IDS`); the instance is the suite instance (1 for a
variant).

Layout (ioh's): OUT/<algorithm>/IOHprofiler_f<id>_femu_<family>.json and
OUT/<algorithm>/data_f<id>_femu_<family>/IOHprofiler_f<id>_DIM<n>.dat; one folder per
optimizer (per optimizer and budget, named <optimizer>_b<budget>, when the runs have several
budgets), one ioh function per family, one ioh run per seed (a run attribute).
`read_ioh` reads the files back, and the export checks what it wrote against the runs.
"""

from __future__ import annotations

import json
import math
import shutil
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from adapters.harness import RunResult
from fe_problem.jsonutil import dumps
from fe_problem.safe_files import write_text
from .render import make_out_dir

#: Prefix of the ioh function names: femu_paper, femu_hframe-freq, ...
PREFIX = "femu_"
MARKER = "femu-ioh.json"

#: Our IOHprofiler function ids, one per problem family (a variant is its own family; the
#: ``paper`` variant is the suite's ``paper`` problem). Stable: never renumber, only add.
FUNCTION_IDS = {"paper": 20001, "synthetic": 20002, "hframe-freq": 20011, "hframe-shape": 20012,
                "hframe-freq-noisy": 20013, "hframe-shape-noisy": 20014, "frame-shape": 20015,
                "frame3d-freq": 20016, "frame3d-shape": 20017}
#: The ids of femu-bench 0.1's first exports (1, 2, 11-15), which collided with BBOB's 1-24.
OLD_FUNCTION_IDS = {"paper": 1, "synthetic": 2, "hframe-freq": 11, "hframe-shape": 12, "hframe-freq-noisy": 13,
                    "hframe-shape-noisy": 14, "frame-shape": 15}
#: The extra column ioh logs raw_y into at full precision (its own RawY property, format {:.17g});
#: it replaces ioh's raw_y column (10 fixed decimals) once a logger is closed (`full_precision`).
FULL = "raw_y_full"
#: The experiment attribute that says what raw_y is (named unlike any data column or metadata field).
ATTRIBUTE = "femu_raw_y_definition"
_PROPERTIES: list = []

_FEEDS: dict[tuple, object] = {}
#: The instance ioh last evaluated per family (`_family_functions`).
_SEEN: dict[str, int] = {}
#: The optimum (x in [0, 1]^n, raw_y) ioh reports per (family, instance, n_var): x NaN where
#: not known, raw_y 0 where f_opt is known (NaN otherwise).
_OPTIMA: dict[tuple, tuple] = {}
_KEEP: dict[str, tuple] = {}


@dataclass(frozen=True, eq=False)
class IOHTerms:
    """How one problem is written for ioh: function id, name and instance; f_opt (J units, 0
    where unknown) and how it is known; scale (raw_y = (J - f_opt) / scale, one per function
    id: `raw_y_scale`); the bounds xl, xu
    (Pa) of x's normalisation; x_opt, the optimum in [0, 1]^n where known (else None)."""

    function_id: int
    family: str
    instance: int
    n_var: int
    f_opt: float
    f_opt_kind: str
    scale: float
    xl: np.ndarray
    xu: np.ndarray
    x_opt: np.ndarray | None

    def raw(self, J):
        """raw_y of objective values J."""
        return (np.asarray(J, dtype=float) - self.f_opt) / self.scale

    def objective(self, raw_y):
        """J of raw_y values (the inverse of `raw`)."""
        return np.asarray(raw_y, dtype=float) * self.scale + self.f_opt

    def unit(self, x):
        """Points (Pa) in the declared search space [0, 1]^n."""
        return (np.asarray(x, dtype=float) - self.xl) / (self.xu - self.xl)

    def to_dict(self) -> dict:
        return {"function_id": self.function_id, "function_name": PREFIX + self.family, "instance": self.instance,
                "n_var": self.n_var, "f_opt": self.f_opt, "f_opt_kind": self.f_opt_kind, "raw_y_scale": self.scale}


@lru_cache(maxsize=None)
def ioh_terms(variant: str) -> IOHTerms:
    """The IOHTerms of a problem variant or suite id (builds the problem once)."""
    from fe_problem.suite import PAPER_F_OPT
    from femu.studies.tasks import is_suite_id, problem_of

    p = problem_of(variant)
    family, instance = (variant.split("/")[0], int(variant.split("/")[2])) if is_suite_id(variant) else (variant, 1)
    f_opt = getattr(p, "f_opt", PAPER_F_OPT if variant == "paper" else None)
    kind = getattr(p, "f_opt_kind", "certified" if variant == "paper" else "unknown")
    xl, xu = np.asarray(p.xl, float), np.asarray(p.xu, float)
    truth = getattr(p, "truth", None)
    return IOHTerms(FUNCTION_IDS[family], family, instance, int(p.n_var), float(f_opt or 0.0), kind,
                    raw_y_scale(family, p, f_opt or 0.0), xl, xu,
                    None if truth is None or f_opt is None else (np.asarray(truth, float) - xl) / (xu - xl))


def raw_y_scale(family: str, problem=None, f_opt: float = 0.0) -> float:
    """The raw_y unit of a family's function id: its top target, 100 * TARGET_SCALE[family]
    (one value for every instance and dimension); for a family without a fixed scale (a
    variant that is its own only instance) the power of ten at or above J(x0) - f_opt of
    `problem`."""
    from fe_problem.suite import TARGET_SCALE

    if family in TARGET_SCALE:
        return 100.0 * TARGET_SCALE[family]
    gap = float(problem.evaluate(problem.x0)[0]) - f_opt
    return 10.0 ** math.ceil(math.log10(gap) - 1e-12)


def _register(family: str) -> None:
    import ioh

    # every family registered at once, before any problem is made: ioh 0.3 crashes making a
    # problem of a family wrapped after another family's problem was made
    for family in (*FUNCTION_IDS, family):
        if family in _KEEP:
            continue
        feed, optimum, seen = _KEEP[family] = _family_functions(family)  # ioh does not hold them: freed, they crash
        ioh.wrap_problem(feed, name=PREFIX + family, dimension=1, lb=0.0, ub=1.0, calculate_objective=optimum,
                         transform_variables=seen)


def _family_functions(family: str):
    """The objective (one argument: x), optimum (instance, dimension) and the variables'
    transformation (x, instance) of a family for ioh. ioh hands the instance to the
    transformation only, just before it calls the objective: it is noted there, and the
    objective answers with the feed of (family, instance, dimension), so that problems of one
    family coexist."""
    def feed(x):
        return _FEEDS[(family, _SEEN[family], len(x))](x)

    def optimum(instance, dimension):
        return _OPTIMA.get((family, instance, dimension), ([math.nan] * dimension, math.nan))

    def seen(x, instance):
        _SEEN[family] = instance
        return x

    return feed, optimum, seen


def ioh_problem(terms: IOHTerms, feed):
    """An ioh RealSingleObjective (minimisation) named femu_<family>, with our function id and
    the problem's instance and dimension, bounds [0, 1], whose value at each call is `feed(x)`
    (one feed per family, instance and dimension at a time: the latest); its optimum (x*, 0)
    where x* is known."""
    import ioh

    _register(terms.family)
    _FEEDS[(terms.family, terms.instance, terms.n_var)] = feed
    x_opt = [math.nan] * terms.n_var if terms.x_opt is None else terms.x_opt.tolist()
    _OPTIMA[(terms.family, terms.instance, terms.n_var)] = (x_opt, 0.0 if terms.f_opt_kind != "unknown" else math.nan)
    p = ioh.get_problem(PREFIX + terms.family, terms.instance, terms.n_var, ioh.ProblemClass.REAL)
    p.set_id(terms.function_id)
    return p


def _analyzer(root: Path, algorithm: str, info: str, triggers: list):
    import ioh

    # the triggers list is held by the caller: ioh does not keep a trigger alive, and a freed
    # one crashes the process at the next evaluation
    from femu.studies.store import safe_name

    full = ioh.logger.property.RawY(FULL, "{:.17g}")
    _PROPERTIES.append(full)  # as the triggers: ioh does not keep it alive
    # the folder's name comes from the optimizer's (user input): a safe file-name piece
    lg = ioh.logger.Analyzer(triggers=triggers, additional_properties=[full], root=str(root),
                             folder_name=safe_name(algorithm), algorithm_name=algorithm, algorithm_info=info,
                             store_positions=False)
    lg.add_run_attribute("seed", 0.0)
    # not named like a data column or a metadata field (raw_y, evals, best_y ...): IOHprofiler's
    # readers join attributes to the data by name (iohinspector moved raw_y to raw_y_right)
    lg.add_experiment_attribute(ATTRIBUTE, "(J - f_opt) / raw_y_scale with J the objective; f_opt per "
                                           "instance and raw_y_scale per function in femu-ioh.json")
    return lg


def _safe(name: str) -> str:
    from femu.studies.store import safe_name

    return safe_name(name)


def full_precision(folder) -> None:
    """Put the full-precision raw_y (ioh's own RawY property logged as `FULL`, 17 significant
    digits) in place of ioh's raw_y column (10 fixed decimals: 1e-14 would read 0) in every
    .dat file under FOLDER (a closed logger's), and drop the extra column from the files and
    the .json's attribute list. Nothing else of ioh's files changes."""
    folder = Path(folder)
    for dat in folder.rglob("IOHprofiler_*.dat"):
        lines = dat.read_text().splitlines()
        head = lines[0].split() if lines else []
        if FULL not in head:
            continue
        i_raw, i_full = head.index("raw_y"), head.index(FULL)
        out = []
        for line in lines:
            cells = line.split()
            if cells and cells[0] != "evaluations":
                cells[i_raw] = cells[i_full]
            out.append(" ".join(c for k, c in enumerate(cells) if k != i_full))
        write_text(dat, "\n".join(out) + "\n")
    for js in folder.rglob("IOHprofiler_*.json"):
        meta = json.loads(js.read_text())
        if FULL in meta.get("attributes", []):
            meta["attributes"] = [a for a in meta["attributes"] if a != FULL]
            write_text(js, json.dumps(meta, indent=1))


class IOHLoggedProblem:
    """A problem whose every evaluation is also passed through an ioh problem with an
    Analyzer attached: live IOHprofiler logging. Evaluates vectorised with the wrapped
    problem, then hands the values to ioh row by row (ioh's problems take points)."""

    def __init__(self, problem, variant: str, logger):
        self.problem = problem
        self.terms = ioh_terms(variant)
        self._values: list[float] = []
        self.ioh = ioh_problem(self.terms, lambda x: self._values.pop())
        self.ioh.attach_logger(logger)

    def __getattr__(self, name):  # n_var, xl, xu, name ... of the problem
        return getattr(self.problem, name)

    def _log(self, X: np.ndarray, f: np.ndarray) -> None:
        self._values = list(self.terms.raw(f)[::-1])
        self.ioh(self.terms.unit(np.atleast_2d(X)))

    def evaluate(self, X) -> np.ndarray:
        """The problem's objective values (n,) for X (n, n_var), each logged by ioh."""
        X = np.atleast_2d(np.asarray(X, dtype=float))
        f = self.problem.evaluate(X)
        self._log(X, f)
        return f

    def least_squares(self, x, charged: int = 1, jacobian: bool | None = None):
        """The problem's least-squares form, logged as the `charged` evaluations the harness
        charged for it (residuals alone 1, with the Jacobian n_var + 1, adapters.budget
        .jacobian_cost): the point once, then as often again without change."""
        out = self.problem.least_squares(x, charged=charged, jacobian=jacobian)
        self._log(np.repeat(np.atleast_2d(x), charged, axis=0), np.full(charged, out.f))
        return out


def run_logged(name: str, variant: str, budget: int, seed: int, out_dir, **options) -> RunResult:
    """Run optimizer `name` on problem variant `variant` through the harness (budget in FE
    evaluations), with ioh's Analyzer logging every evaluation live under OUT_DIR/<name>."""
    import ioh

    from adapters.harness import run
    from femu.studies.tasks import problem_of

    triggers = [ioh.logger.trigger.ON_IMPROVEMENT]
    logger = _analyzer(Path(out_dir), name, f"femu-bench {name}, variant {variant}", triggers)
    logger.set_run_attribute("seed", float(seed))
    wrapped = IOHLoggedProblem(problem_of(variant), variant, logger)
    result = run(name, wrapped, budget, seed, variant=variant, **options)
    wrapped.ioh.reset()
    logger.close()
    from femu.studies.store import safe_name

    full_precision(Path(out_dir) / safe_name(name))
    return result


# == after the fact ===========================================================================
def improvements(run: RunResult) -> list[tuple[int, float]]:
    """The trace's strict improvements as (evaluation, best objective)."""
    out, best = [], math.inf
    for n, f in run.trace:
        if f < best:
            out.append((int(n), float(f)))
            best = f
    return out


def _replay_values(run: RunResult, terms: IOHTerms) -> np.ndarray:
    """What the replay answers at evaluations 1..n_evals (raw_y)."""
    values = np.full(int(run.n_evals), np.nan)
    for k, f in improvements(run):  # each improvement holds until the next
        values[k - 1:] = terms.raw(f)
    values[-1] = terms.raw(run.best_f)
    return values


def algorithm_names(runs) -> dict[str, list[RunResult]]:
    """The ioh algorithm (folder) name of each run: the optimizer, with _b<budget> when the
    runs hold several budgets of it."""
    budgets: dict[str, set] = {}
    for r in runs:
        budgets.setdefault(r.optimizer, set()).add(r.budget)
    out: dict[str, list[RunResult]] = {}
    for r in sorted(runs, key=lambda r: (r.optimizer, r.budget, r.variant, r.seed)):
        out.setdefault(r.optimizer if len(budgets[r.optimizer]) == 1 else f"{r.optimizer}_b{r.budget}", []).append(r)
    return out


def export_runs(runs, out_dir, validate: bool = True) -> Path:
    """Write IOHprofiler files for `runs` (RunResults, a Store or a store path) under OUT_DIR,
    replacing a previous export there; runs without any evaluation are left out and listed
    in OUT_DIR/femu-ioh.json. With `validate`, read the files back and check every run's
    evaluations, best and improvements (RuntimeError if they differ). Returns OUT_DIR."""
    import ioh

    from femu.studies.store import Store

    if isinstance(runs, (str, Path, Store)):
        runs = (runs if isinstance(runs, Store) else Store(runs)).runs()
    out = Path(out_dir)
    if out.exists():
        if (out / MARKER).exists():
            shutil.rmtree(out)
        elif not out.is_dir() or any(out.iterdir()):
            raise ValueError(f"{out}: exists and is not a femu IOH export; choose an empty or new directory")
    make_out_dir(out, "--out")
    usable = [r for r in runs if r.n_evals > 0 and r.trace and len(r.best_x)]
    skipped = [r for r in runs if r.n_evals <= 0 or not r.trace or not len(r.best_x)]
    by_alg = algorithm_names(usable)
    triggers = [ioh.logger.trigger.ON_IMPROVEMENT]
    for alg, rs in by_alg.items():
        logger = _analyzer(out, alg, f"femu-bench {rs[0].optimizer}, budget {rs[0].budget}", triggers)
        for r in rs:
            terms = ioh_terms(r.variant)
            values = iter(_replay_values(r, terms).tolist())
            problem = ioh_problem(terms, lambda x: next(values))
            problem.attach_logger(logger)
            logger.set_run_attribute("seed", float(r.seed))
            problem(np.tile(terms.unit(r.best_x), (r.n_evals, 1)))
            problem.reset()
            problem.detach_logger()
        logger.close()
        full_precision(out / _safe(alg))
    write_text(out / MARKER, dumps({
        "format": "femu.ioh-export/1",
        "raw_y": "(J - f_opt) / raw_y_scale; x in [0, 1]: (x - xl) / (xu - xl)",
        "problems": {v: ioh_terms(v).to_dict() for v in sorted({r.variant for r in usable})},
        "algorithms": {a: len(rs) for a, rs in by_alg.items()},
        "skipped": [{"optimizer": r.optimizer, "variant": r.variant, "seed": r.seed, "status": r.status}
                    for r in skipped]}))
    if validate:
        check_export(out, by_alg)
    return out


# == reading back =============================================================================
@dataclass(frozen=True, eq=False)
class IOHRun:
    """One run read from IOHprofiler files: `points` (k, 2) as (evaluations, raw_y)."""

    algorithm: str
    function_id: int
    function_name: str
    dimension: int
    instance: int
    evals: int
    best_y: float
    attributes: dict
    points: np.ndarray


def read_ioh(root) -> list[IOHRun]:
    """Every run under ROOT's IOHprofiler .json files, with its .dat block, in file order.
    ValueError naming the file when a .dat does not hold one block per listed run."""
    runs = []
    for js in sorted(Path(root).rglob("IOHprofiler_*.json")):
        meta = json.loads(js.read_text())
        for sc in meta["scenarios"]:
            dat = js.parent / sc["path"]
            blocks = _dat_blocks(dat)
            if len(blocks) != len(sc["runs"]):
                raise ValueError(f"{dat}: {len(blocks)} runs of data but {js} lists {len(sc['runs'])}")
            for r, pts in zip(sc["runs"], blocks):
                extra = {k: v for k, v in r.items() if k not in ("instance", "evals", "best")}
                runs.append(IOHRun(meta["algorithm"]["name"], int(meta["function_id"]), meta["function_name"],
                                   int(sc["dimension"]), int(r["instance"]), int(r["evals"]),
                                   float(r["best"]["y"]), extra, pts))
    return runs


def _dat_blocks(path: Path) -> list[np.ndarray]:
    blocks: list[list] = []
    for i, line in enumerate(path.read_text().splitlines(), 1):
        if line.startswith("evaluations"):
            blocks.append([])
        elif line.strip():
            if not blocks:
                raise ValueError(f"{path}:{i}: data before the first header line")
            e, y = line.split()[:2]
            blocks[-1].append((float(e), float("nan") if y == "None" else float(y)))
    return [np.array(b, float).reshape(-1, 2) for b in blocks]


def check_export(root, by_algorithm: dict[str, list[RunResult]]) -> None:
    """RuntimeError unless the files under ROOT hold exactly the runs of `by_algorithm`
    (as from `algorithm_names`): for each, the same evaluations, best value and improvements
    plus ioh's last-evaluation line, all as raw_y (`IOHTerms.raw`)."""
    got = {(r.algorithm, r.function_id, r.instance, int(r.attributes.get("seed", -1))): r for r in read_ioh(root)}
    n = sum(len(rs) for rs in by_algorithm.values())
    if len(got) != n:
        raise RuntimeError(f"{root}: {len(got)} runs in the IOHprofiler files, {n} exported")
    for alg, runs in by_algorithm.items():
        for run in runs:
            terms = ioh_terms(run.variant)
            key = (alg, terms.function_id, terms.instance, run.seed)
            r = got.get(key)
            if r is None:
                raise RuntimeError(f"{root}: run {key} is missing from the IOHprofiler files")
            expect = [(k, float(terms.raw(f))) for k, f in improvements(run)]
            if expect[-1][0] != run.n_evals:
                expect.append((run.n_evals, float(terms.raw(run.best_f))))
            # raw_y at full precision (`full_precision`): equal to the last bits
            if (r.evals != run.n_evals or r.points.shape != (len(expect), 2)
                    or not np.allclose(r.points, expect, rtol=1e-15, atol=0)):
                raise RuntimeError(f"{root}: run {key} reads back as {r.evals} evaluations, {r.points.tolist()}; "
                                   f"expected {run.n_evals}, {expect}")
            if not math.isclose(float(terms.objective(r.best_y)), run.best_f, rel_tol=1e-9):
                raise RuntimeError(f"{root}: run {key} best {r.best_y} != {float(terms.raw(run.best_f))}")
