"""The summary records of a study report: medians and quartiles over seeds, per optimizer and
per (problem variant, budget), and the paper's own numbers. Plain data: computed by
femu.reports.summary, rendered by femu.reports.figures and femu.reports.markdown; `to_dict`
gives the summary.json form (a number that is not finite becomes null: fe_problem.jsonutil).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from fe_problem.jsonutil import jsonable

#: Statuses that count as a failed run (no usable result or cut short by an error).
FAILED = ("failed", "timeout")


class _Quartiles:
    """The summary.json form shared by Spread and ArraySpread (median, q1, q3, n)."""

    def to_dict(self) -> dict:
        """{"median", "q1", "q3", "n"}; numbers that are not finite become None."""
        return jsonable({"median": self.median, "q1": self.q1, "q3": self.q3, "n": self.n})


@dataclass(frozen=True)
class Spread(_Quartiles):
    """Median and quartiles of one quantity over the runs that have it (n of them)."""

    median: float
    q1: float
    q3: float
    n: int

    @classmethod
    def of(cls, values) -> "Spread":
        v = np.asarray(list(values), dtype=float)
        v = v[np.isfinite(v)]
        if not v.size:
            return cls(math.nan, math.nan, math.nan, 0)
        q1, med, q3 = np.quantile(v, [0.25, 0.5, 0.75])
        return cls(float(med), float(q1), float(q3), int(v.size))

    @property
    def iqr(self) -> float:
        """Interquartile range q3 - q1."""
        return self.q3 - self.q1



@dataclass(frozen=True, eq=False)
class ArraySpread(_Quartiles):
    """Per-component median and quartiles over runs: arrays of shape (m,)."""

    median: np.ndarray
    q1: np.ndarray
    q3: np.ndarray
    n: int

    @classmethod
    def of(cls, rows: np.ndarray) -> "ArraySpread":
        rows = np.asarray(rows, dtype=float)
        q1, med, q3 = np.nanquantile(rows, [0.25, 0.5, 0.75], axis=0)
        return cls(med, q1, q3, rows.shape[0])



@dataclass(frozen=True, eq=False)
class Curve:
    """Best-so-far objective against evaluations: median and quartiles over runs (grid,)."""

    evals: np.ndarray
    median: np.ndarray
    q1: np.ndarray
    q3: np.ndarray


@dataclass(frozen=True, eq=False)
class SolverSummary:
    """One optimizer on one (variant, budget), over its seeds.

    Frequencies in Hz, errors in % of the measured frequency (signed: model - measured),
    times in seconds, overhead_ms_per_eval = 1000 (wall_s - fe_s) / n_evals. Quantities from
    the updated model (frequencies_hz .. mean_comac) cover the runs that produced a point.
    """

    optimizer: str
    variant: str
    budget: int
    seeds: tuple[int, ...]
    statuses: dict
    failures: tuple[tuple[int, str, str], ...]  # (seed, status, first line of the error)
    best_f: Spread
    frequencies_hz: ArraySpread | None
    error_pct: ArraySpread | None
    abs_error_pct: ArraySpread | None
    mean_abs_error_pct: Spread
    mac: ArraySpread | None
    mean_comac: Spread | None
    n_evals: Spread
    wall_s: Spread
    cpu_s: Spread
    fe_s: Spread
    overhead_s: Spread
    overhead_ms_per_eval: Spread
    curve: Curve | None
    ecdf: np.ndarray | None = None  # fraction of (run, target) pairs reached on the group's grid
    best_seed: int | None = None  # the seed of this optimizer's best run (lowest best_f)
    best_x: np.ndarray | None = None  # that run's point: the updated parameters (Pa for moduli)
    best_run_f: float = math.nan  # that run's J

    @property
    def n_runs(self) -> int:
        return len(self.seeds)

    @property
    def n_failed(self) -> int:
        return sum(self.statuses.get(s, 0) for s in FAILED)

    @property
    def status(self) -> str:
        """The common status of every run, or ``mixed``."""
        return next(iter(self.statuses)) if len(self.statuses) == 1 else "mixed"

    def to_dict(self) -> dict:
        opt = lambda s: None if s is None else s.to_dict()  # noqa: E731
        return {"optimizer": self.optimizer, "variant": self.variant, "budget": self.budget,
                "seeds": list(self.seeds), "status": self.status, "statuses": dict(self.statuses),
                "failures": [{"seed": s, "status": st, "error": e} for s, st, e in self.failures],
                "best_f": self.best_f.to_dict(), "frequencies_hz": opt(self.frequencies_hz),
                "error_pct": opt(self.error_pct), "abs_error_pct": opt(self.abs_error_pct),
                "mean_abs_error_pct": self.mean_abs_error_pct.to_dict(), "mac": opt(self.mac),
                "mean_comac": opt(self.mean_comac), "n_evals": self.n_evals.to_dict(),
                "wall_s": self.wall_s.to_dict(), "cpu_s": self.cpu_s.to_dict(), "fe_s": self.fe_s.to_dict(),
                "overhead_s": self.overhead_s.to_dict(),
                "overhead_ms_per_eval": self.overhead_ms_per_eval.to_dict(),
                "best_run": {"seed": self.best_seed, "best_f": _num(self.best_run_f), "x": _arr(self.best_x)}}


@dataclass(frozen=True, eq=False)
class PaperComparison:
    """The paper's Table 1 and text figures, with its mean absolute errors recomputed (%)
    from the table's frequencies; `disagreements` name the methods whose text percentage
    differs from what the table implies by more than 0.05 percentage points."""

    measured_hz: np.ndarray
    initial_hz: np.ndarray
    updated_hz: dict
    abs_error_pct: dict  # method (and "initial") -> (m,) from the table
    mean_abs_error_pct: dict  # method -> float, from the table
    mean_error_pct_text: dict
    mean_comac_text: dict
    cpu_minutes_text: dict
    disagreements: tuple[str, ...]


@dataclass(frozen=True, eq=False)
class Parameters:
    """The updating parameters of a group's problem: labels (E1 ...), what each is, initial
    values and bounds (SI units: Pa for moduli)."""

    labels: tuple[str, ...]
    kinds: tuple[str, ...]
    x0: np.ndarray
    lower: np.ndarray
    upper: np.ndarray

    def at_bound(self, x: np.ndarray, rtol: float = 1e-3) -> np.ndarray:
        """-1 / +1 where x is within rtol of the range from its lower / upper bound, else 0."""
        tol = rtol * (self.upper - self.lower)
        return np.where(x <= self.lower + tol, -1, np.where(x >= self.upper - tol, 1, 0))


@dataclass(frozen=True, eq=False)
class ModeComparison:
    """The model at its initial parameters and at the group's best point (the lowest J of any
    run): the first modes of both for drawing, and MAC matrices against the updated modes.

    `shapes_initial`, `shapes_updated`: (n_dof, k) on every nodal DOF of `model` (its
    `model.dofs` order), the updated ones signed to agree with the initial mode they pair with;
    `mac_initial_updated`: (k, k) over the measured coordinates; `mac_measured_updated`: (m, k),
    measured against updated modes (None when the data have no measured shapes)."""

    model: object  # the FrameModel the shapes are drawn on
    optimizer: str
    seed: int
    best_f: float
    frequencies_initial_hz: np.ndarray
    frequencies_updated_hz: np.ndarray
    shapes_initial: np.ndarray
    shapes_updated: np.ndarray
    mac_initial_updated: np.ndarray
    mac_measured_updated: np.ndarray | None

    def to_dict(self) -> dict:
        return {"optimizer": self.optimizer, "seed": self.seed, "best_f": _num(self.best_f),
                "frequencies_initial_hz": _arr(self.frequencies_initial_hz),
                "frequencies_updated_hz": _arr(self.frequencies_updated_hz),
                "mac_initial_updated": jsonable(self.mac_initial_updated),
                "mac_measured_updated": None if self.mac_measured_updated is None
                else jsonable(self.mac_measured_updated)}


@dataclass(frozen=True, eq=False)
class GroupSummary:
    """Every optimizer on one problem variant under one budget, with the initial model,
    the ECDF targets and grid, and (variant 'paper') the paper's own numbers."""

    variant: str
    budget: int
    measured_hz: np.ndarray
    initial_hz: np.ndarray
    initial_error_pct: np.ndarray
    initial_mac: np.ndarray | None
    initial_mean_comac: float | None
    has_shapes: bool
    solvers: tuple[SolverSummary, ...]
    grid: np.ndarray  # evaluations at which curves and ECDFs are sampled
    targets: np.ndarray  # ECDF objective targets, descending
    paper: PaperComparison | None = None
    notes: tuple[str, ...] = field(default_factory=tuple)
    parameters: Parameters | None = None
    best_known_f: float | None = None  # the lowest J known for the problem (a line on the curves)
    best_known_how: str = ""  # where that value comes from
    modes: ModeComparison | None = None

    @property
    def initial_mean_abs_error_pct(self) -> float:
        return float(np.mean(np.abs(self.initial_error_pct)))

    def solver(self, name: str) -> SolverSummary:
        for s in self.solvers:
            if s.optimizer == name:
                return s
        raise KeyError(f"no optimizer {name!r} in {self.variant} b{self.budget}")

    def to_dict(self) -> dict:
        d = {"variant": self.variant, "budget": self.budget, "measured_hz": _arr(self.measured_hz),
             "initial_hz": _arr(self.initial_hz), "initial_error_pct": _arr(self.initial_error_pct),
             "initial_mean_abs_error_pct": self.initial_mean_abs_error_pct,
             "initial_mean_comac": self.initial_mean_comac, "has_shapes": self.has_shapes,
             "targets": _arr(self.targets), "solvers": {s.optimizer: s.to_dict() for s in self.solvers},
             "best_known_f": _num(self.best_known_f), "best_known_how": self.best_known_how,
             "modes": None if self.modes is None else self.modes.to_dict()}
        if self.parameters is not None:
            q = self.parameters
            d["parameters"] = {"labels": list(q.labels), "kinds": list(q.kinds), "x0": _arr(q.x0),
                               "lower": _arr(q.lower), "upper": _arr(q.upper)}
        if self.paper is not None:
            p = self.paper
            d["paper"] = {"measured_hz": _arr(p.measured_hz), "initial_hz": _arr(p.initial_hz),
                          "updated_hz": {k: _arr(v) for k, v in p.updated_hz.items()},
                          "mean_abs_error_pct_from_table": p.mean_abs_error_pct,
                          "mean_error_pct_text": p.mean_error_pct_text, "mean_comac_text": p.mean_comac_text,
                          "cpu_minutes_text": p.cpu_minutes_text, "text_disagrees_with_table": list(p.disagreements)}
        return d


def _num(x):
    """A float for JSON: None when missing or not finite."""
    return jsonable(None if x is None else float(x))


def _arr(a):
    """A float list for JSON: None when missing, non-finite entries None."""
    return None if a is None else jsonable(np.asarray(a, dtype=float))
