"""The FE model-updating task as a bounded minimisation problem.

    J(theta) = sum_i w_i ((f_i_meas - f_i(theta)) / f_i_meas)^2  +  shape_weight * sum_i (1 - MAC_i)

The default is the paper's: the 12 element moduli of the H-frame in [6e10, 8e10] Pa, initial
7e10, and its eq. 4 weights w_i = gamma_i = ((f_i_meas - f_i_initial) / f_i_meas)^2. Measured
modes are paired with model modes once, at the initial parameters (by MAC where shapes were
measured, by frequency otherwise); the pairing then stays fixed, as in the paper.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .correlation import Pairing, correlate, pair_modes, pow2_scaled
from .modal_data import ModalData, load_modal_data
from .modal import ModalResult, frequencies_hz
from .model import FrameModel
from .assembly import AffineModel
from .any_model import load_any_model
from .matrix_model import MatrixModel, MatrixSystem
from ._threads import blas_pinned, one_blas_thread
from .parameters import Parameter, element_moduli

WEIGHTS = ("gamma", "unit")
#: The objectives: ``weighted`` (the paper's J above, the suite's) and ``balanced`` (the
#: measured noise within each kind of data, an error scale per kind: `balanced_objective`).
OBJECTIVES = ("weighted", "balanced")


def balanced_objective(rss: np.ndarray, n: int) -> np.ndarray:
    """One kind's share of the balanced objective: -2 log of its Gaussian likelihood with the
    error scale s^2 >= 1 (a multiple of the stated noise) profiled out, up to a constant:
    rss where rss <= n (s = 1: the data fit within their noise), else n (1 + log(rss / n))
    (s^2 = rss / n). Continuous with its first derivative at rss = n."""
    rss = np.asarray(rss, dtype=float)
    with np.errstate(divide="ignore"):
        return np.where(rss <= n, rss, n * (1.0 + np.log(np.maximum(rss, n) / n)))


@dataclass(frozen=True, eq=False)
class LeastSquares:
    """Objective f, residuals r (m,) and Jacobian dr/dtheta (m, n_var) at one point."""

    f: float
    residuals: np.ndarray
    jacobian: np.ndarray


@dataclass(frozen=True, eq=False)
class CorrelationReport:
    """How the model at x compares with the measurements (paired modes only).

    measured_hz, model_hz, error_pct: (m,) for the measured modes (NaN where unpaired);
    mac: (m,) MAC of each pair (NaN without a measured shape); mac_matrix: measured x model
    (None without shapes); comac: (n_measured_dofs,) over the paired modes with shapes (None
    without shapes); objective: J(x).
    """

    x: np.ndarray
    measured_hz: np.ndarray
    model_hz: np.ndarray
    error_pct: np.ndarray
    mac: np.ndarray
    mac_matrix: np.ndarray | None
    comac: np.ndarray | None
    pairing: Pairing
    objective: float

    @property
    def mean_abs_error_pct(self) -> float:
        return float(np.nanmean(np.abs(self.error_pct)))

    def to_dict(self) -> dict:
        def arr(a):
            return None if a is None else np.where(np.isnan(a), None, a).tolist()
        return {"x": self.x.tolist(), "measured_hz": arr(self.measured_hz), "model_hz": arr(self.model_hz),
                "error_pct": arr(self.error_pct), "mean_abs_error_pct": self.mean_abs_error_pct,
                "mac": arr(self.mac), "comac": arr(self.comac), "objective": self.objective,
                "paired_model_mode": (self.pairing.model_index + 1).tolist()}


class UpdatingProblem:
    """A bounded, vectorised, counted model-updating problem.

    Parameters
    ----------
    model: FrameModel, MatrixModel, shipped model name, model file or matrix manifest path
        (default: the data's model).
    data: ModalData, shipped dataset name (``"paper"``) or a data file path.
    parameters: the updating parameters (default: every element modulus in [6e10, 8e10] Pa; for
        a MatrixModel, the multipliers of its terms with bounds, or a subset of them by name).
    weights: ``"gamma"`` (the paper's eq. 4), ``"unit"``, or an array of one weight per mode.
    shape_weight: weight of the sum of (1 - MAC) over paired modes with measured shapes
        (0 leaves the objective frequency-only; needs shapes in the data).
    n_model_modes: how many model modes to compute for pairing (default: measured + 4).
    solver: ``"auto"`` (dense batched for small models, sparse shift-invert above
        `fe_problem.assembly.SPARSE_MIN_DOFS` free DOFs), ``"dense"`` or ``"sparse"``.
    objective: ``"weighted"`` (default: J above, with `weights` and `shape_weight`) or
        ``"balanced"`` (what `femu update` minimises, docs/update.md): each frequency residual
        divided by its standard deviation, each shape entry's residual (the measured shape minus
        the model shape scaled to it by least squares) by its own; per kind of data (frequencies,
        shapes) with sum of squares R_k over n_k entries, J = sum_k `balanced_objective`(R_k,
        n_k): an error scale s_k^2 = max(1, R_k / n_k) estimated with the parameters, so each kind
        weighs by its entries' misfit relative to its own scatter, not by its nominal noise.
        Deviations a mode does not state are `ModalData.noise`'s defaults; `weights` and
        `shape_weight` do not apply.

    `evaluate(X)` takes one point (n_var,) or a population (n, n_var) and returns (n,)
    objective values; every row counts as one FE evaluation in `n_evals`.
    """

    @blas_pinned  # the pairing and initial modes: the same on any thread count
    def __init__(self, model: FrameModel | MatrixModel | str | None = None, data: ModalData | str = "paper",
                 parameters: tuple[Parameter, ...] | None = None, weights="gamma",
                 shape_weight: float = 0.0, n_model_modes: int | None = None, name: str | None = None,
                 solver: str = "auto", objective: str = "weighted"):
        if objective not in OBJECTIVES:
            raise ValueError(f"objective must be one of {OBJECTIVES}, got {objective!r}")
        if objective == "balanced" and shape_weight:
            raise ValueError("shape_weight applies to objective='weighted' only (the balanced objective "
                             "weighs every measured shape by its noise)")
        self.objective = objective
        self.data = load_modal_data(data)
        self.model = self.data.load_model() if model is None else load_any_model(model)
        self.data.check_model(self.model)
        if isinstance(self.model, MatrixModel):
            self.system = MatrixSystem(self.model, parameters, solver=solver)
            self.parameters = self.system.parameters
            if not self.parameters:
                raise ValueError(f"{self.model.source or self.model.name}: UpdatingProblem needs at least one parameter "
                                 "(a term with 'lower' and 'upper')")
        else:
            self.parameters = element_moduli(self.model) if parameters is None else tuple(parameters)
            if not self.parameters:
                raise ValueError("UpdatingProblem needs at least one parameter")
            self.system = AffineModel(self.model, self.parameters, solver=solver)
        m = self.data.n_modes
        if n_model_modes is not None and n_model_modes < m:
            raise ValueError(f"n_model_modes={n_model_modes} is fewer than the {m} measured modes of "
                             f"{self.data.source}")
        self.n_model_modes = min(n_model_modes or m + 4, self.system.n_elastic)
        if self.n_model_modes < m:
            raise ValueError(f"{self.data.source}: {m} measured modes but model {self.model.name!r} "
                             f"has only {self.system.n_elastic} elastic modes")
        self.rows = self.system.nodal_rows(self.data.dofs)
        self.has_shape = self.data.has_shape
        if not shape_weight >= 0:
            raise ValueError(f"shape_weight must be >= 0, got {shape_weight}")
        if shape_weight and not self.has_shape.any():
            raise ValueError(f"shape_weight={shape_weight} but {self.data.source} has no measured shapes")
        self.shape_weight = float(shape_weight)

        lam, phi = self.system.eigen(self.x0[None], self.n_model_modes, vectors=True, rows=self.rows)
        f0 = frequencies_hz(lam[0])
        self.pairing = pair_modes(self.data.frequencies_hz, f0, self.data.shapes, phi[0],
                                  self.has_shape)
        if not self.pairing.paired.all():
            bad = np.flatnonzero(~self.pairing.paired)
            raise ValueError(
                f"{self.data.source}: measured mode(s) {[int(i) + 1 for i in bad]} "
                f"({', '.join(f'{self.data.frequencies_hz[i]:.1f} Hz' for i in bad)}) pair with no mode of model "
                f"{self.model.name!r} (no MAC >= 0.5 and no model frequency within 30 %)")
        self.model_index = self.pairing.model_index
        self.initial_hz = f0[self.model_index]
        fm = self.data.frequencies_hz
        if isinstance(weights, str):
            if weights not in WEIGHTS:
                raise ValueError(f"weights must be one of {WEIGHTS} or an array, got {weights!r}")
            w = ((fm - self.initial_hz) / fm) ** 2 if weights == "gamma" else np.ones(m)
            self.weights_name = weights
        else:
            w = np.asarray(weights, dtype=float)
            if w.shape != (m,) or not np.all(np.isfinite(w)) or np.any(w < 0):
                raise ValueError(f"weights must be {m} finite numbers >= 0, got {weights!r}")
            self.weights_name = "custom"
        self.weights = w
        self.sigma_hz, sigma_s = self.data.noise()
        self.shape_modes = np.flatnonzero(self.has_shape) if objective == "balanced" else np.zeros(0, dtype=int)
        self.sigma_shape = sigma_s[:, self.shape_modes]
        self.n_evals = 0
        self._points = 0  # never reset: what the budget harness cross-checks (points_evaluated)
        label = self.data.meta.get("source", "data") if self.data.source == "<memory>" else Path(self.data.source).stem
        self.name = name or f"{self.model.name}:{label}"

    # -- the standard problem interface -------------------------------------------------
    @property
    def n_var(self) -> int:
        return len(self.parameters)

    @property
    def xl(self) -> np.ndarray:
        return self.system.lower

    @property
    def xu(self) -> np.ndarray:
        return self.system.upper

    @property
    def x0(self) -> np.ndarray:
        return self.system.x0

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        return self.xl, self.xu

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.label for p in self.parameters)

    def check_x(self, X, name: str = "X") -> np.ndarray:
        """X as a (n, n_var) float array, or a ValueError that says what is wrong."""
        try:
            X = np.asarray(X, dtype=float)
        except (TypeError, ValueError) as exc:
            raise ValueError(f"{name} must be an array of numbers ({exc})") from None
        given = X.shape  # reported as passed, before a single point becomes a row
        if X.ndim == 1:
            X = X[None, :]
        if X.ndim != 2 or X.shape[1] != self.n_var:
            raise ValueError(f"{name} must have shape ({self.n_var},) or (n, {self.n_var}), got {given}")
        if not np.all(np.isfinite(X)):
            r, c = np.argwhere(~np.isfinite(X))[0]
            raise ValueError(f"{name}[{r}, {c}] is {X[r, c]}: every value must be finite")
        tol = 1e-9 * (self.xu - self.xl)
        out = (X < self.xl - tol) | (X > self.xu + tol)
        if out.any():
            r, c = np.argwhere(out)[0]
            raise ValueError(f"{name}[{r}, {c}] = {X[r, c]:.6g} ({self.parameter_names[c]}) is outside its bounds "
                             f"[{self.xl[c]:.6g}, {self.xu[c]:.6g}]")
        return X

    def _solve(self, X: np.ndarray, shapes: bool):
        """Paired model frequencies (b, m) and, with `shapes`, shapes at the measured DOFs only."""
        lam, phi = self.system.eigen(X, self.n_model_modes, vectors=shapes, rows=self.rows)
        f = frequencies_hz(lam)[:, self.model_index]
        return f, phi

    def objective_from_modes(self, f: np.ndarray, phi: np.ndarray | None) -> np.ndarray:
        """J for paired model frequencies f (b, m) and the model's shapes at the measured DOFs
        (b, n_measured_dofs, n_model_modes; `system.eigen(..., rows=self.rows)`), or None."""
        if self.objective == "balanced":
            e_f, e_s = self.noise_residuals(f, phi)
            return (balanced_objective(np.sum(e_f**2, axis=1), e_f.shape[1])
                    + (balanced_objective(np.sum(e_s**2, axis=1), e_s.shape[1]) if e_s.shape[1] else 0.0))
        fm = self.data.frequencies_hz
        j = np.sum(self.weights * ((fm - f) / fm) ** 2, axis=1)
        if self.shape_weight:
            # 1 - MAC as the squared norm of the shape residuals: a sum of squares, so J >= 0 by
            # construction, and without the cancellation of 1 - a computed MAC near a perfect fit
            # (which rounds to +-2e-16 per mode, where this is 1e-32); the J of least_squares
            with one_blas_thread():  # one summation order on any thread count
                j = j + np.sum(self.shape_residuals(phi) ** 2, axis=1)
        return j

    @property
    def points_evaluated(self) -> int:
        """Every point this problem has evaluated since it was built. `n_evals` is a plain counter
        its user may reset; this one is not (no setter), and the budget harness checks it."""
        return self._points

    def evaluate(self, X) -> np.ndarray:
        """Objective values (n,) for X (n_var,) or (n, n_var); counts n FE evaluations."""
        X = self.check_x(X)
        f, phi = self._solve(X, shapes=self._uses_shapes)
        self.n_evals += X.shape[0]
        self._points += X.shape[0]
        return self.objective_from_modes(f, phi)

    __call__ = evaluate

    @property
    def _uses_shapes(self) -> bool:
        return bool(self.shape_weight) or bool(self.shape_modes.size)

    def noise_residuals(self, f: np.ndarray, phi: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
        """The residuals of the balanced objective in units of the data's noise: frequencies
        (b, m), (f_meas - f) / sigma_f, and the measured shapes' entries (b, n_shape_modes *
        n_measured_dofs, mode by mode), (a - c b) / sigma_s for the measured shape a as given,
        the model shape b at the measured DOFs and c = a.b / b.b (b scaled to a by least
        squares: blind to b's sign and scale). sigma: `ModalData.noise`."""
        e_f = (self.data.frequencies_hz - f) / self.sigma_hz
        sel = self.shape_modes
        if not sel.size or phi is None:
            return e_f, np.zeros((f.shape[0], 0))
        a = self.data.shapes[:, sel]
        b = pow2_scaled(phi[:, :, self.model_index[sel]])  # exact scalings: no norm overflows
        c = np.einsum("ik,bik->bk", a, b) / np.einsum("bik,bik->bk", b, b)
        e_s = (a[None] - c[:, None, :] * b) / self.sigma_shape[None]
        return e_f, e_s.transpose(0, 2, 1).reshape(e_s.shape[0], -1)

    def noise_jacobian(self, x) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """`noise_residuals` at one point x and their Jacobians in the parameters' units:
        e_f (m,), e_s (n_s,), de_f (m, n_var) analytic, de_s (n_s, n_var) by forward differences.
        For intervals and reports: not counted as evaluations."""
        X = self.check_x(x, "x")
        lam, phi, dlam = self.system.eigen_sensitivities(X, self.n_model_modes, rows=self.rows)
        f = frequencies_hz(lam)[:, self.model_index]
        df = dlam[0, self.model_index, :] / (8.0 * np.pi**2 * f[0, :, None])
        e_f, e_s = (v[0] for v in self.noise_residuals(f, phi))
        de_s = (self._shape_jacobian(X[0], e_s, lambda p: self.noise_residuals(f, p)[1]) if e_s.size
                else np.zeros((0, self.n_var)))
        return e_f, e_s, -df / self.sigma_hz[:, None], de_s

    def _balanced_least_squares(self, X, f, phi, df, charged, residuals_only: bool = False):
        """`least_squares` of the balanced objective: residuals rho whose squares sum to J, each
        kind's noise residuals e times c = sqrt(balanced_objective(R) / R), and their exact
        Jacobian c de + e (dc/dR) 2 e^T de (frequency rows analytic, shape rows by forward
        differences)."""
        e_f, e_s = (v[0] for v in self.noise_residuals(f, phi))
        jac_f = -df / self.sigma_hz[:, None]
        parts = [(e_f, jac_f)]
        if e_s.size:
            jac_s = None
            if not residuals_only:
                jac_s = self._shape_jacobian(X[0], e_s, lambda p: self.noise_residuals(f, p)[1])
                extra = self.n_var if charged is None else min(self.n_var, int(charged) - 1)
                self.n_evals += extra
                self._points += extra
            parts.append((e_s, jac_s))
        rho, jac = [], []
        for e, de in parts:
            n, rss = e.size, float(e @ e)
            if rss <= n:
                c, dc = 1.0, 0.0
            else:
                c = np.sqrt(balanced_objective(rss, n) / rss)
                dc = -n * np.log(rss / n) / rss**2 / (2.0 * c)  # d c / d rss
            rho.append(c * e)
            jac.append(None if de is None else c * de + np.outer(e, dc * 2.0 * (e @ de)))
        r = np.concatenate(rho)
        J = None if any(j is None for j in jac) else np.vstack(jac)
        return LeastSquares(float(self.objective_from_modes(f, phi)[0]), r, J)

    # -- least-squares form (for Gauss-Newton / sensitivity methods) ---------------------
    def residuals(self, X) -> np.ndarray:
        """Weighted frequency residuals r (n, m) with J_freq = sum r^2 (the balanced objective:
        its frequency noise residuals, `noise_residuals`); counts n evaluations."""
        X = self.check_x(X)
        f, _ = self._solve(X, shapes=False)
        self.n_evals += X.shape[0]
        self._points += X.shape[0]
        if self.objective == "balanced":
            return self.noise_residuals(f, None)[0]
        fm = self.data.frequencies_hz
        return np.sqrt(self.weights) * (fm - f) / fm

    def shape_residuals(self, phi: np.ndarray) -> np.ndarray:
        """The shape part of J as residuals (b, n_shape_modes * n_measured_dofs): per paired mode
        with a measured shape, sqrt(shape_weight) (a - (a.b) b) for the unit measured shape a and
        unit model shape b, whose squared norm is shape_weight (1 - MAC) exactly, smooth where
        MAC -> 1 (unlike sqrt(1 - MAC)) and blind to the sign of b. Empty without a shape term."""
        if not self.shape_weight:
            return np.zeros((phi.shape[0], 0))
        sel = np.flatnonzero(self.has_shape)
        model = pow2_scaled(phi[:, :, self.model_index[sel]])  # exact scalings: no norm overflows
        measured = pow2_scaled(self.data.shapes[:, sel])
        a = measured / np.linalg.norm(measured, axis=0)
        b = model / np.linalg.norm(model, axis=1, keepdims=True)
        ab = np.einsum("ik,bik->bk", a, b)
        r = np.sqrt(self.shape_weight) * (a[None] - ab[:, None, :] * b)
        return r.transpose(0, 2, 1).reshape(len(phi), -1)

    def least_squares(self, x, charged: int | None = None, jacobian: bool | None = None) -> "LeastSquares":
        """J, the weighted residuals r of the whole objective (J = sum r^2) and dr/dtheta at one
        point: the frequency residuals (m,), then, when J has a shape term, `shape_residuals`.

        Frequency rows use analytic eigenvalue derivatives (d lambda = phi^T (dK - lambda dM)
        phi): one eigen-solve with vectors, counted as `jacobian_cost_evals` of this problem's
        own evaluations. Shape rows are forward differences (one batched solve of n_var points,
        counted as n_var more evaluations, or charged - 1 when less was charged), computed only when the caller paid for a Jacobian:
        `charged` (what the harness charged for the call, adapters.budget.jacobian_cost) of 1
        means residuals only (the Jacobian is then None), unless `jacobian` says which: with one
        parameter a Jacobian at the point whose residuals were just paid is charged 1 too, so the
        harness passes `jacobian` explicitly. The harness charges n_var + 1 for a Jacobian
        whichever way it is computed."""
        residuals_only = (charged == 1) if jacobian is None else not jacobian
        X = self.check_x(x, "x")
        if X.shape[0] != 1:
            raise ValueError(f"least_squares takes one point, got {X.shape[0]}")
        lam, phi, dlam = self.system.eigen_sensitivities(X, self.n_model_modes, rows=self.rows)
        self.n_evals += self.jacobian_cost_evals
        self._points += self.jacobian_cost_evals
        f = frequencies_hz(lam)[:, self.model_index]
        df = dlam[0, self.model_index, :] / (8.0 * np.pi**2 * f[0, :, None])
        if self.objective == "balanced":
            return self._balanced_least_squares(X, f, phi, df, charged, residuals_only)
        fm = self.data.frequencies_hz
        sw = np.sqrt(self.weights)
        r = sw * (fm - f[0]) / fm
        jac = -(sw / fm)[:, None] * df
        if self.shape_weight:
            rs = self.shape_residuals(phi)[0]
            r = np.concatenate([r, rs])
            if residuals_only:
                jac = None
            else:
                jac = np.vstack([jac, self._shape_jacobian(X[0], rs)])
                # n_var more solves; a caller that paid the point's value before (charged n_var)
                # is counted what it paid: the point itself was solved again, not a new point
                extra = self.n_var if charged is None else min(self.n_var, int(charged) - 1)
                self.n_evals += extra
                self._points += extra
        return LeastSquares(float(self.objective_from_modes(f, phi)[0]), r, jac)

    def _shape_jacobian(self, x: np.ndarray, r0: np.ndarray, residuals=None) -> np.ndarray:
        """d shape_residuals / d theta at x by forward differences (a step of 1e-6 of each
        parameter's range, taken backwards at the upper bound), one batched solve of n_var points.
        `residuals(phi)`: the shape residuals to differentiate (default `shape_residuals`)."""
        span = self.xu - self.xl
        h = 1e-6 * span
        h = np.where(x + h > self.xu, -h, h)
        X = x[None] + np.diag(h)
        _, phi = self._solve(X, shapes=True)
        return (((residuals or self.shape_residuals)(phi) - r0[None]) / h[:, None]).T

    #: What one analytic Jacobian costs, in FE evaluations: one eigen-solve with vectors.
    jacobian_cost_evals = 1

    # -- results for people -------------------------------------------------------------
    def modal(self, x=None, n_modes: int | None = None) -> ModalResult:
        """The updated model's modes at x (default x0); not counted as an evaluation."""
        x = self.x0 if x is None else self.check_x(x, "x")[0]
        lam, phi = self.system.eigen(x[None], n_modes or self.n_model_modes, vectors=True)
        return ModalResult(frequencies_hz(lam[0]), self.system.expand(phi[0]), self.model.dofs,
                           self.system.n_rigid, self.system.mechanism, self.system.path)

    def correlation(self, x=None) -> CorrelationReport:
        """Paired frequencies, errors, MAC and COMAC of the model at x (default x0): `correlate`
        with the problem's fixed pairing."""
        x = self.x0 if x is None else self.check_x(x, "x")[0]
        lam, phi = self.system.eigen(x[None], self.n_model_modes, vectors=True, rows=self.rows)
        c = correlate(frequencies_hz(lam[0]), phi[0], self.data, self.pairing)
        obj = float(self.objective_from_modes(c.model_hz[None], phi)[0])
        return CorrelationReport(x, c.measured_hz, c.model_hz, c.error_pct, c.mac, c.mac_matrix, c.comac,
                                 self.pairing, obj)

    def updated_model(self, x) -> FrameModel | MatrixModel:
        """The model with modulus parameters set to x (other kinds are not written back); a
        MatrixModel with its parameters' `initial` multipliers set to x."""
        x = self.check_x(x, "x")[0]
        if isinstance(self.model, MatrixModel):
            return self.model.with_initials({p.name: float(v) for p, v in zip(self.parameters, x)})
        moduli = {}
        for p, v in zip(self.parameters, x):
            if p.kind != "modulus":
                raise ValueError(f"updated_model writes back moduli only, not {p.kind}")
            moduli.update({e: float(v) for e in p.targets})
        return self.model.with_element_moduli(moduli)
