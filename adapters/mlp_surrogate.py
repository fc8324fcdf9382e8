"""mlp-surrogate: the paper's response-surface method (what it calls "PSO").

An initial Latin-hypercube design of FE runs trains a multi-layer perceptron (n_var inputs,
8 tanh hidden units, 1 linear output) by scaled conjugate gradient; a GA minimises the
network; its optimum is evaluated with the FE model and added to the training data; the
network is refitted and the loop repeats until the budget is spent. Only FE evaluations count
towards the budget; training and the GA on the network are the method's overhead (wall time).

The network and SCG (Møller 1993, as in Bishop's Netlab, which the paper most likely used)
are written here in numpy: nothing in the stack provides SCG.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .deap_ga import evolve, make_toolbox
from .ga_operators import latin_hypercube
from .harness import unit_scaled


@dataclass(frozen=True)
class MLP:
    """A one-hidden-layer perceptron: n_in inputs, n_hidden tanh units, one linear output.

    Its weights are one flat vector w of length n_weights: W1 (n_hidden, n_in) row by row,
    b1 (n_hidden,), w2 (n_hidden,), b2, so that an optimizer sees a plain vector. The error
    is the sum-of-squares 0.5 * sum (y(x) - t)^2 over the training pairs.
    """

    n_in: int
    n_hidden: int = 8

    @property
    def n_weights(self) -> int:
        return self.n_hidden * (self.n_in + 2) + 1

    def init(self, rng: np.random.Generator) -> np.ndarray:
        """Random weights, Netlab's scaling: N(0, 1) / sqrt(fan-in + 1) per layer."""
        h, n = self.n_hidden, self.n_in
        w1 = rng.standard_normal(h * (n + 1)) / np.sqrt(n + 1)
        w2 = rng.standard_normal(h + 1) / np.sqrt(h + 1)
        return np.concatenate([w1, w2])

    def _unpack(self, w):
        h, n = self.n_hidden, self.n_in
        W1 = w[: h * n].reshape(h, n)
        return W1, w[h * n: h * (n + 1)], w[h * (n + 1): h * (n + 2)], w[-1]

    def _hidden(self, w, X):
        W1, b1, w2, b2 = self._unpack(w)
        H = np.tanh(X @ W1.T + b1)
        return H, H @ w2 + b2

    def predict(self, w, X) -> np.ndarray:
        """Outputs (n,) for inputs X (n, n_in), the whole batch in one pass."""
        return self._hidden(w, np.asarray(X, dtype=float))[1]

    def error(self, w, X, t) -> float:
        """Sum-of-squares error 0.5 * sum (y - t)^2."""
        return 0.5 * float(np.sum((self.predict(w, X) - t) ** 2))

    def gradient(self, w, X, t) -> np.ndarray:
        """Analytic d error / d w (n_weights,) by back-propagation."""
        W1, b1, w2, b2 = self._unpack(w)
        H, y = self._hidden(w, X)
        e = y - t
        dA = np.outer(e, w2) * (1.0 - H**2)  # error signal at the hidden pre-activations
        return np.concatenate([(dA.T @ X).ravel(), dA.sum(axis=0), H.T @ e, [e.sum()]])


def scg(error, gradient, w, cycles: int, tol_w: float = 1e-10, tol_f: float = 1e-14):
    """Scaled conjugate gradient (Møller 1993, in the form of Netlab's scg.m): minimise
    error(w) with gradient(w), for at most `cycles` iterations (a training cycle of the paper).

    Conjugate directions with a Levenberg-Marquardt-like scale beta instead of a line search:
    the curvature along d comes from one extra gradient at w + sigma d. Stops early when a
    step moves no weight by more than tol_w and changes the error by less than tol_f, or when
    the gradient vanishes. Returns (w, errors): the weights and the error after each cycle.
    """
    sigma0, beta, beta_min, beta_max = 1e-4, 1.0, 1e-15, 1e100
    w = np.array(w, dtype=float)
    f_old = error(w)
    g_new = gradient(w)
    g_old = g_new
    d = -g_new
    success, n_success = True, 0
    errors = []
    mu = kappa = theta = 0.0
    for _ in range(int(cycles)):
        if success:
            mu = d @ g_new
            if mu >= 0:  # not a descent direction: restart along the steepest descent
                d = -g_new
                mu = d @ g_new
            kappa = d @ d
            if kappa < np.finfo(float).eps:
                break
            sigma = sigma0 / np.sqrt(kappa)
            theta = d @ (gradient(w + sigma * d) - g_new) / sigma
        delta = theta + beta * kappa
        if delta <= 0:  # make the scaled curvature positive
            delta = beta * kappa
            beta = beta - theta / kappa
        alpha = -mu / delta
        w_new = w + alpha * d
        f_new = error(w_new)
        comparison = 2.0 * (f_new - f_old) / (alpha * mu)
        success = comparison >= 0
        if success:
            n_success += 1
            step, f_change = np.max(np.abs(alpha * d)), abs(f_new - f_old)
            w, f_old, g_old = w_new, f_new, g_new
            errors.append(f_new)
            if step < tol_w and f_change < tol_f:
                break
            g_new = gradient(w)
            if g_new @ g_new == 0:
                break
        else:
            errors.append(f_old)
        if comparison < 0.25:
            beta = min(4.0 * beta, beta_max)
        elif comparison > 0.75:
            beta = max(0.5 * beta, beta_min)
        if n_success == len(w):
            d, n_success = -g_new, 0
        elif success:
            d = (g_old - g_new) @ g_new / mu * d - g_new
    return w, errors


class MLPSurrogate:
    """The paper's response-surface method: MLP (n_var-8-1) trained by SCG, minimised by the GA.

    Options: n_initial FE runs in the Latin-hypercube design (default 150, the paper's; for a
    budget under 160 it takes 15/16 of the budget, the paper's ratio 150/160), n_hidden (8),
    initial_cycles (200) and refit_cycles (5) of SCG, and the GA on the network: population
    (100) and generations (50) -- the paper's 600 x 100 costs no FE runs but 12 times the time
    per refit, for little gain on a 113-weight surface -- plus q, b, crossover_prob and
    mutation_prob as in deap-ga. The GA's first population holds the best FE point so far, so
    its answer is never predicted worse than that point (the paper does not say how it seeded
    the GA). One FE evaluation per refit, as in the paper. x0 (study option x0=all) replaces
    the design's first point.
    """

    name = "mlp-surrogate"
    #: capabilities (adapters.capabilities); not anytime: under 160 evaluations the design's
    #: size follows the budget (15/16 of it, the paper's ratio)
    anytime = False
    uses_gradients = False
    batch = False
    supports_x0 = True
    #: the distribution it wraps (its version is listed by `femu optimizers`)
    library = None

    def min_budget(self, n_var: int, n_initial: int | None = None, **options) -> int:
        """The design and one refit: 16 evaluations by default (15 design points, budget * 15 // 16,
        and one refit), `n_initial` + 1 when the design's size is given."""
        return 16 if n_initial is None else int(n_initial) + 1

    def minimize(self, objective, bounds, budget, rng: np.random.Generator, x0=None, n_initial: int | None = None,
                 n_hidden: int = 8, initial_cycles: int = 200, refit_cycles: int = 5,
                 population: int = 100, generations: int = 50, q: float = 0.08, b: float = 3.0,
                 crossover_prob: float = 0.8, mutation_prob: float | None = None):
        """Design, train, minimise the network, evaluate its optimum, refit: until the harness stops the run."""
        fe, _ = unit_scaled(objective, bounds)
        n_var = len(bounds[0])
        if n_initial is None:
            n_initial = 150 if budget >= 160 else budget * 15 // 16
        if not 2 <= n_initial <= budget:
            raise ValueError(f"n_initial must be in [2, budget={budget}], got {n_initial}")

        U = latin_hypercube(n_initial, n_var, rng)
        if x0 is not None:  # the study gives the initial point: the design's first row
            xl, xu = (np.asarray(v, dtype=float) for v in bounds)
            U[0] = np.clip((np.asarray(x0, dtype=float) - xl) / (xu - xl), 0.0, 1.0)
        F = fe(U)
        # Train on log J, standardised once on the initial design: J is a sum of squares that
        # spans orders of magnitude (1e-4 at x0, 1e-6 near the optimum on the paper's data), so
        # a least-squares fit of J itself spends the network on the worst designs and is flat
        # where the minimum is; log J resolves the low end and has the same minimiser. The floor
        # only guards log(0) on a perfect fit.
        floor = 1e-12 * float(np.max(F)) + np.finfo(float).tiny
        T = np.log(F + floor)
        mean, std = T.mean(), T.std() or 1.0
        T = (T - mean) / std
        Z = 2.0 * U - 1.0  # network inputs in [-1, 1], where tanh units are well conditioned
        net = MLP(n_var, n_hidden)
        w, _ = scg(lambda w: net.error(w, Z, T), lambda w: net.gradient(w, Z, T), net.init(rng), initial_cycles)
        toolbox = make_toolbox(q, b, crossover_prob, mutation_prob)
        while True:  # until the harness raises BudgetExhausted
            best = U[np.argmin(T)]
            new = evolve(lambda V: net.predict(w, 2.0 * V - 1.0), n_var, rng, population, generations,
                         toolbox=toolbox, initial=best).x[None]
            F_new = fe(new)
            U, Z = np.vstack([U, new]), np.vstack([Z, 2.0 * new - 1.0])
            T = np.concatenate([T, (np.log(F_new + floor) - mean) / std])
            w, _ = scg(lambda w: net.error(w, Z, T), lambda w: net.gradient(w, Z, T), w, refit_cycles)
